"""Fixtures: a simulated fleet on free loopback ports, and a pymavlink ground station."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from sim import FleetOptions, HomePose, SimFleet, VehicleConfig
from tests.sim.helpers import HOME, Gcs, fast


@pytest.fixture
def make_fleet() -> Iterator[Callable[..., SimFleet]]:
    fleets: list[SimFleet] = []

    def make(homes: list[HomePose] | None = None, config: VehicleConfig | None = None, **options) -> SimFleet:
        options.setdefault("base_port", 0)
        options.setdefault("speedup", 20.0)
        fleet = SimFleet(homes or [HOME], config or fast(), FleetOptions(**options))
        fleets.append(fleet.start())
        return fleet

    yield make
    for fleet in fleets:
        fleet.stop()
    assert not [e for f in fleets for e in f.errors], "the simulator raised inside its tick"


@pytest.fixture
def make_gcs() -> Iterator[Callable[..., Gcs]]:
    clients: list[Gcs] = []

    def make(fleet: SimFleet, sysid: int = 1, **kwargs) -> Gcs:
        gcs = Gcs(fleet.addresses[sysid - 1], sysid, **kwargs)
        clients.append(gcs)
        return gcs

    yield make
    for gcs in clients:
        gcs.close()
