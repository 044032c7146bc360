"""Taking a flight over after the station died (`gcs fly --resume FOLDER`, docs/fly.md).

The vehicles flew on by themselves meanwhile. `Resumption` gives a new `FlightController` what
the journal (`gcs.flight.journal`) kept: the flight's clock, each vehicle's readings, battery
samples (the return trigger's learned consumption), place on the plan's track, return reason
and operator range. Then, for every vehicle not yet landed, concurrently, it listens for it,
reads what it reports (HEARTBEAT mode and armed state, position, landed state, battery,
MISSION_CURRENT) and downloads its mission to see which list it flies: the plan's search, the
return leg the journal says was uploaded, or neither. `decide` (pure) turns that into what the
station does: watch it land, prepare and launch a vehicle that never left the ground, follow
a vehicle flying our mission (the return trigger carries on from the real battery), follow an
autopilot RTL, or send home on the planned return a vehicle holding or flying a mission the
station did not upload. Nothing flying is re-uploaded or re-armed. Readings taken while the
station was away are asked for again (MAV_CMD_REQUEST_MESSAGE by image index)."""

from __future__ import annotations

import asyncio
import math
import time
from dataclasses import dataclass, replace
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from gcs.autopilots import Autopilot, compare_items
from gcs.autopilots.mission_transfer import MissionTransferError, MissionType, download, renumber
from gcs.autopilots.modes import MISSION_MODES
from gcs.errors import UserError
from gcs.flight.events import Reattached
from gcs.flight.journal import JournalError, JournalState, VehicleRecord, read_journal
from gcs.links import LinkError, mavlink
from gcs.links.connection import Connection, LinkKind, parse_connection
from gcs.plans.belief_file import file_sha256
from gcs.plans.plan_folder import FleetPlan, load_plan_dir
from gcs.telemetry.status import FINAL_STAGES, Stage

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController

__all__ = ["Action", "Decision", "Found", "Resumption", "decide", "links_from_the_same_ports", "resumable_flight"]

AUTOPILOT_RETURN_MODES = frozenset({"RTL", "LAND", "SMART_RTL", "QRTL", "QLAND"})
LOOK_FOR = {"HEARTBEAT": mavlink.MAVLINK_MSG_ID_HEARTBEAT,
            "GLOBAL_POSITION_INT": mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
            "MISSION_CURRENT": mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
            "EXTENDED_SYS_STATE": mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
            "SYS_STATUS": mavlink.MAVLINK_MSG_ID_SYS_STATUS}


class Action(str, Enum):
    LANDED = "landed"  # on the ground after flying: it landed while the station was away
    KEEP_ON_GROUND = "keep_on_ground"  # ordered home before it took off
    LAUNCH = "launch"  # never left the ground: prepared and launched as any vehicle
    RELAUNCH = "relaunch"  # armed on the ground, its mission not started: disarmed, then launched
    FOLLOW = "follow"  # flying our mission (or taking off on it): watched, the trigger carries on
    RTL = "rtl"  # in the autopilot's RTL or LAND: watched to the ground
    SEND_HOME = "send_home"  # holding, or flying a list we did not upload: the planned return


@dataclass(frozen=True, slots=True)
class Found:
    """What a vehicle reported when the restarted station heard it; `on_board` is the mission
    it holds ("search", "return", "other", or None when it could not be read)."""

    armed: bool
    airborne: bool
    mode: str
    on_board: str | None


@dataclass(frozen=True, slots=True)
class Decision:
    action: Action
    stage: Stage
    return_reason: str | None
    why: str


