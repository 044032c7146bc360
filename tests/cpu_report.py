"""`--cpu-report` (on by itself under `CI`): the CPU each test took, beside its wall time, at the
end of the run.

The machine CI runs on has two cores, and the real autopilots' tests are CPU-bound (SITL's
lock-step loop), so a suite's time is set by the CPU its tests take as much as by their wall
time (docs/tests.md, "Where the time goes"). A test's CPU is its worker process's user and
system time from its set-up to its teardown, with that of the child processes it started and
waited for (SITL, a `gcs fly` station, a broker); a process left running for later tests counts
for the test that stops it. Carried to the controlling process under pytest-xdist."""

from __future__ import annotations

import os
from dataclasses import dataclass

import pytest

PROPERTY = "cpu_seconds"
#: lines of the report
TOP = 15


@dataclass(frozen=True, slots=True)
class CpuUse:
    test: str
    wall_s: float
    cpu_s: float

    @property
    def cores(self) -> float:
        return self.cpu_s / self.wall_s if self.wall_s > 0 else 0.0


def _cpu_now() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def report_lines(tests: list[CpuUse], top: int = TOP) -> list[str]:
    """The `top` tests by CPU seconds, each with its wall time and cores, and the totals."""
    if not tests:
        return []
    lines = [f"{t.cpu_s:8.1f} CPU-s {t.wall_s:8.1f} s {t.cores:5.2f} cores  {t.test}"
             for t in sorted(tests, key=lambda t: (-t.cpu_s, t.test))[:top]]
    cpu, wall = sum(t.cpu_s for t in tests), sum(t.wall_s for t in tests)
    lines.append(f"{cpu:8.1f} CPU-s {wall:8.1f} s {cpu / wall if wall else 0:5.2f} cores  all {len(tests)} tests")
    return lines


def add_option(parser: pytest.Parser) -> None:
    parser.addoption("--cpu-report", action="store_true",
                     help=f"end with the {TOP} tests that took the most CPU (their own and their child processes')")


class CpuReport:
    """Measures each test in the process that runs it; reports in the controlling one."""

    def __init__(self) -> None:
        self.tests: list[CpuUse] = []
        self._start: dict[str, float] = {}
        self._wall: dict[str, float] = {}

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> None:
        self._start[item.nodeid] = _cpu_now()

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: pytest.Item, call: pytest.CallInfo):
        if call.when == "teardown" and item.nodeid in self._start:
            item.user_properties.append((PROPERTY, _cpu_now() - self._start.pop(item.nodeid)))
        yield

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        self._wall[report.nodeid] = self._wall.get(report.nodeid, 0.0) + report.duration
        if report.when == "teardown":
            for name, value in report.user_properties:
                if name == PROPERTY:
                    self.tests.append(CpuUse(report.nodeid, self._wall.pop(report.nodeid, 0.0), float(value)))

    def pytest_terminal_summary(self, terminalreporter) -> None:
        lines = report_lines(self.tests)
        if lines:
            terminalreporter.write_sep("=", f"most CPU, {TOP} tests")
            for line in lines:
                terminalreporter.write_line(line)
