"""The detector for real vehicles (`sim/detector.py`) against the simulated vehicle: the same
world as `gcs fly --sim` (frame, grid, targets), the same readings for the same track and seed,
message for message; its MAVLink side (positions in, commands answered, ids and heartbeat)."""

from __future__ import annotations

import asyncio
import dataclasses
import math
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from gcs.cli import main
from gcs.flight.fly import fly_async
from gcs.links import MavLink, mavlink
from gcs.plans.plan_folder import load_plan_dir
from sim.autopilot.telemetry import reading_message
from sim.detector import CAMERA_COMPONENT_ID, MAX_GAP_S, Detector, Fix, World, serve
from sim.plan_fleet import fleet_for_plan
from tests.gcs.flight.conftest import fast_options
from tests.gcs.flight.test_bad_input import _one_error_line

ROOT = Path(__file__).resolve().parents[2]
PC, PF = 0.9, 0.1


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("detector") / "paper"
    assert main(["plan", "--area", str(ROOT / "missions" / "paper.geojson"), "--seed", "0", "--strategy", "exhaustive",
                 "--out", str(out), "--quiet", "--no-rrd"]) == 0
    return out


@pytest.fixture(scope="module")
def plan(plan_dir):
    return load_plan_dir(plan_dir)


def _track(vehicle, points_lat_lon, *, alt_m: float = 20.0, speed_m_s: float = 10.0, dt_s: float = 0.1,
           offset_m: tuple[float, float] = (0.0, 0.0)):
    """(time, east, north, alt) every `dt_s`: a vertical climb at the first point, then straight
    legs through the points (shifted by `offset_m`) at `speed_m_s`, in the vehicle's frame."""
    pts = [tuple(a + b for a, b in zip(vehicle.frame.geodetic2en(lat, lon), offset_m)) for lat, lon in points_lat_lon]
    out, t, here, alt = [], 0.0, pts[0], 0.0
    while alt < alt_m:
        out.append((t, *here, alt))
        t, alt = round(t + dt_s, 6), min(alt_m, alt + 2.5 * dt_s)
    for goal in pts[1:]:
        while here != goal:
            d = math.dist(here, goal)
            f = min(1.0, speed_m_s * dt_s / d)
            here = goal if f == 1.0 else (here[0] + f * (goal[0] - here[0]), here[1] + f * (goal[1] - here[1]))
            t = round(t + dt_s, 6)
            out.append((t, *here, alt))
    return out


def _sim_readings(vehicle, track):
    """What the simulated vehicle reports flying `track`: its sensor stepped as `SimVehicle.step`
    steps it, its own CAMERA_IMAGE_CAPTURED."""
    out = []
    for t, east, north, alt in track:
        kin = vehicle.airframe.kin
        kin.east_m, kin.north_m, kin.alt_m = east, north, alt
        obs = vehicle.airframe.sense(t)
        if obs is not None:
            out.append(vehicle._capture_msg(obs))
    return out


def _detector_readings(detector, frame, track, every: int = 2):
    """What the detector reports from every `every`-th point of `track` as position reports."""
    out = []
    for t, east, north, alt in track[::every]:
        lat, lon = frame.en2geodetic(east, north)
        fix = Fix(round(t * 1000) / 1000, round(lat * 1e7) / 1e7, round(lon * 1e7) / 1e7, round(alt * 1000) / 1000,
                  round(alt * 1000) / 1000)
        out += [m for m in detector.position(fix) if m.get_type() == "CAMERA_IMAGE_CAPTURED"]
    return out


def _same(a, b) -> bool:
    """The same reading; the time within one sim step (0.1 s: after a corner the sim's steps and
    the detector's interpolation do not line up), altitudes within rounding."""
    exact = ("image_index", "lat", "lon", "file_url", "capture_result", "camera_id", "q")
    return all(getattr(a, f) == getattr(b, f) for f in exact) and abs(a.time_boot_ms - b.time_boot_ms) <= 100 \
        and abs(a.alt - b.alt) <= 1 and abs(a.relative_alt - b.relative_alt) <= 1