def decide(record: VehicleRecord, found: Found) -> Decision:
    """What the restarted station does with one vehicle the journal knew as `record`."""
    reason = record.return_reason
    was = record.flying_stage
    if not found.airborne and not found.armed:
        if record.airborne_seen:
            return Decision(Action.LANDED, Stage.LANDED, reason, "on the ground and disarmed: it landed while the "
                                                                 "station was away")
        if reason is not None:
            return Decision(Action.KEEP_ON_GROUND, Stage.LANDED, reason, f"on the ground: return ordered ({reason}) "
                                                                         "before it took off, so it stays there")
        return Decision(Action.LAUNCH, Stage.CONNECTING, None, "on the ground, never launched: prepared and launched")
    on_board = found.on_board or record.mission
    if not found.airborne:
        if record.airborne_seen:
            going_home = was in (Stage.RETURN, Stage.RTL)
            return Decision(Action.FOLLOW, was, reason or ("resume" if going_home else None),
                            "on the ground, still armed: landing")
        if found.mode in MISSION_MODES and on_board == "search" and reason is None:
            return Decision(Action.FOLLOW, Stage.SEARCH, None, "taking off on its search")
        return Decision(Action.RELAUNCH, Stage.CONNECTING, None, f"armed on the ground in {found.mode}, its mission "
                                                                 "not started: disarmed, then launched")
    if found.mode in AUTOPILOT_RETURN_MODES:
        return Decision(Action.RTL, Stage.RTL, reason or "autopilot", f"in {found.mode}: its autopilot takes it home")
    if found.mode in MISSION_MODES:
        if on_board == "search" and was in (Stage.RETURN, Stage.RTL):
            return Decision(Action.SEND_HOME, Stage.SEARCH, reason or "resume",
                            f"still on its search though it was sent home ({reason}): sending it home again")
        if on_board == "search":
            return Decision(Action.FOLLOW, Stage.SEARCH, None, "flying its search")
        if on_board == "return":
            return Decision(Action.FOLLOW, Stage.RETURN, reason or "resume", "flying its return leg home")
        return Decision(Action.SEND_HOME, Stage.SEARCH, reason or "resume",
                        f"flying a mission the station did not upload ({found.on_board}): sending it home")
    return Decision(Action.SEND_HOME, Stage.SEARCH, reason or "resume",
                    f"holding in {found.mode}: sending it home on its planned return")


