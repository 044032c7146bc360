"""What the station asks of one vehicle over its link (`VehicleCommands`): commands, flight
modes, parameters, message rates, starting its mission, disarming it, asking again for lost
readings. Each vehicle's flight (`gcs.flight.vehicle_flight.VehicleFlight`) owns one; its link is
the one the vehicle was first heard on."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import upload_verified
from gcs.links import CommandError, LinkError, MavLink, mavlink
from gcs.telemetry.status import VehicleStatus

__all__ = ["REFUSED_FOR_NOW", "VehicleCommands"]

#: How long to wait for the HEARTBEAT that confirms a state change (autopilots send one a second)
HEARTBEAT_WAIT_S = 2.5

REFUSED_FOR_NOW = (mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_FAILED)


class VehicleCommands:
    """Commands to system `uid` (see the module docstring); `say` tells the operator about it."""

    def __init__(self, uid: int, status: VehicleStatus, say: Callable[[str], None], *,
                 command_timeout_s: float) -> None:
        self.uid = uid
        self.status = status
        self.say = say
        self.command_timeout_s = command_timeout_s
        self.link: MavLink | None = None  # the link it was first heard on

    @property
    def autopilot(self) -> Autopilot:
        return self.status.autopilot or Autopilot.GENERIC

    async def command(self, cmd: int, *params: float, retries: int = 3) -> int:
        if self.link is None:
            raise CommandError(f"command to vehicle {self.uid}", None, "vehicle not connected")
        return await self.link.command(self.uid, cmd, *params, timeout_s=self.command_timeout_s, retries=retries)

    async def set_mode(self, name: str) -> None:
        await self.command(mavlink.MAV_CMD_DO_SET_MODE, *self.autopilot.set_mode_params(self.status.mav_type, name))

    async def set_param(self, name: str, value: float, timeout_s: float = 1.0, tries: int = 3) -> bool:
        """PARAM_SET, confirmed by the PARAM_VALUE echo (ArduPilot answers with the new value)."""
        got = await self._param(name, lambda: mavlink.MAVLink_param_set_message(
            self.uid, mavlink.MAV_COMP_ID_AUTOPILOT1, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32),
            timeout_s, tries)
        return got is not None and abs(got - value) < 1e-6

    async def get_param(self, name: str, timeout_s: float = 1.0, tries: int = 3) -> float | None:
        """PARAM_REQUEST_READ by name; the value, or None when the vehicle does not answer (an
        unknown name gets no answer from ArduPilot)."""
        return await self._param(name, lambda: mavlink.MAVLink_param_request_read_message(
            self.uid, mavlink.MAV_COMP_ID_AUTOPILOT1, name.encode(), -1), timeout_s, tries)

    async def _param(self, name: str, message: Callable[[], mavlink.MAVLink_message], timeout_s: float,
                     tries: int) -> float | None:
        """Send `message()` until the PARAM_VALUE of `name` answers (at most `tries` times, `timeout_s`
        each): its value, or None."""
        link = self.link
        assert link is not None
        for _ in range(tries):
            async with link.listen(self.uid, ("PARAM_VALUE",)) as queue:
                link.send(message())
                end = time.monotonic() + timeout_s
                while (left := end - time.monotonic()) > 0:
                    try:
                        async with asyncio.timeout(left):
                            reply = await queue.get()
                    except TimeoutError:
                        break
                    param_id = reply.param_id if isinstance(reply.param_id, str) \
                        else reply.param_id.decode(errors="replace")
                    if param_id.rstrip("\x00") == name:
                        return float(reply.param_value)
        return None

    async def request_streams(self) -> None:
        """Ask the vehicle for the telemetry its autopilot needs (`Autopilot.streams_hz`); a
        stream it refuses is noted in `unsupported_streams` and said."""
        st = self.status
        for msg_id, hz in self.autopilot.streams_hz().items():
            try:
                await self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=2)
            except CommandError as exc:
                st.unsupported_streams.add(msg_id)
                name = mavlink.mavlink_map[msg_id].msgname if msg_id in mavlink.mavlink_map else msg_id
                self.say(f"stream {name} not set ({exc}); using what the vehicle sends")
        for msg_id, hz in self.autopilot.optional_streams_hz().items():
            try:
                await self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=1)
            except CommandError:
                st.unsupported_streams.add(msg_id)

    async def arm(self, timeout_s: float, heard_within_s: float, give_up: Callable[[], bool]) -> bool:
        """Arm it, asking again (for up to `timeout_s`) while the autopilot refuses for now, as real
        ones do a while after boot, or leaves the command unanswered while it is still heard (within
        `heard_within_s`: a loaded autopilot or link), each new reason said. A lost COMMAND_ACK of an
        arming its HEARTBEAT shows done counts as armed. False when `give_up()` came true first;
        CommandError when it will not arm."""
        st = self.status
        end = time.monotonic() + timeout_s
        reasons: list[str] = []
        while not give_up():
            try:
                await self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                return True
            except CommandError as exc:
                if exc.result is None and st.armed:
                    return True
                heard = st.last_heard_s is not None and time.monotonic() - st.last_heard_s < heard_within_s
                unanswered = exc.result is None and heard
                if (exc.result not in REFUSED_FOR_NOW and not unanswered) or time.monotonic() > end:
                    raise
                reason = f"unanswered: {exc}" if unanswered else f"refused: {st.last_text or exc}"
                if reason not in reasons:
                    reasons.append(reason)
                    self.say(f"arming {reason} (retrying for up to {timeout_s:g} s)")
                await asyncio.sleep(1.0)
        return False

    async def start_mission(self, patience_s: float = 3.0) -> None:
        """MISSION_START(0, 0), asked again for a few seconds while it is refused: PX4 checks a
        new mission in the background and may refuse a start right after the upload."""
        end = time.monotonic() + patience_s
        while True:
            try:
                await self.command(mavlink.MAV_CMD_MISSION_START, *self.autopilot.mission_start_params())
                return
            except CommandError as exc:
                if exc.result not in REFUSED_FOR_NOW or time.monotonic() > end:
                    raise
                await asyncio.sleep(0.5)

    async def armed_after(self, t0: float, timeout_s: float) -> bool | None:
        """Whether the first HEARTBEAT heard after monotonic time `t0` shows it armed; None when
        none came within `timeout_s`."""
        end = time.monotonic() + timeout_s
        while (self.status.heartbeat_s or -math.inf) <= t0:
            if time.monotonic() > end:
                return None
            await asyncio.sleep(0.02)
        return self.status.armed

    async def replace_mission(self, items: Callable[[], list], timeout_s: float, uploaded: Callable[[], None]) -> None:
        """Replace the mission it flies with `items()` and fly it: hold (ArduPilot swaps the items
        of a mission flown in AUTO as they arrive), upload and verify, `uploaded()`, point the
        mission at its first item (MISSION_START alone resumes the old one) and start it."""
        autopilot, st = self.autopilot, self.status
        await self.set_mode(autopilot.hold_mode(st.fixed_wing))
        await upload_verified(self.link, self.uid, items(), autopilot, timeout_s=timeout_s, fixed_wing=st.fixed_wing)
        uploaded()
        if autopilot.restart_needs_current_item():
            await self.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, autopilot.first_mission_seq())
        await self.start_mission()

    async def disarm(self) -> bool | None:
        """Disarm a vehicle on the ground: True when confirmed, False when its autopilot refused
        (it counts itself flying), None when unanswered. A COMMAND_ACK does not say whether it
        answered an arming or a disarming (a late one of an earlier arming looks the same), so an
        accepted disarm is believed only when the next HEARTBEAT does not show it still armed."""
        try:
            await self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, retries=5)
        except LinkError as exc:
            self.say(f"disarm not acknowledged: {exc}")
            return False if isinstance(exc, CommandError) and exc.result is not None else None
        if await self.armed_after(time.monotonic(), HEARTBEAT_WAIT_S):
            self.say("disarm acknowledged, but its HEARTBEAT still shows it armed")
            return None
        return True

    def request_readings(self, indices: list[int], component: int) -> None:
        """Ask `component` again (MAV_CMD_REQUEST_MESSAGE, param2 = image index) for readings
        `indices` (CAMERA_IMAGE_CAPTURED)."""
        if self.link is None:
            return
        for index in indices:
            self.link.send(mavlink.MAVLink_command_long_message(
                self.uid, component, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED,
                index, 0, 0, 0, 0, 0))
