"""Fixtures: a throw-away CA and certificates, a real FreeTAKServer (its own virtual environment,
installed when missing) shared by the tests that only read from it, and fresh ones for the tests
that kill it."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.gcs.tak.helpers import Authority, Certificates, FreeTakServer, make_certificates


@pytest.fixture(scope="session")
def tak_pki(tmp_path_factory: pytest.TempPathFactory) -> tuple[Certificates, Authority]:
    return make_certificates(tmp_path_factory.mktemp("tak-certs"))


@pytest.fixture(scope="session")
def tak_server(tmp_path_factory: pytest.TempPathFactory, tak_pki) -> Iterator[FreeTakServer]:
    server = FreeTakServer(tmp_path_factory.mktemp("freetakserver"), tak_pki[1])
    server.start()
    yield server
    server.stop()


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
