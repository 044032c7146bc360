"""The simulator's `px4` profile against real PX4 v1.15.3 SITL (SIH copter): the same exchange
with both, and their answers compared field by field.

Right after boot (before PX4's navigator runs, as in the research's measurements): the first
upload's requests (MISSION_REQUEST for item 0, then _INT), a planned mission, a mission of
varied items and frames (one flagged current), refused uploads over a stored mission (terrain
frame, a location command in frame 2, DO_CHANGE_SPEED in frame 3, an unknown command, a fence
vertex in the mission), the last item sent again, the planned fence and rally point and varied
ones, COUNTs over each capacity, a legacy MISSION_REQUEST read-back; every MISSION_ACK, every
read-back item, MISSION_CURRENT after each upload, and the refusal texts. Then, once each is
ready: when the pre-arm bit came (vehicle time) and in which SYS_STATUS field, the current item
the navigator took up, an upload after it, the SET_MESSAGE_INTERVAL and command answers, and
COM_ARMABLE's effect.

The simulator stores items through the station's model of PX4's storage
(`gcs.autopilots.px4_storage.stored_item`), so this test is what keeps that model true."""

from __future__ import annotations

import math
import socket
import time
import warnings
from dataclasses import dataclass, field, fields
from pathlib import Path

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots import Autopilot
from gcs.autopilots.px4_storage import stored_item
from gcs.autopilots.wire_item import renumber
from gcs.plans.plan_folder import load_plan_dir
from sim import FleetOptions, HomePose, MissionType, SimFleet, VehicleConfig, WireItem
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import Px4Sitl
from tests.peers.site import Airport, Site
from tests.sim import helpers  # noqa: F401  (MAVLink 2 for pymavlink, before mavutil is used)
from tests.sim.mission_client import MissionClient

pytestmark = [pytest.mark.autopilot, SITL_WORKER]

SITE = Site((Airport("field", 150.0, -120.0, "E", 3000.0),), half_m=400.0)
SPEEDUP = 5.0
REL, ABS = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL
REL_INT, ABS_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_INT
MISSION, FENCE, RALLY = MissionType.MISSION, MissionType.FENCE, MissionType.RALLY
# PX4's 50 Hz streams the simulator does not have, off so that no answer is lost in the flood
NOISY = (mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET,
         mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
         mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, mavlink.MAVLINK_MSG_ID_ATTITUDE)
INTERVALS = (33, 1, 147, 245, 24, 242, 230, 42, 193)  # the station's streams, MISSION_CURRENT, EKF_STATUS_REPORT
#: PX4's own readiness moves between runs (35.2-38.2 s of vehicle time seen on this SITL)
READY_SPREAD_S = 3.0
# the texts compared (PX4 SITL's own, such as "Preflight Fail: horizontal velocity unstable", are not)
TEXTS = ("IGN MISSION_ITEM", "WPM:", "REJ.", "Operation timeout", "Arming denied", "Switching to",
         "Mission start denied", "Geofence", "Preflight Fail: Vehicle is in safety configuration")


@dataclass
class Transcript:
    """What one vehicle answered: per step a MAV_MISSION_RESULT (or a command result), the
    requests of an upload, read-back lists, MISSION_CURRENT seqs, texts, readiness."""

    sent: dict[str, list[WireItem]] = field(default_factory=dict)
    results: dict[str, int | None] = field(default_factory=dict)
    requests: dict[str, list[tuple[str, int]]] = field(default_factory=dict)
    lists: dict[str, list[WireItem]] = field(default_factory=dict)
    current: dict[str, int | None] = field(default_factory=dict)
    legacy: list[tuple] = field(default_factory=list)
    texts: list[str] = field(default_factory=list)
    params: dict[str, tuple[float, int]] = field(default_factory=dict)
    ready_vt_s: float | None = None
    before_navigator_vt_s: float | None = None
    prearm_fields: tuple[bool, bool, bool] | None = None


