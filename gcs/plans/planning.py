"""`gcs plan --area`: area file -> grid and scenario -> closed search -> mission files (run by
`gcs.plans.campaign.run_area`, which also plans later sorties).

Bad input raises `UserError` before anything is written; the outputs are staged and published
together (`gcs.atomic.staged_outputs`), so a failed run leaves the output folder as it was."""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from shapely.geometry import MultiPolygon, Point

from gcs.atomic import staged_outputs
from gcs.errors import UserError
from gcs.missions.from_plan import ApproachOptions, FlownPath, landing_approach, uav_mission
from gcs.missions.items import AltitudeReference, UavMission, Vehicle
from gcs.missions.paths import paths_geojson
from gcs.missions.qgc_plan import qgc_plan
from gcs.missions.wpl import wpl_text
from gcs.plans.area_file import AreaFile, read_area_file
from gcs.plans.plan_file import plan_to_dict
from planner.area_grid import (
    DIAGONAL,
    MAX_CELLS,
    AreaGrid,
    PriorCells,
    airport_cell,
    area_scenario,
    build_area_grid,
    steps_for_range,
)
from planner.campaign import Belief, sortie_seed
from planner.dtscs import ClosedSearch, MissionConfig
from planner.environment import Sensor
from planner.horizon import HorizonValue
from planner.motion import constraint_by_name
from planner.plan import Plan
from planner.scenario import Scenario, UavSpec

DEFAULT_CELL_SIZE_M = 50.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("area planning (--area)")
    g.add_argument("--area", metavar="GEOJSON", default=None,
                   help="plan over a GeoJSON search area (docs/areas.md) instead of a built-in scenario")
    g.add_argument("--cell-size", dest="cell_size_m", metavar="METRES", type=float, default=None,
                   help=f"grid cell side (default: the file's cell_size_m, else {DEFAULT_CELL_SIZE_M:g})")
    g.add_argument("--speed", dest="speed_m_s", metavar="M/S", type=float, default=12.0, help="cruise speed")
    g.add_argument("--range-m", dest="range_m", metavar="METRES", type=float, default=None,
                   help="range of airports that give neither range_m nor endurance_s (overrides --endurance)")
    g.add_argument("--endurance", dest="endurance_s", metavar="SECONDS", type=float, default=900.0,
                   help="endurance of airports that give neither range_m nor endurance_s")
    g.add_argument("--altitude", dest="altitude_m", metavar="METRES", type=float, default=50.0,
                   help="the lowest altitude layer, above the airport (or the ground with --terrain-follow)")
    g.add_argument("--altitude-step", dest="altitude_step_m", metavar="METRES", type=float, default=10.0,
                   help="vertical spacing of the altitude layers: UAVs fly one layer each, between --altitude and "
                        "--ceiling (an airport's altitude_m overrides)")
    g.add_argument("--ceiling", dest="ceiling_m", metavar="METRES", type=float, default=120.0,
                   help="highest flight altitude allowed (120 m is the legal ceiling in the EU and the US)")
    g.add_argument("--terrain-follow", action="store_true",
                   help="fly the search at its altitude above the ground below (MAV_FRAME_GLOBAL_TERRAIN_ALT_INT; "
                        "the autopilot needs terrain data or a rangefinder)")
    g.add_argument("--vehicle", choices=[v.value for v in Vehicle], default=Vehicle.COPTER.value,
                   help="copter: take-off and NAV_LAND at the airport; plane: take-off along the runway (the "
                        "airport's heading) and a landing approach lined up with it")
    g.add_argument("--approach-m", dest="approach_m", metavar="METRES", type=float, default=500.0,
                   help="plane: length of the final approach on the runway axis (shortened to 250 m where the "
                        "area leaves no room); twice this is kept out of the search range")
    g.add_argument("--approach-alt", dest="approach_alt_m", metavar="METRES", type=float, default=30.0,
                   help="plane: altitude above the airport at the start of the final approach")
    g.add_argument("--margin", dest="margin_m", metavar="METRES", type=float, default=0.0,
                   help="safety buffer: shrink the area and grow the no-fly zones by this much")
    g.add_argument("--default-tep", type=float, default=0.5, help="target probability outside prior regions")
    g.add_argument("--default-eu", type=float, default=0.5, help="uncertainty outside prior regions")
    g.add_argument("--max-cells", type=int, default=MAX_CELLS, help="refuse grids with more cells than this")


