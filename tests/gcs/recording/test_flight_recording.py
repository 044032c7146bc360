"""Recordings of flights (`gcs fly` against the simulated fleet) and experiments (`gcs experiment`),
read back with Rerun's own chunk reader."""

from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from gcs.cli import main
from gcs.plans.plan_folder import FleetPlan, load_plan_dir
from gcs.recording.figures import figure_series
from gcs.recording.flight import FLIGHT_TIME
from gcs.recording.plan import read_recording
from tests.peers.process import CLOCK_WORKER


def _metres(plan: FleetPlan, a: tuple[float, float], b: tuple[float, float]) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)


@pytest.fixture(scope="module")
def flown(tmp_path_factory, flight_area) -> Path:
    """One real flight of the paper area (at the test flights' range): UAV 1's battery drains 5x
    faster, so it is sent home early by the return trigger; the others fly their plans. At 30 times
    real time, as the other simulated flights with a battery spent by the clock: at 60, a CI run's
    loaded station took 2 s to hold UAV 1 and send its way home, two minutes of a 4x drain, and it
    came down 26 m short.
    Its tests run among the flights whose battery is spent by the clock."""
    out = tmp_path_factory.mktemp("flight") / "paper"
    assert main(["fly", "--area", str(flight_area), "--sim", "--speedup", "30", "--out", str(out), "--seed", "0",
                 "--sim-drain", "1:5"]) == 0
    return out


@CLOCK_WORKER
def test_a_flight_is_recorded_in_the_plan_folder(flown):
    plan = load_plan_dir(flown)
    rec = read_recording(flown / "flight.rrd", FLIGHT_TIME)
    assert rec.blueprints >= 1
    for uid, task in plan.uavs.items():
        times, positions = rec.column(f"geo/uav/{uid}", "GeoPoints:positions")
        assert len(times) > 10 and times == sorted(times)
        last = positions[-1][0]
        assert _metres(plan, tuple(last), task.airport_lat_lon) < 5.0, f"UAV {uid} ends {last}"
        far = max(_metres(plan, tuple(p[0]), task.airport_lat_lon) for p in positions)
        assert far > 100.0  # it did fly somewhere
        assert f"geo/plan/{uid}" in rec.static and f"geo/uav/{uid}/trail" in rec.temporal
        _, stages = rec.column(f"uav/{uid}/state", "stage")
        stages = [s[0] for s in stages]
        assert "search" in stages and stages[-1] == "landed"
        _, items = rec.column(f"uav/{uid}/mission", "Scalars:scalars")
        assert max(v[0] for v in items) > 5  # mission progress went through the items
        _, left = rec.column(f"uav/{uid}/range/left", "Scalars:scalars")
        assert left and all(math.isfinite(v[0]) for v in left)


@CLOCK_WORKER
def test_battery_falls_over_the_flight(flown):
    plan = load_plan_dir(flown)
    rec = read_recording(flown / "flight.rrd", FLIGHT_TIME)
    for uid in plan.uavs:
        _, values = rec.column(f"uav/{uid}/battery", "Scalars:scalars")
        battery = np.array([v[0] for v in values])
        assert battery[0] >= 95.0 and battery[-1] < battery[0] - 10.0
        assert np.all(np.diff(battery) <= 1.0)  # never climbs (a reading may repeat)
    _, fast = rec.column("uav/1/battery", "Scalars:scalars")
    _, normal = rec.column("uav/2/battery", "Scalars:scalars")
    assert fast[-1][0] < normal[-1][0] - 20.0  # UAV 1 drained 6x faster, though it came home first