def _at(lat: float, lon: float, frame: int, command: int, dn: float, de: float, z: float, *params: float,
        **kw) -> WireItem:
    p = list(params) + [0.0] * (4 - len(params))
    return WireItem(seq=0, frame=frame, command=command, x=round((lat + dn * 1e-5) * 1e7),
                    y=round((lon + de * 1e-5) * 1e7), z=z, param1=p[0], param2=p[1], param3=p[2], param4=p[3], **kw)


def varied(lat: float, lon: float) -> list[WireItem]:
    """Items whose storage loses or changes something: every accepted frame, params dropped,
    wrapped or made whole, float32 altitudes, NaN, autocontinue 0, one flagged current."""
    cmd = mavlink
    return renumber([
        _at(lat, lon, REL_INT, cmd.MAV_CMD_NAV_TAKEOFF, 0, 0, 30.456, 15.3, 2, 3, -30),
        _at(lat, lon, REL, cmd.MAV_CMD_NAV_WAYPOINT, 20, 0, 12.345, 7.5, 3.7, 2.2, 400),
        _at(lat, lon, ABS, cmd.MAV_CMD_NAV_WAYPOINT, 20, 20, 612.3449, -5, 300, 256, -90),
        _at(lat, lon, ABS_INT, cmd.MAV_CMD_NAV_WAYPOINT, 0, 20, 1234.5678, 70000, -3, 1, math.nan),
        _at(lat, lon, mavlink.MAV_FRAME_MISSION, cmd.MAV_CMD_DO_CHANGE_SPEED, 1, 1, 5.0, 1, 12.34, math.nan, 0,
            current=1, autocontinue=0),
        _at(lat, lon, REL, cmd.MAV_CMD_NAV_LOITER_TIME, 10, 10, 20.0, 12.5, 0.5, -40, math.nan),
        _at(lat, lon, mavlink.MAV_FRAME_MISSION, cmd.MAV_CMD_DO_LAND_START, 3, 3, 50.0, 1, 2, 3, 4),
        _at(lat, lon, REL, cmd.MAV_CMD_NAV_LAND, 0, 0, 0.004, 25.5, 2.9, 7, 720.5),
        _at(lat, lon, ABS_INT, cmd.MAV_CMD_NAV_LAND, 1, 1, 584.0, 0, -1, 0, 370),
        _at(lat, lon, mavlink.MAV_FRAME_MISSION, cmd.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0.0, 1, 2, 3, 4),
    ], MISSION)


def refused(lat: float, lon: float) -> dict[str, WireItem]:
    """Item 3 of a 6-item upload, each refused by PX4."""
    cmd = mavlink
    return {
        "terrain frame": _at(lat, lon, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, cmd.MAV_CMD_NAV_WAYPOINT, 5, 5, 30),
        "waypoint in frame 2": _at(lat, lon, mavlink.MAV_FRAME_MISSION, cmd.MAV_CMD_NAV_WAYPOINT, 5, 5, 30),
        "change speed in frame 3": _at(lat, lon, REL, cmd.MAV_CMD_DO_CHANGE_SPEED, 0, 0, 0, 1, 5),
        "unknown command": _at(lat, lon, REL, 31010, 5, 5, 30),
        "fence vertex in the mission": _at(lat, lon, REL_INT, cmd.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                                           5, 5, 0, 4),
    }


def odd_fence(lat: float, lon: float) -> list[WireItem]:
    """Vertex counts rounded, a negative radius, a return point with params, every frame."""
    cmd = mavlink
    inc, exc = cmd.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, cmd.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
    return renumber([
        _at(lat, lon, REL, cmd.MAV_CMD_NAV_FENCE_RETURN_POINT, 0, 0, 12.5, 1, 2, 3, 4),
        _at(lat, lon, ABS, inc, -50, -50, 0.0, 4.4, 1.1),
        _at(lat, lon, REL_INT, inc, -50, 50, 3.3, 3.6),
        _at(lat, lon, ABS_INT, inc, 50, 50, 640.0, 4.0, 0, 0, 9),
        _at(lat, lon, REL, inc, 50, -50, 1.0, 4.0),
        _at(lat, lon, ABS, exc, 10, 10, 0.0, 2.5),
        _at(lat, lon, ABS, exc, 10, 20, 0.0, 3.49),
        _at(lat, lon, ABS, exc, 20, 15, 0.0, 3.0),
        _at(lat, lon, REL_INT, cmd.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 0, 0.0, 500.5, 7),
        _at(lat, lon, ABS, cmd.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 30, 30, 5.0, -5.5),
    ], FENCE)