class Resumption:
    """The `resume` of `gcs.flight.fly.fly_async`: restores a controller from a journal and takes
    the vehicles over."""

    def __init__(self, plan: FleetPlan, state: JournalState, *, look_timeout_s: float = 5.0,
                 catch_up_s: float = 30.0) -> None:
        self.plan = plan
        self.state = state
        self.look_timeout_s = look_timeout_s
        self.catch_up_s = catch_up_s
        self.decisions: dict[int, Decision] = {}

    def restore(self, controller: FlightController) -> None:
        """The flight's clock and what the journal kept of each vehicle; the stages of landed
        and failed vehicles (not reattached). Called before anything listens."""
        c = controller
        c.t0 = time.monotonic() - (time.time() - self.state.start.wall_s)
        for uid, v in self.state.vehicles.items():
            if uid not in c.status:
                continue
            st = c.status[uid]
            st.detections = list(v.readings)
            st.detection_indices = {d.index for d in v.readings}
            st.battery_samples.extend(v.battery_samples[-(st.battery_samples.maxlen or 0):])
            st.track_index, st.steps_flown = v.track_index, float(v.track_index)
            st.odometer_m = v.odometer_m
            st.return_reason = v.return_reason
            st.airborne_seen = v.airborne_seen
            if v.stage in FINAL_STAGES:
                st.stage, st.note = v.stage, "before the station's restart"
            vehicle = c.vehicles[uid]
            if v.reading_component is not None:
                vehicle.reading_component = v.reading_component
            if v.operator_range is not None:
                vehicle.operator_range = v.operator_range

    def _record(self, uid: int) -> VehicleRecord:
        return self.state.vehicles.get(uid) or VehicleRecord(uid)

    async def run(self, controller: FlightController) -> None:
        """Reattach every vehicle still out, watch the fleet to the end (the controller's own
        loop), leave nothing armed on the ground, and ask for the readings still missing."""
        c = controller
        c.say(None, f"the station was away {time.time() - self.state.start.wall_s - self.state.last_t:.1f} s: "
                    f"reattaching {sum(st.stage not in FINAL_STAGES for st in c.status.values())} vehicles")
        for uid in self.plan.uavs:
            if c.status[uid].stage in FINAL_STAGES:
                c.say(uid, f"{c.status[uid].stage.value} before the restart")
            else:
                c.spawn(self._reattach(c, uid))
        await c.monitor()
        await c.make_safe()
        if not c.interrupted:
            await self._catch_up_readings(c)

    # ---- one vehicle ---------------------------------------------------------------------

    async def _reattach(self, c: FlightController, uid: int) -> None:
        vehicle, record = c.vehicles[uid], self._record(uid)
        st = vehicle.status
        vehicle.claim()
        try:
            if not await c.wait_until(lambda: st.autopilot is not None, c.options.connect_timeout_s):
                links = ", ".join(link.name for link in c.links)
                vehicle.mark_lost(f"did not answer after the restart: no HEARTBEAT from system id {uid} within "
                                 f"{c.options.connect_timeout_s:g} s on {links}; it flies on by itself, its "
                                 "autopilot's failsafes are the backstop", time.monotonic(), before=Stage.CONNECTING)
                await c.wait_until(lambda: st.stage is not Stage.LOST, math.inf)
            await vehicle.commands.request_streams()
            await self._look(c, uid)
            on_board = await self._on_board(c, uid, record) if st.armed or st.airborne else None
            found = Found(st.armed, st.airborne, st.mode_name, on_board)
            decision = self.decisions[uid] = decide(record, found)
            await self._act(c, uid, record, decision)
        except LinkError as exc:
            vehicle.set_stage(Stage.LOST if st.airborne_seen else Stage.FAILED, f"reattaching: {exc}")
        finally:
            vehicle.release()

    async def _look(self, c: FlightController, uid: int) -> None:
        """Wait (up to `look_timeout_s`) until the vehicle has sent each message the decision
        reads, the ones it refuses to stream excepted."""
        link, st = c.vehicles[uid].link, c.status[uid]
        wanted = {kind for kind, msg_id in LOOK_FOR.items() if msg_id not in st.unsupported_streams}
        end = time.monotonic() + self.look_timeout_s
        async with link.listen(uid, wanted) as queue:
            while wanted and (left := end - time.monotonic()) > 0:
                try:
                    async with asyncio.timeout(left):
                        msg = await queue.get()
                except TimeoutError:
                    break
                if msg.get_srcComponent() == mavlink.MAV_COMP_ID_AUTOPILOT1:
                    wanted.discard(msg.get_type())
        await asyncio.sleep(0)  # the controller's own handler has folded the last one in
        if wanted:
            c.say(uid, f"reattaching without {', '.join(sorted(wanted))} (not heard in {self.look_timeout_s:g} s)")

    async def _on_board(self, c: FlightController, uid: int, record: VehicleRecord) -> str | None:
        """Which mission the vehicle holds: "search", "return" (the leg the journal has), "other",
        or None when it could not be downloaded. A vehicle still receiving an upload (the killed
        station's return leg, which the autopilot waits for until its own timeout) is not asked
        again: every second it holds in the air costs charge, and the journal says what it was sent."""
        st, task = c.status[uid], self.plan.uavs[uid]
        autopilot = st.autopilot or Autopilot.GENERIC
        try:
            got = await download(c.vehicles[uid].link, uid, MissionType.MISSION, timeout_s=c.options.transfer_timeout_s,
                                 busy_is_final=True)
        except (MissionTransferError, LinkError) as exc:
            c.say(uid, f"its mission could not be read back ({exc}); going by the journal")
            return None
        candidates = {"search": lambda: task.mission_wire(autopilot)}
        if record.leg:
            candidates["return"] = lambda: task.return_wire(autopilot, record.leg)
        for name, items in candidates.items():
            try:
                wanted = renumber(items(), MissionType.MISSION)
            except ValueError:
                continue
            if not compare_items(wanted, got, autopilot, fixed_wing=st.fixed_wing):
                return name
        return "other"

    async def _act(self, c: FlightController, uid: int, record: VehicleRecord, decision: Decision) -> None:
        vehicle = c.vehicles[uid]
        st = vehicle.status
        battery = f", battery {st.battery_pct:.0f}%" if st.battery_pct is not None else ""
        found = f"{decision.why} (mode {st.mode_name}, mission item {st.mission_seq}{battery})"
        if st.time_boot_s and st.battery_samples and st.time_boot_s < st.battery_samples[-1][0]:
            st.battery_samples.clear()  # it rebooted: its clock started again
        st.return_reason = decision.return_reason
        action = decision.action
        c.say(uid, f"reattached: {found}")
        if action in (Action.LANDED, Action.KEEP_ON_GROUND):
            st.stage = record.flying_stage if record.flying_stage is not Stage.CONNECTING else Stage.SEARCH
            c.emit(Reattached(uid, st.stage, found))
            st.battery_at_landing = st.battery_pct
            vehicle.set_stage(Stage.LANDED, "while the station was away" if action is Action.LANDED
                        else "kept on the ground: return ordered before take-off")
            return
        if action in (Action.LAUNCH, Action.RELAUNCH):
            c.emit(Reattached(uid, Stage.CONNECTING, found))
            if action is Action.RELAUNCH and not await vehicle.commands.disarm():
                vehicle.set_stage(Stage.FAILED, "armed on the ground and would not disarm: check it")
                return
            vehicle.release()
            await vehicle.prepare_and_launch()
            return
        st.airborne_seen = st.airborne_seen or st.airborne
        if decision.stage is Stage.SEARCH and st.has_position:
            autopilot = st.autopilot or Autopilot.GENERIC
            st.track_index = vehicle.track.index_on_board(autopilot, st.mission_seq, st.lat_deg, st.lon_deg,
                                                          st.track_index)
            st.steps_flown = float(st.track_index)
        st.stage = decision.stage
        vehicle.return_leg_flying = decision.stage is Stage.RETURN  # FOLLOW: flying its return leg
        c.emit(Reattached(uid, decision.stage, found))
        if action is Action.SEND_HOME:
            vehicle.release()
            await c.send_home(uid, decision.return_reason or "resume")

    # ---- readings taken while the station was away ------------------------------------------

    async def _catch_up_readings(self, c: FlightController) -> None:
        """Once every vehicle is down: ask each reattached vehicle for the readings it took that
        never arrived (below its highest index, and after it, one by one, until none comes)."""
        end = time.monotonic() + self.catch_up_s
        await asyncio.gather(*(self._catch_up(c, uid, end) for uid in self.decisions
                               if c.vehicles[uid].link is not None and c.status[uid].stage is not Stage.LOST))

    async def _catch_up(self, c: FlightController, uid: int, end: float) -> None:
        st = c.status[uid]
        if not st.detection_indices:
            return  # a vehicle that never sent a reading has no sensor
        before = len(st.detection_indices)
        vehicle = c.vehicles[uid]
        while time.monotonic() < end:
            wanted = st.lost_detections[:50] + [max(st.detection_indices) + 1]
            vehicle.commands.request_readings(wanted, vehicle.reading_from)
            count = len(st.detection_indices)
            await c.wait_until(lambda wanted=wanted: all(i in st.detection_indices for i in wanted), 1.0)
            if len(st.detection_indices) == count:
                break
        recovered = len(st.detection_indices) - before
        if recovered:
            c.say(uid, f"{recovered} readings taken while the station was away asked for and received")


