"""`gcs experiment` from the outside: exit codes, one-line errors, and tiny end-to-end runs whose
CSV and PNG files are checked."""

import csv
import subprocess
import sys

import pytest

from gcs.experiments import ExperimentSettings, fig10

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def gcs(*args):
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, check=False)


def rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("args, message", [
    (["fig99"], "invalid choice"),
    (["fig8", "--runs", "0"], "--runs must be at least 1"),
    (["fig8", "--runs", "many"], "invalid int value"),
    (["fig12", "--footprint", "-1"], "--footprint must be >= 0"),
    ([], "the following arguments are required: name"),
])
def test_bad_arguments_give_one_error_line_and_exit_2(tmp_path, args, message):
    run = gcs("experiment", *args, "--out", str(tmp_path / "x"))
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], run.stderr
    assert not (tmp_path / "x").exists()


def test_out_that_is_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("")
    run = gcs("experiment", "fig12", "--runs", "1", "--out", str(tmp_path / "f"))
    assert run.returncode == 2 and "is a file" in run.stderr


def test_fig8_and_fig12_end_to_end(tmp_path):
    out = tmp_path / "exp"
    for name in ("fig8", "fig12"):
        run = gcs("experiment", name, "--runs", "2", "--range", "40", "--seed", "3", "--out", str(out), "--quiet")
        assert run.returncode == 0, run.stderr
        assert (out / f"{name}.png").read_bytes()[:8] == PNG_MAGIC
    summary = {r["strategy"]: r for r in rows(out / "fig8.csv")}
    assert set(summary) == {"cpio", "pio", "pso", "ga", "exhaustive", "lawnmower"}
    for r in summary.values():
        assert r["runs"] == "2"
        assert 0 <= float(r["targets_mean"]) <= 10
        assert 0 < float(r["eta_mean"]) <= 1
    assert float(summary["exhaustive"]["paths_scored_per_decision"]) == 243
    assert 1000 < float(summary["pio"]["paths_scored_per_decision"]) < 1200
    convergence = rows(out / "fig8_convergence.csv")
    for name in ("cpio", "pio", "pso", "ga"):
        curve = [float(r["fraction_of_optimum_mean"]) for r in convergence if r["strategy"] == name]
        assert len(curve) > 20 and all(0.5 < v < 1.05 for v in curve)
        assert curve[-1] <= 1.0 + 1e-9          # no optimiser beats the exact optimum of its final state
    eta = rows(out / "fig12_runs.csv")
    assert len(eta) == 2 * 2 * 4                      # 2 OCs x 2 runs x 4 UAVs
    assert all(0 < float(r["eta"]) <= 1 and int(r["search_steps"]) + int(r["return_steps"]) <= 40 for r in eta)


def test_fig6_end_to_end(tmp_path):
    run = gcs("experiment", "fig6", "--runs", "1", "--range", "30", "--out", str(tmp_path), "--quiet")
    assert run.returncode == 0, run.stderr
    summary = rows(tmp_path / "fig6.csv")
    assert [int(r["np"]) for r in summary] == list(range(1, 8))
    assert [int(r["paths_per_uav"]) for r in summary] == [3 ** n for n in range(1, 8)]
    assert all(float(r["run_time_s_mean"]) > 0 and 0 <= float(r["targets_mean"]) <= 10 for r in summary)
    assert (tmp_path / "fig6.png").read_bytes()[:8] == PNG_MAGIC


def test_fig10_on_the_unsubdivided_map(tmp_path):
    paths = fig10.run(ExperimentSettings(tmp_path, runs=1, quiet=True), subdivisions=(1,))
    assert {p.name for p in paths} == {"fig10.csv", "fig10_returns.csv", "fig10.png"}
    returns = rows(tmp_path / "fig10_returns.csv")
    assert len(returns) == 3 * 4
    for r in returns:
        assert 0 <= float(r["phi"]) <= 1
        assert int(r["st_steps"]) >= int(r["exact_steps"])       # the exact planner is the shortest
    by_oc = {r["oc"]: float(r["phi_mean"]) for r in rows(tmp_path / "fig10.csv")}
    assert by_oc["3OC"] > 0.8 and by_oc["8OC"] > 0.8
