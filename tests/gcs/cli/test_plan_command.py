"""`gcs plan` from the outside: a real process, its output files and its exit codes."""

import json
import subprocess
import sys

import numpy as np
import pytest

from gcs.cli import main
from gcs.plans.plan_file import validate_plan_dict


def gcs(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_plan_writes_a_valid_closed_plan(tmp_path):
    out = tmp_path / "plan.json"
    run = gcs("plan", "--scenario", "paper", "--seed", "7", "--np", "3", "--oc", "3", "--range", "90",
              "--out", str(out))
    assert run.returncode == 0, run.stderr
    data = json.loads(out.read_text())
    validate_plan_dict(data)
    assert data["grid"] == {**data["grid"], "nx": 50, "ny": 50}
    assert len(data["grid"]["no_fly"]) == 16 * 11 + 11 * 11
    assert [u["airport"] for u in data["uavs"]] == [[1, 20], [20, 50], [27, 1], [50, 26]]
    for u in data["uavs"]:
        traj = u["trajectory"]
        assert traj[0]["step"] == 0 and [traj[0]["x"], traj[0]["y"]] == u["airport"]
        assert [traj[-1]["x"], traj[-1]["y"]] == u["airport"]
        assert len(traj) - 1 == u["search_steps"] + u["return_steps"] <= 90
        assert {p["stage"] for p in traj} <= {"search", "return"}
    assert data["summary"]["targets"] == 10
    assert "targets found" in run.stdout and "UAV" in run.stdout
    bound = data["summary"]["bound"]    # by default, within --bound-time's default seconds (planner/bound.py)
    assert bound["finished"] and bound["time_limit_s"] == 5
    expected = data["summary"]["expected_targets_found"]
    assert 0 < bound["share_of_max"] <= 1
    assert bound["share_of_max"] == pytest.approx(expected / bound["expected_targets_found_max"], abs=1e-6)
    assert bound["probability_of_success_max"] == pytest.approx(
        bound["expected_targets_found_max"] / data["summary"]["expected_targets_in_area"], abs=1e-6)
    [line] = [line for line in run.stdout.splitlines() if line.startswith("bound:")]
    assert f"at least {bound['share_of_max']:.1%} of the most any plan of these airports and ranges" in line


@pytest.mark.parametrize("args, message", [
    (["--scenario", "moon"], "unknown scenario"),
    (["--np", "0"], "Np must be at least 1"),
    (["--range", "2"], "too short to leave"),
    (["--oc", "6"], "unknown orientation constraint"),
    (["--strategy", "magic"], "unknown search strategy"),
    (["--return", "teleport"], "unknown return planner"),
    (["--bound-time", "-1"], "--bound-time: must be 0 or more seconds"),
    (["--camera-fov", "45"], "--camera-fov needs --area"),
])
def test_bad_arguments_give_one_line_exit_2_and_no_file(tmp_path, capsys, args, message):
    """In this process (each a planner start-up in a process of its own took 4-9 s in CI); the
    process itself below."""
    out = tmp_path / "plan.json"
    assert main(["plan", *args, "--out", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, message", [
    (["--np", "five"], "invalid int value"),
    (["--pc", "0.05", "--pf", "0.1"], "pf < pc"),
])
def test_a_bad_argument_ends_the_process_with_one_line_exit_2_and_no_file(tmp_path, args, message):
    """One refused by the argument parser, one by the planner's set-up: the process's own exit."""
    out = tmp_path / "plan.json"
    run = gcs("plan", *args, "--out", str(out))
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0]
    assert "Traceback" not in run.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_plan_records_the_run_and_draws_a_picture_by_default_and_the_same_seed_writes_the_same_file(tmp_path):
    """`--out run/plan.json` writes the recording and the picture beside it; `--out b`, a folder,
    gets b/plan.json, the same file to the byte on the same seed in another process. (The folder
    and the same seed were a test of two more runs of their own until 2026-12-02.)"""
    from PIL import Image

    from gcs.recording.plan import read_recording

    out = tmp_path / "run" / "plan.json"
    args = ("plan", "--np", "3", "--range", "70", "--seed", "2", "--quiet")
    run = gcs(*args, "--out", str(out))
    assert run.returncode == 0, run.stderr
    again = gcs(*args, "--out", str(tmp_path / "b"))
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "b" / "plan.json").read_text() == out.read_text()
    data = json.loads(out.read_text())
    tables = read_recording(out.with_suffix(".rrd"))
    for u in data["uavs"]:
        state = tables.temporal[f"uav/{u['id']}/state"].to_pydict()
        assert state["step"] == [p["step"] for p in u["trajectory"]]
        assert [v[0] for v in state["x"]] == [p["x"] for p in u["trajectory"]]
        assert [v[0] for v in state["stage"]] == [p["stage"] for p in u["trajectory"]]
    with Image.open(out.with_suffix(".png")) as picture:
        assert picture.size == (1400, 1000)
        assert len(np.unique(np.asarray(picture.convert("RGB")).reshape(-1, 3), axis=0)) > 50


def test_no_rrd_writes_no_recording(tmp_path):
    out = tmp_path / "plan.json"
    assert gcs("plan", "--np", "2", "--range", "40", "--no-rrd", "--out", str(out), "--quiet",
               "--bound-time", "0").returncode == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.json", "plan.png"]
    assert "bound" not in json.loads(out.read_text())["summary"], "--bound-time 0: no bound"


def test_a_bound_not_had_in_time_is_said_in_one_line(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["plan", "--np", "2", "--range", "30", "--no-rrd", "--out", str(out), "--bound-time", "0.001"]) == 0
    bound = json.loads(out.read_text())["summary"]["bound"]
    assert not bound["finished"] and "expected_targets_found_max" not in bound
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("bound")]
    assert lines == ["bound: not had within --bound-time 0.001 s (blocks model); a longer --bound-time may have it"]
