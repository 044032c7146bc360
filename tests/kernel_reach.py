"""Which tests reach a numba kernel: `.ci/run` runs the planner's tests once more with
NUMBA_DISABLE_JIT=1 so that every kernel's Python body runs and is checked, and only those tests
need it (a test that reaches no kernel runs the same Python either way), and of those only the
cheapest few per kernel.

With the JIT on, every kernel `planner.config.njit` makes counts the calls Python makes to it
(calls from kernel to kernel stay compiled); a test reaches a kernel when it, or a fixture it
uses, called it. Each run with the JIT on merges what it saw into pytest's cache
(`gcs/kernel-tests`, test id -> the kernels it reached and the seconds it took); `--kernel-tests`
keeps each test function that reaches a kernel in its quickest case, for every kernel the COVER
quickest tests that reach it (`covering_tests`), and every test it has no record of."""

from __future__ import annotations

import sys
import warnings

import numba
import pytest
from numba.core.registry import CPUDispatcher

import planner.config

CACHE_KEY = "gcs/kernel-tests"
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
                          f"{COVER} quickest tests that reach it, as the last run with the JIT on recorded them, and "
                          "the tests it has no record of (the NUMBA_DISABLE_JIT=1 pass)")


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
        self.recording = not numba.config.DISABLE_JIT and getattr(config, "cache", None) is not None
        self.records: dict[str, dict] = {}
        self._seconds: dict[str, float] = {}
        self._before: set[str] = set()
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
            item.user_properties.append((PROPERTY, sorted(reached)))  # carried to the controlling process under xdist
        yield

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        self._seconds[report.nodeid] = self._seconds.get(report.nodeid, 0.0) + report.duration
        if report.when == "teardown":
            for name, value in report.user_properties:
                if name == PROPERTY:
                    self.records[report.nodeid] = {"kernels": list(value),
                                                   "seconds": round(self._seconds[report.nodeid], 3)}

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if self.recording and self.records and not hasattr(self.config, "workerinput"):
            known = self.config.cache.get(CACHE_KEY, {})
            known = {test: record for test, record in known.items() if isinstance(record, dict)}
            self.config.cache.set(CACHE_KEY, {**known, **self.records})

    def pytest_collection_modifyitems(self, config: pytest.Config, items: list[pytest.Item]) -> None:
        if not config.getoption("kernel_tests"):
            return
        known = config.cache.get(CACHE_KEY, None) if getattr(config, "cache", None) is not None else None
        known = {test: record for test, record in (known or {}).items() if isinstance(record, dict)}
        if not known:
            warnings.warn(pytest.PytestWarning("--kernel-tests: no run with the JIT on has recorded which tests reach "
                                               "a numba kernel; running them all"), stacklevel=1)
            return
        chosen = covering_tests({item.nodeid: known[item.nodeid] for item in items if item.nodeid in known})
        keep = [item for item in items if item.nodeid in chosen or item.nodeid not in known]
        if len(keep) < len(items):
            config.hook.pytest_deselected(items=[item for item in items if item not in keep])
            items[:] = keep
