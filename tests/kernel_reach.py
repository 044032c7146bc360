"""Which tests reach a numba kernel: `.ci/run` runs the planner's tests once more with
NUMBA_DISABLE_JIT=1 so that every kernel's Python body runs and is checked, and only those tests
need it (a test that reaches no kernel runs the same Python either way).

With the JIT on, every kernel `planner.config.njit` makes counts the calls Python makes to it
(calls from kernel to kernel stay compiled); a test reaches a kernel when it, or a fixture it
uses, made one. Each run with the JIT on merges what it saw into pytest's cache
(`gcs/kernel-tests`, test id -> reached); `--kernel-tests` leaves out the tests recorded there
as reaching none, and keeps every test it has no record of."""

from __future__ import annotations

import sys
import warnings

import numba
import pytest
from numba.core.registry import CPUDispatcher

import planner.config

CACHE_KEY = "gcs/kernel-tests"
PROPERTY = "reaches_kernel"


class _CountedKernel(CPUDispatcher):
    """A kernel dispatcher that counts the calls made to it from Python."""

    calls = 0

    def __call__(self, *args, **kwargs):
        _CountedKernel.calls += 1
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
                     help="run only the tests that reach a numba kernel, as the last run with the JIT on recorded "
                          "them (for the NUMBA_DISABLE_JIT=1 pass)")


class KernelReach:
    """Records, with the JIT on, which tests reach a kernel; selects them with `--kernel-tests`."""

    def __init__(self, config: pytest.Config) -> None:
        self.config = config
        self.recording = not numba.config.DISABLE_JIT and getattr(config, "cache", None) is not None
        self.reached: dict[str, bool] = {}
        self._start = 0
        self._fixtures: set[str] = set()  # names of fixtures whose set-up called a kernel

    @pytest.hookimpl(hookwrapper=True)
    def pytest_fixture_setup(self, fixturedef: pytest.FixtureDef, request: pytest.FixtureRequest):
        before = _CountedKernel.calls
        yield
        if _CountedKernel.calls > before:
            self._fixtures.add(fixturedef.argname)

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> None:
        self._start = _CountedKernel.calls

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: pytest.Item, call: pytest.CallInfo):
        if call.when == "teardown" and self.recording:
            fixtures = set(getattr(item, "fixturenames", ()))
            reached = _CountedKernel.calls > self._start or bool(self._fixtures & fixtures)
            item.user_properties.append((PROPERTY, reached))  # carried to the controlling process under xdist
        yield

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        if report.when == "teardown":
            for name, value in report.user_properties:
                if name == PROPERTY:
                    self.reached[report.nodeid] = bool(value)

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if self.recording and self.reached and not hasattr(self.config, "workerinput"):
            known = self.config.cache.get(CACHE_KEY, {})
            self.config.cache.set(CACHE_KEY, {**known, **self.reached})

    def pytest_collection_modifyitems(self, config: pytest.Config, items: list[pytest.Item]) -> None:
        if not config.getoption("kernel_tests"):
            return
        known = config.cache.get(CACHE_KEY, None) if getattr(config, "cache", None) is not None else None
        if not known:
            warnings.warn(pytest.PytestWarning("--kernel-tests: no run with the JIT on has recorded which tests reach "
                                               "a numba kernel; running them all"), stacklevel=1)
            return
        keep = [item for item in items if known.get(item.nodeid, True)]
        if len(keep) < len(items):
            config.hook.pytest_deselected(items=[item for item in items if not known.get(item.nodeid, True)])
            items[:] = keep
