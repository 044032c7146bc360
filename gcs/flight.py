"""The flight controller: uploads a plan to every vehicle, launches the missions and watches the
fleet until every vehicle has landed, sending vehicles home early when their battery no longer
covers the planned search (the live DTSCS return trigger, docs/fly.md).

`FlightController` publishes what happens as `FlightEvent`s (`subscribe`): stage changes, take-
offs, flight-mode changes and sensor readings, the moment the controller sees them; the Rerun
recorder and the MQTT feed listen, and sample only the telemetry. `fly_async` wires links,
listeners and the online planner around one controller."""

from __future__ import annotations

import asyncio
import math
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from contextlib import AsyncExitStack
from dataclasses import dataclass, field

import numpy as np

from gcs.errors import UserError
from gcs.fleet import FINAL_STAGES, Detection, FleetPlan, Stage, VehicleStatus, set_mode_params
from gcs.link import CommandError, LinkError, MavLink, mavlink
from gcs.mission_transfer import Autopilot, MissionTransferError, MissionType, WireItem, upload_verified
from gcs.return_trigger import (RangeModel, battery_drain_pct_s, check_return, drain_rate_pct_s, landing_steps,
                                range_left_steps)
from gcs.status_table import render_table
from planner.return_exact import follow_table

STREAMS_HZ = {  # message -> rate asked with MAV_CMD_SET_MESSAGE_INTERVAL (vehicle time)
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0,
}


class FlightAborted(UserError):
    """The controller failed mid-flight; every vehicle in the air was sent home first."""

    exit_code = 1


@dataclass(frozen=True, slots=True)
class StageChanged:
    uav_id: int
    before: Stage
    after: Stage
    note: str


@dataclass(frozen=True, slots=True)
class TookOff:
    """The vehicle was seen airborne for the first time."""

    uav_id: int
    alt_m: float
    mode: str


@dataclass(frozen=True, slots=True)
class ModeChanged:
    uav_id: int
    before: str
    after: str


@dataclass(frozen=True, slots=True)
class ReadingReceived:
    """One sensor reading (CAMERA_IMAGE_CAPTURED), as it arrived."""

    uav_id: int
    detection: Detection


FlightEvent = StageChanged | TookOff | ModeChanged | ReadingReceived
FlightListener = Callable[[FlightEvent, float], None]

REFUSED_FOR_NOW = (mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_FAILED)


@dataclass
class FlyOptions:
    """Knobs of a flight; times are real (wall-clock) seconds unless named otherwise."""

    speed_m_s: float = 10.0
    reserve_pct: float = 30.0
    descent_m_s: float = 1.5
    link_timeout_s: float = 3.0
    lost_giveup_s: float = 20.0
    connect_timeout_s: float = 15.0
    gps_timeout_s: float = 120.0
    arm_timeout_s: float = 60.0
    transfer_timeout_s: float = 0.5
    command_timeout_s: float = 0.5
    tick_s: float = 0.05
    table_every_s: float = 0.5
    live_table: bool = False
    fence: bool = True
    return_after_s: dict[int, float] = field(default_factory=dict)
    fly: bool = True
    lookahead_steps: int = 2


