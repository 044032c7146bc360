"""The simulator's `ardupilot` profile against real ArduCopter and ArduPlane SITL: the same
uploads to both (a planned mission, a mission of varied items, a plane's landing sequence, the
planned fence polygons and rally point, a refused upload over a stored mission, a COUNT over
capacity), and their read-backs compared field by field. Item 0 is each vehicle's own home
(SITL's differs from the `--home` given by a few degE7): its frame and command are compared,
and its position with that vehicle's HOME_POSITION.

The simulator stores items through the one model of ArduPilot's storage the ground station's
verify also uses (`gcs.autopilots.ardupilot_storage.stored_item`), so this test is what keeps
that model true: every field must agree, down to the float32 of an altitude."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from pathlib import Path

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots import Autopilot
from gcs.autopilots.wire_item import renumber
from gcs.plans.plan_folder import load_plan_dir
from sim import FleetOptions, HomePose, MissionType, SimFleet, VehicleConfig, WireItem
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.process import SITL_WORKER
from tests.peers.site import Airport, Site
from tests.sim import helpers  # noqa: F401  (MAVLink 2 for pymavlink, before mavutil is used)
from tests.sim.mission_client import MissionClient, MissionTransferError

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

# an airport with room for a plane's 250 m approach west of it, inside the square
SITE = Site((Airport("runway", 150.0, -120.0, "E", 3000.0),), half_m=400.0)
REL, ABS = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL
CAPACITY = {"copter": 650, "plane": 655}
STEPS = ("planned", "varied", "refused", "fence", "rally")


@dataclass
class Transcript:
    """What one vehicle answered: per step the upload's MAV_MISSION_RESULT and the read-back."""

    home: tuple[int, int, float]
    results: dict[str, int] = field(default_factory=dict)
    lists: dict[str, list[WireItem]] = field(default_factory=dict)
    texts: list[str] = field(default_factory=list)


def varied(lat: float, lon: float, plane: bool) -> list[WireItem]:
    """Items whose storage loses or changes something: frames with and without _INT, cut
    altitudes, params made whole, NaN where allowed, a location on a command without one."""
    def at(seq, frame, command, dn, de, z, *params, **kw):
        return WireItem(seq=seq, frame=frame, command=command, x=round((lat + dn * 1e-5) * 1e7),
                        y=round((lon + de * 1e-5) * 1e7), z=z, param1=params[0] if params else 0.0,
                        param2=params[1] if len(params) > 1 else 0.0, param3=params[2] if len(params) > 2 else 0.0,
                        param4=params[3] if len(params) > 3 else 0.0, **kw)

    items = [
        at(0, ABS, mavlink.MAV_CMD_NAV_WAYPOINT, 55, 55, 999.0, 9, 8, 7, 6),
        at(1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 30.456, 15.3, 2, 3,
           math.nan),
        at(2, REL, mavlink.MAV_CMD_NAV_WAYPOINT, 20, 0, 12.349, 7.5, 3.7, 2.2, math.nan),
        at(3, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_NAV_WAYPOINT, 20, 20, 612.3449, 300.9, 300, 256, 45),
        at(4, REL, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, 1, 5.0, 1, 12.34, 55.5, 0, current=1, autocontinue=0),
        at(5, REL, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 20, -12.345, -5, -3, 0.9, 0),
        at(5, mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_NAV_WAYPOINT, 5, 25, 603.0),
        at(5, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT, 10, 25, 55.5),
        at(6, ABS, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, 3, 3, 50.0, 1, 2, 3, 4),
        at(7, REL, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0.004, 25.5, 0, 0, 0),
        at(8, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_LAND, 1, 1, 0.0, 0, 0, 0, -7),
    ]
    if plane:
        items[6:6] = [at(6, REL, mavlink.MAV_CMD_DO_LAND_START, -10, -10, 0.0),
                      at(7, REL, mavlink.MAV_CMD_NAV_WAYPOINT, -10, -30, 40.0)]
    return renumber(items, MissionType.MISSION)


