"""Fixtures: a real Mosquitto broker on a free loopback port (installed when missing), shared by
the tests that only need a broker (each uses its own fleet name), and fresh ones for the tests
that restart it or configure it."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.gcs.bus.helpers import Mosquitto

_fleets = itertools.count(1)


@pytest.fixture(scope="session")
def broker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Mosquitto]:
    server = Mosquitto(tmp_path_factory.mktemp("mosquitto"))
    server.start()
    yield server
    server.stop()


@pytest.fixture
def make_broker(tmp_path: Path) -> Iterator[Callable[..., Mosquitto]]:
    servers: list[Mosquitto] = []

    def make(extra_config: str = "", allow_anonymous: bool = True) -> Mosquitto:
        folder = tmp_path / f"broker{len(servers)}"
        folder.mkdir()
        server = Mosquitto(folder, extra_config, allow_anonymous)
        server.start()
        servers.append(server)
        return server

    yield make
    for server in servers:
        server.stop()


@pytest.fixture
def fleet_name(request: pytest.FixtureRequest) -> str:
    """A topic tree of its own for every test."""
    return f"t{next(_fleets)}-{request.node.name[:40].replace('[', '-').replace(']', '')}"
