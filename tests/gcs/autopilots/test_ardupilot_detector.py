"""The detector (`sim/detector.py`, `gcs detector`) on ArduCopter SITL: a camera component on
SERIAL2 reads the copter's position and its readings reach the station on SERIAL1 through
ArduPilot's routing, with the cells flown over and the hit/miss pattern the simulated vehicle
would give on the same seed; a lost reading comes back on the station's MAV_CMD_REQUEST_MESSAGE."""

from __future__ import annotations

import asyncio
import math
import signal
import subprocess
import sys
import time

import pytest

from gcs.flight.controller import FlightController, FlyOptions
from gcs.flight.fly import fly_async
from gcs.flight.online import observed_search
from gcs.links import CommandError, MavLink, mavlink
from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.plan_folder import load_plan_dir
from gcs.plans.planning import build_area_search
from gcs.telemetry.status import Stage
from planner.sensor_noise import reading_draw
from sim.detector import CAMERA_COMPONENT_ID, Detector, World, serve
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.ports import free_udp_port
from tests.peers.process import SITL_WORKER
from tests.peers.site import GROUND_AMSL_M, Airport, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

# the copter flies east along the row of the airport over five cell centres; targets in two of them
SITE = Site((Airport("west", -225.0, -45.0, "E", 700.0),), targets=((-165.0, -45.0), (-105.0, -45.0)))
SEED, PC, PF = 3, 0.9, 0.1
ALT_M = 20.0
SPEEDUP = 10.0  # at 20 the readings test's copter, steered cell by cell from here, leaves the readings behind
POSITION_ONLY = 0b0000_1101_1111_1000


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory):
    return SITE.plan(tmp_path_factory.mktemp("detector"), "--seed", str(SEED))


def _expected(world: World, cells: list[tuple[int, int]]) -> list[bool]:
    """What the simulated vehicle reports over these cells, each read once, on SEED."""
    sensor = world.sensor(1, seed=SEED, pc=PC, pf=PF)
    targets = {sensor.cell_of(*world.frame.geodetic2en(lat, lon)) for lat, lon in world.targets}
    return [reading_draw(SEED, 1, x, y, 0) < (PC if (x, y) in targets else PF) for x, y in cells]


async def _until(predicate, timeout_s: float, what: str) -> None:
    end = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        await asyncio.sleep(0.05)


async def _arm_and_take_off(station: MavLink, alt_m: float) -> None:
    await station.command(1, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)  # GUIDED
    end = time.monotonic() + 60.0
    while True:  # refused until the EKF uses GPS (about 4.5 s at speed-up 10)
        try:
            await station.command(1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, retries=0)
            break
        except CommandError:
            assert time.monotonic() < end, "the copter never armed"
            await asyncio.sleep(0.5)
    await station.command(1, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, alt_m)


