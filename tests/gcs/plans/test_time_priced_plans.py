"""A copter's area plan is improved with its path priced by its time (`planner.time_pricing`):
the profile of the vehicle that flies it from vehicles.json, else the stock ArduCopter's; a
plane's, or a profile that prices metres, plans as before."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.planning import build_area_search
from gcs.plans.vehicle_file import STOCK_PROFILES
from planner.area_grid import AREA_MOVE_COSTS
from planner.energy import Airframe
from planner.path_time import path_time_s
from planner.time_pricing import time_pricing
from tests.gcs.plans.conftest import vehicles_file
from tests.peers.site import COPTERS, PLANE

ARDUCOPTER = STOCK_PROFILES[("ardupilot", Airframe.COPTER)]


@pytest.fixture(scope="module")
def site_file(tmp_path_factory: pytest.TempPathFactory):
    """The real autopilots' copter site: a 600 m square of 30 m cells, two airports of 1300 m."""
    path = tmp_path_factory.mktemp("site") / "site.geojson"
    path.write_text(json.dumps(COPTERS.geojson()))
    return path


def test_a_copter_without_a_vehicles_file_is_priced_as_the_stock_arducopter_and_a_plane_by_its_metres(site_file,
                                                                                                      tmp_path):
    copters = build_area_search(site_file, AreaOptions(), SearchOptions(improve=False))
    want = time_pricing(ARDUCOPTER, 30.0, AREA_MOVE_COSTS)
    assert want is not None and want.turn_units[1] > 0
    assert [u.time_pricing for u in copters.search.scenario.uavs] == [want, want]
    runway = tmp_path / "plane.geojson"
    runway.write_text(json.dumps(PLANE.geojson()))
    planes = build_area_search(runway, AreaOptions(vehicle="plane"), SearchOptions(improve=False))
    assert [u.time_pricing for u in planes.search.scenario.uavs] == [None]


def test_each_copter_is_priced_by_its_own_vehicles_profile(site_file, tmp_path):
    """UAV 1's learned profile draws more a second than the stock one: its range buys fewer
    seconds; UAV 2's prices metres (no cornering): no time pricing."""
    learned = replace(ARDUCOPTER, moving_mah_per_s=9.0)
    metres = replace(ARDUCOPTER, cornering=None, moving_mah_per_s=None)
    setup = build_area_search(site_file, AreaOptions(vehicles=vehicles_file(tmp_path, {1: learned, 2: metres})),
                              SearchOptions(improve=False))
    first, second = setup.search.scenario.uavs
    assert first.time_pricing == time_pricing(learned, 30.0, AREA_MOVE_COSTS)
    assert first.time_pricing is not None
    assert first.time_pricing.units_per_range_unit == pytest.approx(ARDUCOPTER.cruise_mah_per_m * 10.0 / 9.0)
    assert second.time_pricing is None


def test_the_improved_plan_of_a_copter_takes_no_longer_than_its_range_or_its_dtscs_path(site_file):
    """`gcs plan --area`'s default plan of the copter site: each path through its cells' centres
    takes no more seconds (`path_time_s`, as the flight's energy account prices it) than the
    charge its range over the grid was sized with flies, or than its DTSCS path's time-priced
    cost, and never more metres than its range."""
    improved = build_area_search(site_file)
    plain = build_area_search(site_file, AreaOptions(), SearchOptions(improve=False))
    plans = []
    for setup in (plain, improved):
        for _ in setup.search.run():
            pass
        plans.append(setup.search.plan())
    before, after = plans
    assert after.settings.get("improved") is True and after.success.expected >= before.success.expected
    cell = improved.area.grid.cell_size_m
    v = ARDUCOPTER.cruise_speed_m_s
    for spec, old, new in zip(improved.search.scenario.uavs, before.uavs, after.uavs):
        pricing = spec.time_pricing
        assert pricing is not None
        range_m = new.range_units * cell / AREA_MOVE_COSTS.straight
        pays_s = range_m * ARDUCOPTER.cruise_mah_per_m / ARDUCOPTER.moving_mah_per_s
        dtscs_s = pricing.path_units([p.heading for p in old.trajectory[1:]], AREA_MOVE_COSTS) * cell \
            / AREA_MOVE_COSTS.straight / v
        points = np.array([improved.area.grid.centre_m(p.x, p.y) for p in new.trajectory])
        assert path_time_s(points, v, ARDUCOPTER.cornering) <= max(pays_s, dtscs_s)
        assert new.spent <= new.range_units
