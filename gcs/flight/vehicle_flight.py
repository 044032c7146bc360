"""One vehicle's flight (`VehicleFlight`): a small state machine that takes one UAV of the plan
from the ground, through its search, back down, and owns all the station keeps of it: telemetry
(`status`), energy model and return trigger (`energy`), plan in metres (`track`), link and
commands (`commands`), the operator's orders and range, and its timers. The fleet controller
(`gcs.flight.controller`) routes messages and orders to it, ticks it and publishes its events.

Its stages (`Stage`, the values the journal, bus and recordings carry), in the order flown:

    preparing   CONNECTING -> PREPARING -> UPLOADING     `prepare` (checks in `gcs.flight.preflight`)
    launching   ARMING                                    `launch` (in `gcs.flight.launch`)
    searching   SEARCH                                    `watch`: the return trigger, every tick
    returning   RETURN (its planned way home), RTL (the autopilot's)   `send_home`, `rtl`
    landed      LANDED, LANDED_AWAY                       `update_stage`, from its telemetry

FAILED can end any stage before the end (in the air after its launch: RTL at once, and the
flight waits for it).
LOST is an overlay: any stage before the end may go silent, and the vehicle comes back to the
stage it was lost in (`update_stage`), or goes on from it where the task commanding it takes it
meanwhile. Every change goes through `set_stage`, which refuses one `TRANSITIONS` does not list
(`StageError`); only a resumed flight's reattachment sets the stage it finds
(`gcs.flight.resume`), outside the table."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import MissionTransferError
from gcs.autopilots.modes import MISSION_MODES, STATION_HELD_MODES
from gcs.flight import launch, preflight
from gcs.flight.events import MissionUploaded, ModeChanged, ReadingReceived, StageChanged, TookOff
from gcs.flight.options import FlyOptions
from gcs.flight.vehicle_commands import VehicleCommands
from gcs.flight.vehicle_energy import VehicleEnergy
from gcs.flight.vehicle_track import PlanTrack, distance_m
from gcs.links import LinkError, MavLink, mavlink
from gcs.plans.plan_folder import FleetPlan
from gcs.plans.vehicle_file import stock_profile
from gcs.telemetry.status import FINAL_STAGES, Stage, VehicleStatus

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController

__all__ = ["FROM_ANY_STAGE", "TRANSITIONS", "StageError", "VehicleFlight", "may_become"]

S = Stage
#: The stages each stage may go on to (`FROM_ANY_STAGE` besides). LANDED before take-off: kept on
#: the ground by a return order. RTL before the search: found in the air when the flight stops (a
#: resumed flight's reattachment). RTL -> RETURN: the online planner taking it home.
TRANSITIONS: dict[Stage, frozenset[Stage]] = {
    S.CONNECTING: frozenset({S.PREPARING, S.LANDED, S.RTL}),
    S.PREPARING: frozenset({S.UPLOADING, S.ARMING, S.LANDED, S.RTL}),
    S.UPLOADING: frozenset({S.ARMING, S.LANDED, S.RTL}),
    S.ARMING: frozenset({S.SEARCH, S.RETURN, S.RTL, S.LANDED}),
    S.SEARCH: frozenset({S.RETURN, S.RTL, S.LANDED, S.LANDED_AWAY}),
    S.RETURN: frozenset({S.RTL, S.LANDED, S.LANDED_AWAY}),
    S.RTL: frozenset({S.RETURN, S.LANDED, S.LANDED_AWAY}),
    S.LANDED: frozenset(), S.LANDED_AWAY: frozenset(),
    S.FAILED: frozenset({S.RTL}),  # failed in the air: sent home at once (`set_stage`)
    S.LOST: frozenset(set(S) - FINAL_STAGES - {S.LOST} | {S.FAILED}),  # narrowed by `may_become`
}
#: Reached from every stage before the end: a failure, and a link gone quiet.
FROM_ANY_STAGE = frozenset({S.FAILED, S.LOST})


def may_become(before: Stage, after: Stage, lost_in: Stage | None = None) -> bool:
    """Whether a vehicle in `before` may go to `after`; a LOST one (lost in `lost_in`) only back to
    that stage or on to where that stage may go."""
    if before is S.LOST:
        return lost_in is not None and (after is lost_in or may_become(lost_in, after))
    return after in TRANSITIONS[before] or (before not in FINAL_STAGES and after in FROM_ANY_STAGE)


#: Wall seconds a flight stopped mid-launch gives an arming already sent to take, and a vehicle
#: whose disarm went unanswered to be seen lifting off (then sent home)
LIFT_OFF_S = 5.0


class StageError(RuntimeError):
    """A stage change `TRANSITIONS` does not list: a bug in the flight code."""


class VehicleFlight:
    """UAV `uid` of `plan`, flown with `options`; `station` (the fleet controller) publishes its
    events and lines (see the module docstring)."""

    def __init__(self, plan: FleetPlan, uid: int, options: FlyOptions, station: FlightController) -> None:
        self.plan, self.uid, self.options, self.station = plan, uid, options, station
        self.task = task = plan.uavs[uid]
        self.track = PlanTrack(plan, uid)
        profile = options.profiles.get(uid) or stock_profile("ardupilot", task.vehicle.value)
        self.status = VehicleStatus(uid)
        self.energy = VehicleEnergy(task, self.status, profile, reserve_pct=options.reserve_pct,
                                    confirm_s=options.confirm_s, wind_m_s=options.wind_m_s, path_en=self.track.track_m)
        self.commands = VehicleCommands(uid, self.status, self.say, command_timeout_s=options.command_timeout_s)
        self.reading_component: int | None = None  # where its readings came from (`reading_from`)
        self.operator_range: float | None = None   # metres along its plan from take-off, set by the operator
        self.orders: list[tuple[int, str]] = []    # return orders not yet carried out: (sequence, reason)
        self.return_after_s = options.return_after_s.get(uid)  # flight seconds: ordered home then
        self.busy = self.stay_on_ground = False  # commanded by a task (`claim`); ordered home before take-off
        self.failed_in_air = False  # FAILED in the air, its RTL not yet answered: the flight waits for it
        self.lost_since: float | None = None  # when its link went quiet, and the stage it was in
        self.stage_before_loss: Stage | None = None
        self.upload_reports: dict | None = None  # the verified uploads, by kind ("mission", "fence", "rally")
        self.return_latency_s: float | None = None  # from its return's decision to its leg flying
        self.return_leg_flying = False  # its planned return leg uploaded and started: it flies home by itself

    @property
    def link(self) -> MavLink | None:  # the link it was first heard on
        return self.commands.link

    def say(self, text: str) -> None:
        self.station.say(self.uid, text)

    # ---- the stages ----------------------------------------------------------------------

    def set_stage(self, stage: Stage, note: str = "") -> None:
        """Move to `stage` (`note` kept even if the stage stays), said and published when it changes;
        `StageError` when `TRANSITIONS` does not allow it."""
        st, before = self.status, self.status.stage
        if before is not stage and not may_become(before, stage, self.stage_before_loss):
            raise StageError(f"UAV {self.uid}: {before.value} -> {stage.value} is not a stage change of a flight")
        if note:
            st.note = note
        if before is not stage:
            st.stage = stage
            self.say(f"{stage.value}{' - ' + note if note else ''}")
            self.station.emit(StageChanged(self.uid, before, stage, note))
            if stage is Stage.FAILED and st.airborne and before in (Stage.ARMING, Stage.SEARCH, Stage.RETURN):
                # launched by this station and no task flies it any more: its autopilot brings it home
                # (one found in the air while it was prepared, e.g. `gcs upload` to a flying vehicle, is not ours)
                self.failed_in_air = True
                self.station.spawn(self._home_after_failure())

    async def _home_after_failure(self) -> None:
        try:
            if not await self.rtl():
                self.say("in the air and did not confirm RTL: check it yourself")
        finally:
            self.failed_in_air = False

    def mark_lost(self, note: str, now: float, before: Stage | None = None) -> None:
        """LOST from `now` (monotonic): heard again, it gets `before` back (by default the stage
        it has now); past `lost_giveup_s` the flight stops waiting for it."""
        self.stage_before_loss = before if before is not None else self.status.stage
        self.lost_since = now
        self.set_stage(Stage.LOST, note)

    def update_stage(self, now: float) -> None:
        """The stage the telemetry implies: LOST after `link_timeout_s` of silence and back when
        heard, LANDED once down after flying, RTL when the autopilot turned home by itself."""
        st, timeout_s = self.status, self.options.link_timeout_s
        if st.last_heard_s is not None and st.stage not in FINAL_STAGES:
            silent = now - st.last_heard_s > timeout_s
            if silent and st.stage is not Stage.LOST:
                self.mark_lost(f"no telemetry for {timeout_s:g} s; the others carry on", now)
            elif not silent and st.stage is Stage.LOST:
                self.lost_since = None
                self.set_stage(self.stage_before_loss or Stage.SEARCH, "link back")
                self.stage_before_loss = None
        if st.stage in (Stage.SEARCH, Stage.RETURN, Stage.RTL) and st.airborne_seen and not st.airborne \
                and (not st.armed or st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND):
            self._touched_down()
        elif st.stage is Stage.SEARCH and st.mode_name in ("RTL", "LAND") and not self.busy:
            st.return_reason = "autopilot"
            self.set_stage(Stage.RTL, f"autopilot switched to {st.mode_name} ({st.last_text or 'no reason given'})")

    def done(self, now: float) -> bool:
        """Landed, failed, or lost for `lost_giveup_s`: the flight no longer waits for it."""
        lost_s = now - (self.lost_since or now) if self.status.stage is Stage.LOST else -math.inf
        return (self.status.stage in FINAL_STAGES and not self.failed_in_air) or lost_s >= self.options.lost_giveup_s

    # ---- telemetry -----------------------------------------------------------------------

    def on_message(self, link: MavLink, msg) -> None:
        """Telemetry from its autopilot; readings (CAMERA_IMAGE_CAPTURED) from any component (`gcs detector`)."""
        st = self.status
        component = msg.get_srcComponent()
        if component != mavlink.MAV_COMP_ID_AUTOPILOT1:
            if msg.get_type() != "CAMERA_IMAGE_CAPTURED":
                return
            self.reading_component = component
        if self.commands.link is None:
            self.commands.link = link
        readings, airborne, mode = len(st.detections), st.airborne_seen, st.mode_name
        st.update(msg, time.monotonic())
        self.energy.on_message(msg)
        while self.energy.notes:
            self.say(self.energy.notes.pop(0))
        if st.airborne_seen and not airborne:
            self.station.emit(TookOff(self.uid, st.rel_alt_m, st.mode_name))
        if st.mode_name != mode:
            self.station.emit(ModeChanged(self.uid, mode, st.mode_name))
        for detection in st.detections[readings:]:
            self.station.emit(ReadingReceived(self.uid, detection))

    def ask_for_lost_readings(self) -> None:
        """Ask again for (at most five of) the readings lost on the link."""
        if self.link is not None and self.status.stage is not Stage.LOST:
            self.commands.request_readings(self.status.lost_detections[:5], self.reading_from)

    @property
    def reading_from(self) -> int:  # the component its readings come from: the autopilot until another sent one
        return self.reading_component if self.reading_component is not None else mavlink.MAV_COMP_ID_AUTOPILOT1

    # ---- orders --------------------------------------------------------------------------

    def claim(self) -> None:
        """A task commands it (an upload, a return, a reattachment): until `release`, `watch`
        skips it, and an RTL or LAND is not taken for the autopilot's own return."""
        self.busy = True

    def release(self) -> None:
        self.busy = False

    def set_range(self, range_m: float) -> None:
        """The operator's range T_i (metres along its plan from take-off): it searches only while the
        way home still fits in it (as in the planner, eq. 23)."""
        if not (math.isfinite(range_m) and range_m > 0):
            raise ValueError(f"range must be a positive number of metres, not {range_m:g}")
        self.operator_range = float(range_m)
        self.say(f"range set to {range_m:.0f} m ({self.track.flown_m(self.status.track_index):.0f} m flown)")

    def return_due(self, elapsed_s: float) -> bool:
        """Its planned return time (`return_after_s`) has come: True once."""
        if self.return_after_s is None or elapsed_s < self.return_after_s:
            return False
        self.return_after_s = None
        return True

    def ordered_home(self) -> bool:
        return self.station.stopping or self.stay_on_ground or bool(self.orders)

    # ---- preparing and launching ---------------------------------------------------------

    async def prepare(self, mission: bool = True) -> bool:
        """Connect, make ready, upload its mission unless not `mission` (`preflight.prepare`); False when FAILED."""
        return await preflight.prepare(self, mission)

    async def launch(self) -> bool:
        """Arm it and start its mission (`gcs.flight.launch`); False when it stays on the ground."""
        return await launch.launch(self)

    async def arm(self, give_up: Callable[[], bool] = lambda: False) -> bool:
        """`VehicleCommands.arm` for up to `arm_timeout_s`, its vehicle heard within `link_timeout_s`."""
        return await self.commands.arm(self.options.arm_timeout_s, self.options.link_timeout_s, give_up)

    async def prepare_and_launch(self) -> None:
        """`prepare`, then (unless `options.fly` is off) `launch`, claimed meanwhile; FAILED when
        the link fails."""
        self.claim()
        try:
            if await self.prepare() and self.options.fly:
                await self.launch()
        except LinkError as exc:
            self.set_stage(Stage.FAILED, str(exc))
        finally:
            self.release()

    async def keep_on_ground(self) -> bool:
        """Ordered home after its mission started, before it left the ground: disarmed there.
        False when it would not disarm (lifting off: it comes home like any other)."""
        if not await self.commands.disarm():
            return False
        self.kept_down()
        return True

    def kept_down(self) -> bool:
        """LANDED without flying: ordered home before take-off, or the flight is stopping (said
        which). False, for a launch that ends here."""
        why = "the flight is stopping" if self.station.stopping else "return ordered before take-off"
        self.set_stage(Stage.LANDED, f"kept on the ground: {why}")
        return False

    # ---- searching: the return trigger -----------------------------------------------------

    def watch(self) -> str | None:
        """One tick of its search, unless a task commands it: the pose it has reached, then the
        return trigger (`VehicleEnergy.check_along`, against the operator's range too); the
        reason to send it home now ("battery", "range"), said, else None."""
        st = self.status
        if self.busy:
            return None
        if st.has_position:
            st.track_index = self.track.advance(st.track_index, st.lat_deg, st.lon_deg)
            if st.stage is Stage.SEARCH and st.mode_name in MISSION_MODES:  # flying its search list
                st.track_index = max(st.track_index, self.track.index_on_board(
                    st.autopilot or Autopilot.GENERIC, st.mission_seq, st.lat_deg, st.lon_deg, 0))
            st.steps_flown = float(st.track_index)
        flown_m = self.track.flown_m(st.track_index)  # metres of the plan behind it
        ordered = None if self.operator_range is None else max(0.0, self.operator_range - flown_m)
        if not self.energy.check_along(self.track, self.options.lookahead_steps, ordered):
            return None
        self.say(self.energy.why_home(self.operator_range))
        decision = self.energy.decision
        return "range" if decision is not None and decision.by_order else "battery"

    # ---- returning -------------------------------------------------------------------------

    async def send_home(self, reason: str) -> float | None:
        """Fly the planned return leg to its airport and land: hold (ArduPilot swaps items of a
        mission flown in AUTO as they arrive), upload and verify the leg and the landing, point
        the mission at its first item (MISSION_START alone resumes the old one) and start it;
        the autopilot's RTL, said, when any of that fails. The vehicle seconds the hold took."""
        st, uid = self.status, self.uid
        if st.stage in FINAL_STAGES or st.stage in (Stage.RETURN, Stage.RTL):
            return None
        st.return_reason = reason
        if not st.airborne_seen:
            self.stay_on_ground = True
            if st.stage is not Stage.SEARCH:
                return None  # not launched yet: launch() sees it and keeps it on the ground
            if await self.keep_on_ground():
                return None  # started, still on the ground: disarmed there; else it is lifting off
        self.set_stage(Stage.RETURN, f"going home ({reason})")
        self.claim()
        started = time.monotonic()
        try:
            leg = self.track.return_leg(st.track_index)
            autopilot = st.autopilot or Autopilot.GENERIC
            self.energy.holding = True
            held_from = st.time_boot_s
            await self.commands.replace_mission(lambda: self.task.return_wire(autopilot, leg),
                                                self.options.transfer_timeout_s,
                                                lambda: self.station.emit(MissionUploaded(uid, "return", tuple(leg))))
            self.energy.holding = False
            self.return_leg_flying = True
            self.return_latency_s = time.monotonic() - started
            self.say(f"return leg of {len(leg)} waypoints uploaded and started")
            return st.time_boot_s - held_from  # what a return's hold takes, in the vehicles' time
        except (LinkError, MissionTransferError, ValueError, KeyError) as exc:
            self.say(f"the planned return could not be flown ({exc}); commanding the autopilot's RTL, which "
                     "flies straight home and ignores the planned path")
            await self.rtl()
            return None
        finally:
            self.energy.holding = False
            self.release()

    async def rtl(self) -> bool:
        try:
            await self.commands.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, retries=5)
        except LinkError as exc:
            self.say(f"RTL not acknowledged: {exc}")
            return False
        self.set_stage(Stage.RTL, "autopilot RTL")
        return True

    # ---- the end ---------------------------------------------------------------------------

    def _touched_down(self) -> None:
        """Down after flying: LANDED at its airport, or LANDED_AWAY (saying where, for the crew)
        past `landed_away_m` from it; then its energy account."""
        st, task = self.status, self.task
        st.battery_at_landing = st.battery_pct
        battery = f"battery {st.battery_pct:.0f}%" if st.battery_pct is not None else "battery unknown"
        if st.has_position:
            away = distance_m(self.plan, (st.lat_deg, st.lon_deg), task.airport_lat_lon)
            st.landed_from_airport_m = away
            if away > self.options.landed_away_m.get(task.vehicle.value, 25.0):
                self.set_stage(Stage.LANDED_AWAY,
                               f"LANDED AWAY at {st.lat_deg:.6f}, {st.lon_deg:.6f}, {away:.0f} m from its airport "
                               f"{task.name!r} ({battery}): fetch it")
            else:
                self.set_stage(Stage.LANDED, f"{battery}, {away:.1f} m from its airport")
        else:
            self.set_stage(Stage.LANDED, battery)
        account = self.energy.energy_account()
        if account is not None:
            self.say(account.line())

    async def secure(self, rtl_airborne: bool) -> None:
        """Disarm it when armed on the ground; with `rtl_airborne`, RTL when in the air and not going
        home. Stopped mid-launch: an arming already sent is given `LIFT_OFF_S` to take (then
        disarmed), and one whose disarm its autopilot refuses (lifting off, its take-off roll) or
        leaves unanswered while it is seen to lift off within `LIFT_OFF_S` is sent home, as is one
        going home but not on its started return leg (its upload cut short by the stop, the online
        search's way home, steered cell by cell), or held on it (`STATION_HELD_MODES`): it would
        stay where it is."""
        st = self.status
        if self.link is None or st.stage is Stage.LOST:
            return
        if rtl_airborne and st.stage is Stage.ARMING and not st.armed:
            await preflight.wait_until(lambda: st.armed, LIFT_OFF_S)
        lifting = False
        if st.armed and not st.airborne:
            disarmed = await self.commands.disarm()
            if disarmed:
                self.say("on the ground, disarmed")
                return
            refused = disarmed is False  # its autopilot counts it flying
            lifting = rtl_airborne and (refused or await preflight.wait_until(lambda: st.airborne, LIFT_OFF_S))
            if not lifting:
                self.say("ARMED ON THE GROUND: disarm did not confirm, check it")
                return
        on_its_way = st.stage in (Stage.RTL, Stage.LANDED) or (
            st.stage is Stage.RETURN and self.return_leg_flying and st.mode_name not in STATION_HELD_MODES)
        if rtl_airborne and (st.airborne or lifting) and not on_its_way:
            if not await self.rtl():
                self.say("in the air and did not confirm RTL: check it yourself")