class FlightController:
    """Uploads, launches and watches one fleet; returns are decided here, by pure functions."""

    def __init__(self, plan: FleetPlan, links: list[MavLink], options: FlyOptions | None = None,
                 out: Callable[[str], None] | None = None) -> None:
        self.plan = plan
        self.links = links
        self.options = options = options or FlyOptions()
        self.out = out or (lambda line: print(line, flush=True))
        self.status = {uid: VehicleStatus(uid) for uid in plan.uavs}
        self.link_of: dict[int, MavLink] = {}
        self.model = RangeModel(step_m=plan.cell_size_m * math.sqrt(2.0), speed_m_s=options.speed_m_s,
                                reserve_pct=options.reserve_pct, descent_m_s=options.descent_m_s)
        self._track_m = {uid: np.array([plan.local_m(p.lat_deg, p.lon_deg) for p in task.trajectory])
                         for uid, task in plan.uavs.items()}
        self._orders: list[tuple[int, str]] = []
        self._busy: set[int] = set()
        self._stay_on_ground: set[int] = set()
        self._last_recovery = 0.0
        self.recent: deque[str] = deque(maxlen=8)
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

    # ---- messages ----------------------------------------------------------------------

    def _on_message(self, link: MavLink, msg) -> None:
        uid = msg.get_srcSystem()
        status = self.status.get(uid)
        if status is None or msg.get_srcComponent() != mavlink.MAV_COMP_ID_AUTOPILOT1:
            return
        self.link_of.setdefault(uid, link)
        readings, airborne, mode = len(status.detections), status.airborne_seen, status.mode_name
        status.update(msg, time.monotonic())
        if status.airborne_seen and not airborne:
            self._emit(TookOff(uid, status.rel_alt_m, status.mode_name))
        if status.mode_name != mode:
            self._emit(ModeChanged(uid, mode, status.mode_name))
        for detection in status.detections[readings:]:
            self._emit(ReadingReceived(uid, detection))

    # ---- listeners ---------------------------------------------------------------------

    def subscribe(self, listener: FlightListener) -> Callable[[], None]:
        """Call `listener(event, monotonic_time)` for every `FlightEvent` from now on; returns
        the call that unsubscribes it. A listener that raises is reported and dropped: it never
        stops the flight."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    def _emit(self, event: FlightEvent) -> None:
        now = time.monotonic()
        for listener in list(self._listeners):
            try:
                listener(event, now)
            except Exception as exc:  # a recorder or bus bug must not stop the flight
                self._listeners.remove(listener)
                self.say(None, f"error: event listener {getattr(listener, '__qualname__', listener)} dropped "
                               f"({type(exc).__name__}: {exc})")

    def say(self, uid: int | None, text: str) -> None:
        stamp = f"[{time.monotonic() - self.t0:6.1f}s]"
        line = f"{stamp} UAV {uid}: {text}" if uid is not None else f"{stamp} {text}"
        if self.options.live_table:
            self.recent.append(line)  # shown under the live table
        else:
            self.out(line)

    def _recover_readings(self, now: float) -> None:
        """Ask again (MAV_CMD_REQUEST_MESSAGE, param2 = image index) for readings lost on the link."""
        if now - self._last_recovery < 1.0:
            return
        self._last_recovery = now
        for uid, st in self.status.items():
            link = self.link_of.get(uid)
            if link is None or st.stage is Stage.LOST:
                continue
            for index in st.lost_detections[:5]:
                link.send(mavlink.MAVLink_command_long_message(
                    uid, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED, index,
                    0, 0, 0, 0, 0))

    def _set_stage(self, uid: int, stage: Stage, note: str = "") -> None:
        st, before = self.status[uid], self.status[uid].stage
        if note:
            st.note = note
        if before is not stage:
            st.stage = stage
            self.say(uid, f"{stage.value}{' - ' + note if note else ''}")
            self._emit(StageChanged(uid, before, stage, note))

    # ---- operator ------------------------------------------------------------------------

    def order_return(self, uid: int, reason: str = "order") -> None:
        """A return order (from the operator or a command); ValueError for an unknown UAV."""
        if uid not in self.status:
            raise ValueError(f"unknown UAV {uid} (the plan has {', '.join(map(str, sorted(self.status)))})")
        self._orders.append((uid, reason))

    def interrupt(self) -> None:
        """Ctrl-C: bring everyone home, then stop."""
        self._interrupted = True

    # ---- preparation ---------------------------------------------------------------------

    async def _wait(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
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
        await self.command(uid, mavlink.MAV_CMD_DO_SET_MODE, *set_mode_params(st.autopilot, st.mav_type, name))

    async def prepare(self, uid: int, mission: bool = True) -> bool:
        """Connect, ask for the streams, wait for a GPS origin, upload and verify (unless
        `mission` is False). False (and stage FAILED with a clear note) when anything cannot be done."""
        opts, st, task = self.options, self.status[uid], self.plan.uavs[uid]
        self._set_stage(uid, Stage.CONNECTING)
        if not await self._wait(lambda: st.autopilot is not None, opts.connect_timeout_s):
            self._set_stage(uid, Stage.FAILED, f"no HEARTBEAT from system id {uid} within {opts.connect_timeout_s:g} s")
            return False
        self._set_stage(uid, Stage.PREPARING, f"{st.autopilot.value} autopilot")
        for msg_id, hz in STREAMS_HZ.items():
            try:
                await self.command(uid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=2)
            except CommandError as exc:
                name = mavlink.mavlink_map[msg_id].msgname if msg_id in mavlink.mavlink_map else msg_id
                self.say(uid, f"stream {name} not set ({exc}); using what the vehicle sends")
        if not st.has_position:
            self.say(uid, "waiting for a GPS origin (position still 0,0)")
            if not await self._wait(lambda: st.has_position, opts.gps_timeout_s):
                self._set_stage(uid, Stage.FAILED, f"no GPS position within {opts.gps_timeout_s:g} s")
                return False
        away = _distance_m(self.plan, (st.lat_deg, st.lon_deg), task.airport_lat_lon)
        if away > self.plan.cell_size_m:
            self.say(uid, f"warning: vehicle is {away:.0f} m from its airport {task.name!r}; check that system id "
                          f"{uid} is the UAV of the plan")
        if not mission:
            return True
        self._set_stage(uid, Stage.UPLOADING)
        link = self.link_of[uid]
        autopilot = st.autopilot
        try:
            report = await upload_verified(link, uid, task.mission_wire(autopilot), autopilot,
                                           timeout_s=opts.transfer_timeout_s)
        except MissionTransferError as exc:
            self._set_stage(uid, Stage.FAILED, f"mission {exc}")
            return False
        self.upload_reports[uid] = {"mission": report}
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

    async def launch(self, uid: int) -> bool:
        """Arm (retrying while the autopilot refuses, as real ones do for a while after boot)
        and start the mission."""
        opts, st = self.options, self.status[uid]
        self._set_stage(uid, Stage.ARMING)
        end = time.monotonic() + opts.arm_timeout_s
        told = False
        while True:
            if self._interrupted or uid in self._stay_on_ground or any(o[0] == uid for o in self._orders):
                self._set_stage(uid, Stage.LANDED, "not launched (return ordered before take-off)")
                return False
            try:
                await self.command(uid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                break
            except CommandError as exc:
                if exc.result not in REFUSED_FOR_NOW or time.monotonic() > end:
                    self._set_stage(uid, Stage.FAILED, f"cannot arm: {exc}{' (' + st.last_text + ')' if st.last_text else ''}")
                    return False
                if not told:
                    self.say(uid, f"arming refused ({st.last_text or exc}); retrying for up to {opts.arm_timeout_s:g} s")
                    told = True
                await asyncio.sleep(1.0)
        first = st.autopilot.first_mission_seq() if st.autopilot else 0
        try:
            await self.command(uid, mavlink.MAV_CMD_MISSION_START, first, 0)
        except CommandError:
            try:
                await self.set_mode(uid, "AUTO")
            except CommandError as exc:
                self._set_stage(uid, Stage.FAILED, f"cannot start the mission: {exc}")
                return False
        self._set_stage(uid, Stage.SEARCH, "mission started")
        return True

    async def _prepare_and_launch(self, uid: int) -> None:
        self._busy.add(uid)
        try:
            if await self.prepare(uid) and self.options.fly:
                await self.launch(uid)
        except LinkError as exc:
            self._set_stage(uid, Stage.FAILED, str(exc))
        finally:
            self._busy.discard(uid)

    async def upload_all(self) -> dict[int, bool]:
        """Prepare every vehicle concurrently; True where the upload verified."""
        results = await asyncio.gather(*(self.prepare(uid) for uid in self.plan.uavs), return_exceptions=True)
        out = {}
        for uid, res in zip(self.plan.uavs, results):
            if isinstance(res, BaseException):
                self._set_stage(uid, Stage.FAILED, str(res))
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
        path = [pose] + follow_table(table, pose, self.plan.oc.successors, self.plan.no_fly)
        keep = [path[0]] + [path[i] for i in range(1, len(path) - 1) if path[i + 1][2] != path[i][2]] + [path[-1]]
        return [self.plan.cell_lat_lon(x, y) for x, y, _ in keep] if len(path) > 1 else \
            [self.plan.cell_lat_lon(pose[0], pose[1])]

    async def send_home(self, uid: int, reason: str) -> None:
        """Fly the planned return leg to the UAV's own airport: hold, upload the leg (the vehicle
        must not fly AUTO while an ArduPilot mission is replaced), verify, start it; fall back to
        the autopilot's RTL when any of that fails."""
        st, task = self.status[uid], self.plan.uavs[uid]
        if st.stage in FINAL_STAGES or st.stage in (Stage.RETURN, Stage.RTL):
            return
        st.return_reason = reason
        if not st.airborne_seen and st.stage is not Stage.SEARCH:
            self._stay_on_ground.add(uid)  # not launched yet: launch() sees it and stays on the ground
            return
        self._set_stage(uid, Stage.RETURN, f"going home ({reason})")
        self._busy.add(uid)
        started = time.monotonic()
        try:
            leg = self.return_leg(uid)
            autopilot = st.autopilot or Autopilot.GENERIC
            rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
            items = [WireItem.at(0, rel, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon, task.altitude_m) for lat, lon in leg]
            lat0, lon0 = task.airport_lat_lon
            items.append(WireItem.at(0, rel, mavlink.MAV_CMD_NAV_LAND, lat0, lon0, 0.0))
            if autopilot.home_item(MissionType.MISSION):
                items.insert(0, WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat0, lon0, 0.0))
            await self.set_mode(uid, "GUIDED" if task.vehicle.value == "copter" else "LOITER")
            await upload_verified(self.link_of[uid], uid, items, autopilot, timeout_s=self.options.transfer_timeout_s)
            await self.command(uid, mavlink.MAV_CMD_MISSION_START, autopilot.first_mission_seq(), 0)
            self.return_latency_s[uid] = time.monotonic() - started
            self.say(uid, f"return leg of {len(leg)} waypoints uploaded and started")
        except (LinkError, MissionTransferError, ValueError, KeyError) as exc:
            self.say(uid, f"return leg failed ({exc}); commanding RTL")
            await self.rtl(uid)
        finally:
            self._busy.discard(uid)

    async def rtl(self, uid: int) -> bool:
        try:
            await self.command(uid, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, retries=5)
        except LinkError as exc:
            self.say(uid, f"RTL not acknowledged: {exc}")
            return False
        self._set_stage(uid, Stage.RTL, "autopilot RTL")
        return True

    def _spawn(self, coro) -> None:
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

    def evaluate(self, uid: int) -> bool:
        """Update range and margin of one searching vehicle; True when it must turn home now."""
        st, task = self.status[uid], self.plan.uavs[uid]
        drain = battery_drain_pct_s(st.battery_pct, st.time_remaining_s, drain_rate_pct_s(list(st.battery_samples)))
        st.range_left = range_left_steps(st.battery_pct, drain, self.model)
        if st.stage is not Stage.SEARCH or not st.airborne_seen:
            return False
        # the loop sees a vehicle every tick, not every step: look a few steps further ahead
        ahead = task.trajectory[st.track_index + 1: st.track_index + 1 + self.options.lookahead_steps]
        if not ahead or ahead[0].stage != "search":
            st.margin = math.inf  # the plan's own return (or its end): already the lowest-cost way home
            return False
        cost = max(self.plan.steps_home(uid, (p.x, p.y, p.heading)) + j for j, p in enumerate(ahead)
                   if p.stage == "search")
        check = check_return(st.range_left, cost, landing_steps(task.altitude_m, self.model))
        st.margin = check.margin
        return check.must_return

    def _update_stage(self, uid: int, now: float) -> None:
        st = self.status[uid]
        if st.last_heard_s is not None and st.stage not in FINAL_STAGES:
            silent = now - st.last_heard_s > self.options.link_timeout_s
            if silent and st.stage is not Stage.LOST:
                self._stage_before_loss[uid] = st.stage
                self._lost_since[uid] = now
                self._set_stage(uid, Stage.LOST, f"no telemetry for {self.options.link_timeout_s:g} s; "
                                                 "the others carry on")
            elif not silent and st.stage is Stage.LOST:
                self._lost_since.pop(uid, None)
                self._set_stage(uid, self._stage_before_loss.pop(uid, Stage.SEARCH), "link back")
        if st.stage in (Stage.SEARCH, Stage.RETURN, Stage.RTL) and st.airborne_seen and not st.airborne \
                and (not st.armed or st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND):
            st.battery_at_landing = st.battery_pct
            self._set_stage(uid, Stage.LANDED, f"battery {st.battery_pct:.0f}%" if st.battery_pct is not None else "")
        elif st.stage is Stage.SEARCH and st.mode_name in ("RTL", "LAND") and uid not in self._busy:
            st.return_reason = "autopilot"
            self._set_stage(uid, Stage.RTL, f"autopilot switched to {st.mode_name} ({st.last_text or 'no reason given'})")

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
        orders, self._orders = self._orders, []
        for uid, reason in orders:
            self.say(uid, f"return ordered ({reason})")
            self._spawn(self.send_home(uid, reason))
        self._recover_readings(now)
        for uid in self.status:
            self._update_stage(uid, now)
            if uid in self._busy:
                continue
            self._advance_track(uid)
            if self.evaluate(uid):
                st = self.status[uid]
                self.say(uid, f"battery {st.battery_pct:.0f}% covers {st.range_left:.1f} steps, the way home needs "
                              f"{st.range_left - st.margin:.1f}: returning")
                self._spawn(self.send_home(uid, "battery"))

    async def monitor(self) -> None:
        """Run the GCS loop until all vehicles have landed (or failed, or stayed lost)."""
        last_table = 0.0
        while True:
            start = time.monotonic()
            if self._interrupted:
                await self.bring_everyone_home()
                return
            self.tick(start)
            self.loop_latency_s.append(time.monotonic() - start)
            if self.options.live_table and start - last_table >= self.options.table_every_s:
                last_table = start
                sys.stdout.write("\x1b[H\x1b[2J" + render_table(self) + "\n\n" + "\n".join(self.recent) + "\n")
                sys.stdout.flush()
            if self.finished(start) and not self._tasks:
                return
            await asyncio.sleep(self.options.tick_s)

    async def bring_everyone_home(self) -> None:
        self.say(None, "interrupted: commanding RTL to every vehicle in the air")
        for task in list(self._tasks):
            task.cancel()
        flying = [uid for uid, st in self.status.items()
                  if st.stage not in FINAL_STAGES and (st.airborne or st.armed)]
        for uid in flying:
            self.status[uid].return_reason = "ctrl-c"
        results = await asyncio.gather(*(self.rtl(uid) for uid in flying), return_exceptions=True)
        for uid, ok in zip(flying, results):
            if ok is not True:
                self.say(uid, "did not confirm RTL: check it yourself")

    async def run(self) -> None:
        """Prepare and launch every vehicle concurrently, then monitor until the end."""
        for uid in self.plan.uavs:
            self._spawn(self._prepare_and_launch(uid))
        await self.monitor()