def test_the_detector_senses_the_world_of_the_simulated_fleet(plan):
    world = World.of_plan(plan)
    fleet = fleet_for_plan(plan, speedup=1.0, seed=5, pc=PC, pf=PF)  # not started: only its vehicles are read
    for uid in plan.uavs:
        sim_sensor, ours = fleet.vehicle(uid).sensor, world.sensor(uid, seed=5, pc=PC, pf=PF)
        assert (ours.frame, ours.origin_en, ours.config, ours.seed, ours.vehicle_id) == \
               (sim_sensor.frame, sim_sensor.origin_en, sim_sensor.config, sim_sensor.seed, sim_sensor.vehicle_id)
        assert ours._target_cells == sim_sensor._target_cells and len(ours._target_cells) == 10
    # the sensor grid is the plan grid: a plan cell's centre is that cell
    sensor = world.sensor(1, seed=0, pc=PC, pf=PF)
    for x, y in [(0, 0), (7, 3), (49, 49)]:
        assert sensor.cell_of(*world.frame.geodetic2en(*plan.cell_lat_lon(x, y))) == (x, y)


def test_an_area_file_gives_the_world_of_its_plan_folder(plan, plan_dir):
    """`gcs detector --area` lays the area out as `gcs plan --area` does, without planning."""
    from gcs.cli import build_parser
    from gcs.cli.commands.detector import _world

    def world(*source: str):
        return _world(build_parser().parse_args(["detector", *source, "--uav", "1", "--connect", "tcp:127.0.0.1:5763"]))

    # the world, the UAVs, the seed (the plan's: 0) and the sensor's Pc and Pf (the plan's: 0.9, 0.1)
    assert world("--area", str(ROOT / "missions" / "paper.geojson")) == (World.of_plan(plan), [1, 2, 3, 4], 0,
                                                                         (PC, PF))
    assert world("--plan", str(plan_dir)) == (World.of_plan(plan), [1, 2, 3, 4], 0, (PC, PF))


@pytest.mark.parametrize("seed, offset_m", [(0, (0.0, 0.0)), (1, (6.0, -4.0)), (2, (-8.5, 3.0))])
def test_same_track_same_seed_same_readings_as_the_simulated_vehicle(plan, seed, offset_m):
    """Every UAV's planned trajectory flown at 10 m/s (cells read again on the way home too),
    on the cell centres and off them: the simulated vehicle steps its sensor every 0.1 s, the
    detector gets positions at 5 Hz; the readings are the same, message for message."""
    world = World.of_plan(plan)
    fleet = fleet_for_plan(plan, speedup=1.0, seed=seed, pc=PC, pf=PF)
    for uid, task in plan.uavs.items():
        vehicle = fleet.vehicle(uid)
        track = _track(vehicle, [(p.lat_deg, p.lon_deg) for p in task.trajectory], offset_m=offset_m)
        sim = _sim_readings(vehicle, track)
        ours = _detector_readings(Detector(world.sensor(uid, seed=seed, pc=PC, pf=PF), uid), world.frame, track)
        assert len(sim) > 100 and any(b"hit=1" in m.file_url.encode() if isinstance(m.file_url, str)
                                      else b"hit=1" in m.file_url for m in sim)
        assert len(ours) == len(sim)
        assert all(_same(a, b) for a, b in zip(ours, sim)), next((a, b) for a, b in zip(ours, sim) if not _same(a, b))


def test_reading_message_is_the_simulated_vehicles_message(plan):
    fleet = fleet_for_plan(plan, speedup=1.0, seed=0, pc=PC, pf=PF)
    vehicle = fleet.vehicle(2)
    track = _track(vehicle, [(p.lat_deg, p.lon_deg) for p in plan.uavs[2].trajectory[:20]])
    for t, east, north, alt in track:
        kin = vehicle.airframe.kin
        kin.east_m, kin.north_m, kin.alt_m = east, north, alt
        obs = vehicle.airframe.sense(t)
        if obs is not None:
            ours = reading_message(obs, vehicle.config.sensor, vehicle.home.alt_m + alt, alt)
            assert ours.pack(mavlink.MAVLink(None)) == vehicle._capture_msg(obs).pack(mavlink.MAVLink(None))


def _detector(plan, uid: int = 1) -> Detector:
    return Detector(World.of_plan(plan).sensor(uid, seed=0, pc=PC, pf=PF), uid)


def _fix(plan, cell, t_s: float, alt_m: float = 20.0) -> Fix:
    lat, lon = plan.cell_lat_lon(*cell)
    return Fix(t_s, lat, lon, 500.0 + alt_m, alt_m)