def odd_rally(lat: float, lon: float) -> list[WireItem]:
    cmd = mavlink.MAV_CMD_NAV_RALLY_POINT
    return renumber([_at(lat, lon, REL, cmd, 10, 0, 15.0, 1.5, 2.5, 3.5, 4.5),
                     _at(lat, lon, ABS, cmd, 0, 10, 600.25, autocontinue=0),
                     _at(lat, lon, REL_INT, cmd, -10, 0, 33.3),
                     _at(lat, lon, ABS_INT, cmd, 0, -10, 612.7)], RALLY)


# ---- the exchange -----------------------------------------------------------------------------


class Station:
    """A pymavlink ground station that records requests, ACKs, MISSION_CURRENT and texts."""

    def __init__(self, connection: str, sysid: int) -> None:
        self.conn = mavutil.mavlink_connection(connection, source_system=255, source_component=190,
                                               dialect="ardupilotmega")
        self.conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 16 << 20)
        self.target = (sysid, 1)
        self.mav = self.conn.mav
        self.texts: list[str] = []
        self.vt_s = 0.0
        self._heartbeat_s = 0.0
        self.client = MissionClient(self.conn, sysid, timeout_s=1.0, deadline_s=60.0)

    def recv(self, types: tuple[str, ...], timeout_s: float, pred=None):
        end = time.monotonic() + timeout_s
        while (left := end - time.monotonic()) > 0:
            if time.monotonic() - self._heartbeat_s >= 1.0:  # a station's HEARTBEAT at 1 Hz, the first to open the link
                self._heartbeat_s = time.monotonic()
                self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            msg = self.conn.recv_match(blocking=True, timeout=min(left, 0.5))
            if msg is None or msg.get_srcSystem() != self.target[0]:
                continue
            kind = msg.get_type()
            if kind == "STATUSTEXT":
                self.texts.append(msg.text)
            if hasattr(msg, "time_boot_ms"):
                self.vt_s = msg.time_boot_ms / 1000.0
            if kind in types and (pred is None or pred(msg)):
                return msg
        return None

    def settle(self, seconds: float) -> None:
        self.recv((), seconds)

    def command(self, command: int, *params: float) -> int | None:
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(*self.target, command, 0, *p)
        ack = self.recv(("COMMAND_ACK",), 3.0, lambda m: m.command == command)
        return None if ack is None else ack.result

    def upload(self, items: list[WireItem], mission_type: int = MISSION) -> tuple[int | None, list[tuple[str, int]]]:
        """Stop-and-wait upload answering every request with MISSION_ITEM_INT: the ACK's
        result and the requests as they came."""
        requests: list[tuple[str, int]] = []
        self.mav.mission_count_send(*self.target, len(items), mission_type)
        while True:
            msg = self.recv(("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"), 3.0,
                            lambda m: m.mission_type == mission_type)
            if msg is None:
                return None, requests
            if msg.get_type() == "MISSION_ACK":
                return msg.type, requests
            if not requests or requests[-1] != (msg.get_type(), msg.seq):  # PX4 asks again every 0.25 s
                requests.append((msg.get_type(), msg.seq))
            if 0 <= msg.seq < len(items):
                self.mav.send(renumber(items, mission_type)[msg.seq].to_msg(self.target))

    def download(self, mission_type: int = MISSION) -> list[WireItem]:
        return self.client.download(mission_type)

    def mission_current(self, *, taken_up: bool = False) -> int | None:
        """The seq of the next MISSION_CURRENT (those before the last answer were read);
        `taken_up`: of the first one within 3 s that names an item (not 65535)."""
        msg = self.recv(("MISSION_CURRENT",), 3.0, (lambda m: m.seq != 0xFFFF) if taken_up else None)
        return None if msg is None else msg.seq

    def legacy_readback(self, count: int) -> list[tuple]:
        self.mav.mission_request_list_send(*self.target, MISSION)
        self.recv(("MISSION_COUNT",), 3.0)
        out = []
        for seq in range(count):
            self.mav.mission_request_send(*self.target, seq, MISSION)
            msg = self.recv(("MISSION_ITEM", "MISSION_ITEM_INT"), 3.0, lambda m, seq=seq: m.seq == seq)
            out.append(None if msg is None else (msg.get_type(), msg.frame, msg.command, msg.current, msg.x, msg.y,
                                                  msg.z, msg.param1, msg.param4))
        self.mav.mission_ack_send(*self.target, mavlink.MAV_MISSION_ACCEPTED, MISSION)
        return out

    def param_set(self, name: str, raw: float, param_type: int) -> tuple[float, int] | None:
        self.mav.param_set_send(*self.target, name.encode(), raw, param_type)
        msg = self.recv(("PARAM_VALUE",), 3.0, lambda m: m.param_id == name)
        return None if msg is None else (msg.param_value, msg.param_type)

    def wait_prearm(self, timeout_s: float) -> tuple[float, tuple[bool, bool, bool]] | None:
        bit = mavlink.MAV_SYS_STATUS_PREARM_CHECK
        msg = self.recv(("SYS_STATUS",), timeout_s, lambda m: m.onboard_control_sensors_health & bit)
        if msg is None:
            return None
        return self.vt_s, (bool(msg.onboard_control_sensors_present & bit),
                           bool(msg.onboard_control_sensors_enabled & bit), True)

    def close(self) -> None:
        self.conn.close()