@CLOCK_WORKER
def test_events_tell_take_offs_the_early_return_and_why_and_landings(flown):
    plan = load_plan_dir(flown)
    rec = read_recording(flown / "flight.rrd", FLIGHT_TIME)
    _, texts = rec.column("events", "TextLog:text")
    lines = [t[0] for t in texts]
    for uid in plan.uavs:
        assert sum(line.startswith(f"UAV {uid}: take-off") for line in lines) == 1
        assert sum(line.startswith(f"UAV {uid}: landed") for line in lines) == 1
        assert lines.index(next(line for line in lines if line.startswith(f"UAV {uid}: take-off"))) < \
            lines.index(next(line for line in lines if line.startswith(f"UAV {uid}: landed")))
    for uid in (2, 3, 4):  # they follow their plans home
        assert sum(line.startswith(f"UAV {uid}: planned return begins") for line in lines) == 1
    returns = [line for line in lines if "return triggered" in line]
    assert len(returns) == 1 and returns[0].startswith("UAV 1: return triggered (reason: battery)")
    assert "range left" in returns[0]
    assert any(line.startswith("UAV") and "detection: positive reading at cell" in line for line in lines)
    _, margins = rec.column("uav/1/range/margin", "Scalars:scalars")
    assert min(v[0] for v in margins) <= 1.0  # the margin ran out: that is what sent it home
    # the wind estimate beside it: the simulator's still air, read as such, with its uncertainty
    _, winds = rec.column("uav/1/wind/speed", "Scalars:scalars")
    _, sigmas = rec.column("uav/1/wind/sigma", "Scalars:scalars")
    assert winds and len(winds) == len(sigmas) and max(v[0] for v in winds) <= 1.5
    assert all(v[0] > 0 for v in sigmas)


@CLOCK_WORKER
def test_no_rrd_writes_no_recording_and_rrd_names_the_file(flown, tmp_path):
    folder = tmp_path / "plan"
    shutil.copytree(flown, folder, ignore=shutil.ignore_patterns("*.rrd"))
    assert main(["fly", "--plan", str(folder), "--sim", "--speedup", "60", "--no-rrd"]) == 0
    assert not list(folder.glob("*.rrd")) and not list(tmp_path.glob("**/*.rrd"))
    assert main(["fly", "--plan", str(folder), "--sim", "--rrd", str(tmp_path / "flight.txt")]) == 2
    assert not list(tmp_path.glob("**/*.rrd"))


def test_an_experiment_records_each_series_of_its_figure(tmp_path):
    assert main(["experiment", "fig12", "--runs", "1", "--out", str(tmp_path), "--quiet"]) == 0
    rec = read_recording(tmp_path / "experiment.rrd", "time_step")
    curves = {e for e in rec.temporal if e.startswith("fig12/range_utilisation_3oc_first_run/")}
    assert curves == {f"fig12/range_utilisation_3oc_first_run/uav{u}" for u in range(1, 5)}
    with open(tmp_path / "fig12_steps.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["oc"] == "3OC" and r["uav"] == "2"]
    steps, values = rec.column("fig12/range_utilisation_3oc_first_run/uav2", "Scalars:scalars")
    assert steps == [int(r["step"]) for r in rows]
    assert np.allclose([v[0] for v in values], [float(r["eta"]) for r in rows], rtol=1e-5)
    bars = read_recording(tmp_path / "experiment.rrd", "uav")
    assert set(bars.temporal) == {"fig12/range_utilisation_per_uav/3oc", "fig12/range_utilisation_per_uav/8oc"}
    assert main(["experiment", "fig12", "--runs", "1", "--out", str(tmp_path / "bare"), "--quiet", "--no-rrd"]) == 0
    assert not (tmp_path / "bare" / "experiment.rrd").exists() and (tmp_path / "bare" / "fig12.png").exists()


def test_figure_series_takes_data_lines_and_bars_not_error_caps():
    fig = Figure()
    a, b = fig.subplots(1, 2)
    a.errorbar([1, 2, 3], [0.5, 0.6, 0.7], yerr=[0.1, 0.1, 0.1], capsize=3, label="mean")
    a.plot([1, 2, 3], [3, 2, 1])
    a.set(title="(a) Some thing (units)")
    b.bar([0.2, 1.2], [4.0, 5.0], 0.4, yerr=[1.0, 1.0], label="3OC")
    series = figure_series(fig)
    assert [(s[0], s[1], s[4]) for s in series] == [("some_thing", "mean", False), ("some_thing", "series2", False),
                                                     ("axes2", "3OC", True)]
    assert series[0][2:4] == ([1.0, 2.0, 3.0], [0.5, 0.6, 0.7])
    assert series[2][2] == pytest.approx([0.2, 1.2]) and series[2][3] == [4.0, 5.0]