@dataclass
class AreaSetup:
    """Everything resolved from the area file and the options, before the search flies."""

    source: AreaFile
    area: AreaGrid
    search: ClosedSearch
    ranges_m: dict[int, float]
    layers: AltitudeLayers
    vehicle: Vehicle
    altitude_reference: AltitudeReference = AltitudeReference.HOME
    approach: ApproachOptions = ApproachOptions()
    belief: Belief | None = None

    def __post_init__(self) -> None:
        if self.belief is None:
            self.belief = Belief.prior(self.search.scenario.search_map)

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


def build_area_search(args: argparse.Namespace, belief: Belief | None = None) -> AreaSetup:
    """The area, airports, ranges and closed search of `args`; with `belief`, the search of that
    belief instead of the area's prior (a later sortie of a campaign, `gcs.plans.campaign`)."""
    source = read_area_file(args.area)
    cell = _positive(args.cell_size_m or source.cell_size_m or DEFAULT_CELL_SIZE_M, "--cell-size")
    speed = _positive(args.speed_m_s, "--speed")
    _positive(args.endurance_s, "--endurance")
    if args.range_m is not None:
        _positive(args.range_m, "--range-m")
    approach = ApproachOptions(_positive(args.approach_m, "--approach-m"),
                               _positive(args.approach_alt_m, "--approach-alt"), min(250.0, args.approach_m))
    landing_m = 2 * approach.distance_m if args.vehicle == Vehicle.PLANE.value else 0.0
    try:
        area = build_area_grid(source.area, list(source.no_fly), cell, args.margin_m, args.max_cells)
        uavs, ranges_m = [], {}
        for ap in source.airports:
            uav_id = ap.index + 1
            label = f"airport {ap.name!r} (UAV {uav_id})"
            east, north = area.point_m(ap.lon_deg, ap.lat_deg)
            x, y = airport_cell(area, east, north, label)
            range_m = (ap.range_m or (ap.endurance_s * speed if ap.endurance_s else None)
                       or args.range_m or args.endurance_s * speed)
            ce, cn = area.grid.centre_m(x, y)
            to_cell_m = float(math.hypot(ce - east, cn - north))
            steps = steps_for_range(range_m - 2 * to_cell_m - landing_m, cell)
            if steps < 2:
                raise ValueError(f"{label}: range {range_m:.0f} m is {max(steps, 0)} steps of {cell * DIAGONAL:.1f} m; "
                                 f"it cannot leave its airport and come back")
            if landing_m:
                landing_approach(area, (east, north), ap.heading * 45.0, np.array([east, north]), approach, label)
            uavs.append(UavSpec(uav_id, (x, y), ap.heading, steps))
            ranges_m[uav_id] = range_m
        layers = altitude_layers([ap.altitude_m for ap in source.airports], args.altitude_m, args.altitude_step_m,
                                 args.ceiling_m)
        targets = []
        for t in source.targets:
            east, north = area.point_m(t.lon_deg, t.lat_deg)
            if not area.area_m.covers(Point(east, north)):
                raise ValueError(f"target {t.name!r} at lon {t.lon_deg}, lat {t.lat_deg} is outside the area")
            targets.append((east, north))
        priors = [PriorCells(area.to_local(p.geometry), p.tep, p.eu) for p in source.priors]
        sensor = Sensor(args.pc, args.pf, args.footprint)
        scenario = area_scenario(source.name, area, priors, uavs, targets, args.default_tep, args.default_eu, sensor)
        config = MissionConfig(np_steps=args.np_steps, oc=constraint_by_name(args.oc), strategy=args.strategy,
                               return_planner=args.return_planner, reserve_steps=args.reserve,
                               range_aware_search=args.range_aware_search,
                               horizon=None if getattr(args, "horizon_value", None) is False else HorizonValue())
        search = _search(scenario, config, args.seed, belief)
    except ValueError as exc:
        raise UserError(f"{args.area}: {exc}") from None
    reference = AltitudeReference.TERRAIN if args.terrain_follow else AltitudeReference.HOME
    return AreaSetup(source, area, search, ranges_m, layers, Vehicle(args.vehicle), reference, approach, belief)


