"""`gcs fly --online` on a mixed fleet: an ArduCopter and a PX4 copter, each with `gcs detector`
attached as a MAVLink camera next to its autopilot (ArduPilot: SERIAL2; PX4: its payload port
14280+I, which PX4 forwards to the station out of the box). One detector process serves both;
the planner steers both vehicles cell by cell on one shared map, every reading is folded into it,
and both land at their own airports."""

from __future__ import annotations

import asyncio
import signal
import subprocess
import sys

import pytest

from gcs.flight.controller import FlyOptions
from gcs.flight.fly import fly_async
from gcs.flight.online import observed_search
from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.plan_folder import load_plan_dir
from gcs.plans.planning import build_area_search
from gcs.telemetry.status import Stage
from planner.sensor_noise import reading_draw
from sim.detector import CAMERA_COMPONENT_ID
from tests.gcs.autopilots.flights import metres
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.ports import free_udp_port
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import PX4_SPEEDUP, STEADY_BATTERY, Px4Sitl
from tests.peers.site import Airport, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]

SEED, PC, PF = 3, 0.9, 0.1
SITE = Site((Airport("west", -225.0, -45.0, "E", 600.0), Airport("south", -45.0, -225.0, "N", 600.0)),
            targets=((-165.0, -45.0), (-45.0, -165.0)))


def test_online_search_on_a_mixed_fleet_with_detectors_folds_both_vehicles_readings(tmp_path):
    plan_dir = SITE.plan(tmp_path, "--seed", str(SEED), "--altitude", "15")
    plan = load_plan_dir(plan_dir)
    ardupilot_camera_port = free_udp_port()
    detector = None
    try:
        with ArduPilotSitl("copter", home=SITE.home(0), sysid=1, speedup=PX4_SPEEDUP,
                           serial2=f"udpclient:127.0.0.1:{ardupilot_camera_port}") as ardupilot, \
                Px4Sitl(home=SITE.home(1)[:3], sysid=2, params=STEADY_BATTERY) as px4:
            detector = subprocess.Popen(
                [sys.executable, "-m", "gcs.cli", "detector", "--plan", str(plan_dir),
                 "--uav", "1", "--connect", f"udpin:127.0.0.1:{ardupilot_camera_port}",
                 "--uav", "2", "--connect", px4.payload_connection],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            setup = build_area_search(tmp_path / "site.geojson", AreaOptions(altitude_m=15),
                                      SearchOptions(seed=SEED, strategy="exhaustive"))
            search = observed_search(setup.search.scenario, setup.search.config, seed=SEED)
            prior = search.map.tep.copy()
            controller = asyncio.run(asyncio.wait_for(
                fly_async(plan, [ardupilot.udp_connection, px4.gcs_connection], FlyOptions(), online=search), 400))
    finally:
        if detector is not None:
            detector.send_signal(signal.SIGTERM)
            try:
                out, _ = detector.communicate(timeout=10)
            finally:
                detector.kill()
    assert detector.returncode == 0, out
    targets, folded = set(plan.targets), 0
    for uid in (1, 2):
        status = controller.status[uid]
        assert status.stage is Stage.LANDED, f"UAV {uid}: {status.stage} {status.note}"
        assert metres(plan, (status.lat_deg, status.lon_deg), plan.uavs[uid].airport_lat_lon) < 3.0
        assert controller.vehicles[uid].reading_component == CAMERA_COMPONENT_ID
        readings = {d.index: d for d in status.detections}
        assert len(readings) >= 4 and sorted(readings) == list(range(len(readings))), f"UAV {uid}: {sorted(readings)}"
        visits: dict = {}
        for i in sorted(readings):  # each the simulated sensor's draw for this UAV, cell and visit
            cell = plan.cell_of(readings[i].lat_deg, readings[i].lon_deg)
            visit = visits[cell] = visits.get(cell, -1) + 1
            assert readings[i].hit == (reading_draw(SEED, uid, *cell, visit) < (PC if cell in targets else PF))
        folded += len(readings)
        assert f"UAV {uid}: {len(readings)} readings" in out
    assert int(search.map.visits.sum()) == folded  # every reading of both vehicles in the one map
    assert (search.map.tep != prior).any()
