"""Planning, from options to a closed search and its files: a built-in scenario's search
(`build_scenario_search`), and for a real area, area file -> grid and scenario -> closed search
(`build_area_search`) -> mission files (`area_outputs`, `write_outputs`). `gcs.plans.make` runs
them for `gcs plan` and `gcs fly --area`; `gcs.plans.campaign` plans later sorties.

Bad input raises `UserError` before anything is written; the outputs are staged and published
together (`gcs.atomic.staged_outputs`), so a failed run leaves the output folder as it was."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from gcs.atomic import staged_outputs
from gcs.autopilots.capacity import fleet_fence_capacity
from gcs.errors import UserError
from gcs.missions.approach import ApproachOptions, landing_approach
from gcs.missions.fence import CORRIDOR_VERTICES, FENCE_CLEARANCE_M, FENCE_GROWTH_CELLS, Fence, uav_fence
from gcs.missions.fence_fit import FenceDoesNotFit, FittedFence, fit_fence
from gcs.missions.from_plan import FlownPath, uav_mission
from gcs.missions.items import AltitudeReference, UavMission, Vehicle, mission_items
from gcs.missions.paths import paths_geojson, uav_label
from gcs.missions.qgc_plan import qgc_plan
from gcs.missions.wpl import wpl_text
from gcs.plans.area_file import AreaFile, read_area_file
from gcs.plans.area_prior import area_mass_prior
from gcs.plans.options import DEFAULT_CELL_SIZE_M, AreaOptions, SearchOptions
from gcs.plans.plan_file import plan_to_dict
from gcs.plans.segments import SortieSegments, segments_for_teams, segments_from, segments_geojson, sortie_segments
from gcs.plans.vehicle_file import VehicleRecord, load_vehicles, profile_for_uav, stock_profile
from planner.area_grid import (
    AREA_MOVE_COSTS,
    AreaGrid,
    PriorCells,
    airport_cell,
    area_scenario,
    build_area_grid,
    local_frame_for,
    range_units,
    units_m,
)
from planner.camera import Camera, CameraSensor, camera_sensor
from planner.campaign import Belief, sortie_seed
from planner.dtscs import ClosedSearch, MissionConfig, uavs_that_cannot_leave
from planner.energy import Airframe, EnergyProfile
from planner.environment import Sensor
from planner.horizon import HorizonValue
from planner.improve import ImproveSettings
from planner.motion import constraint_by_name
from planner.plan import Plan
from planner.priors import MassPrior
from planner.scenario import SCENARIOS, Scenario, UavSpec
from planner.time_pricing import time_pricing


@dataclass
class AreaSetup:
    """Everything resolved from the area file and the options, before the search flies."""

    source: AreaFile
    area: AreaGrid
    search: ClosedSearch
    ranges_m: dict[int, float]
    layers: AltitudeLayers
    overheads_m: dict[int, float]
    vehicle: Vehicle
    altitude_reference: AltitudeReference = AltitudeReference.HOME
    approach: ApproachOptions = ApproachOptions()
    belief: Belief | None = None
    range_sources: dict[int, str] = field(default_factory=dict)
    grounded: dict[int, str] = field(default_factory=dict)  # UAV -> why its range cannot leave its airport
    fence: FittedFence | None = None  # the area's fence as the vehicles hold it (`area_fence`)
    prior_mass: MassPrior | None = None  # the subject's probability per cell, from rasters or an IPP
    camera: CameraSensor | None = None  # the sensor derived from --camera-fov, when given

    def __post_init__(self) -> None:
        if self.belief is None:
            scenario = self.search.scenario
            self.belief = Belief.prior(scenario.search_map) if scenario.p0 is None else Belief(
                scenario.search_map.copy(), scenario.p0, np.zeros(scenario.search_map.shape, dtype=np.int64))

    def for_belief(self, belief: Belief, seed: int) -> AreaSetup:
        """The same area, airports and fresh ranges searching `belief` (sortie `belief.sortie` of
        the campaign on `seed`)."""
        return replace(self, search=_search(self.search.scenario, self.search.config, seed, belief), belief=belief)


def _search(scenario: Scenario, config: MissionConfig, seed: int, belief: Belief | None) -> ClosedSearch:
    """The closed search of `scenario`, or of a later sortie's belief over it (its own seed)."""
    if belief is None:
        return ClosedSearch(scenario, config, seed=seed)
    return ClosedSearch(belief.scenario(scenario), config, seed=sortie_seed(seed, belief.sortie))


