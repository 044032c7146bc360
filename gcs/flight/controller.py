"""The flight controller: uploads a plan to every vehicle, launches the missions and watches the
fleet until every vehicle has landed, sending vehicles home early when their battery no longer
covers the planned search (the live DTSCS return trigger, docs/fly.md).

`FlightController` publishes what happens as `FlightEvent`s (`subscribe`): stage changes, take-
offs, flight-mode changes and sensor readings, the moment the controller sees them; the Rerun
recorder and the MQTT feed listen, and sample only the telemetry. What it has to tell the
operator goes, as stamped lines, to one output channel (`out`, `say`); it draws nothing itself
(the live table is `gcs.display.status_table.LiveTable`, given by whoever starts the flight).
`gcs.flight.fly.fly_async` wires links, listeners and the online planner around one controller.

Besides its own loop (`run`), the controller offers what the flight modules that drive the
vehicles beside it need (the online planner, a resumed flight): `set_stage`, `update_stage`,
`mark_lost`, `claim` / `release`, `take_orders`, `recover_readings`, `wait_until`, `spawn`,
`emit`, `interrupted`."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import MissionTransferError, MissionType, upload_verified
from gcs.errors import UserError
from gcs.flight.events import (
    FlightEvent,
    FlightListener,
    LinkChanged,
    MissionUploaded,
    ModeChanged,
    ReadingReceived,
    StageChanged,
    TookOff,
)
from gcs.flight.vehicle_flight import Legs, VehicleFlight
from gcs.links import CommandError, LinkError, LinkStatus, MavLink, mavlink
from gcs.plans.plan_folder import FleetPlan
from gcs.plans.vehicle_file import stock_profile
from gcs.telemetry.status import FINAL_STAGES, Stage, VehicleStatus
from planner.energy import EnergyProfile
from planner.return_exact import follow_table


class FlightAborted(UserError):
    """The controller failed mid-flight; every vehicle in the air was sent home first."""

    exit_code = 1



#: Farther than this from its airport a vehicle has landed away, by airframe: a copter lands on its
#: spot, a plane rolls out along its runway.
LANDED_AWAY_M = {"copter": 25.0, "plane": 200.0}

REFUSED_FOR_NOW = (mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_FAILED)


@dataclass
class FlyOptions:
    """Knobs of a flight; times are real (wall-clock) seconds unless named otherwise.

    `profiles[uav]`: the energy profile of the vehicle flying as that UAV (`gcs fly --vehicles`);
    a UAV without one gets its autopilot's stock profile (`gcs.plans.vehicle_file.stock_profile`).
    `confirm_s`: vehicle seconds the return trigger must hold before it is acted on.
    `fit_charge`: a vehicle whose charge cannot pay for its plan flies a range cut to its charge
    instead of being kept on the ground. `wind_m_s`: (east, north) m/s the air moves towards, as
    the crew measured it at launch: the check before arming and the trigger price the plan in it
    until the vehicle's own wind reading replaces it. `vehicles_file`: the vehicles.json the profiles this
    flight learns are merged into. `landed_away_m[airframe]`: farther than this from its airport a
    vehicle has landed away."""

    reserve_pct: float = 30.0
    profiles: dict[int, EnergyProfile] = field(default_factory=dict)
    confirm_s: float = 3.0
    fit_charge: bool = False
    wind_m_s: tuple[float, float] | None = None
    vehicles_file: str | None = None
    landed_away_m: dict[str, float] = field(default_factory=lambda: dict(LANDED_AWAY_M))
    link_timeout_s: float = 3.0
    lost_giveup_s: float = 20.0
    connect_timeout_s: float = 15.0
    gps_timeout_s: float = 120.0
    arm_timeout_s: float = 60.0
    transfer_timeout_s: float = 0.5
    command_timeout_s: float = 0.5
    tick_s: float = 0.05
    # the live table: drawn by `gcs.display.status_table.LiveTable`, never by the controller;
    # `fly_async` still honours these two for callers that give no `out` (see its docstring)
    fence: bool = True
    return_after_s: dict[int, float] = field(default_factory=dict)
    fly: bool = True
    lookahead_steps: int = 2
    check_home: bool = True
    ready_timeout_s: float = 180.0


class FlightController:
    """Uploads, launches and watches one fleet; returns are decided here, by pure functions."""

    def __init__(self, plan: FleetPlan, links: list[MavLink], options: FlyOptions | None = None,
                 out: Callable[[str], None] | None = None) -> None:
        self.plan = plan
        self.links = links
        self.options = options = options or FlyOptions()
        self.out = out or (lambda line: print(line, flush=True))
        self.vehicles = {uid: VehicleFlight(plan, task, self._profile(uid, task.vehicle.value),
                                            reserve_pct=options.reserve_pct, confirm_s=options.confirm_s,
                                            wind_m_s=options.wind_m_s)
                         for uid, task in plan.uavs.items()}
        self.status = {uid: v.status for uid, v in self.vehicles.items()}
        self.link_of: dict[int, MavLink] = {}
        self.reading_component: dict[int, int] = {}  # a vehicle's readings come from this component
        self.operator_range: dict[int, float] = {}  # ranges (metres along the plan from take-off) set by the operator
        self._track_m = {uid: np.array([plan.local_m(p.lat_deg, p.lon_deg) for p in task.trajectory])
                         for uid, task in plan.uavs.items()}
        self._along_m = {uid: np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(track, axis=0).T))])
                         for uid, track in self._track_m.items()}
        self._orders: list[tuple[int, str]] = []
        self._busy: set[int] = set()
        self._stay_on_ground: set[int] = set()
        self._last_recovery = 0.0
        self._tasks: set[asyncio.Task] = set()
        self._lost_since: dict[int, float] = {}
        self._stage_before_loss: dict[int, Stage] = {}
        self._interrupted = False
        self.t0 = time.monotonic()
        self.loop_latency_s: list[float] = []
        self.upload_reports: dict[int, dict] = {}
        self.return_latency_s: dict[int, float] = {}
        self._listeners: list[FlightListener] = []
        for link in links:
            link.subscribe(lambda msg, link=link: self._on_message(link, msg))
            link.on_status(lambda status, link=link: self._on_link_status(link, status))

    # ---- messages ----------------------------------------------------------------------

    def _on_message(self, link: MavLink, msg) -> None:
        """Telemetry from each vehicle's autopilot; readings (CAMERA_IMAGE_CAPTURED) from any of its
        components, e.g. a detector on a companion computer (`gcs detector`)."""
        uid = msg.get_srcSystem()
        status = self.status.get(uid)
        if status is None:
            return
        component = msg.get_srcComponent()
        if component != mavlink.MAV_COMP_ID_AUTOPILOT1:
            if msg.get_type() != "CAMERA_IMAGE_CAPTURED":
                return
            self.reading_component[uid] = component
        self.link_of.setdefault(uid, link)
        readings, airborne, mode = len(status.detections), status.airborne_seen, status.mode_name
        status.update(msg, time.monotonic())
        vehicle = self.vehicles[uid]
        vehicle.on_message(msg)
        while vehicle.notes:
            self.say(uid, vehicle.notes.pop(0))
        if status.airborne_seen and not airborne:
            self.emit(TookOff(uid, status.rel_alt_m, status.mode_name))
        if status.mode_name != mode:
            self.emit(ModeChanged(uid, mode, status.mode_name))
        for detection in status.detections[readings:]:
            self.emit(ReadingReceived(uid, detection))

    def _on_link_status(self, link: MavLink, status: LinkStatus) -> None:
        uids = tuple(sorted(uid for uid, heard_on in self.link_of.items() if heard_on is link))
        self.say(None, f"{status}{' - UAV ' + ', '.join(map(str, uids)) if uids else ''}")
        self.emit(LinkChanged(status, uids))

    # ---- listeners ---------------------------------------------------------------------

    def subscribe(self, listener: FlightListener) -> Callable[[], None]:
        """Call `listener(event, monotonic_time)` for every `FlightEvent` from now on; returns
        the call that unsubscribes it. A listener that raises is reported and dropped: it never
        stops the flight."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    def emit(self, event: FlightEvent) -> None:
        """Hand `event` to every listener now: the controller's own events, and those of the
        modules that drive vehicles beside it (`Reattached` from a resumed flight)."""
        now = time.monotonic()
        for listener in list(self._listeners):
            try:
                listener(event, now)
            except Exception as exc:  # a recorder or bus bug must not stop the flight
                self._listeners.remove(listener)
                self.say(None, f"error: event listener {getattr(listener, '__qualname__', listener)} dropped "
                               f"({type(exc).__name__}: {exc})")

    def say(self, uid: int | None, text: str) -> None:
        """Tell the operator: one line, stamped with the flight time (and the UAV), to `out`, the
        controller's only output channel."""
        stamp = f"[{time.monotonic() - self.t0:6.1f}s]"
        self.out(f"{stamp} UAV {uid}: {text}" if uid is not None else f"{stamp} {text}")

    def recover_readings(self, now: float) -> None:
        """Ask again (MAV_CMD_REQUEST_MESSAGE, param2 = image index) for readings lost on the link;
        at most once a second, whoever calls it."""
        if now - self._last_recovery < 1.0:
            return
        self._last_recovery = now
        for uid, st in self.status.items():
            link = self.link_of.get(uid)
            if link is None or st.stage is Stage.LOST:
                continue
            component = self.reading_component.get(uid, mavlink.MAV_COMP_ID_AUTOPILOT1)
            for index in st.lost_detections[:5]:
                link.send(mavlink.MAVLink_command_long_message(
                    uid, component, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED,
                    index, 0, 0, 0, 0, 0))


    def set_stage(self, uid: int, stage: Stage, note: str = "") -> None:
        """Move a vehicle to `stage` (`note`, when given, is kept even if the stage stays): said,
        and a `StageChanged` for the listeners, when the stage changes."""
        st, before = self.status[uid], self.status[uid].stage
        if note:
            st.note = note
        if before is not stage:
            st.stage = stage
            self.say(uid, f"{stage.value}{' - ' + note if note else ''}")
            self.emit(StageChanged(uid, before, stage, note))

    # ---- operator ------------------------------------------------------------------------

    def order_return(self, uid: int, reason: str = "order") -> None:
        """A return order (from the operator or a command); ValueError for an unknown UAV."""
        if uid not in self.status:
            raise ValueError(f"unknown UAV {uid} (the plan has {', '.join(map(str, sorted(self.status)))})")
        self._orders.append((uid, reason))

    def set_range(self, uid: int, range_m: float) -> None:
        """The operator's new range T_i for a UAV, in metres along its plan from take-off: from
        now on the vehicle searches only while the way home still fits in it (as in the planner,
        eq. 23), whatever its battery would allow. ValueError for an unknown UAV or a range that
        is not a positive number of metres."""
        if uid not in self.status:
            raise ValueError(f"unknown UAV {uid} (the plan has {', '.join(map(str, sorted(self.status)))})")
        if not (math.isfinite(range_m) and range_m > 0):
            raise ValueError(f"range must be a positive number of metres, not {range_m:g}")
        self.operator_range[uid] = float(range_m)
        self.say(uid, f"range set to {range_m:.0f} m ({self.flown_along_plan_m(uid):.0f} m flown)")

    def flown_along_plan_m(self, uid: int) -> float:
        """Metres of the plan behind the vehicle: its trajectory's length up to the pose it is at."""
        along = self._along_m[uid]
        return float(along[min(self.status[uid].track_index, len(along) - 1)])

    def _profile(self, uid: int, airframe: str, autopilot: str = "ardupilot") -> EnergyProfile:
        """The energy profile the vehicle flying as `uid` is priced with: the one given for it, else
        its autopilot's stock profile for its airframe."""
        return self.options.profiles.get(uid) or stock_profile(autopilot, airframe)

    def interrupt(self) -> None:
        """Ctrl-C: bring everyone home, then stop."""
        self._interrupted = True

    @property
    def interrupted(self) -> bool:
        """The operator stopped the flight (`interrupt`, Ctrl-C): every vehicle is brought home,
        and loops driving vehicles beside the controller stop."""
        return self._interrupted

    def take_orders(self) -> list[tuple[int, str]]:
        """The return orders (UAV, reason) given since the last call, now the caller's to carry
        out (the controller's `tick`, or the online planner, which makes its own returns)."""
        orders, self._orders = self._orders, []
        return orders

    def claim(self, uid: int) -> None:
        """Another task commands this vehicle (an upload, a return, a reattachment): until
        `release`, the loop neither advances its track nor evaluates its return trigger, and an
        autopilot RTL or LAND is not taken for the autopilot's own return."""
        self._busy.add(uid)

    def release(self, uid: int) -> None:
        """End a `claim`: the loop watches the vehicle again."""
        self._busy.discard(uid)

    # ---- preparation ---------------------------------------------------------------------

    async def wait_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        """Poll `predicate` (every 20 ms) until it holds: True; False after `timeout_s`."""
        end = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > end:
                return False
            await asyncio.sleep(0.02)
        return True

    async def command(self, uid: int, cmd: int, *params: float, retries: int = 3) -> int:
        link = self.link_of.get(uid)
        if link is None:
            raise CommandError(f"command to vehicle {uid}", None, "vehicle not connected")
        return await link.command(uid, cmd, *params, timeout_s=self.options.command_timeout_s, retries=retries)

    async def set_mode(self, uid: int, name: str) -> None:
        st = self.status[uid]
        autopilot = st.autopilot or Autopilot.GENERIC
        await self.command(uid, mavlink.MAV_CMD_DO_SET_MODE, *autopilot.set_mode_params(st.mav_type, name))

    async def set_param(self, uid: int, name: str, value: float, timeout_s: float = 1.0, tries: int = 3) -> bool:
        """PARAM_SET, confirmed by the PARAM_VALUE echo (ArduPilot answers with the new value)."""
        link = self.link_of[uid]
        raw = name.encode()
        for _ in range(tries):
            async with link.listen(uid, ("PARAM_VALUE",)) as queue:
                link.send(mavlink.MAVLink_param_set_message(uid, mavlink.MAV_COMP_ID_AUTOPILOT1, raw, value,
                                                            mavlink.MAV_PARAM_TYPE_REAL32))
                end = time.monotonic() + timeout_s
                while (left := end - time.monotonic()) > 0:
                    try:
                        msg = await asyncio.wait_for(queue.get(), left)
                    except TimeoutError:
                        break
                    param_id = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode(errors="replace")
                    if param_id.rstrip("\x00") == name:
                        return abs(msg.param_value - value) < 1e-6
        return False

    async def prepare(self, uid: int, mission: bool = True) -> bool:
        """Connect, ask for the telemetry, wait until the vehicle is ready to fly (GPS fix, the
        estimator's position, a home), check its home is the plan's airport, upload and verify
        (unless `mission` is False). False (and stage FAILED with a clear note) when anything
        cannot be done."""
        opts, st, task = self.options, self.status[uid], self.plan.uavs[uid]
        self.set_stage(uid, Stage.CONNECTING)
        if not await self.wait_until(lambda: st.autopilot is not None, opts.connect_timeout_s):
            links = ", ".join(link.name for link in self.links)
            self.set_stage(uid, Stage.FAILED, f"no HEARTBEAT from system id {uid} within {opts.connect_timeout_s:g} s "
                                              f"on {links}")
            return False
        link = self.link_of[uid]
        if link.signing is None and uid in link.signing_systems:
            self.set_stage(uid, Stage.FAILED, f"vehicle {uid} signs its MAVLink messages and will refuse ours: give "
                                              "the station its key (--signing-key or --signing-passphrase)")
            return False
        self.set_stage(uid, Stage.PREPARING, f"{st.autopilot.value} autopilot")
        await self.request_streams(uid)
        if not await self._wait_ready(uid):
            return False
        if not self._home_matches(uid):
            return False
        await self._battery_setup(uid)
        for name, value in st.autopilot.param_changes_before_arming(st.fixed_wing, task.approach is not None).items():
            if await self.set_param(uid, name, value):
                self.say(uid, f"{name} set to {value:g}: RTL lands on the runway through the mission's landing sequence"
                         if name == "RTL_AUTOLAND" else f"{name} set to {value:g}")
            else:
                self.say(uid, f"warning: {name} not confirmed; the autopilot may refuse to arm")
        if not mission:
            return True
        self.set_stage(uid, Stage.UPLOADING)
        autopilot = st.autopilot
        try:
            items = task.mission_wire(autopilot)
        except ValueError as exc:
            self.set_stage(uid, Stage.FAILED, f"mission not uploaded: {exc}")
            return False
        try:
            report = await upload_verified(link, uid, items, autopilot, timeout_s=opts.transfer_timeout_s,
                                           fixed_wing=st.fixed_wing)
        except MissionTransferError as exc:
            self.set_stage(uid, Stage.FAILED, f"mission {exc}")
            return False
        self.upload_reports[uid] = {"mission": report}
        self.emit(MissionUploaded(uid, "search"))
        extra = []
        if opts.fence:
            for kind, items in ((MissionType.FENCE, task.fence_wire()), (MissionType.RALLY, task.rally_wire())):
                if not items:
                    continue
                try:
                    self.upload_reports[uid][kind.name.lower()] = await upload_verified(
                        link, uid, items, autopilot, kind, timeout_s=opts.transfer_timeout_s)
                    extra.append(f"{len(items)} {kind.name.lower()}")
                except MissionTransferError as exc:
                    self.say(uid, f"warning: {exc}; flying without it")
        self.say(uid, f"mission verified: {report.items} items"
                      f"{' + ' + ', '.join(extra) if extra else ''} in {report.elapsed_s:.2f} s "
                      f"({report.resends} re-sends{', legacy MISSION_REQUEST used' if report.legacy_requests else ''})")
        return True

    async def _battery_setup(self, uid: int) -> None:
        """Before the flight: the vehicle's stock profile for its autopilot and airframe (unless
        one was given), the pack capacity its autopilot counts with, and its board's unique id
        (AUTOPILOT_VERSION, the key of its learned profile)."""
        st, vehicle = self.status[uid], self.vehicles[uid]
        autopilot = (st.autopilot or Autopilot.GENERIC).value
        airframe = "plane" if st.fixed_wing else "copter"
        vehicle.autopilot = autopilot
        if uid not in self.options.profiles:
            vehicle.set_profile(stock_profile(autopilot, airframe))
        name = (st.autopilot or Autopilot.GENERIC).capacity_param()
        if name is not None:
            capacity = await self.get_param(uid, name)
            if capacity is not None and capacity > 0:
                vehicle.fuel.set_capacity(capacity)
        try:
            await self.command(uid, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                               retries=2)
        except CommandError:
            pass  # keyed by its system id

    async def get_param(self, uid: int, name: str, timeout_s: float = 1.0, tries: int = 3) -> float | None:
        """PARAM_REQUEST_READ by name; the value, or None when the vehicle does not answer (an
        unknown name gets no answer from ArduPilot)."""
        link = self.link_of[uid]
        raw = name.encode()
        for _ in range(tries):
            async with link.listen(uid, ("PARAM_VALUE",)) as queue:
                link.send(mavlink.MAVLink_param_request_read_message(uid, mavlink.MAV_COMP_ID_AUTOPILOT1, raw, -1))
                end = time.monotonic() + timeout_s
                while (left := end - time.monotonic()) > 0:
                    try:
                        msg = await asyncio.wait_for(queue.get(), left)
                    except TimeoutError:
                        break
                    param_id = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode(errors="replace")
                    if param_id.rstrip("\x00") == name:
                        return float(msg.param_value)
        return None

    async def request_streams(self, uid: int) -> None:
        """Ask the vehicle for the telemetry its autopilot needs (`Autopilot.streams_hz`); a
        stream it refuses is noted in `unsupported_streams` and said."""
        st = self.status[uid]
        for msg_id, hz in st.autopilot.streams_hz().items():
            try:
                await self.command(uid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=2)
            except CommandError as exc:
                st.unsupported_streams.add(msg_id)
                name = mavlink.mavlink_map[msg_id].msgname if msg_id in mavlink.mavlink_map else msg_id
                self.say(uid, f"stream {name} not set ({exc}); using what the vehicle sends")
        for msg_id, hz in st.autopilot.optional_streams_hz().items():
            try:
                await self.command(uid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=1)
            except CommandError:
                st.unsupported_streams.add(msg_id)

    async def _wait_ready(self, uid: int) -> bool:
        """Until `VehicleStatus.waiting_for` is empty, showing what is missing (and the
        autopilot's own words) whenever that changes."""
        st, end = self.status[uid], time.monotonic() + self.options.ready_timeout_s
        shown: tuple = ()
        while missing := st.waiting_for():
            now = (tuple(missing), st.last_text)
            if now != shown:
                shown = now
                said = f" - autopilot: {st.last_text}" if st.last_text else ""
                self.set_stage(uid, Stage.PREPARING, f"waiting for {', '.join(missing)}{said}")
                self.say(uid, f"waiting for {', '.join(missing)}{said}")
            if time.monotonic() > end:
                autopilot = f" ({st.last_text})" if st.last_text else ""
                self.set_stage(uid, Stage.FAILED, f"not ready after {self.options.ready_timeout_s:g} s: no "
                                                  f"{', '.join(missing)}{autopilot}")
                return False
            await asyncio.sleep(0.05)
        self.say(uid, "ready: " + ", ".join(part for part in (
            f"GPS fix {st.gps_fix_type}" + (f" ({st.satellites} satellites)" if st.satellites else "")
            if st.gps_fix_type is not None else "", "EKF position" if st.ekf_position_ok else "",
            "home set" if st.home else "") if part))
        return True

    def _home_matches(self, uid: int) -> bool:
        """The vehicle's home (HOME_POSITION, else its position) must be the plan's airport, within
        a cell; refused, naming both, unless the operator allowed the offset (`check_home`)."""
        st, task = self.status[uid], self.plan.uavs[uid]
        here = st.home[:2] if st.home else (st.lat_deg, st.lon_deg)
        away = _distance_m(self.plan, here, task.airport_lat_lon)
        if away <= self.plan.cell_size_m:
            return True
        what = (f"vehicle {uid}'s home {here[0]:.7f}, {here[1]:.7f} is {away:.0f} m from UAV {uid}'s airport "
                f"{task.name!r} at {task.airport_lat_lon[0]:.7f}, {task.airport_lat_lon[1]:.7f} (more than a cell, "
                f"{self.plan.cell_size_m:g} m)")
        if not self.options.check_home:
            self.say(uid, f"warning: {what}; flying anyway (--allow-home-offset)")
            return True
        self.set_stage(uid, Stage.FAILED, f"{what}: is system id {uid} the right vehicle? (--allow-home-offset "
                                          "flies anyway)")
        return False

    async def launch(self, uid: int) -> bool:
        """Arm and start the mission the way the autopilot wants it (`Autopilot.arm_mode`,
        `start_after_arming`): ArduCopter GUIDED, arm, MISSION_START; ArduPlane AUTO, arm (it
        takes off by itself). Arming is retried while the autopilot refuses, as real ones do
        for a while after boot, and every new reason it gives is shown. A vehicle that armed
        but could not be started is disarmed again: nothing is left armed on the ground."""
        opts, st = self.options, self.status[uid]
        autopilot = st.autopilot or Autopilot.GENERIC
        if not self._charge_covers_plan(uid):
            return False
        self.set_stage(uid, Stage.ARMING)
        mode = autopilot.arm_mode(st.fixed_wing)
        if mode is not None:
            try:
                await self.set_mode(uid, mode)
            except CommandError as exc:
                self.set_stage(uid, Stage.FAILED, f"cannot switch to {mode} to arm: {exc}{_said(st)}")
                return False
        end = time.monotonic() + opts.arm_timeout_s
        reasons: list[str] = []
        while True:
            if self._ordered_home(uid):
                self.set_stage(uid, Stage.LANDED, "kept on the ground: return ordered before take-off")
                return False
            try:
                await self.command(uid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                break
            except CommandError as exc:
                reason = st.last_text or str(exc)
                if exc.result not in REFUSED_FOR_NOW or time.monotonic() > end:
                    self.set_stage(uid, Stage.FAILED, f"cannot arm: {exc}{_said(st)}; left on the ground")
                    return False
                if reason not in reasons:
                    reasons.append(reason)
                    self.say(uid, f"arming refused: {reason} (retrying for up to {opts.arm_timeout_s:g} s)")
                await asyncio.sleep(1.0)
        if self._ordered_home(uid):
            await self._keep_on_ground(uid)
            return False
        if autopilot.start_after_arming(st.fixed_wing):
            try:
                await self._start_mission(uid)
            except CommandError as exc:
                disarmed = await self.disarm(uid)
                self.set_stage(uid, Stage.FAILED, f"cannot start the mission: {exc}{_said(st)}; "
                                                  + ("disarmed again" if disarmed else "COULD NOT DISARM: check it"))
                return False
        self.set_stage(uid, Stage.SEARCH, "mission started")
        return True

    def _charge_covers_plan(self, uid: int) -> bool:
        """Before arming: does the charge the vehicle reports now pay for its plan (launch, the
        mission path, the landing) and leave the reserve, at its profile's prices? When it does
        not, the vehicle stays on the ground (FAILED, naming both figures), or with `fit_charge`
        flies a range cut to what its charge pays for. A charge not reported yet is not checked."""
        vehicle, st, task = self.vehicles[uid], self.status[uid], self.plan.uavs[uid]
        fuel, profile = vehicle.fuel, vehicle.profile
        have = fuel.remaining_mah
        if have is None:
            self.say(uid, "warning: no battery report yet; its charge is not checked against its plan")
            return True
        path_m = float(self.plan.raw_uav(uid).get("length_m", self._along_m[uid][-1]))
        reserve = fuel.reserve_mah(self.options.reserve_pct)
        ends = profile.launch_cost_mah(task.altitude_m) + profile.landing_cost_mah(vehicle.landing_altitude_m)
        legs = [(float(e), float(n)) for e, n in np.diff(self._track_m[uid], axis=0)]
        along = fuel.way_cost(legs)
        per_m = along.mah / along.metres if along.metres > 0 else fuel.rate_mah_per_m  # the wind known included
        need = ends + per_m * path_m + reserve
        pct = f"{st.battery_pct:.0f}%" if st.battery_pct is not None else "charge"
        wind = "" if fuel.wind_m_s is None else " in the wind"
        if have >= need:
            self.say(uid, f"charge {pct} ({have:.0f} of {fuel.capacity_mah:.0f} mAh) pays for its {path_m:.0f} m plan"
                          f"{wind}: {need:.0f} mAh with the {self.options.reserve_pct:g}% reserve")
            return True
        covers_m = max(0.0, have - reserve - ends) / per_m
        what = (f"charge {pct} = {have:.0f} mAh pays for {covers_m:.0f} m of its plan's {path_m:.0f} m{wind} (the plan "
                f"needs {need:.0f} mAh with the {self.options.reserve_pct:g}% reserve of a {fuel.capacity_mah:.0f} mAh "
                f"pack)")
        if not self.options.fit_charge:
            self.set_stage(uid, Stage.FAILED, f"not armed: {what}; charge it, or fly a range cut to its charge "
                                              "(--fit-charge)")
            return False
        overhead = max(0.0, path_m - float(self._along_m[uid][-1]))
        if len(task.trajectory) > 1:
            home = fuel.way_cost(self._home_legs(uid, 1))
            shortest_m = float(self._along_m[uid][1]) + home.metres
            shortest_mah = float(self._along_m[uid][1]) * per_m + home.mah
        else:
            shortest_m = shortest_mah = 0.0
        if (covers_m - overhead) * per_m < shortest_mah:
            self.set_stage(uid, Stage.FAILED, f"not armed: {what}, less than its shortest way out and home "
                                              f"({shortest_m:.0f} m{wind})")
            return False
        self.operator_range[uid] = covers_m - overhead
        self.say(uid, f"{what}: flying a range cut to {covers_m - overhead:.0f} m along its plan (--fit-charge)")
        return True

    async def _start_mission(self, uid: int, patience_s: float = 3.0) -> None:
        """MISSION_START(0, 0), asked again for a few seconds while it is refused: PX4 checks a
        new mission in the background and may refuse a start right after the upload."""
        autopilot = self.status[uid].autopilot or Autopilot.GENERIC
        end = time.monotonic() + patience_s
        while True:
            try:
                await self.command(uid, mavlink.MAV_CMD_MISSION_START, *autopilot.mission_start_params())
                return
            except CommandError as exc:
                if exc.result not in REFUSED_FOR_NOW or time.monotonic() > end:
                    raise
                await asyncio.sleep(0.5)

    def _ordered_home(self, uid: int) -> bool:
        return self._interrupted or uid in self._stay_on_ground or any(o[0] == uid for o in self._orders)

    async def _keep_on_ground(self, uid: int) -> bool:
        """A vehicle ordered home after its mission started but before it left the ground:
        disarm it there. False when it would not disarm (it is already lifting off: it then
        comes home like any other)."""
        if not await self.disarm(uid):
            return False
        self.set_stage(uid, Stage.LANDED, "kept on the ground: return ordered before take-off")
        return True

    async def disarm(self, uid: int) -> bool:
        """Disarm a vehicle on the ground; False when it did not confirm."""
        try:
            await self.command(uid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, retries=5)
        except LinkError as exc:
            self.say(uid, f"disarm not acknowledged: {exc}")
            return False
        return True

    async def prepare_and_launch(self, uid: int) -> None:
        """`prepare`, then (unless `options.fly` is off) `launch`, the vehicle claimed meanwhile;
        a link failure leaves it FAILED."""
        self.claim(uid)
        try:
            if await self.prepare(uid) and self.options.fly:
                await self.launch(uid)
        except LinkError as exc:
            self.set_stage(uid, Stage.FAILED, str(exc))
        finally:
            self.release(uid)

    async def upload_all(self) -> dict[int, bool]:
        """Prepare every vehicle concurrently; True where the upload verified."""
        results = await asyncio.gather(*(self.prepare(uid) for uid in self.plan.uavs), return_exceptions=True)
        out = {}
        for uid, res in zip(self.plan.uavs, results):
            if isinstance(res, BaseException):
                self.set_stage(uid, Stage.FAILED, str(res))
                res = False
            out[uid] = bool(res)
        return out

    # ---- the return ----------------------------------------------------------------------

    def _pose_next(self, uid: int) -> tuple[int, int, int]:
        traj = self.plan.uavs[uid].trajectory
        p = traj[min(self.status[uid].track_index + 1, len(traj) - 1)]
        return p.x, p.y, p.heading

    def return_leg(self, uid: int) -> list[tuple[float, float]]:
        """Lat/lon turn points of the lowest-cost OC-respecting way home from the pose after the
        current step (the exact table's path), straight runs merged, ending at the airport cell."""
        pose = self._pose_next(uid)
        table = self.plan.return_table(uid)
        path = [pose] + follow_table(table, pose, self.plan.oc.successors, self.plan.no_fly, self.plan.move_costs)
        keep = [path[0]] + [path[i] for i in range(1, len(path) - 1) if path[i + 1][2] != path[i][2]] + [path[-1]]
        return [self.plan.cell_lat_lon(x, y) for x, y, _ in keep] if len(path) > 1 else \
            [self.plan.cell_lat_lon(pose[0], pose[1])]

    async def send_home(self, uid: int, reason: str) -> None:
        """Fly the planned return leg to the UAV's own airport and land there: hold (the vehicle
        must not fly AUTO while its mission is replaced: ArduPilot swaps items as they arrive),
        upload the leg and the landing (a plane's runway sequence), verify, point the mission at
        its first item (MISSION_START alone resumes where the old mission was) and start it. The
        autopilot's RTL only when any of that fails, and the operator is told."""
        st, task = self.status[uid], self.plan.uavs[uid]
        if st.stage in FINAL_STAGES or st.stage in (Stage.RETURN, Stage.RTL):
            return
        st.return_reason = reason
        if not st.airborne_seen:
            self._stay_on_ground.add(uid)
            if st.stage is not Stage.SEARCH:
                return  # not launched yet: launch() sees it and keeps it on the ground
            if await self._keep_on_ground(uid):
                return  # started, still on the ground: disarmed there; else it is lifting off
        self.set_stage(uid, Stage.RETURN, f"going home ({reason})")
        self.claim(uid)
        started = time.monotonic()
        try:
            leg = self.return_leg(uid)
            autopilot = st.autopilot or Autopilot.GENERIC
            self.vehicles[uid].holding = True
            held_from = st.time_boot_s
            await self.set_mode(uid, autopilot.hold_mode(st.fixed_wing))
            await upload_verified(self.link_of[uid], uid, task.return_wire(autopilot, leg), autopilot,
                                  timeout_s=self.options.transfer_timeout_s, fixed_wing=st.fixed_wing)
            self.emit(MissionUploaded(uid, "return", tuple(leg)))
            if autopilot.restart_needs_current_item():
                await self.command(uid, mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, autopilot.first_mission_seq())
            await self._start_mission(uid)
            self.vehicles[uid].holding = False
            held = st.time_boot_s - held_from  # what a return's hold takes, in the vehicles' time
            for vehicle in self.vehicles.values():
                vehicle.hold_s = max(vehicle.hold_s, held)
            self.return_latency_s[uid] = time.monotonic() - started
            self.say(uid, f"return leg of {len(leg)} waypoints uploaded and started")
        except (LinkError, MissionTransferError, ValueError, KeyError) as exc:
            self.say(uid, f"the planned return could not be flown ({exc}); commanding the autopilot's RTL, which "
                          "flies straight home and ignores the planned path")
            await self.rtl(uid)
        finally:
            self.vehicles[uid].holding = False
            self.release(uid)

    async def rtl(self, uid: int) -> bool:
        try:
            await self.command(uid, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, retries=5)
        except LinkError as exc:
            self.say(uid, f"RTL not acknowledged: {exc}")
            return False
        self.set_stage(uid, Stage.RTL, "autopilot RTL")
        return True

    def spawn(self, coro) -> None:
        """Run `coro` as a task the controller owns: cancelled when the flight is stopped
        (`bring_everyone_home`) or stops waiting for lost vehicles."""
        task = asyncio.create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # ---- monitoring ----------------------------------------------------------------------

    def _advance_track(self, uid: int) -> None:
        st = self.status[uid]
        if not st.has_position:
            return
        track = self._track_m[uid]
        pos = np.array(self.plan.local_m(st.lat_deg, st.lon_deg))
        i = st.track_index
        while i + 1 < len(track) and np.hypot(*(track[i + 1] - pos)) <= np.hypot(*(track[i] - pos)):
            i += 1
        st.track_index = i
        st.steps_flown = float(i)

    def _circuit_legs(self, uid: int) -> Legs:
        """A plane flies out to its approach point and back before it lands (a copter lands where
        the way home ends): those legs, in metres."""
        task = self.plan.uavs[uid]
        if task.approach is None:
            return []
        airport = np.array(self.plan.local_m(*task.airport_lat_lon))
        approach = np.array(self.plan.local_m(task.approach.lat_deg, task.approach.lon_deg))
        out = approach - airport
        return [(float(out[0]), float(out[1])), (float(-out[0]), float(-out[1]))]

    def _home_legs(self, uid: int, index: int) -> Legs:
        """The planned way home from trajectory pose `index` (the exact table's path under the OC),
        cell centre to cell centre, and on to the airport point: legs in metres, kept per pose."""
        vehicle = self.vehicles[uid]
        legs = vehicle.home_legs.get(index)
        if legs is None:
            p = self.plan.uavs[uid].trajectory[index]
            pose = (p.x, p.y, p.heading)
            path = [pose] + follow_table(self.plan.return_table(uid), pose, self.plan.oc.successors, self.plan.no_fly,
                                         self.plan.move_costs)
            points = np.array([self.plan.grid.centre_m(x, y) for x, y, _ in path]
                              + [self.plan.local_m(*self.plan.uavs[uid].airport_lat_lon)])
            legs = [(float(e), float(n)) for e, n in np.diff(points, axis=0)]
            vehicle.home_legs[index] = legs
        return legs

    def evaluate(self, uid: int) -> bool:
        """The return trigger's check for one searching vehicle (`VehicleFlight.evaluate`): the
        next `lookahead_steps` poses of its plan, the way home from each, the landing circuit;
        True when it must turn home now. Its status shows the range left and margin (metres)."""
        vehicle, st, task = self.vehicles[uid], self.status[uid], self.plan.uavs[uid]
        start = st.track_index + 1
        ahead = task.trajectory[start: start + self.options.lookahead_steps]
        if not ahead or ahead[0].stage != "search" or not st.has_position:
            vehicle.decision = None
            st.margin = math.inf  # the plan's own return (or its end): already the lowest-cost way home
            return False
        track = self._track_m[uid]
        here = np.array(self.plan.local_m(st.lat_deg, st.lon_deg))
        steps_ahead, home = [], []
        for j, p in enumerate(ahead):
            if p.stage != "search":
                break
            points = np.vstack([[here], track[start: start + j + 1]])
            steps_ahead.append([(float(e), float(n)) for e, n in np.diff(points, axis=0)])
            home.append(self._home_legs(uid, start + j))
        ordered = None
        if uid in self.operator_range:
            ordered = max(0.0, self.operator_range[uid] - self.flown_along_plan_m(uid))
        vehicle.evaluate(steps_ahead, home, self._circuit_legs(uid), ordered)
        return st.airborne_seen and st.stage is Stage.SEARCH and vehicle.must_return(st.time_boot_s)

    def mark_lost(self, uid: int, note: str, now: float, before: Stage | None = None) -> None:
        """Stage LOST from `now` (monotonic): heard again, the vehicle gets `before` back (by
        default the stage it has now); past `lost_giveup_s` the flight stops waiting for it."""
        self._stage_before_loss[uid] = before if before is not None else self.status[uid].stage
        self._lost_since[uid] = now
        self.set_stage(uid, Stage.LOST, note)

    def update_stage(self, uid: int, now: float) -> None:
        """The stage the telemetry implies: LOST after `link_timeout_s` of silence and back when
        heard, LANDED once down after flying, RTL when the autopilot turned home by itself."""
        st = self.status[uid]
        if st.last_heard_s is not None and st.stage not in FINAL_STAGES:
            silent = now - st.last_heard_s > self.options.link_timeout_s
            if silent and st.stage is not Stage.LOST:
                self.mark_lost(uid, f"no telemetry for {self.options.link_timeout_s:g} s; the others carry on", now)
            elif not silent and st.stage is Stage.LOST:
                self._lost_since.pop(uid, None)
                self.set_stage(uid, self._stage_before_loss.pop(uid, Stage.SEARCH), "link back")
        if st.stage in (Stage.SEARCH, Stage.RETURN, Stage.RTL) and st.airborne_seen and not st.airborne \
                and (not st.armed or st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND):
            self._touched_down(uid)
        elif st.stage is Stage.SEARCH and st.mode_name in ("RTL", "LAND") and uid not in self._busy:
            st.return_reason = "autopilot"
            self.set_stage(uid, Stage.RTL,
                           f"autopilot switched to {st.mode_name} ({st.last_text or 'no reason given'})")

    def _touched_down(self, uid: int) -> None:
        """Down after flying: LANDED at its airport, or LANDED_AWAY (where it is, for the crew that
        must fetch it) farther than `landed_away_m` from it; then what the flight cost against
        what its profile predicted at launch."""
        st, task, vehicle = self.status[uid], self.plan.uavs[uid], self.vehicles[uid]
        st.battery_at_landing = st.battery_pct
        battery = f"battery {st.battery_pct:.0f}%" if st.battery_pct is not None else "battery unknown"
        if st.has_position:
            away = _distance_m(self.plan, (st.lat_deg, st.lon_deg), task.airport_lat_lon)
            st.landed_from_airport_m = away
            limit = self.options.landed_away_m.get(task.vehicle.value, 25.0)
            if away > limit:
                self.set_stage(uid, Stage.LANDED_AWAY,
                               f"LANDED AWAY at {st.lat_deg:.6f}, {st.lon_deg:.6f}, {away:.0f} m from its airport "
                               f"{task.name!r} ({battery}): fetch it")
            else:
                self.set_stage(uid, Stage.LANDED, f"{battery}, {away:.1f} m from its airport")
        else:
            self.set_stage(uid, Stage.LANDED, battery)
        account = vehicle.energy_account()
        if account is not None:
            self.say(uid, f"energy: used {account.used_mah:.0f} mAh from launch to touch-down; its profile predicted "
                          f"{account.predicted_mah:.0f} mAh for the {account.cruise_m:.0f} m it cruised "
                          f"({account.error:+.1%})")

    def finished(self, now: float) -> bool:
        for uid, st in self.status.items():
            if st.stage in FINAL_STAGES:
                continue
            if st.stage is Stage.LOST and now - self._lost_since.get(uid, now) >= self.options.lost_giveup_s:
                continue
            return False
        return True

    def tick(self, now: float) -> None:
        """One pass of the GCS loop: stages, return orders, the trigger for every vehicle."""
        elapsed = now - self.t0
        for uid, after in list(self.options.return_after_s.items()):
            if elapsed >= after:
                del self.options.return_after_s[uid]
                self._orders.append((uid, "order"))
        for uid, reason in self.take_orders():
            self.say(uid, f"return ordered ({reason})")
            self.spawn(self.send_home(uid, reason))
        self.recover_readings(now)
        for uid in self.status:
            self.update_stage(uid, now)
            if uid in self._busy:
                continue
            self._advance_track(uid)
            if self.evaluate(uid):
                self.say(uid, self._why_home(uid))
                decision = self.vehicles[uid].decision
                self.spawn(self.send_home(uid, "range" if decision is not None and decision.by_order else "battery"))

    def _why_home(self, uid: int) -> str:
        """The trigger's reason, in the operator's terms."""
        vehicle, st = self.vehicles[uid], self.status[uid]
        decision, fuel = vehicle.decision, vehicle.fuel
        assert decision is not None
        if decision.by_order:
            ordered = decision.ordered
            assert ordered is not None
            return (f"the ordered range of {self.operator_range[uid]:.0f} m leaves {ordered.range_left:.0f} m, "
                    f"the way home needs {ordered.cost:.0f} m: returning")
        remaining = fuel.remaining_mah or 0.0
        pct = f"{st.battery_pct:.0f}%" if st.battery_pct is not None else f"{remaining:.0f} mAh"
        return (f"battery {pct} ({remaining:.0f} mAh) pays for {decision.range_left_m:.0f} m above the "
                f"{self.options.reserve_pct:g}% reserve and the landing; the way home is {decision.home_m:.0f} m "
                f"({decision.home_mah:.0f} mAh with the landing, at {fuel.rate_mah_per_m:.2f} mAh/m in the wind): "
                "returning")

    async def monitor(self) -> None:
        """Run the GCS loop until all vehicles have landed (or failed, or stayed lost)."""
        while True:
            start = time.monotonic()
            if self._interrupted:
                await self.bring_everyone_home()
                return
            self.tick(start)
            self.loop_latency_s.append(time.monotonic() - start)
            if self.finished(start):
                await self._give_up_on_lost(start)
                return
            await asyncio.sleep(self.options.tick_s)

    async def _give_up_on_lost(self, now: float) -> None:
        """Every vehicle has landed, failed or stayed lost past `lost_giveup_s`: stop waiting for
        the lost ones (their preparation or return may still be waiting on the link) and say so."""
        for uid, st in self.status.items():
            if st.stage is Stage.LOST:
                self.say(uid, f"lost for {now - self._lost_since.get(uid, now):.0f} s: no longer waited for; its "
                              "autopilot's own failsafe is the backstop")
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def bring_everyone_home(self) -> None:
        """Ctrl-C, or the controller failed: RTL for every vehicle in the air, disarm every one
        armed on the ground; then say where each vehicle was left."""
        self.say(None, "stopping: every vehicle in the air is sent home (RTL), every armed one on the ground disarmed")
        for task in list(self._tasks):
            task.cancel()
        for _uid, st in self.status.items():
            if st.stage not in FINAL_STAGES and (st.airborne or st.armed):
                st.return_reason = st.return_reason or "stop"
        await self.make_safe(rtl_airborne=True)

    async def make_safe(self, *, rtl_airborne: bool = False) -> None:
        """Leave no vehicle armed on the ground (disarm it), and, with `rtl_airborne`, send every
        vehicle in the air that is not already going home to RTL. Reports each one it acted on."""
        async def secure(uid: int) -> None:
            st = self.status[uid]
            if uid not in self.link_of or st.stage is Stage.LOST:
                return
            if st.armed and not st.airborne and st.stage is not Stage.SEARCH:
                ok = await self.disarm(uid)
                self.say(uid, "on the ground, disarmed" if ok
                         else "ARMED ON THE GROUND: disarm did not confirm, check it")
            elif rtl_airborne and st.airborne and st.stage not in (Stage.RETURN, Stage.RTL, Stage.LANDED):
                if not await self.rtl(uid):
                    self.say(uid, "in the air and did not confirm RTL: check it yourself")

        await asyncio.gather(*(secure(uid) for uid in self.status), return_exceptions=True)

    async def run(self) -> None:
        """Prepare and launch every vehicle concurrently, monitor until the end, and leave no
        vehicle armed on the ground."""
        for uid in self.plan.uavs:
            self.spawn(self.prepare_and_launch(uid))
        await self.monitor()
        await self.make_safe()


def _said(st: VehicleStatus) -> str:
    return f" (autopilot: {st.last_text})" if st.last_text else ""


def _distance_m(plan: FleetPlan, a: tuple[float, float], b: tuple[float, float]) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)
