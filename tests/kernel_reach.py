"""Which tests reach a numba kernel: `.ci/run` runs the planner's tests once more with
NUMBA_DISABLE_JIT=1 so that every kernel's Python body runs and is checked, and only those tests
need it (a test that reaches no kernel runs the same Python either way), and of those only the
cheapest few per kernel.

With the JIT on, every kernel `planner.config.njit` makes counts the calls Python makes to it
(calls from kernel to kernel stay compiled); a test reaches a kernel when it, or a fixture it
uses, called it. What the planner's tests (`SCOPE`) reach is kept in the repository (`RECORD`:
test id -> the kernels it reached and the seconds it took), so the JIT-off pass knows its tests
before any run, and runs beside the tests with the JIT on (`.ci/run`). `--record-kernel-tests`
rewrites the record from a run. A run with the JIT on fails under `CI` (where Hypothesis draws
fixed examples), and warns elsewhere, naming each test it ran that reaches other kernels than the
record says, a new test that reaches one included: a test the record does not know reaches none.
`--kernel-tests` keeps each recorded test function in its quickest case, and for every kernel the
COVER quickest tests that reach it (`covering_tests`)."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numba
import pytest
from numba.core.registry import CPUDispatcher

import planner.config

RECORD = Path(__file__).with_name("kernel_tests.json")
#: the tests the JIT-off pass runs from (`.ci/run`), and the record holds
SCOPE = "tests/planner/"
RECORD_COMMAND = "CI=1 .venv/bin/python -m pytest -n 2 tests/planner --record-kernel-tests"
PROPERTY = "reaches_kernels"
#: The JIT-off pass runs, for every kernel, this many of the quickest tests that reach it.
COVER = 3


class _CountedKernel(CPUDispatcher):
    """A kernel dispatcher that counts the calls made to it from Python."""

    #: the kernels called from Python since the process started, by qualified name
    called: set[str] = set()

    def __call__(self, *args, **kwargs):
        _CountedKernel.called.add(f"{self.py_func.__module__}.{self.py_func.__qualname__}")
        return super().__call__(*args, **kwargs)


def _counted(njit):
    def make(func):
        kernel = njit(func)
        if type(kernel) is CPUDispatcher:  # not under NUMBA_DISABLE_JIT, where the kernel is `func`
            kernel.__class__ = _CountedKernel
        return kernel

    return make


_loaded = [name for name in sys.modules if name.startswith("planner.") and name != "planner.config"]
assert not _loaded, f"planner modules imported before the kernel counter was installed: {_loaded}"
planner.config.njit = _counted(planner.config.njit)


def add_option(parser: pytest.Parser) -> None:
    parser.addoption("--kernel-tests", action="store_true",
                     help=f"run each test that reaches a numba kernel in its quickest case and, for every kernel, the "
                          f"{COVER} quickest tests that reach it, as {RECORD.name} records them (the "
                          "NUMBA_DISABLE_JIT=1 pass)")
    parser.addoption("--record-kernel-tests", action="store_true",
                     help=f"write which kernels each test of this run reaches, and its seconds, into {RECORD.name}")


def read_record(path: Path = RECORD) -> dict[str, dict]:
    """Test id -> {"kernels": [names], "seconds": time}; empty when there is no record."""
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        return {}


def write_record(records: dict[str, dict], path: Path = RECORD) -> None:
    """`records` as the record, sorted and one test a line, written whole or not at all."""
    lines = [f"{json.dumps(test)}: {json.dumps(records[test])}" for test in sorted(records)]
    temporary = path.with_suffix(".tmp")
    temporary.write_text("{\n" + ",\n".join(lines) + "\n}\n")
    os.replace(temporary, path)


def stale_tests(recorded: dict[str, dict], seen: dict[str, dict]) -> list[str]:
    """The tests of a run (`seen`) that reach other kernels than the record says, each with both
    lists; a test that reaches no kernel needs no record."""
    stale = []
    for test, record in sorted(seen.items()):
        want = sorted(recorded.get(test, {}).get("kernels", []))
        if sorted(record["kernels"]) != want:
            stale.append(f"{test}: reaches {sorted(record['kernels']) or 'no kernel'}, recorded {want or 'none'}")
    return stale


def covering_tests(records: dict[str, dict], cover: int = COVER) -> set[str]:
    """The ids of the tests the JIT-off pass runs (`records`: test id -> {"kernels": [names],
    "seconds": time} of a run with the JIT on): each test function that reaches a kernel in its
    quickest case (its other cases ran with the JIT on), and for every kernel its `cover`
    quickest tests; ties go to the id."""
    by_kernel: dict[str, list[tuple[float, str]]] = {}
    by_function: dict[str, list[tuple[float, str]]] = {}
    for test, record in records.items():
        if record["kernels"]:
            by_function.setdefault(test.split("[", 1)[0], []).append((float(record["seconds"]), test))
        for kernel in record["kernels"]:
            by_kernel.setdefault(kernel, []).append((float(record["seconds"]), test))
    quickest_cases = {min(cases)[1] for cases in by_function.values()}
    return quickest_cases | {test for reaching in by_kernel.values() for _, test in sorted(reaching)[:cover]}


class KernelReach:
    """Records, with the JIT on, which kernels each test reaches; selects with `--kernel-tests`."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.recording = not numba.config.DISABLE_JIT
        self.records: dict[str, dict] = {}
        self.stale: list[str] = []
        self._seconds: dict[str, float] = {}
        self._failed: set[str] = set()
        self._fixtures: dict[str, set[str]] = {}  # fixture name -> the kernels its set-up called

    @pytest.hookimpl(hookwrapper=True)
    def pytest_fixture_setup(self, fixturedef: pytest.FixtureDef, request: pytest.FixtureRequest):
        before = set(_CountedKernel.called)
        _CountedKernel.called.clear()
        yield
        if _CountedKernel.called:
            self._fixtures.setdefault(fixturedef.argname, set()).update(_CountedKernel.called)
        _CountedKernel.called |= before

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> None:
        _CountedKernel.called.clear()

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: pytest.Item, call: pytest.CallInfo):
        if call.when == "teardown" and self.recording:
            reached = set(_CountedKernel.called)
            for name in getattr(item, "fixturenames", ()):
                reached |= self._fixtures.get(name, set())
            if item.nodeid.startswith(SCOPE):
                item.user_properties.append((PROPERTY, sorted(reached)))  # to the controller under xdist
        yield

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        self._seconds[report.nodeid] = self._seconds.get(report.nodeid, 0.0) + report.duration
        if report.failed:
            self._failed.add(report.nodeid)  # stopped early: it may not have reached its kernels
        if report.when == "teardown":
            for name, value in report.user_properties:
                if name == PROPERTY:
                    self.records[report.nodeid] = {"kernels": list(value),
                                                   "seconds": round(self._seconds[report.nodeid], 3)}

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if not self.recording or hasattr(self.config, "workerinput"):
            return
        if self.config.getoption("record_kernel_tests"):
            ran = {test.split("::", 1)[0] for test in self.records}
            kept = {test: record for test, record in read_record().items() if test.split("::", 1)[0] not in ran}
            write_record({**kept, **{test: r for test, r in self.records.items() if r["kernels"]}})
            return
        self.stale = stale_tests(read_record(), {test: record for test, record in self.records.items()
                                                 if test not in self._failed})
        if self.stale and os.environ.get("CI"):
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    def pytest_terminal_summary(self, terminalreporter) -> None:
        if self.stale:
            terminalreporter.write_line(f"{RECORD.name} is out of date (the JIT-off pass chooses its tests from it); "
                                        f"run `{RECORD_COMMAND}`:", red=True)
            for line in self.stale:
                terminalreporter.write_line(f"  {line}", red=True)

    def pytest_collection_modifyitems(self, config: pytest.Config, items: list[pytest.Item]) -> None:
        if not config.getoption("kernel_tests"):
            return
        known = read_record()
        chosen = covering_tests({item.nodeid: known[item.nodeid] for item in items if item.nodeid in known})
        keep = [item for item in items if item.nodeid in chosen]
        if len(keep) < len(items):
            config.hook.pytest_deselected(items=[item for item in items if item not in keep])
            items[:] = keep