def _rings_lat_lon(geometry) -> tuple[list, list]:
    """Outer rings and holes of a (multi)polygon as lists of (lat, lon)."""
    parts = geometry.geoms if isinstance(geometry, MultiPolygon) else [geometry]
    outer = [[(lat, lon) for lon, lat in p.exterior.coords] for p in parts]
    holes = [[(lat, lon) for lon, lat in h.coords] for p in parts for h in p.interiors]
    return outer, holes


def area_outputs(setup: AreaSetup, plan: Plan, seed: int, speed_m_s: float, campaign: dict | None = None
                 ) -> dict[str, str]:
    """File name -> text of every output of an area plan; `campaign` is plan.json's campaign
    section (`gcs.plans.campaign`)."""
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
                           "airport_lat_lon": [ap.lat_deg, ap.lon_deg],
                           "waypoints": [[a, b] for a, b in mission.waypoints],
                           "length_m": round(flown.length_m, 3)}
    outer, holes = _rings_lat_lon(source.area)
    exclusion = holes + [ring for zone in source.no_fly for ring in _rings_lat_lon(zone)[0]]
    data = plan_to_dict(plan, seed=seed, area=area, uav_extra=extra)
    if campaign is not None:
        data["campaign"] = campaign
    files = {"plan.json": json.dumps(data, indent=1) + "\n"}
    for m in missions:
        files[f"uav{m.uav_id}.waypoints"] = wpl_text(m)
        files[f"uav{m.uav_id}.plan"] = json.dumps(qgc_plan(m, outer, exclusion, speed_m_s), indent=1) + "\n"
    lengths = {uid: p.length_m for uid, p in paths.items()}
    files["paths.geojson"] = json.dumps(paths_geojson(missions, lengths, source.name), indent=1) + "\n"
    return files


def write_outputs(out_dir: Path, files: dict[str, str]) -> None:
    """Publish all files together (names may hold sub-folders, `sortie2/plan.json`); on failure
    remove nothing old and leave no new folder behind."""
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


def area_out_dir(args: argparse.Namespace) -> Path:
    if args.out is None:
        return Path("runs") / Path(args.area).stem
    out = Path(args.out)
    if out.suffix == ".json":
        raise UserError(f"--out {args.out}: --area writes several files; give a folder")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {args.out}: exists and is not a folder")
    return out


def mission_table(setup: AreaSetup, plan: Plan, files: dict[str, str]) -> str:
    data = json.loads(files["plan.json"])
    rows = [f"{'UAV':>3}  {'name':<16} {'alt m':>6} {'layer':>5} {'range m':>8} {'path m':>8} {'waypoints':>9}"]
    for u in data["uavs"]:
        layer = u.get("altitude_layer")
        rows.append(f"{u['id']:>3}  {u['name'][:16]:<16} {u['altitude_m']:>6.0f} {layer or '-':>5} "
                    f"{u['range_m']:>8.0f} {u['length_m']:>8.0f} {len(u['waypoints']):>9}")
    layers = setup.layers
    above = "the ground below" if setup.altitude_reference is AltitudeReference.TERRAIN else "each airport"
    if layers.levels_m:
        rows.append(f"altitude layers {layers.levels_m[0]:g}-{layers.levels_m[-1]:g} m above {above} "
                    f"({len(layers.levels_m)} layers)")
    for level, uavs in sorted(layers.shared.items()):
        rows.append(f"UAVs {', '.join(map(str, uavs))} share layer {level} ({layers.levels_m[level - 1]:g} m): "
                    "the plan keeps them out of each other's cells; raise --ceiling or lower --altitude-step to part "
                    "them")
    g = setup.area.grid
    rows.append(f"grid {g.nx}x{g.ny} cells of {g.cell_size_m:g} m, {int(setup.area.free.sum())} searchable, "
                f"{setup.area.edge_blocked} blocked at edges")
    return "\n".join(rows)
