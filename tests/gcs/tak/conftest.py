"""Fixtures: a throw-away CA and certificates, a real FreeTAKServer (its own virtual environment,
installed when missing) shared by the tests that only read from it, and fresh ones for the tests
that kill it.

The shared server is started when a test first asks for it and stopped as soon as the next test
does not: idle it takes about a sixth of a core (3.3 CPU-s in 20 s, 12 processes), and as a
session fixture it idled from the first TAK test to the end of its worker's run, on each worker
that ran one. Its tests carry `helpers.SHARED_TAK_SERVER` (one xdist group), so one worker runs
them one after the other and starts it once."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.gcs.tak.helpers import Authority, Certificates, FreeTakServer, make_certificates


@pytest.fixture(scope="session")
def tak_pki(tmp_path_factory: pytest.TempPathFactory) -> tuple[Certificates, Authority]:
    return make_certificates(tmp_path_factory.mktemp("tak-certs"))


_shared: dict[str, FreeTakServer] = {}


@pytest.fixture
def tak_server(tmp_path_factory: pytest.TempPathFactory, tak_pki) -> FreeTakServer:
    """The shared server, started when first asked for (see the module's docstring)."""
    if "server" not in _shared:
        server = FreeTakServer(tmp_path_factory.mktemp("freetakserver"), tak_pki[1])
        server.start()
        _shared["server"] = server
    return _shared["server"]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The shared server's tests one after the other, where the first of them was (in one process,
    as in `pytest tests/gcs/tak`, the server then starts once; under xdist their group does it)."""
    users = [item for item in items if "tak_server" in getattr(item, "fixturenames", ())]
    if users:
        first, others = items.index(users[0]), [item for item in items if item not in users]
        items[:] = others[:first] + users + others[first:]


@pytest.hookimpl(trylast=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> None:
    if "server" in _shared and (nextitem is None or "tak_server" not in getattr(nextitem, "fixturenames", ())):
        _shared.pop("server").stop()


def pytest_sessionfinish() -> None:
    if "server" in _shared:
        _shared.pop("server").stop()


@pytest.fixture
def make_tak_server(tmp_path: Path, tak_pki) -> Iterator[Callable[[], FreeTakServer]]:
    servers: list[FreeTakServer] = []

    def make() -> FreeTakServer:
        server = FreeTakServer(tmp_path / f"freetakserver{len(servers)}", tak_pki[1])
        servers.append(server)
        server.start()
        return server

    yield make
    for server in servers:
        server.stop()


SQUARE = Path(__file__).with_name("square.geojson")


@pytest.fixture(scope="session")
def square_plan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example area of docs/areas.md (a 600 m square, a no-fly box, two UAVs), planned."""
    from gcs.cli import main

    out = tmp_path_factory.mktemp("square") / "square"
    assert main(["plan", "--area", str(SQUARE), "--out", str(out), "--quiet"]) == 0
    return out