def exercise(st: Station, plan_dir: Path) -> Transcript:
    """The same exchange, in the same order, with any PX4 vehicle."""
    out = Transcript()
    assert st.recv(("HEARTBEAT",), 30.0) is not None
    for msg_id in NOISY:
        st.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, -1)
    st.settle(0.3)
    task = load_plan_dir(plan_dir).uavs[1]
    lat, lon = task.airport_lat_lon
    planned = renumber(task.mission_wire(Autopilot.PX4), MISSION)

    def upload(name: str, items: list[WireItem], mission_type: int = MISSION, read: bool = True,
               navigator: bool = False) -> None:
        """`navigator`: the navigator runs and takes up a new list some time after it arrived:
        MISSION_CURRENT is awaited until it has, then the list is read back."""
        out.sent[name] = items
        out.results[name], out.requests[name] = st.upload(items, mission_type)
        if mission_type == MISSION:
            out.current[name] = st.mission_current(taken_up=navigator)
        if read:
            out.lists[name] = st.download(mission_type)

    upload("planned", planned)
    st.mav.send(planned[-1].to_msg(st.target))  # the last item again, as after a lost ACK
    ack = st.recv(("MISSION_ACK",), 3.0)
    out.results["late item"] = None if ack is None else ack.type
    upload("varied", varied(lat, lon))
    out.legacy = st.legacy_readback(4)
    upload("planned again", planned)
    for name, bad in refused(lat, lon).items():
        items = planned[:6]
        items[3] = bad
        upload(name, renumber(items, MISSION), read=False)
    out.lists["after refusals"] = st.download()
    upload("fence", renumber(task.fence_wire(), FENCE), FENCE)
    upload("odd fence", odd_fence(lat, lon), FENCE)
    upload("rally", renumber(task.rally_wire(), RALLY), RALLY)
    upload("odd rally", odd_rally(lat, lon), RALLY)
    for name, mission_type, count in (("mission over capacity", MISSION, 65535),
                                      ("fence over capacity", FENCE, 65), ("rally over capacity", RALLY, 33),
                                      ("fence at capacity", FENCE, 64)):
        st.mav.mission_count_send(*st.target, count, mission_type)
        ack = st.recv(("MISSION_ACK", "MISSION_REQUEST", "MISSION_REQUEST_INT"), 3.0,
                      lambda m, t=mission_type: m.mission_type == t)
        out.results[name] = None if ack is None else (ack.type if ack.get_type() == "MISSION_ACK" else -1)
    st.mav.mission_ack_send(*st.target, mavlink.MAV_MISSION_OPERATION_CANCELLED, FENCE)
    out.lists["fence kept"] = st.download(FENCE)
    out.results["arm before ready"] = st.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    out.results["set current"] = st.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 1)
    for msg_id in INTERVALS:
        out.results[f"interval {msg_id}"] = st.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6)
    out.results["request 193"] = st.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 193)
    out.before_navigator_vt_s = st.vt_s
    out.results["before the navigator"] = int(st.vt_s < 33.0)  # PX4's navigator starts at 34.6 s

    ready = st.wait_prearm(90.0)
    assert ready is not None, "no pre-arm bit"
    out.ready_vt_s, out.prearm_fields = ready
    out.current["navigator"] = st.mission_current(taken_up=True)
    upload("fence cleared", [], FENCE, read=False)
    upload("after ready", planned[:8], navigator=True)
    # PX4 checks a list's feasibility after taking it up; a start before that is refused with "No
    # valid mission" (a slow machine, ci58), after it for its index: the texts depend on when it ends
    st.settle(1.0)
    out.results["start past the end"] = st.command(mavlink.MAV_CMD_MISSION_START, 8, 0)
    out.results["start NaN"] = st.command(mavlink.MAV_CMD_MISSION_START, math.nan, 0)
    out.params["COM_ARMABLE 0"] = st.param_set("COM_ARMABLE", 0.0, mavlink.MAV_PARAM_TYPE_INT32)
    st.settle(1.0)
    out.prearm_fields = (*out.prearm_fields, st.wait_prearm(1.0) is None)
    out.results["start, arming refused"] = st.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    out.results["arm, arming refused"] = st.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    st.settle(1.5)  # PX4's texts may come a second after the ACK they explain
    out.texts = [t.rstrip("\x00") for t in st.texts if t.startswith(TEXTS)]
    return out


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b