def test_long_gaps_and_missing_gps_are_not_tracks(plan):
    det = _detector(plan)
    assert det.position(Fix(0.0, 0.0, 0.0, 0.0, 30.0)) == []  # no GPS origin yet: (0, 0)
    det.position(_fix(plan, (5, 5), 1.0))
    assert [o.cell for o in det.observations] == [(5, 5)]
    det.position(_fix(plan, (9, 5), 1.0 + MAX_GAP_S + 0.1))  # a jump: cells 6-8 were not seen flown over
    assert [o.cell for o in det.observations] == [(5, 5), (9, 5)]
    det.position(_fix(plan, (12, 5), 1.0 + 2 * MAX_GAP_S))  # a track: 10 and 11 on the way
    assert [o.cell for o in det.observations] == [(5, 5), (9, 5), (10, 5), (11, 5), (12, 5)]
    det.position(_fix(plan, (12, 5), 5.0, alt_m=1.0))  # below the sensor's floor: nothing, and ...
    det.position(_fix(plan, (12, 5), 5.2))  # ... back up, the cell is read again (its second visit)
    assert [o.cell for o in det.observations][-1] == (12, 5) and len(det.observations) == 6


def _wire(msg, system: int, component: int):
    """`msg` as received from (system, component)."""
    codec = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
    return codec.parse_char(msg.pack(codec))


def test_commands_to_the_camera_are_answered_and_a_lost_reading_is_sent_again(plan):
    det = _detector(plan, 3)
    det.position(_fix(plan, (5, 5), 1.0))
    det.position(_fix(plan, (6, 5), 1.2))
    ask = mavlink.MAVLink_command_long_message(3, CAMERA_COMPONENT_ID, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                               mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED, 1, 0, 0, 0, 0, 0)
    ack, again = det.handle(_wire(ask, 255, 190))
    assert (ack.command, ack.result, ack.target_system, ack.target_component) == \
           (mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAV_RESULT_ACCEPTED, 255, 190)
    assert again is det.captures[1] and again.image_index == 1
    ask.param2 = 7
    assert [m.result for m in det.handle(_wire(ask, 255, 190))] == [mavlink.MAV_RESULT_DENIED]  # not taken yet
    other = mavlink.MAVLink_command_long_message(3, CAMERA_COMPONENT_ID, mavlink.MAV_CMD_DO_DIGICAM_CONTROL, 0,
                                                 0, 0, 0, 0, 1, 0, 0)
    assert [m.result for m in det.handle(_wire(other, 255, 190))] == [mavlink.MAV_RESULT_UNSUPPORTED]
    ask.param2 = 1
    for target in ((3, 1), (3, 0), (4, CAMERA_COMPONENT_ID)):  # the autopilot's, or another vehicle's
        ask.target_system, ask.target_component = target
        assert det.handle(_wire(ask, 255, 190)) == []
    lat, lon = plan.cell_lat_lon(8, 5)
    position = mavlink.MAVLink_global_position_int_message(1400, round(lat * 1e7), round(lon * 1e7), 520_000, 20_000,
                                                           0, 0, 0, 0)
    assert det.handle(_wire(position, 3, 7)) == []  # not the autopilot
    out = det.handle(_wire(position, 3, 1))  # the autopilot: 7 and 8 read on the way from 6
    assert [m.image_index for m in out if m.get_type() == "CAMERA_IMAGE_CAPTURED"] == [2, 3]


def test_attached_to_a_simulated_vehicle_it_reports_what_the_vehicle_reports(plan):
    """Over MAVLink: the detector on vehicle 1's TCP port (as on a companion computer) asks for
    positions and reads what vehicle 1's own sensor reads while `gcs fly` flies the plan."""
    fleet = fleet_for_plan(plan, speedup=10.0, seed=4, pc=PC, pf=PF)
    fleet.options = dataclasses.replace(fleet.options, tcp=True)
    det = Detector(World.of_plan(plan).sensor(1, seed=4, pc=PC, pf=PF), 1)

    async def main():
        camera = MavLink(fleet.tcp_connection_strings()[0], source_system=1, source_component=CAMERA_COMPONENT_ID,
                         heartbeat=False)
        async with camera:
            served = asyncio.create_task(serve(camera, det))
            flight = asyncio.create_task(fly_async(plan, fleet.connection_strings(), fast_options()))
            end = time.monotonic() + 60.0
            while len(fleet.vehicle(1).observations) < 15 and time.monotonic() < end and not flight.done():
                await asyncio.sleep(0.2)
            await asyncio.sleep(0.5)  # the last position reports on their way
            for task in (flight, served):
                task.cancel()
            await asyncio.gather(flight, served, return_exceptions=True)

    with fleet.running():
        asyncio.run(main())
    sim, ours = fleet.vehicle(1).observations, det.observations
    assert len(sim) >= 15 and len(ours) >= len(sim) - 1
    assert [(o.cell, o.reported) for o in ours[:len(sim)]] == [(o.cell, o.reported) for o in sim[:len(ours)]]
    assert not fleet.errors