def _wait_home(conn, sysid: int, timeout_s: float = 60.0) -> tuple[int, int, float]:
    """Ask for HOME_POSITION until the vehicle has one (ArduPilot: some seconds after boot)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        conn.mav.command_long_send(sysid, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                   mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0, 0, 0, 0, 0, 0)
        msg = conn.recv_match(type="HOME_POSITION", blocking=True, timeout=0.5)
        if msg is not None and msg.get_srcSystem() == sysid:
            return msg.latitude, msg.longitude, msg.altitude / 1000.0
    raise AssertionError("no HOME_POSITION")


def _texts(conn) -> list[str]:
    out = []
    while (msg := conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.3)) is not None:
        out.append(msg.text)
    return out


def exercise(conn, sysid: int, vehicle: str, plan_dir: Path) -> Transcript:
    """The same uploads, in the same order, to any ArduPilot vehicle on `conn`."""
    conn.wait_heartbeat(timeout=30)
    home = _wait_home(conn, sysid)
    task = load_plan_dir(plan_dir).uavs[1]
    planned = task.mission_wire(Autopilot.ARDUPILOT)
    lat, lon = task.airport_lat_lon
    odd = varied(lat, lon, vehicle == "plane")
    refused = odd[:6]
    refused[3] = WireItem(seq=3, frame=mavlink.MAV_FRAME_LOCAL_NED, command=mavlink.MAV_CMD_NAV_WAYPOINT,
                          x=1, y=2, z=3)
    client = MissionClient(conn, sysid, timeout_s=0.5, deadline_s=60.0)
    out = Transcript(home)
    for name, items, kind in (("planned", planned, MissionType.MISSION), ("varied", odd, MissionType.MISSION),
                              ("refused", refused, MissionType.MISSION), ("fence", task.fence_wire(), 1),
                              ("rally", task.rally_wire(), 2)):
        if name == "refused":
            client.upload(planned)  # a known list for the refused upload to mix with
        try:
            client.upload(items, kind)
            out.results[name] = mavlink.MAV_MISSION_ACCEPTED
        except MissionTransferError as exc:
            out.results[name] = exc.result
        out.lists[name] = client.download(kind)
        if name == "planned":  # the last item again, as after a lost ACK: the upload is over
            conn.mav.send(planned[-1].to_msg((sysid, 1)))
            ack = conn.recv_match(type="MISSION_ACK", blocking=True, timeout=5)
            out.results["late item"] = ack.type if ack is not None else None
    conn.mav.mission_count_send(sysid, 1, CAPACITY[vehicle] + 1, 0)
    ack = conn.recv_match(type="MISSION_ACK", blocking=True, timeout=5)
    out.results["too many"] = ack.type if ack is not None else None
    out.texts = _texts(conn)
    return out


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def differences(sim: Transcript, real: Transcript) -> list[str]:
    """Every field in which the simulator's answers differ from SITL's."""
    problems = [f"{step}: result {sim.results.get(step)} != {real.results.get(step)}"
                for step in (*STEPS, "late item", "too many") if sim.results.get(step) != real.results.get(step)]
    for step in STEPS:
        got, want = sim.lists[step], real.lists[step]
        if len(got) != len(want):
            problems.append(f"{step}: {len(got)} items read back, SITL {len(want)}")
            continue
        for g, w in zip(got, want):
            if step != "fence" and step != "rally" and g.seq == 0:  # home: each vehicle's own
                if (g.frame, g.command) != (w.frame, w.command):
                    problems.append(f"{step} home: frame/command {g.frame}/{g.command} != {w.frame}/{w.command}")
                for t, item in (("sim", g), ("SITL", w)):
                    home = sim.home if t == "sim" else real.home
                    if (item.x, item.y) != home[:2] or abs(item.z - home[2]) > 0.011:
                        problems.append(f"{step} home ({t}): {item.x},{item.y},{item.z} is not HOME_POSITION {home}")
                continue
            for f in fields(WireItem):
                a, b = getattr(g, f.name), getattr(w, f.name)
                if not _same(a, b):
                    problems.append(f"{step} item {g.seq} (command {w.command}): {f.name} {a!r}, SITL {b!r}")
    return problems


def _sim_transcript(vehicle: str, plan_dir: Path) -> Transcript:
    lat, lon, alt, heading = SITE.home(0)
    fleet = SimFleet([HomePose(lat, lon, alt, heading)], VehicleConfig(vehicle_type=vehicle),
                     FleetOptions(base_port=0, speedup=10.0))
    with fleet.running():
        conn = mavutil.mavlink_connection(fleet.connection_strings()[0], source_system=255, source_component=190,
                                          dialect="ardupilotmega")
        try:
            conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            transcript = exercise(conn, 1, vehicle, plan_dir)
        finally:
            conn.close()
    assert not fleet.errors
    return transcript


def _sitl_transcript(vehicle: str, plan_dir: Path) -> Transcript:
    with ArduPilotSitl(vehicle, home=SITE.home(0), speedup=20) as sitl:
        conn = mavutil.mavlink_connection(sitl.udp_connection, source_system=255, source_component=190,
                                          dialect="ardupilotmega")
        try:
            return exercise(conn, sitl.sysid, vehicle, plan_dir)
        finally:
            conn.close()


@pytest.mark.parametrize("vehicle", ["copter", "plane"])
def test_the_sim_reads_back_what_arducopter_and_arduplane_read_back(tmp_path, vehicle):
    plan_dir = SITE.plan(tmp_path, "--vehicle", vehicle)
    sim, real = _sim_transcript(vehicle, plan_dir), _sitl_transcript(vehicle, plan_dir)  # each about 6 s
    assert real.results["refused"] == mavlink.MAV_MISSION_UNSUPPORTED_FRAME  # the SITL did refuse it
    assert real.results["too many"] == mavlink.MAV_MISSION_NO_SPACE
    assert real.results["late item"] == mavlink.MAV_MISSION_ERROR  # not a repeated ACCEPTED
    assert f"Only {CAPACITY[vehicle]} items are supported" in real.texts
    assert f"Only {CAPACITY[vehicle]} items are supported" in sim.texts
    assert len(real.lists["refused"]) == 6  # COUNT 6 refused at item 3: 1-2 new, 3-5 old
    assert any(it.command == mavlink.MAV_CMD_DO_LAND_START for it in real.lists["planned"]) is (vehicle == "plane")
    assert differences(sim, real) == []