def differences(sim: Transcript, real: Transcript) -> list[str]:
    """Every answer in which the simulator differs from PX4 (readiness within 1.5 s)."""
    problems = [f"{k}: result {sim.results.get(k)}, PX4 {v}" for k, v in real.results.items()
                if sim.results.get(k) != v]
    problems += [f"{k}: requests {sim.requests.get(k)}, PX4 {v}" for k, v in real.requests.items()
                 if sim.requests.get(k) != v]
    problems += [f"{k}: MISSION_CURRENT {sim.current.get(k)}, PX4 {v}" for k, v in real.current.items()
                 if sim.current.get(k) != v]
    for name, want in real.lists.items():
        got = sim.lists.get(name, [])
        if len(got) != len(want):
            problems.append(f"{name}: {len(got)} items read back, PX4 {len(want)}")
            continue
        for g, w in zip(got, want):
            for f in fields(WireItem):
                a, b = getattr(g, f.name), getattr(w, f.name)
                if not _same(a, b):
                    problems.append(f"{name} item {w.seq} (command {w.command}): {f.name} {a!r}, PX4 {b!r}")
    for i, (g, w) in enumerate(zip(sim.legacy, real.legacy, strict=True)):
        if not _same(g, w):
            problems.append(f"legacy read-back {i}: {g}, PX4 {w}")
    # which texts, not how often: PX4 now and then leaves out a repeat (9 or 10 texts in runs in a row)
    if sorted(set(sim.texts)) != sorted(set(real.texts)):
        problems.append(f"texts {sorted(set(sim.texts))}, PX4 {sorted(set(real.texts))}")
    if sim.params != real.params:
        problems.append(f"params {sim.params}, PX4 {real.params}")
    if sim.prearm_fields != real.prearm_fields:
        problems.append(f"pre-arm bit (present, enabled, health, gone with COM_ARMABLE 0) {sim.prearm_fields}, "
                        f"PX4 {real.prearm_fields}")
    if sim.ready_vt_s is None or real.ready_vt_s is None or abs(sim.ready_vt_s - real.ready_vt_s) > READY_SPREAD_S:
        problems.append(f"ready at {sim.ready_vt_s} s, PX4 at {real.ready_vt_s} s")
    return problems


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory) -> Path:
    return SITE.plan(tmp_path_factory.mktemp("site") / "copter")