def _positive(value: float, what: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise UserError(f"{what} must be a positive number, got {value:g}")
    return value


@dataclass(frozen=True)
class AltitudeLayers:
    """The altitudes UAVs fly at: `altitudes_m[uav]`, and `layer[uav]` (1-based, lowest first;
    None for an airport that asked for its own altitude). Layers run from the floor up in
    steps, never above the ceiling; with more UAVs than layers, layers are shared in turn
    (`shared` lists them) and the plan's cell separation keeps those UAVs apart."""

    altitudes_m: dict[int, float]
    layer: dict[int, int | None]
    levels_m: tuple[float, ...]

    @property
    def shared(self) -> dict[int, list[int]]:
        groups: dict[int, list[int]] = {}
        for uav, level in self.layer.items():
            if level is not None:
                groups.setdefault(level, []).append(uav)
        return {level: uavs for level, uavs in groups.items() if len(uavs) > 1}


def altitude_layers(explicit: list[float | None], floor_m: float, step_m: float, ceiling_m: float) -> AltitudeLayers:
    """Layers floor, floor + step, ... up to the ceiling, minus those within step/2 of an
    altitude an airport asked for; UAV i (1-based) without its own altitude takes the next layer."""
    if not (math.isfinite(floor_m) and floor_m > 0):
        raise ValueError(f"--altitude must be positive, got {floor_m:g}")
    if not (math.isfinite(ceiling_m) and ceiling_m >= floor_m):
        raise ValueError(f"--ceiling {ceiling_m:g} m is below the lowest layer (--altitude {floor_m:g} m)")
    if not (math.isfinite(step_m) and step_m > 0):
        raise ValueError(f"--altitude-step must be positive, got {step_m:g}")
    taken = [a for a in explicit if a is not None]
    for i, alt in enumerate(explicit):
        if alt is not None and alt > ceiling_m:
            raise ValueError(f"UAV {i + 1}: altitude_m {alt:g} m is above the ceiling of {ceiling_m:g} m")
    count = int(math.floor((ceiling_m - floor_m) / step_m + 1e-9)) + 1
    levels = tuple(floor_m + k * step_m for k in range(count)
                   if all(abs(floor_m + k * step_m - t) >= step_m / 2 for t in taken))
    altitudes: dict[int, float] = {}
    layer: dict[int, int | None] = {}
    nth = 0
    for i, alt in enumerate(explicit):
        if alt is None:
            if not levels:
                raise ValueError(f"UAV {i + 1}: no altitude layer left between {floor_m:g} and {ceiling_m:g} m")
            layer[i + 1] = nth % len(levels) + 1
            alt = levels[nth % len(levels)]
            nth += 1
        else:
            layer[i + 1] = None
        altitudes[i + 1] = alt
    return AltitudeLayers(altitudes, layer, levels)


def mission_config(search: SearchOptions, horizon: bool) -> MissionConfig:
    """The closed search's configuration; `horizon` is the horizon value's default (on for an
    area, off for a built-in scenario) when `search.horizon_value` is None. ValueError when a
    name or number is not one the planner knows."""
    return MissionConfig(np_steps=search.np_steps, oc=constraint_by_name(search.oc), strategy=search.strategy,
                         return_planner=search.return_planner, reserve_steps=search.reserve,
                         range_aware_search=search.range_aware_search,
                         horizon=HorizonValue() if _default(search.horizon_value, horizon) else None,
                         improve=ImproveSettings() if _default(search.improve, horizon) else None)


def _default(value: bool | None, default: bool) -> bool:
    return default if value is None else value


def build_scenario_search(scenario: str = "paper", search: SearchOptions | None = None) -> ClosedSearch:
    """The closed search of built-in scenario `scenario` (`planner.scenario.SCENARIOS`) under
    `search` (None: the defaults); bad values raise UserError."""
    search = search or SearchOptions()
    if scenario not in SCENARIOS:
        raise UserError(f"unknown scenario {scenario!r} (choose from {', '.join(SCENARIOS)})")
    if search.camera_fov_deg is not None:
        raise UserError("--camera-fov needs --area: a built-in scenario's cells have no size in metres")
    try:
        sensor = Sensor(search.pc, search.pf, search.footprint)
        config = mission_config(search, horizon=False)
        if search.range_steps < 1:
            raise ValueError(f"range must be at least 1 step, got {search.range_steps}")
        built = SCENARIOS[scenario](seed=search.seed, range_steps=search.range_steps, sensor=sensor)
        return ClosedSearch(built, config, seed=search.seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def build_area_search(area_file: str | Path, area: AreaOptions | None = None, search: SearchOptions | None = None,
                      belief: Belief | None = None) -> AreaSetup:
    """The area, airports, ranges and closed search of `area_file` under the options (None: the
    defaults); with `belief`, the search of that belief instead of the area's prior (a later
    sortie of a campaign, `gcs.plans.campaign`). Bad input raises UserError naming the option or
    the file."""
    area, search = area or AreaOptions(), search or SearchOptions()
    source = read_area_file(area_file)
    given_cell = area.cell_size_m if area.cell_size_m is not None else source.cell_size_m
    cell = _positive(given_cell if given_cell is not None else DEFAULT_CELL_SIZE_M, "--cell-size")
    speed = _positive(area.speed_m_s, "--speed")
    _positive(area.endurance_s, "--endurance")
    if area.range_m is not None:
        _positive(area.range_m, "--range-m")
    approach = ApproachOptions(_positive(area.approach_m, "--approach-m"),
                               _positive(area.approach_alt_m, "--approach-alt"), min(250.0, area.approach_m))
    vehicle = Vehicle(area.vehicle)
    if not 0 <= area.reserve_pct < 100:
        raise UserError(f"--reserve-pct must be in [0, 100), got {area.reserve_pct:g}")
    records = load_vehicles(area.vehicles) if area.vehicles else {}
    try:
        fence = area_fence(source, vehicle, cell)
        grid = build_area_grid(source.area, [*source.no_fly, *grown_zones_lonlat(fence)], cell, area.margin_m,
                               area.max_cells)
        layers = altitude_layers([ap.altitude_m for ap in source.airports], area.altitude_m, area.altitude_step_m,
                                 area.ceiling_m)
        uavs, ranges_m, overheads_m, sources = [], {}, {}, {}
        grounded: dict[int, str] = {}
        taken: set[tuple[int, int]] = set()
        for ap in source.airports:
            uav_id = ap.index + 1
            label = f"airport {ap.name!r} (UAV {uav_id})"
            east, north = grid.point_m(ap.lon_deg, ap.lat_deg)
            x, y = airport_cell(grid, east, north, label, taken)
            taken.add((x, y))
            record = profile_for_uav(records, uav_id)
            if record is not None:
                range_m = record.profile.range_m(layers.altitudes_m[uav_id], area.reserve_pct)
                sources[uav_id] = (f"{area.vehicles}: vehicle {record.key}, {record.profile.capacity_mah:.0f} mAh, "
                                   f"{area.reserve_pct:g}% reserve")
            else:
                range_m = (ap.range_m or (ap.endurance_s * speed if ap.endurance_s else None)
                           or area.range_m or area.endurance_s * speed)
            ce, cn = grid.grid.centre_m(x, y)
            circuit_m = landing_approach(grid, (east, north), ap.heading * 45.0, np.array([east, north]), approach,
                                         label).circuit_m if vehicle is Vehicle.PLANE else 0.0
            overhead_m = 2 * float(math.hypot(ce - east, cn - north)) + circuit_m
            units = range_units(range_m - overhead_m, cell)
            ranges_m[uav_id] = range_m
            overheads_m[uav_id] = overhead_m
            if units < 2 * AREA_MOVE_COSTS.straight:
                grounded[uav_id] = (f"range {range_m:.0f} m leaves {max(range_m - overhead_m, 0):.0f} m over the "
                                    f"{cell:g} m cells once {overhead_m:.0f} m to the airport's cell and back"
                                    f"{' and the landing circuit' if circuit_m else ''} are taken off; it cannot "
                                    "leave its airport and come back")
            else:
                pricing = time_pricing(pricing_profile(record, vehicle), cell, AREA_MOVE_COSTS)
                uavs.append(UavSpec(uav_id, (x, y), ap.heading, units, pricing))
        targets = []
        for t in source.targets:
            east, north = grid.point_m(t.lon_deg, t.lat_deg)
            if not grid.area_m.covers(Point(east, north)):
                raise ValueError(f"target {t.name!r} at lon {t.lon_deg}, lat {t.lat_deg} is outside the area")
            targets.append((east, north))
        priors = [PriorCells(grid.to_local(p.geometry), p.tep, p.eu) for p in source.priors]
        mass = area_mass_prior(source, grid)
        camera = area_camera(search, [layers.altitudes_m[u.uav_id] for u in uavs], cell)
        sensor = Sensor(search.pc, search.pf, search.footprint) if camera is None else camera.sensor(search.pf)
        config = mission_config(search, horizon=True)
        scenario = area_scenario(source.name, grid, priors, uavs, targets, area.default_tep, area.default_eu, sensor,
                                 None if mass is None else mass.tep)
        if mass is not None:  # the probability of success counts the subject's probability, not the TEP
            scenario = replace(scenario, p0=mass.mass)
        for spec in uavs_that_cannot_leave(scenario, config):
            grounded[spec.uav_id] = (f"range {ranges_m[spec.uav_id]:.0f} m ({units_m(spec.range_units, cell):.0f} m "
                                     f"over the {cell:g} m cells) is too short to leave its airport and come back "
                                     f"under {config.oc.name}")
        scenario = replace(scenario, uavs=[u for u in uavs if u.uav_id not in grounded])
        if not scenario.uavs:
            names = {ap.index + 1: ap.name for ap in source.airports}
            raise ValueError("no UAV can leave its airport and come back: " + "; ".join(
                f"UAV {uid} ({names[uid]!r}): {why}" for uid, why in sorted(grounded.items())))
        closed = _search(scenario, config, search.seed, belief)
    except ValueError as exc:
        raise UserError(f"{area_file}: {exc}") from None
    reference = AltitudeReference.TERRAIN if area.terrain_follow else AltitudeReference.HOME
    return AreaSetup(source, grid, closed, ranges_m, layers, overheads_m, vehicle, reference, approach, belief, sources,
                     dict(sorted(grounded.items())), fence, mass, camera)


def pricing_profile(record: VehicleRecord | None, vehicle: Vehicle) -> EnergyProfile | None:
    """The energy profile a UAV's path is priced with when the whole-mission improvement re-solves
    it (`planner.time_pricing`): its vehicle's in the vehicles file, else a copter's stock profile
    (ArduCopter's, whose corners cost it time: which autopilot flies it is known only once it
    connects, and PX4's stock copter prices a path by its metres), else None (a plane: its path
    is priced by its metres)."""
    if record is not None:
        return record.profile
    return stock_profile("ardupilot", Airframe.COPTER) if vehicle is Vehicle.COPTER else None


def area_camera(search: SearchOptions, altitudes_m: list[float], cell_size_m: float) -> CameraSensor | None:
    """The sensor of `search`'s camera over the area's cells, at the lowest altitude a UAV flies
    (the narrowest swath: no UAV is credited with ground it did not see); None without a camera."""
    if search.camera_fov_deg is None:
        return None
    camera = Camera(search.camera_fov_deg, search.camera_pixels, search.camera_pd)
    return camera_sensor(camera, min(altitudes_m) if altitudes_m else 1.0, cell_size_m)


def area_fence(source: AreaFile, vehicle: Vehicle, cell_size_m: float) -> FittedFence:
    """The area's geofence (its rings, the area's holes and the no-fly zones) fitted, before the
    grid is laid, to what every autopilot that flies `vehicle` holds, with room left for a
    plane's landing corridor. A no-fly zone it grows is flown as one: the grid blocks the cells
    it covers, so the plan never meets the fence. Zones grow at most FENCE_GROWTH_CELLS cells and
    never onto an airport."""
    capacity = fleet_fence_capacity(vehicle is Vehicle.PLANE)
    if vehicle is Vehicle.PLANE:
        capacity = capacity.less(CORRIDOR_VERTICES * len(shapely.get_parts(source.area)))
    airports = shapely.union_all([Point(ap.lon_deg, ap.lat_deg) for ap in source.airports])
    frame = local_frame_for(source.area)
    clear_m = shapely.transform(airports, frame.lonlat2local_coords).buffer(cell_size_m + FENCE_CLEARANCE_M)
    try:
        return fit_fence(uav_fence(source.area, source.no_fly), capacity,
                         shapely.transform(clear_m, frame.local2lonlat_coords), FENCE_GROWTH_CELLS * cell_size_m)
    except FenceDoesNotFit as exc:
        raise UserError(f"{source.name}: {exc}") from None


def grown_zones_lonlat(fitted: FittedFence) -> list[Polygon]:
    """The fence's exclusions that reach beyond their zones, as polygons the grid must keep out of."""
    if fitted.grown_m <= 0:
        return []
    return [Polygon([(lon, lat) for lat, lon in ring]) for ring in fitted.fence.exclusion]


def uav_fitted_fence(setup: AreaSetup, flown: FlownPath) -> FittedFence:
    """The UAV's geofence: the area's fitted fence, its inclusion joined with a plane's landing
    corridor (and simplified again if that no longer fits)."""
    fitted = setup.fence
    if flown.corridor_m is None:
        return fitted
    source = setup.source
    corridor = setup.area.to_lonlat(flown.corridor_m)
    joined = uav_fence(source.area, [], corridor)
    refit = fit_fence(Fence(joined.inclusion, fitted.fence.exclusion), fleet_fence_capacity(True))
    return replace(refit, source_vertices=uav_fence(source.area, source.no_fly, corridor).vertices,
                   grown_m=fitted.grown_m)


def area_outputs(setup: AreaSetup, plan: Plan, seed: int, speed_m_s: float, campaign: dict | None = None,
                 bound: dict | None = None, segments: SortieSegments | None = None) -> dict[str, str]:
    """File name -> text of every output of an area plan; `campaign` is plan.json's campaign
    section (`gcs.plans.campaign`), `bound` its `summary.bound` (`gcs.plans.plan_bound`),
    `segments` the sortie's segments whose figures the picture and the recording were given
    (`gcs.plans.segments.sortie_segments` of `setup` when None)."""
    source, area = setup.source, setup.area
    missions: list[UavMission] = []
    paths: dict[int, FlownPath] = {}
    extra: dict[int, dict] = {}
    airports = {ap.index + 1: ap for ap in source.airports}
    for u in plan.uavs:
        ap = airports[u.uav_id]
        try:
            mission, flown = uav_mission(area, u, ap.name, setup.vehicle, (ap.lat_deg, ap.lon_deg),
                                         setup.layers.altitudes_m[u.uav_id], home_amsl_m=ap.elevation_m or 0.0,
                                         altitude_reference=setup.altitude_reference, approach=setup.approach)
        except ValueError as exc:
            raise UserError(f"{source.name}: {exc}") from None
        missions.append(mission)
        paths[u.uav_id] = flown
        extra[u.uav_id] = {"name": ap.name, "vehicle": setup.vehicle.value, "altitude_m": mission.altitude_m,
                           "altitude_layer": setup.layers.layer[u.uav_id],
                           "altitude_reference": setup.altitude_reference.value,
                           "elevation_m": ap.elevation_m,
                           "approach": None if mission.approach is None else {
                               "lat_lon": [mission.approach.lat_deg, mission.approach.lon_deg],
                               "alt_m": mission.approach.alt_m},
                           "range_m": round(setup.ranges_m[u.uav_id], 3),
                           "range_used_m": round(units_m(u.spent, area.grid.cell_size_m)
                                                 + setup.overheads_m[u.uav_id], 3),
                           **({"range_source": setup.range_sources[u.uav_id]}
                              if u.uav_id in setup.range_sources else {}),
                           "airport_lat_lon": [ap.lat_deg, ap.lon_deg],
                           "waypoints": [[a, b] for a, b in mission.waypoints],
                           "length_m": round(flown.length_m, 3),
                           "mission_items": len(mission_items(mission)) + 1}
    fences = {uid: uav_fitted_fence(setup, flown) for uid, flown in paths.items()}
    for uid, fitted in fences.items():
        extra[uid]["fence"] = {"vertices": fitted.fence.vertices, "source_vertices": fitted.source_vertices,
                               "outside_m": round(fitted.outside_m, 1), "grown_m": round(fitted.grown_m, 1)}
    data = plan_to_dict(plan, seed=seed, area=area, uav_extra=extra, bound=bound)
    if setup.grounded:
        data["grounded"] = [{"id": uid, "name": airports[uid].name, "reason": why,
                             "airport_lat_lon": [airports[uid].lat_deg, airports[uid].lon_deg]}
                            for uid, why in setup.grounded.items()]
    if campaign is not None:
        data["campaign"] = campaign
    sortie = segments if segments is not None else sortie_segments(setup)
    theory = sortie.figures(plan)
    data["search_theory"] = theory.as_dict() | {"segments_from": segments_from(source)}
    files = {"plan.json": json.dumps(data, indent=1) + "\n"}
    for m in missions:
        files[f"uav{m.uav_id}.waypoints"] = wpl_text(m)
        fence = fences[m.uav_id].fence
        files[f"uav{m.uav_id}.plan"] = json.dumps(qgc_plan(m, fence.inclusion, fence.exclusion, speed_m_s),
                                                  indent=1) + "\n"
    lengths = {uid: p.length_m for uid, p in paths.items()}
    collection = paths_geojson(missions, lengths, source.name)
    files["paths.geojson"] = json.dumps(collection, indent=1) + "\n"
    files.update(paths_for_teams(collection, missions, source.name))
    files.update(segments_for_teams(segments_geojson(area, sortie.segments, theory, source.name, source), source.name))
    return files


def paths_for_teams(collection: dict, missions: list[UavMission], name: str) -> dict[str, str]:
    """paths.kml (Google Earth, CalTopo, QGIS) and paths.gpx (handheld GPS) of the paths' GeoJSON."""
    from gcs.missions.gpx import gpx_text
    from gcs.missions.kml import kml_text

    names = [uav_label(m.uav_id, m.name) for m in missions]
    return {"paths.kml": kml_text(collection, "paths", names, f"{name}: planned paths", "LineString"),
            "paths.gpx": gpx_text(collection, names, "LineString")}


def write_outputs(out_dir: Path, files: dict[str, str]) -> None:
    """Publish all files together (names may hold sub-folders, `sortie2/plan.json`); on failure
    remove nothing old and leave no new folder behind. Once published, a plan folder keeps no
    mission file of a UAV its new plan.json does not fly (one left on the ground, an airport gone):
    a crew must not load a mission planned for another range."""
    paths = [out_dir / name for name in files]
    folders = {out_dir} | {parent for path in paths for parent in path.parents if out_dir in parent.parents}
    new_dirs = sorted((d for d in folders if not d.exists()), key=lambda d: len(d.parts), reverse=True)
    try:
        with staged_outputs(paths) as staged:
            for name, text in files.items():
                staged[out_dir / name].write_text(text, encoding="utf-8")
    except BaseException:
        for folder in new_dirs:  # deepest first
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()
        raise
    for plan_file in (path for path in paths if path.name == "plan.json"):
        for old in [*plan_file.parent.glob("uav*.waypoints"), *plan_file.parent.glob("uav*.plan")]:
            if old not in paths:
                old.unlink(missing_ok=True)


def area_out_dir(area_file: str | Path, out: str | Path | None = None) -> Path:
    """The folder an area plan is written to: `out`, else runs/<area file name>; UserError when
    `out` names a file."""
    if out is None:
        return Path("runs") / Path(area_file).stem
    path = Path(out)
    if path.suffix == ".json":
        raise UserError(f"--out {out}: --area writes several files; give a folder")
    if path.exists() and not path.is_dir():
        raise UserError(f"--out {out}: exists and is not a folder")
    return path