def resumable_flight(folder: Path) -> tuple[JournalState, FleetPlan]:
    """The journal and plan of the flight in progress in `folder`; UserError saying why there is
    none to take over (no folder or journal, ended, simulated, online, or the plan changed)."""
    if not folder.is_dir():
        raise UserError(f"--resume {folder}: no such folder")
    try:
        state = read_journal(folder)
    except JournalError as exc:
        raise UserError(f"--resume {folder}: {exc}") from None
    if state.ended is not None:
        raise UserError(f"--resume {folder}: no flight in progress there: the flight started {state.start.utc} ended "
                        f"with its station running ({_end_text(state.ended)})")
    if state.start.sim:
        raise UserError(f"--resume {folder}: the flight flew the built-in simulated fleet (--sim), which stopped with "
                        "its station: nothing is flying")
    if state.start.online:
        raise UserError(f"--resume {folder}: an online flight (--online) cannot be taken over: its vehicles hold "
                        "their last cell in GUIDED until their failsafes bring them home")
    plan = load_plan_dir(folder)
    if file_sha256(folder / "plan.json") != state.start.plan_sha256:
        raise UserError(f"--resume {folder}: plan.json changed since the flight started (it is not the plan flown)")
    return state, plan


def _end_text(end: dict) -> str:
    if end.get("error"):
        return f"the station failed: {end['error']}"
    if end.get("interrupted"):
        return "stopped by the operator"
    landed, still = end.get("landed", []), end.get("open", [])
    text = f"{len(landed)} landed"
    return text + (f", UAV {', '.join(map(str, still))} not landed" if still else "")


def links_from_the_same_ports(connections: list[str], source_ports: dict[str, int]) -> list[str | Connection]:
    """The links again, each `udpout` sending from the local port it sent from before: PX4 answers
    only the first address that spoke to it, and the dead station's is the one it knows."""
    links: list[str | Connection] = []
    for text in connections:
        c = parse_connection(text)
        port = source_ports.get(str(c))
        links.append(replace(c, source_port=port) if port and c.kind is LinkKind.UDP_OUT else text)
    return links