def test_the_camera_heartbeat(plan):
    hb = _detector(plan).heartbeat()
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID)


# ---- the command ----------------------------------------------------------------------------


def test_bad_input_is_one_line(plan_dir, tmp_path, capsys):
    plan = ["--plan", str(plan_dir)]
    cases = [
        ([*plan, "--connect", "tcp:127.0.0.1:5763"], "give --uav ID"),
        (["--uav", "1", "--connect", "tcp:127.0.0.1:5763"], "give --plan DIR"),
        ([*plan, "--area", "x.geojson", "--uav", "1", "--connect", "tcp:127.0.0.1:5763"], "give --plan DIR"),
        ([*plan, "--uav", "1", "--uav", "2", "--connect", "tcp:127.0.0.1:5763"], "one --connect per --uav"),
        ([*plan, "--uav", "1", "--uav", "1", "--connect", "tcp:127.0.0.1:5763", "--connect", "tcp:127.0.0.1:5773"],
         "each UAV once"),
        ([*plan, "--uav", "9", "--connect", "tcp:127.0.0.1:5763"],
         "--uav 9: not a UAV of the plan (it has 1, 2, 3, 4)"),
        ([*plan, "--uav", "1", "--connect", "tcp:127.0.0.1"], "bad connection string"),
        ([*plan, "--uav", "1", "--connect", "tcp:127.0.0.1:5763", "--pf", "1.5"], "--pf must be a probability"),
        (["--plan", str(tmp_path / "nowhere"), "--uav", "1", "--connect", "tcp:127.0.0.1:5763"], "does not exist"),
        (["--area", str(tmp_path / "nowhere.geojson"), "--uav", "1", "--connect", "tcp:127.0.0.1:5763"],
         "cannot read area file"),
        ([*plan, "--uav", "one", "--connect", "tcp:127.0.0.1:5763"], "invalid int value"),
    ]
    for args, said in cases:
        assert main(["detector", *args]) == 2, args
        assert said in _one_error_line(capsys), args
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))  # bound, not listening: the connection is refused
        port = s.getsockname()[1]
        assert main(["detector", *plan, "--uav", "1", "--connect", f"tcp:127.0.0.1:{port}"]) == 2
    assert "connection refused" in _one_error_line(capsys)


def test_one_process_serves_several_vehicles_until_interrupted(plan_dir, plan):
    fleet = fleet_for_plan(plan, speedup=10.0, seed=0, pc=PC, pf=PF)
    fleet.options = dataclasses.replace(fleet.options, tcp=True)
    with fleet.running():
        tcp = fleet.tcp_connection_strings()
        proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "detector", "--plan", str(plan_dir), "--seed", "4",
                                 "--uav", "1", "--connect", tcp[0], "--uav", "3", "--connect", tcp[2]],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        watchdog = threading.Timer(60.0, proc.kill)  # a detector that never comes up fails the test, not CI
        watchdog.start()
        try:
            started = []
            for line in proc.stdout:  # interrupted once both are serving (its start takes seconds on a busy machine)
                started.append(line)
                if "UAV 3: detector on" in line:
                    break
            time.sleep(2.0)  # 20 s of the vehicles' time: positions asked for and received
            proc.send_signal(signal.SIGINT)
            rest, _ = proc.communicate(timeout=10)
            out = "".join(started) + rest
        finally:
            watchdog.cancel()
            proc.kill()
    assert proc.returncode == 0, out
    assert f"world of {plan_dir}: 20 m cells, 10 targets, seed 4, pc 0.9, pf 0.1" in out
    for uid, conn in ((1, tcp[0]), (3, tcp[2])):
        assert f"UAV {uid}: detector on {conn} as system {uid} component 100" in out
        positions = re.search(rf"UAV {uid}: 0 readings \(0 positive\) from (\d+) positions", out)
        assert positions and int(positions[1]) > 5, out  # asked for and got them, on the ground
