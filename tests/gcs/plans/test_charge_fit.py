"""`gcs plan --vehicles` fits a cornering copter's range to what its planned path costs
(`gcs.plans.charge_fit`): planned again with the fitted ranges, every such path costs, as its
profile prices it, no more than its charge pays for in straight cruise."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from gcs.cli import main
from gcs.plans.charge_fit import FIT_MARGIN, _closed_path_en, fit_ranges_to_paths
from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.planning import build_area_search
from gcs.plans.vehicle_file import STOCK_PROFILES, load_vehicles
from planner.energy import Airframe
from planner.path_time import path_length_m
from tests.gcs.plans.conftest import vehicles_file
from tests.peers.site import COPTERS

ARDUCOPTER = STOCK_PROFILES[("ardupilot", Airframe.COPTER)]


def _cost_over_charge(setup, plan, profiles):
    """Each UAV's closed path cost (its profile's price) over what its straight range pays for."""
    out = {}
    for u in plan.uavs:
        if u.uav_id in profiles:
            path = _closed_path_en(setup, u.uav_id, [(p.x, p.y) for p in u.trajectory])
            p = profiles[u.uav_id]
            paid_mah = p.cruise_mah_per_m * setup.ranges_m[u.uav_id]
            out[u.uav_id] = p.path_mah_per_m(path) * path_length_m(path) / paid_mah
    return out


def test_a_copter_whose_corners_cost_more_than_its_range_was_sized_for_is_fitted_and_then_fits(tmp_path):
    """The copter site's 30 m cells; UAV 1's learned cruise metre is what a straight leg costs
    (its corners are then dearer than the range counts), UAV 2's profile prices metres only (no
    cornering: not fitted). The trial plan of UAV 1 costs more than its charge pays for; the
    plan made with the fitted range does not (within FIT_MARGIN), and its range and range_source say so."""
    area = tmp_path / "site.geojson"
    area.write_text(json.dumps(COPTERS.geojson()))
    straight = replace(ARDUCOPTER, cruise_mah_per_m=ARDUCOPTER.moving_mah_per_s / ARDUCOPTER.cruise_speed_m_s)
    metres = replace(ARDUCOPTER, cornering=None, moving_mah_per_s=None)
    vehicles = vehicles_file(tmp_path, {1: straight, 2: metres})
    options = AreaOptions(vehicles=vehicles)
    records = load_vehicles(vehicles)
    before = build_area_search(area, options, SearchOptions())
    fitted, fits = fit_ranges_to_paths(before, records)
    assert [f.uav_id for f in fits] == [1] and fits[0].corner_ratio > 1.0
    assert fits[0].straight_m / fits[0].fitted_m > 1.0 + FIT_MARGIN  # the trial plan's path cost more
    assert fitted.ranges_m[1] == pytest.approx(fits[0].fitted_m) and fitted.ranges_m[1] < before.ranges_m[1]
    assert fitted.ranges_m[2] == before.ranges_m[2]
    for _ in fitted.search.run():
        pass
    after = _cost_over_charge(replace(fitted, ranges_m=before.ranges_m), fitted.search.plan(), {1: straight})
    assert after[1] <= 1.0 + FIT_MARGIN, after

    out = tmp_path / "plan"
    assert main(["plan", "--area", str(area), "--out", str(out), "--vehicles", vehicles, "--quiet", "--no-rrd"]) == 0
    uavs = {u["id"]: u for u in json.loads((out / "plan.json").read_text())["uavs"]}
    assert uavs[1]["range_m"] == pytest.approx(fits[0].fitted_m, abs=1e-3)
    assert f"fitted to {fits[0].fitted_m:.0f} m of the {before.ranges_m[1]:.0f} m" in uavs[1]["range_source"]
    assert "fitted" not in uavs[2]["range_source"]
    assert uavs[1]["range_used_m"] <= uavs[1]["range_m"]


def test_a_fleet_without_cornering_profiles_is_planned_once_as_before(tmp_path):
    area = tmp_path / "site.geojson"
    area.write_text(json.dumps(COPTERS.geojson()))
    metres = replace(ARDUCOPTER, cornering=None, moving_mah_per_s=None)
    vehicles = vehicles_file(tmp_path, {1: metres, 2: metres})
    setup = build_area_search(area, AreaOptions(vehicles=vehicles), SearchOptions())
    same, fits = fit_ranges_to_paths(setup, load_vehicles(vehicles))
    assert fits == [] and same is setup and setup.search.step_index == 0
