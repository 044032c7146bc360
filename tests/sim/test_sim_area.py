"""`gcs sim --area`: one vehicle per airport of an area file, at the airport, with its heading."""

import signal
import subprocess
import sys
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.plans.area_file import read_area_file
from tests.peers.ports import free_ports
from tests.sim.helpers import Gcs, distance_m

ROOT = Path(__file__).resolve().parents[2]
AREA = ROOT / "missions" / "paper.geojson"


def test_vehicles_start_at_the_area_airports():
    airports = read_area_file(AREA).airports
    base = free_ports(len(airports))
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "sim", "--area", str(AREA), "--base-port", str(base),
                             "--speedup", "5"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        banner = proc.stdout.readline()
        assert f"{len(airports)} copter" in banner
        for i, airport in enumerate(airports):
            link = Gcs(("127.0.0.1", base + i), i + 1)
            assert link.hello().get_srcSystem() == i + 1
            link.request_streams({mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0})  # ArduCopter sends none unasked
            pos = link.wait("GLOBAL_POSITION_INT", lambda m: (m.lat, m.lon) != (0, 0))  # after its GPS fix
            assert distance_m(pos.lat / 1e7, pos.lon / 1e7, airport.lat_deg, airport.lon_deg) < 1.0
            assert abs(((pos.hdg / 100.0) - airport.heading * 45.0 + 180) % 360 - 180) < 1.0
            link.close()
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_area_and_home_together_are_refused():
    run = subprocess.run([sys.executable, "-m", "gcs.cli", "sim", "--area", str(AREA), "--home", "1,2"],
                         cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert run.returncode == 2 and run.stderr.strip() == "error: give either --area or --home, not both"


def test_the_area_world_is_the_grid_and_targets_gcs_plan_lays_out(tmp_path):
    """`gcs sim --area` senses on the plan's grid: same cell size, south-west corner and target
    cells as the folder `gcs plan --area` writes from the same file."""
    import argparse

    import numpy as np

    from gcs.cli import main
    from gcs.cli.commands.sim import _area_world
    from gcs.plans.plan_folder import load_plan_dir
    from sim.detector import World

    assert main(["plan", "--area", str(AREA), "--out", str(tmp_path / "p"), "--quiet", "--no-rrd"]) == 0
    planned = World.of_plan(load_plan_dir(tmp_path / "p"))
    homes, world = _area_world(argparse.Namespace(area=str(AREA), cell_size_m=None, margin_m=0.0, home_alt_m=0.0))
    assert len(homes) == len(read_area_file(AREA).airports)
    assert world.cell_size_m == planned.cell_size_m == 20.0  # the file's cell_size_m
    assert np.allclose(world.grid_origin, planned.grid_origin, atol=1e-9)
    assert np.allclose(sorted(world.targets), sorted(planned.targets), atol=1e-9) and world.targets
    _, finer = _area_world(argparse.Namespace(area=str(AREA), cell_size_m=25.0, margin_m=0.0, home_alt_m=0.0))
    assert finer.cell_size_m == 25.0