def test_readings_reach_the_station_through_ardupilot_and_a_lost_one_is_recovered(plan_dir):
    plan = load_plan_dir(plan_dir)
    world = World.of_plan(plan)
    start = plan.cell_of(*plan.uavs[1].airport_lat_lon)
    cells = [(start[0] + i, start[1]) for i in range(5)]
    expected = _expected(world, cells)
    assert any(expected) and not all(expected)  # the seed gives hits and misses to tell apart
    lat0, lon0 = plan.cell_lat_lon(*cells[0])
    lat1, lon1 = plan.cell_lat_lon(*cells[-1])

    async def main():
        with ArduPilotSitl("copter", home=(lat0, lon0, GROUND_AMSL_M, 90.0), speedup=SPEEDUP) as sitl:
            detector = Detector(world.sensor(1, seed=SEED, pc=PC, pf=PF), 1)
            camera = MavLink(f"tcp:127.0.0.1:{sitl.tcp_port_2}", source_system=1,
                             source_component=CAMERA_COMPONENT_ID, heartbeat=False)
            async with MavLink(sitl.udp_connection) as station, camera:
                send, lost = camera.send, []

                def lossy(msg):  # the first sending of reading 1 is lost on the way
                    if msg.get_type() == "CAMERA_IMAGE_CAPTURED" and msg.image_index == 1 and not lost:
                        lost.append(msg)
                        return
                    send(msg)

                camera.send = lossy
                from_camera = []  # what the station hears from (1, 100) besides the readings
                station.subscribe(lambda msg: from_camera.append(msg) if msg.get_srcComponent() == CAMERA_COMPONENT_ID
                                  and msg.get_type() in ("STATUSTEXT", "HEARTBEAT") else None)
                controller = FlightController(plan, [station], FlyOptions())
                served = asyncio.create_task(serve(camera, detector))
                status = controller.status[1]
                try:
                    assert await controller.vehicles[1].prepare(mission=False), status.note  # streams, GPS, EKF, home
                    await _arm_and_take_off(station, ALT_M)
                    await _until(lambda: status.rel_alt_m > ALT_M - 1.0, 60.0, "the take-off")
                    end_en = plan.local_m(lat1, lon1)
                    while math.dist(plan.local_m(status.lat_deg, status.lon_deg), end_en) > 1.0:
                        station.send(mavlink.MAVLink_set_position_target_global_int_message(
                            0, 1, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POSITION_ONLY, round(lat1 * 1e7),
                            round(lon1 * 1e7), ALT_M, 0, 0, 0, 0, 0, 0, 0, 0))
                        await asyncio.sleep(0.2)
                        controller.recover_readings(time.monotonic())
                    await _until(lambda: len(status.detections) >= len(cells), 10.0, "the readings")
                    end = time.monotonic() + 10.0
                    while 1 not in status.detection_indices and time.monotonic() < end:
                        controller.recover_readings(time.monotonic())  # asks again once a second
                        await asyncio.sleep(0.1)
                finally:
                    served.cancel()
        return status, controller, lost, from_camera

    status, controller, lost, from_camera = asyncio.run(main())
    assert lost, "reading 1 was never sent"
    assert controller.vehicles[1].reading_component == CAMERA_COMPONENT_ID
    arrived = [d.index for d in status.detections]
    assert arrived.index(1) > arrived.index(2)  # recovered after the next one came
    got = sorted(status.detections, key=lambda d: d.index)
    assert [d.index for d in got] == list(range(len(cells)))
    assert [plan.cell_of(d.lat_deg, d.lon_deg) for d in got] == cells
    assert [d.hit for d in got] == expected
    texts = [m.text for m in from_camera if m.get_type() == "STATUSTEXT"]
    assert texts == [f"DETECT cell {x},{y} img {i}" for i, ((x, y), hit) in enumerate(zip(cells, expected)) if hit]
    beats = [m for m in from_camera if m.get_type() == "HEARTBEAT"]
    camera = (mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID)
    assert beats and all((m.type, m.autopilot) == camera for m in beats)


def test_online_search_on_ardupilot_with_the_detector_updates_the_belief_map(tmp_path):
    """`gcs detector` on SERIAL2 (SITL pushing to it over UDP) and the online flight on SERIAL1:
    the planner steers the copter cell by cell on the detector's readings, folds every one into
    the shared map, and lands it at its airport."""
    site = Site((Airport("west", -225.0, -45.0, "E", 500.0),), targets=((-165.0, -45.0),))
    plan_dir = site.plan(tmp_path, "--seed", str(SEED), "--altitude", "15")
    area = str(tmp_path / "site.geojson")
    plan = load_plan_dir(plan_dir)
    port = free_udp_port()
    detector = subprocess.Popen([sys.executable, "-m", "gcs.cli", "detector", "--plan", str(plan_dir), "--uav", "1",
                                 "--connect", f"udpin:127.0.0.1:{port}"], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
    try:
        with ArduPilotSitl("copter", home=site.home(0), speedup=SPEEDUP, serial2=f"udpclient:127.0.0.1:{port}") as sitl:
            setup = build_area_search(area, AreaOptions(altitude_m=15), SearchOptions(seed=SEED, strategy="exhaustive"))
            search = observed_search(setup.search.scenario, setup.search.config, seed=SEED)
            prior = search.map.tep.copy()
            controller = asyncio.run(asyncio.wait_for(
                fly_async(plan, [sitl.udp_connection], FlyOptions(), online=search), 240))
    finally:
        detector.send_signal(signal.SIGTERM)
        try:
            out, _ = detector.communicate(timeout=10)
        finally:
            detector.kill()
    assert detector.returncode == 0, out
    status = controller.status[1]
    assert status.stage is Stage.LANDED, status.note
    assert controller.vehicles[1].reading_component == CAMERA_COMPONENT_ID
    readings = {d.index: d for d in status.detections}
    assert len(readings) >= 5 and sorted(readings) == list(range(len(readings)))
    assert int(search.map.visits.sum()) == len(readings)  # every reading folded into the map
    targets, visits = set(plan.targets), {}
    for i in sorted(readings):  # each the simulated sensor's draw for this UAV, cell and visit
        d, cell = readings[i], plan.cell_of(readings[i].lat_deg, readings[i].lon_deg)
        visit = visits[cell] = visits.get(cell, -1) + 1
        assert d.hit == (reading_draw(SEED, 1, *cell, visit) < (PC if cell in targets else PF))
        if search.map.visits[cell] == 1:
            assert (search.map.tep[cell] > prior[cell]) == d.hit
    assert f"seed {SEED}, pc 0.9, pf 0.1" in out and f"UAV 1: {len(readings)} readings" in out