def _distance_m(plan: FleetPlan, a: tuple[float, float], b: tuple[float, float]) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)


async def fly_async(plan: FleetPlan, connections: list[str], options: FlyOptions,
                    stdin_orders: bool = False, online=None, recorder=None, bus: dict | None = None,
                    listeners: Sequence[FlightListener] = ()) -> FlightController:
    """Fly the plan (or, with `online` an observed search, search with the planner in the loop);
    `recorder` (a `gcs.flight_recording.FlightRecorder`) records it; `bus` (keywords of
    `gcs.bus.flight.attach_bus`) shares it over MQTT; `listeners` get every `FlightEvent`."""
    async with AsyncExitStack() as stack:
        links = [await stack.enter_async_context(MavLink(c)) for c in connections]
        controller = FlightController(plan, links, options)
        for listener in listeners:
            controller.subscribe(listener)
        if bus is not None:
            from gcs.bus.flight import attach_bus

            await stack.enter_async_context(attach_bus(controller, online=online, **bus))
        if recorder is not None:
            await stack.enter_async_context(recorder.attach(controller))
        loop = asyncio.get_running_loop()
        try:
            loop.add_signal_handler(signal.SIGINT, controller.interrupt)
        except (NotImplementedError, RuntimeError):
            pass
        if stdin_orders:
            _start_stdin_reader(loop, controller)
        try:
            if online is not None:
                from gcs.online import OnlineFlight

                await OnlineFlight(controller, online).run()
            else:
                await controller.run()
        except Exception as exc:  # a bug in the loop must not leave vehicles flying unwatched
            controller.say(None, f"error: the flight controller failed ({type(exc).__name__}: {exc})")
            await controller.bring_everyone_home()
            raise FlightAborted(f"the flight controller failed ({type(exc).__name__}: {exc}); "
                                "every vehicle in the air was commanded RTL") from exc
        finally:
            try:
                loop.remove_signal_handler(signal.SIGINT)
            except (NotImplementedError, RuntimeError):
                pass
    return controller


def _start_stdin_reader(loop: asyncio.AbstractEventLoop, controller: FlightController) -> None:
    """`r ID` (or `rtl ID`) on stdin orders UAV ID home; `r all` orders every UAV home."""

    def order(line: str) -> None:
        parts = line.split()
        if len(parts) != 2 or parts[0].lower() not in ("r", "rtl", "return"):
            controller.say(None, f"unknown input {line.strip()!r}: type 'r ID' to send UAV ID home")
            return
        targets = list(controller.status) if parts[1] == "all" else [parts[1]]
        for t in targets:
            try:
                controller.order_return(int(t))
            except ValueError as exc:
                controller.say(None, f"error: {exc}")

    def read() -> None:
        for line in sys.stdin:
            if line.strip():
                loop.call_soon_threadsafe(order, line)

    threading.Thread(target=read, name="stdin-orders", daemon=True).start()