def _sim_transcript(plan_dir: Path) -> Transcript:
    lat, lon, alt, heading = SITE.home(0)
    fleet = SimFleet([HomePose(lat, lon, alt, heading)], VehicleConfig(profile="px4"),
                     FleetOptions(base_port=0, speedup=SPEEDUP))
    with fleet.running():
        st = Station(fleet.connection_strings()[0], 1)
        try:
            transcript = exercise(st, plan_dir)
        finally:
            st.close()
    assert not fleet.errors
    return transcript


def _px4_transcript(plan_dir: Path) -> Transcript:
    with Px4Sitl(home=SITE.home(0)[:3], sysid=1, speedup=SPEEDUP) as px4:
        st = Station(px4.gcs_connection, px4.sysid)
        try:
            return exercise(st, plan_dir)
        finally:
            st.close()


@pytest.fixture(scope="module")
def transcripts(plan_dir) -> tuple[Transcript, Transcript]:
    """(simulator, PX4), one after the other; each about 10 s. Both are asked once more, PX4 on a
    fresh instance, when their answers differ: in full-suite runs on the loaded 2-core CI machine
    a PX4 SITL now and then lost a STATUSTEXT or took up a list too late for the 3 s wait (twice in
    two runs, never in isolation), and the real CI of 7288668 failed on a difference that asking
    PX4 again did not mend (its text was cut from the log: the simulator's side, which was not asked
    again, is the suspect). The comparison itself is unchanged and must hold exactly for the second
    pair; the first pair's differences are reported as a warning, so a passing run still shows them."""
    sim, real = _sim_transcript(plan_dir), _px4_transcript(plan_dir)
    if first := differences(sim, real):
        warnings.warn(f"the first simulator/PX4 pair differed, asked both again: {first}", stacklevel=1)
        sim, real = _sim_transcript(plan_dir), _px4_transcript(plan_dir)
    return sim, real


def test_the_sim_answers_uploads_read_backs_and_commands_as_px4_does(transcripts):
    sim, real = transcripts
    assert real.requests["planned"][:2] == [("MISSION_REQUEST", 0), ("MISSION_REQUEST_INT", 1)]
    assert real.results["terrain frame"] == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    assert real.results["mission over capacity"] == mavlink.MAV_MISSION_NO_SPACE
    assert real.results["before the navigator"] == 1, \
        f"the SITL was too slow to finish before its navigator ran (at {real.before_navigator_vt_s} s of its time)"
    assert real.current["planned"] == 65535 and real.current["varied"] == 4
    assert len(real.lists["after refusals"]) == len(real.lists["planned again"])  # the old list, whole
    assert real.lists["varied"][1].frame == REL_INT and real.lists["fence"][0].frame == ABS_INT
    assert differences(sim, real) == []


def test_the_stations_model_predicts_what_px4_reads_back(transcripts):
    """The station's model (`px4_storage.stored_item`, what its verify compares with) against
    every list PX4 read back after an accepted upload (`current` aside)."""
    _, real = transcripts
    problems = []
    for name, back in real.lists.items():
        sent = real.sent.get(name)
        if sent is None or real.results.get(name) != mavlink.MAV_MISSION_ACCEPTED:
            continue
        assert len(sent) == len(back), name
        for s, b in zip(sent, back):
            want = stored_item(s)
            problems += [f"{name} item {s.seq} (command {s.command}): {f.name} {getattr(want, f.name)!r}, "
                         f"PX4 {getattr(b, f.name)!r}" for f in fields(WireItem)
                         if f.name != "current" and not _same(getattr(want, f.name), getattr(b, f.name))]
    assert problems == []
