"""Fixtures: one area plan made through the plan command's code path, and flights of it
against the simulated fleet on free loopback ports."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from gcs.cli import main
from gcs.flight.controller import FlightController, FlyOptions
from gcs.flight.fly import fly_async
from gcs.plans.plan_folder import FleetPlan, load_plan_dir
from sim.plan_fleet import fleet_for_plan

ROOT = Path(__file__).resolve().parents[3]
#: The simulated fleet's speed-up. A station's round trips and timeouts are in real seconds: at
#: 60, on the 2-core CI machine beside autopilot SITLs (load 7), a station stalled for a tenth of
#: a second let the vehicles fly on six seconds; at 30 the same flights need the same CPU, spread
#: over more real time.
SPEEDUP = 30.0


@pytest.fixture(scope="session")
def plan_dir(tmp_path_factory, flight_area) -> Path:
    out = tmp_path_factory.mktemp("plan") / "paper"
    assert main(["plan", "--area", str(flight_area), "--seed", "0", "--strategy", "exhaustive",
                 "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture
def plan(plan_dir) -> FleetPlan:
    return load_plan_dir(plan_dir)


def fast_options(**overrides) -> FlyOptions:
    """Timeouts shorter than a real link's, long enough for a loaded machine (several autopilot
    SITLs beside the test) where a process may wait a second for a core."""
    base = dict(tick_s=0.01, transfer_timeout_s=0.25, command_timeout_s=0.5, link_timeout_s=2.0, lost_giveup_s=2.0,
                connect_timeout_s=5.0, arm_timeout_s=5.0)
    base.update(overrides)
    return FlyOptions(**base)


def fly(plan: FleetPlan, options: FlyOptions | None = None, *, during=None, listeners=(), watchers=(),
        **sim) -> tuple[FlightController, object]:
    """Fly `plan` against a fresh simulated fleet; `during(fleet)` runs once it is up."""
    sim.setdefault("speedup", SPEEDUP)
    fleet = fleet_for_plan(plan, **sim).start()
    try:
        if during is not None:
            during(fleet)
        controller = asyncio.run(asyncio.wait_for(
            fly_async(plan, fleet.connection_strings(), options or fast_options(), listeners=listeners,
                      watchers=watchers), 120))
    finally:
        fleet.stop()
    assert not fleet.errors, fleet.errors
    return controller, fleet
