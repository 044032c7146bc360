"""Launching one vehicle (`launch`): arm it as its autopilot wants (`Autopilot.arm_mode`) and
start its mission (`Autopilot.start_after_arming`), once its charge pays for its plan; confirm
from its next HEARTBEAT that it is still armed, and arm and start it again when its autopilot
disarmed it on the ground before the start took."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from gcs.autopilots import Autopilot
from gcs.autopilots.modes import MISSION_MODES
from gcs.flight import preflight
from gcs.links import CommandError
from gcs.telemetry.status import Stage

if TYPE_CHECKING:
    from gcs.flight.vehicle_flight import VehicleFlight

__all__ = ["LAUNCH_TRIES", "launch"]

#: How many times a vehicle its autopilot disarms before the start took is armed and started
LAUNCH_TRIES = 3


async def launch(vehicle: VehicleFlight) -> bool:
    """Arm `vehicle` and start its mission as its autopilot wants it (ArduPlane takes off by
    itself once armed in AUTO), once its charge pays for its plan; one armed but not started is
    disarmed again, one ordered home meanwhile, or of a flight being stopped, kept on the ground.
    One its autopilot disarmed on the ground before the start took (ArduCopter's DISARM_DELAY:
    10 s of its time from arming to MISSION_START, half a second at speed-up 20) is armed and
    started again."""
    st = vehicle.status
    autopilot = st.autopilot or Autopilot.GENERIC
    if vehicle.station.stopping:
        return vehicle.kept_down()
    await preflight.battery_report(vehicle)
    if not preflight.charge_covers_plan(vehicle):
        return False
    vehicle.set_stage(Stage.ARMING)
    mode = autopilot.arm_mode(st.fixed_wing)
    for tries_left in reversed(range(LAUNCH_TRIES)):
        try:
            if mode is not None:
                await vehicle.commands.set_mode(mode)
        except CommandError as exc:
            vehicle.set_stage(Stage.FAILED, f"cannot switch to {mode} to arm: {exc}{_said(vehicle)}")
            return False
        try:
            if not await vehicle.arm(give_up=vehicle.ordered_home):
                return vehicle.kept_down()
        except CommandError as exc:
            vehicle.set_stage(Stage.FAILED, f"cannot arm: {exc}{_said(vehicle)}; left on the ground")
            return False
        if vehicle.ordered_home():
            await vehicle.keep_on_ground()
            return False
        if not autopilot.start_after_arming(st.fixed_wing):
            break
        try:
            await vehicle.commands.start_mission()
        except CommandError as exc:
            took = await _started_unanswered(vehicle) if exc.result is None else None
            if took:
                vehicle.say(f"MISSION_START unanswered, but its HEARTBEAT shows it armed in {st.mode_name}: "
                            "its mission started")
                break
            if took is False and tries_left:  # disarmed by its autopilot meanwhile, as below
                vehicle.say(f"MISSION_START unanswered and disarmed on the ground{_said(vehicle)}: arming it again")
                continue
            disarmed = await vehicle.commands.disarm()
            vehicle.set_stage(Stage.FAILED, f"cannot start the mission: {exc}{_said(vehicle)}; "
                                            + ("disarmed again" if disarmed else "COULD NOT DISARM: check it"))
            return False
        started = time.monotonic()
        if st.airborne or await vehicle.commands.armed_after(started, vehicle.options.link_timeout_s) is not False:
            break
        if tries_left:
            vehicle.say(f"disarmed on the ground as its mission started{_said(vehicle)}: arming it again")
    else:
        vehicle.set_stage(Stage.FAILED, f"disarmed on the ground each time its mission started ({LAUNCH_TRIES} "
                                        f"tries){_said(vehicle)}")
        return False
    vehicle.set_stage(Stage.SEARCH, "mission started")
    return True


async def _started_unanswered(vehicle: VehicleFlight) -> bool | None:
    """After a MISSION_START never acknowledged, from its next HEARTBEAT: True when it took (armed
    in its mission mode: ArduCopter was armed in GUIDED, and only the start switches it to AUTO),
    False when its autopilot has disarmed it, None otherwise (armed outside it, or not heard)."""
    armed = await vehicle.commands.armed_after(time.monotonic(), vehicle.options.link_timeout_s)
    if armed is None or (armed and vehicle.status.mode_name not in MISSION_MODES):
        return None
    return armed


def _said(vehicle: VehicleFlight) -> str:
    """The autopilot's last words, to follow a refusal."""
    return f" (autopilot: {vehicle.status.last_text})" if vehicle.status.last_text else ""
