"""Test-wide settings: Hypothesis profiles, how many processes run the suite, and which tests
reach a numba kernel (the tests `.ci/run` runs once more with the JIT off).

Property tests: under `CI` (`.ci/run` sets it) the `ci` profile: derandomised (the same examples
on every run, drawn from a seed derived from each test), no example database, no deadline and no
too-slow health check (the time a shared machine takes must not decide a result); examples that
ever failed are kept in the tests as `@example`. Elsewhere the default profile draws new examples
on every run and replays the failures it saved in `.hypothesis/`.

Workers (pytest-xdist, `-n auto` in pyproject's addopts): the whole suite, `pytest` without
arguments, runs in `GCS_TEST_WORKERS` processes (default 2: one starts with the real-autopilot
tests, the other with the simulated flights whose battery is spent by the clock, each group one
test at a time, tests/peers/process.py; both then take the rest; three were faster but failed on
timing at load 8-9, docs/tests.md); tests named on the command line run in one process unless
`-n N` is given."""

from __future__ import annotations

import os
from importlib import metadata
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings
from packaging.version import Version

from tests import cpu_report, kernel_reach
from tests.areas import paper_area_with_range

settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci" if os.environ.get("CI") else "default")

WORKERS = 2


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    if "GCS_TEST_WORKERS" in os.environ:
        return int(os.environ["GCS_TEST_WORKERS"])
    return WORKERS if config.args_source is pytest.Config.ArgsSource.TESTPATHS else 0


@pytest.fixture(scope="session")
def flight_area(tmp_path_factory) -> Path:
    """The paper area at the simulated flights' range (tests/areas.py)."""
    return paper_area_with_range(tmp_path_factory.mktemp("area"))


def pytest_addoption(parser: pytest.Parser) -> None:
    kernel_reach.add_option(parser)
    cpu_report.add_option(parser)


def pytest_configure(config: pytest.Config) -> None:
    config.pluginmanager.register(kernel_reach.KernelReach(config), "gcs-kernel-reach")
    if config.getoption("cpu_report") or os.environ.get("CI"):
        config.pluginmanager.register(cpu_report.CpuReport(), "gcs-cpu-report")
    if config.getoption("dist", "no") == "loadgroup" and _groups_lost():
        raise pytest.UsageError("pytest-xdist 3.8 does not keep an xdist_group in one worker under pytest 9.2 "
                                "(pytest-dev/pytest-xdist#1386): install the test extra's pytest, below 9.2")


def _groups_lost() -> bool:
    """Whether this pytest and pytest-xdist are the pair whose `--dist loadgroup` spreads a group's
    tests over workers without a word (xdist renames the tests, pytest 9.2 ignores the renaming)."""
    return Version(pytest.__version__) >= Version("9.2") and Version(metadata.version("pytest-xdist")) <= Version("3.8")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """A test of the station or the simulator (tests/gcs, tests/sim) outside the real autopilots'
    worker waits while a fleet of several PX4 SITLs flies (`tests.peers.process.cpu_share`),
    for its whole run: the module fixtures its setup flies included. One marked `cpu_alone` takes
    the lock alone: the others wait for it as for such a fleet."""
    path = str(item.path)
    if f"{os.sep}tests{os.sep}gcs{os.sep}" not in path and f"{os.sep}tests{os.sep}sim{os.sep}" not in path \
            or item.get_closest_marker("autopilot") is not None \
            or any(m.args == ("sitl",) for m in item.iter_markers("xdist_group")):
        yield
        return
    from tests.peers.process import cpu_share

    with cpu_share(heavy=item.get_closest_marker("cpu_alone") is not None):
        yield
