"""Ranges fitted to what the planned paths cost: a copter whose profile prices a path by its time
(`EnergyProfile.cornering`) gets a range its charge pays for once its path's corners are priced.

`gcs plan --vehicles` sizes each UAV's range as the metres of straight cruise its charge pays for
(`EnergyProfile.range_m`, at `cruise_mah_per_m`). A search path turns: through its cells' centres
it costs `path_mah_per_m` a metre (its seconds at the profile's `moving_mah_per_s`), which the
planner's metre ranges do not see. A learned profile's `cruise_mah_per_m` is what the last
flight's path cost a metre, and the next plan's path may turn more: on ArduCopter SITL a plan
sized that way cost 6 % more than its charge paid for, and its copter came home by battery at 16
of 20 waypoints. `fit_ranges_to_paths` plans the fleet by DTSCS alone (the whole-mission
improvement after it keeps each such copter's time-priced path within what its range's charge
pays for, `planner.improve`, and costs many times the search), prices each such UAV's closed
path (its airport, its cells' centres, its airport) by its profile, and every UAV whose path costs more
than its range was sized to pay for gets the range whose metres, each at its path's price, the
charge pays for (a plan may fly all of its range: its trial path may have left some); a shorter
path can turn more, so it plans again with those ranges (the same seed) and fits again what is
still over, `FIT_PLANS` trial plans at most. The search it returns plans with the last ranges,
so the caller's recording and progress see the plan it keeps."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gcs.plans.planning import AreaSetup
from gcs.plans.vehicle_file import VehicleRecord, profile_for_uav
from planner.area_grid import range_units
from planner.dtscs import ClosedSearch, uavs_that_cannot_leave
from planner.energy import EnergyProfile
from planner.path_time import path_length_m
from planner.plan import UavPlan

__all__ = ["FIT_MARGIN", "FIT_PLANS", "RangeFit", "fit_ranges_to_paths"]

#: A path within this share over what its range pays for is left as planned.
FIT_MARGIN = 0.005
#: Trial plans at most before the plan kept.
FIT_PLANS = 3


@dataclass(frozen=True)
class RangeFit:
    """One UAV's range as the charge pays for it in straight cruise (`straight_m`) and as fitted
    to its first plan's path (`fitted_m`), with that path's cost of a metre over the straight
    cruise's (`corner_ratio`)."""

    uav_id: int
    straight_m: float
    fitted_m: float
    corner_ratio: float


def _closed_path_en(setup: AreaSetup, uav_id: int, cells: list[tuple[int, int]]) -> np.ndarray:
    ap = setup.source.airports[uav_id - 1]
    home = setup.area.point_m(ap.lon_deg, ap.lat_deg)
    centres = [setup.area.grid.centre_m(x, y) for x, y in cells]
    return np.array([home, *centres, home], dtype=float)


def _priced(setup: AreaSetup, uav_id: int, planned: UavPlan, profile: EnergyProfile) -> tuple[float, float]:
    """(the path's cost of a metre over the straight cruise's, its cost in straight-cruise metres)."""
    path = _closed_path_en(setup, uav_id, [(p.x, p.y) for p in planned.trajectory])
    ratio = profile.path_mah_per_m(path) / profile.cruise_mah_per_m
    return ratio, ratio * path_length_m(path)


def fit_ranges_to_paths(setup: AreaSetup, records: dict[str, VehicleRecord]) -> tuple[AreaSetup, list[RangeFit]]:
    """`setup` with the ranges of its cornering copters fitted to their planned paths (module
    docstring), and the fits made; `setup` itself (its search not run) when no UAV has such a
    profile. Up to `FIT_PLANS` trial plans: a fitted plan whose path turns more than its trial's
    is fitted again from its own path. Its search is spent: use the returned setup's."""
    profiles = {}
    for spec in setup.search.scenario.uavs:
        record = profile_for_uav(records, spec.uav_id)
        if record is not None and record.profile.cornering is not None:
            profiles[spec.uav_id] = record.profile
    if not profiles:
        return setup, []
    cell = setup.area.grid.cell_size_m
    scenario, config = setup.search.scenario, setup.search.config
    fitted: dict[int, RangeFit] = {}
    trial_config = replace(config, improve=None)  # the improvement keeps a copter's time within its range's charge
    for _ in range(FIT_PLANS):
        trial = ClosedSearch(scenario, trial_config, seed=setup.search.seed)
        for _ in trial.run():
            pass
        specs, changed = [], False
        for spec, planned in zip(scenario.uavs, trial.plan().uavs):
            profile = profiles.get(spec.uav_id)
            straight_m = setup.ranges_m[spec.uav_id]
            ratio, cost_m = (1.0, 0.0) if profile is None else _priced(setup, spec.uav_id, planned, profile)
            if cost_m <= straight_m * (1.0 + FIT_MARGIN):
                specs.append(spec)
                continue
            now_m = fitted[spec.uav_id].fitted_m if spec.uav_id in fitted else straight_m
            # a plan may fly its whole range: its metres at this path's price fit, and at least by how far it was over
            range_m = min(straight_m / ratio, now_m * straight_m / cost_m)
            units = range_units(range_m - setup.overheads_m[spec.uav_id], cell)
            candidate = replace(spec, range_units=min(spec.range_units, units))
            if uavs_that_cannot_leave(replace(scenario, uavs=[candidate]), config):
                specs.append(spec)  # fitted below the shortest loop out and home: it keeps the range it has
                continue
            fitted[spec.uav_id] = RangeFit(spec.uav_id, straight_m, range_m, ratio)
            specs.append(candidate)
            changed = True
        scenario = replace(scenario, uavs=specs)
        if not changed:
            break
    ranges_m, sources = dict(setup.ranges_m), dict(setup.range_sources)
    for f in fitted.values():
        ranges_m[f.uav_id] = f.fitted_m
        sources[f.uav_id] = (sources.get(f.uav_id, "") + f"; fitted to {f.fitted_m:.0f} m of the {f.straight_m:.0f} m "
                             f"it pays for in straight cruise: its path's corners cost {f.corner_ratio - 1:.1%} more a "
                             "metre")
    search = ClosedSearch(scenario, config, seed=setup.search.seed)
    return replace(setup, search=search, ranges_m=ranges_m, range_sources=sources), list(fitted.values())
