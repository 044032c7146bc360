"""Fixtures: a recorded closed search over the paper scenario, and Debian's Chromium."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from gcs.recording.plan import PlanRecorder
from planner.dtscs import ClosedSearch, MissionConfig
from planner.plan import Plan
from planner.scenario import Scenario, paper_scenario

CHROMIUM = Path("/usr/bin/chromium")
SEED = 3
RANGE_STEPS = 60


@dataclass
class RecordedRun:
    scenario: Scenario
    plan: Plan
    rrd: Path
    tep: dict[int, np.ndarray]
    eu: dict[int, np.ndarray]
    ranges: dict[int, dict[int, tuple[int, int, int]]]
    j1: dict[int, dict[int, tuple[float, float | None]]]
    false_alarms_by_step: dict[int, int]


def record_search(rrd: Path | None, seed: int = SEED, range_steps: int = RANGE_STEPS, connect: str | None = None,
                  **recorder_options) -> RecordedRun:
    """A real closed search logged step by step, with what the test needs to check the recording."""
    scenario = paper_scenario(seed, range_steps=range_steps)
    search = ClosedSearch(scenario, MissionConfig(), seed=seed)
    tep, eu, ranges, j1, false_alarms = {}, {}, {}, {}, {}
    with PlanRecorder(rrd, connect, scenario, **recorder_options) as rec:
        for record in search.run():
            rec.log_step(record)
            tep[record.step] = record.tep.copy()
            eu[record.step] = record.eu.copy()
            ranges[record.step] = {u: (r.range_left, r.return_cost, r.margin) for u, r in record.ranges.items()}
            j1[record.step] = {u: (d.j1, d.runner_up_j1) for u, d in record.decisions.items()}
            false_alarms[record.step] = search.false_alarms
        plan = search.plan()
        rec.log_plan(plan)
    return RecordedRun(scenario, plan, rrd, tep, eu, ranges, j1, false_alarms)


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory) -> RecordedRun:
    return record_search(tmp_path_factory.mktemp("recording") / "run.rrd")


@pytest.fixture(scope="session")
def chromium() -> Path:
    """Debian's Chromium, installed with apt-get when missing (the tests run as root)."""
    if not CHROMIUM.exists():
        apt = shutil.which("apt-get")
        assert apt, "chromium is missing and apt-get is not available to install it"
        subprocess.run([apt, "update"], check=True, capture_output=True)
        subprocess.run([apt, "install", "-y", "chromium"], check=True, capture_output=True,
                       env={"DEBIAN_FRONTEND": "noninteractive", "PATH": "/usr/sbin:/usr/bin:/sbin:/bin"})
    assert CHROMIUM.exists()
    return CHROMIUM
