"""The simulated sensor reads a plan's world at the plan's Pc and Pf: its camera's Pc when it was
planned with `--camera-fov`, unless `--pc` / `--pf` are given: `gcs fly --sim` (`fleet_for_plan`),
`gcs sim --plan` and `gcs detector --plan` alike."""

from __future__ import annotations

import socket

import pytest

from gcs.cli import main
from gcs.plans.plan_folder import load_plan_dir
from planner.camera import Camera, camera_sensor
from sim.plan_fleet import fleet_for_plan
from tests.gcs.flight.test_sortie_segments import segments_area
from tests.peers.ports import free_ports


@pytest.fixture(scope="module")
def camera_plan(tmp_path_factory):
    """A 600 m square (30 m cells, one copter at 50 m) planned with a 45 degree camera."""
    base = tmp_path_factory.mktemp("camera-plan")
    out = base / "square"
    assert main(["plan", "--area", str(segments_area(base)), "--out", str(out), "--strategy", "exhaustive",
                 "--no-improve", "--bound-time", "0", "--no-rrd", "--quiet", "--camera-fov", "45", "--pf", "0.05"]) == 0
    return out


def test_the_plan_knows_its_cameras_pc(camera_plan):
    plan = load_plan_dir(camera_plan)
    expected = camera_sensor(Camera(45.0), 50.0, 30.0).pc
    assert plan.pc == pytest.approx(expected) and abs(plan.pc - 0.9) > 0.05
    assert plan.pc == pytest.approx(plan.raw["search_theory"]["pc"])  # the Pc the plan's figures were made with
    assert plan.pf == 0.05


def test_the_plans_pc_is_the_one_its_figures_were_made_with(camera_plan):
    """plan.json's search_theory.pc is read as written (not derived again from the options, which
    a later change of the camera model would move): the camera's; a plan without it, its `pc`."""
    import copy
    import dataclasses

    plan = load_plan_dir(camera_plan)
    assert plan.pc == pytest.approx(camera_sensor(Camera(45.0), 50.0, 30.0).pc)
    raw = copy.deepcopy(plan.raw)
    raw["search_theory"]["pc"] = 0.42
    assert dataclasses.replace(plan, raw=raw).pc == 0.42
    del raw["search_theory"]
    assert dataclasses.replace(plan, raw=raw).pc == raw["campaign"]["options"]["pc"]


def test_the_simulated_fleet_reads_at_the_plans_pc_unless_told(camera_plan):
    plan = load_plan_dir(camera_plan)
    sensor = fleet_for_plan(plan, speedup=1.0).config.sensor  # not started: only its configuration is read
    assert (sensor.pc, sensor.pf) == (plan.pc, plan.pf)
    sensor = fleet_for_plan(plan, speedup=1.0, pc=0.8, pf=0.2).config.sensor
    assert (sensor.pc, sensor.pf) == (0.8, 0.2)


def _refused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))  # bound, not listening: a connection is refused
        return s.getsockname()[1]


@pytest.mark.parametrize("given, said", [([], None), (["--pc", "0.8"], "pc 0.8, pf 0.05"),
                                          (["--pf", "0.2"], "pf 0.2")])
def test_the_detector_reads_at_the_plans_pc_unless_told(camera_plan, capsys, given, said):
    plan = load_plan_dir(camera_plan)
    args = ["detector", "--plan", str(camera_plan), "--uav", "1", "--connect", f"tcp:127.0.0.1:{_refused_port()}"]
    assert main([*args, *given]) == 2  # the world line is printed before the link is opened
    out = capsys.readouterr().out
    assert (said or f"pc {plan.pc:.3g}, pf 0.05") in out, out


@pytest.mark.parametrize("given, said", [([], None), (["--pc", "0.8"], "sensor Pc 0.8 Pf 0.05")])
def test_gcs_sim_with_a_plan_reads_at_its_pc_unless_told(camera_plan, capsys, given, said):
    plan = load_plan_dir(camera_plan)
    assert main(["sim", "--plan", str(camera_plan), "--base-port", str(free_ports(1)), "--duration-s", "0.2",
                 *given]) == 0
    banner = capsys.readouterr().out.splitlines()[0]
    assert banner.startswith("gcs sim: 1 copter(s)")
    assert (said or f"sensor Pc {plan.pc:.3g} Pf 0.05") in banner, banner


def test_gcs_sim_takes_one_of_plan_area_or_home(camera_plan, capsys):
    assert main(["sim", "--plan", str(camera_plan), "--home", "1,2"]) == 2
    assert capsys.readouterr().err.strip() == "error: give one of --plan, --area or --home"
