"""SAREnv (Grøntved et al., Drones 2025): its scenarios, its five baselines and gcs, all scored by
SAREnv's own evaluator (`sarenv.analytics.metrics.PathEvaluator`).

    tools/setup --test                                                     # .venv-bench: the bench extra
    .venv-bench/bin/python benchmarks/sarenv_bench.py                      # the eight shipped scenarios
    .venv-bench/bin/python benchmarks/sarenv_bench.py --ids 1 --drones 2 --budget 8000 --size small
    B=".venv-bench/bin/python benchmarks/sarenv_bench.py --cell-m 66.3 --footprint 0 --np 5 --strategy cpio"
    $B                                                                     # gcs as the bench planned it before
    $B --no-improve                                                        # and as before issue 37

Per scenario (`--datasets DIR/ID/heatmap.npy`, the centre of the id from `--source`'s
`data/export_all_data.py`), as SAREnv's README and `DatasetLoader.load_environment` place it: the
master heatmap (30 m bins, row 0 south) centred on the id's point in its UTM zone, cropped to the
box of the size's circle (Koester's hiker radius: medium 1.8 km on flat temperate ground) with the
bins outside the circle zeroed, not renormalised. The baselines (Greedy, Spiral, Concentric,
Pizza, RandomWalk) run with the published runs' parameters; their unseeded generator
(`np.random.default_rng()`: RandomWalk's steps, Greedy's ties) is seeded with `--seed`.

gcs plans the same scenario through the product: an area file (the circle, one airport per UAV
at the IPP, the heatmap as its raster prior) planned as `gcs plan --area` plans it, each UAV's
range its share of the budget, the camera of SAREnv's setting (45 deg FOV at 80 m: a 66.3 m
swath). By default gcs plans as a crew would with `gcs plan --area FILE --cell-size 22.1 --footprint 1
--pc 0.95 --pf 0.01 --np 7 --strategy exhaustive`: cells a third of the swath, the footprint's 3 x 3
cells the swath, so a step is credited with the ground its metres see (an axis step of 22 m 3 new
cells, a diagonal of 31 m 5), and a look-ahead of 7 steps (155 m) searched exhaustively; the
options are printed under the table. `--cell-m 66.3 --footprint 0 --np 5 --strategy cpio` plans as
the bench did before (cells of the swath's width, one look per cell flown). Its closed paths (IPP ->
mission -> IPP, from the plan's `paths.geojson`) are projected to the UTM zone and scored like the
baselines.

Victims: `--victims` points drawn from the cropped heatmap with `--seed` (SAREnv draws them from
its features files, which are not shipped), the same for every planner.

SAREnv is not on PyPI and its package `__init__` imports its map generator (osmnx, rasterio, ...):
its `analytics/metrics.py` and `analytics/paths.py` are loaded by path from `--source` (they need
numpy, scipy, shapely and geopandas: the `bench` extra)."""

from __future__ import annotations

import argparse
import ast
import contextlib
import csv
import importlib.util
import json
import math
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np
import pyproj
from shapely.geometry import LineString, Point

ROOT = Path(__file__).resolve().parents[1]
PEERS = ROOT.parent / "shared" / "peers" / "sarenv"
DEFAULT_SOURCE = PEERS / "source"
DEFAULT_DATASETS = PEERS / "datasets"
SHIPPED_IDS = (1, 3, 4, 6, 7, 9, 12, 14)
BASELINES = ("Greedy", "Spiral", "Concentric", "Pizza", "RandomWalk")
RANDOM_BASELINES = ("Greedy", "RandomWalk")
SIZES = ("small", "medium", "large", "xlarge")
METRES_PER_BIN = 30
FOV_DEG = 45.0
ALTITUDE_M = 80.0
DISCOUNT = 0.999
SWATH_M = 2 * ALTITUDE_M * math.tan(math.radians(FOV_DEG / 2))  # 66.3 m on the ground
CELL_M = 22.1  # a third of the swath (22.10 m), as a crew would write it: the footprint's 3 x 3 cells are the swath
GCS_FOOTPRINT = 1
GCS_NP = 7
GCS_STRATEGY = "exhaustive"
GCS_PC = 0.95  # SAREnv's evaluator counts every bin within the swath as seen
GCS_PF = 0.01


class BenchError(Exception):
    """Bad input: one line, no traceback."""


@dataclass(frozen=True)
class Sarenv:
    """SAREnv's evaluator and baseline generators, loaded from its source tree."""

    metrics: ModuleType
    paths: ModuleType
    centres: dict[int, tuple[float, float, str, str]]  # id -> lon, lat, climate, environment type
    radii_km: dict[tuple[str, str], list[float]]  # (type, climate) -> small, medium, large, xlarge
    published: dict[tuple[int, str, str, int, int], tuple[float, float]]  # (id, algo, size, n, budget) -> scores


@dataclass(frozen=True)
class Scenario:
    """One SAREnv scenario at one size, in its UTM zone's metres."""

    ident: int
    size: str
    lon_deg: float
    lat_deg: float
    crs: str
    centre_xy: tuple[float, float]
    radius_m: float
    heatmap: np.ndarray  # [row, col], row 0 south
    bounds: tuple[float, float, float, float]


@dataclass(frozen=True)
class Score:
    """One planner's paths on one scenario, as SAREnv's evaluator scores them."""

    algorithm: str
    likelihood: float
    discounted: float
    victims_pct: float
    length_km: float
    longest_km: float
    published: tuple[float, float] | None = None
    seconds: float = 0.0
    spread: tuple[float, float] | None = None  # least and greatest likelihood over repeated runs


def _load_module(path: Path, name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise BenchError(f"{path}: not a Python module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _names_as_strings(node: ast.expr, constants: dict[str, str]) -> object:
    class Names(ast.NodeTransformer):
        def visit_Name(self, n: ast.Name) -> ast.AST:
            return ast.Constant(constants.get(n.id, n.id))

    return ast.literal_eval(ast.fix_missing_locations(Names().visit(node)))


def load_sarenv(source: Path) -> Sarenv:
    """SAREnv's evaluator, baselines, dataset centres, radii and published scores from `source`."""
    needed = [source / "sarenv/analytics/metrics.py", source / "sarenv/analytics/paths.py",
              source / "sarenv/utils/lost_person_behavior.py", source / "data/export_all_data.py"]
    missing = [str(p) for p in needed if not p.is_file()]
    if missing:
        raise BenchError(f"--source {source}: not SAREnv's source tree (missing {', '.join(missing)})")
    try:
        metrics = _load_module(needed[0], "sarenv_metrics")
    except ImportError as exc:
        raise BenchError(f"SAREnv's evaluator needs {exc.name}: pip install -e '.[bench]'") from None
    paths = _load_module(needed[1], "sarenv_paths")
    behaviour = _load_module(needed[2], "sarenv_lost_person_behavior")
    constants = {k: v for k, v in vars(behaviour).items() if k.startswith(("CLIMATE_", "ENVIRONMENT_TYPE_"))}
    points = _names_as_strings(next(
        n.value for n in ast.parse(needed[3].read_text()).body
        if isinstance(n, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "points" for t in n.targets)),
        constants)
    centres = {int(p[0]): (float(p[1]), float(p[2]), str(p[3]), str(p[4])) for p in points}  # type: ignore[union-attr]
    radii = {(t, c): behaviour.get_environment_radius(t, c) for t in ("flat", "mountainous")
             for c in ("temperate", "dry")}
    published: dict[tuple[int, str, str, int, int], tuple[float, float]] = {}
    for table in sorted((source / "results").glob("comparative_metrics_results_*.csv")):
        with table.open(newline="", encoding="utf-8") as f:
            for row in csv.DictReader(f):
                key = (int(row["Dataset"]), row["Algorithm"], row["Environment Size"], int(row["n_agents"]),
                       int(float(row["Budget (m)"])))
                published[key] = (float(row["Likelihood Score"]), float(row["Time-Discounted Score"]))
    return Sarenv(metrics, paths, centres, radii, published)


def utm_crs(lon_deg: float, lat_deg: float) -> str:
    """SAREnv's projected CRS: the UTM zone of the point (`sarenv.utils.geo.get_utm_epsg`)."""
    zone = int((lon_deg + 180) / 6) + 1
    return f"EPSG:{326 if lat_deg >= 0 else 327}{zone}"


def load_scenario(sarenv: Sarenv, datasets: Path, ident: int, size: str) -> Scenario:
    """Scenario `ident` at `size`, placed and cropped as SAREnv's `DatasetLoader.load_environment` does."""
    if ident not in sarenv.centres:
        raise BenchError(f"dataset id {ident} has no centre in the SAREnv source (ids {min(sarenv.centres)}-"
                         f"{max(sarenv.centres)})")
    heatmap_file = datasets / str(ident) / "heatmap.npy"
    if not heatmap_file.is_file():
        raise BenchError(f"{heatmap_file}: no such heatmap")
    master = np.load(heatmap_file)
    if master.ndim != 2 or not np.isfinite(master).all() or master.min() < 0:
        raise BenchError(f"{heatmap_file}: not a 2-D heatmap of finite non-negative values")
    lon, lat, climate, kind = sarenv.centres[ident]
    crs = utm_crs(lon, lat)
    cx, cy = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    h, w = master.shape
    master_minx, master_miny = cx - w * METRES_PER_BIN / 2, cy - h * METRES_PER_BIN / 2
    radius_m = sarenv.radii_km[(kind, climate)][SIZES.index(size)] * 1000
    circle = Point(cx, cy).buffer(radius_m)  # geopandas' buffer: shapely's, 16 segments a quarter
    minx, miny, maxx, maxy = circle.bounds
    x0, x1 = np.clip([int((minx - master_minx) / METRES_PER_BIN), int((maxx - master_minx) / METRES_PER_BIN)], 0, w)
    y0, y1 = np.clip([int((miny - master_miny) / METRES_PER_BIN), int((maxy - master_miny) / METRES_PER_BIN)], 0, h)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    px, py, pr = (cx - master_minx) / METRES_PER_BIN, (cy - master_miny) / METRES_PER_BIN, radius_m / METRES_PER_BIN
    heatmap = np.where((xx - px) ** 2 + (yy - py) ** 2 <= pr**2, master[y0:y1, x0:x1], 0.0)
    return Scenario(ident, size, lon, lat, crs, (cx, cy), radius_m, heatmap, (minx, miny, maxx, maxy))


def draw_victims(scenario: Scenario, count: int, seed: int) -> np.ndarray:
    """`count` points (x, y) drawn from the heatmap: a bin by its mass, a point uniform in it."""
    rng = np.random.default_rng(seed)
    h, w = scenario.heatmap.shape
    flat = scenario.heatmap.ravel() / scenario.heatmap.sum()
    cells = rng.choice(flat.size, size=count, p=flat)
    rows, cols = np.divmod(cells, w)
    minx, miny, maxx, maxy = scenario.bounds
    return np.column_stack([minx + (cols + rng.random(count)) * (maxx - minx) / w,
                            miny + (rows + rng.random(count)) * (maxy - miny) / h])


@contextlib.contextmanager
def seeded_default_rng(seed: int) -> Iterator[None]:
    """numpy's `default_rng()` without a seed returns a generator seeded with `seed` (SAREnv's
    baselines draw from an unseeded one)."""
    original = np.random.default_rng

    def default_rng(s: object = None) -> np.random.Generator:
        return original(seed if s is None else s)  # type: ignore[arg-type]

    np.random.default_rng = default_rng  # type: ignore[assignment]
    try:
        yield
    finally:
        np.random.default_rng = original  # type: ignore[assignment]


def baseline_paths(sarenv: Sarenv, scenario: Scenario, name: str, drones: int, budget_m: float,
                   seed: int) -> list[LineString]:
    """The paths of SAREnv baseline `name`, called as its published runs called it
    (`PathGeneratorConfig` defaults: overlap 0, 10 m point spacing, 50 m transition, 15 m border gap)."""
    functions = {"Greedy": "generate_greedy_path", "Spiral": "generate_spiral_path",
                 "Concentric": "generate_concentric_circles_path", "Pizza": "generate_pizza_zigzag_path",
                 "RandomWalk": "generate_random_walk_path"}
    params = dict(center_x=scenario.centre_xy[0], center_y=scenario.centre_xy[1], max_radius=scenario.radius_m,
                  probability_map=scenario.heatmap, bounds=scenario.bounds, num_drones=drones, budget=budget_m,
                  fov_deg=FOV_DEG, altitude=ALTITUDE_M, overlap=0, path_point_spacing_m=10.0,
                  transition_distance_m=50.0, border_gap_m=15.0)
    with seeded_default_rng(seed):
        return list(getattr(sarenv.paths, functions[name])(**params))


def score(sarenv: Sarenv, scenario: Scenario, victims_xy: np.ndarray, name: str, paths: list[LineString],
          published: tuple[float, float] | None = None, seconds: float = 0.0) -> Score:
    """`paths` scored by SAREnv's `PathEvaluator` as its published runs scored theirs."""
    import geopandas as gpd

    victims = gpd.GeoDataFrame(geometry=gpd.points_from_xy(victims_xy[:, 0], victims_xy[:, 1]), crs=scenario.crs)
    evaluator = sarenv.metrics.PathEvaluator(scenario.heatmap, scenario.bounds, victims, FOV_DEG, ALTITUDE_M,
                                             METRES_PER_BIN)
    m = evaluator.calculate_all_metrics(paths, DISCOUNT)
    longest = max((p.length for p in paths), default=0.0) / 1000
    return Score(name, float(m["total_likelihood_score"]), float(m["total_time_discounted_score"]),
                 float(m["victim_detection_metrics"]["percentage_found"]), float(m["total_path_length"]), longest,
                 published, seconds)


def area_file_for(scenario: Scenario, drones: int, budget_m: float, folder: Path, cell_m: float = CELL_M) -> Path:
    """The scenario as a gcs area file in `folder`: the size's circle, the cropped heatmap as its
    raster prior (`heatmap.npy`, placed by its UTM bounds, row 0 south) and one airport per UAV
    at the IPP (each flies from its own cell nearest the point, to and from it on its range),
    headings spread around, each with its share of the budget."""
    to_lonlat = pyproj.Transformer.from_crs(scenario.crs, "EPSG:4326", always_xy=True)
    cx, cy = scenario.centre_xy
    ring = np.asarray(Point(cx, cy).buffer(scenario.radius_m, quad_segs=32).exterior.coords)
    lon, lat = to_lonlat.transform(ring[:, 0], ring[:, 1])
    ipp = list(to_lonlat.transform(cx, cy))
    np.save(folder / "heatmap.npy", scenario.heatmap)
    features = [
        {"type": "Feature", "properties": {"role": "area", "name": f"SAREnv {scenario.ident} {scenario.size}"},
         "geometry": {"type": "Polygon", "coordinates": [[[float(a), float(b)] for a, b in zip(lon, lat)]]}},
        {"type": "Feature", "properties": {"role": "raster_prior", "name": "SAREnv heatmap", "path": "heatmap.npy",
                                           "crs": scenario.crs, "bounds": list(scenario.bounds), "row0": "south"},
         "geometry": None}]
    for i in range(drones):
        features.append({"type": "Feature", "properties": {
            "role": "airport", "name": f"IPP {i + 1}", "heading": round(360 * i / drones) % 360,
            "range_m": budget_m / drones, "altitude_m": ALTITUDE_M},
            "geometry": {"type": "Point", "coordinates": ipp}})
    path = folder / f"sarenv-{scenario.ident}-{scenario.size}.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "properties": {"cell_size_m": cell_m},
                                "features": features}))
    return path


@dataclass(frozen=True)
class GcsSettings:
    """How gcs plans a SAREnv scenario: its cell size, sensor (Pc, Pf, footprint radius in cells)
    and search (strategy, Np); `improve` False plans as gcs did before issue 37's whole-mission
    improvement (`gcs plan --no-improve`: DTSCS's plan as flown), None as `gcs plan --area` does by
    default (improved)."""

    cell_m: float = CELL_M
    pc: float = GCS_PC
    pf: float = GCS_PF
    footprint: int = GCS_FOOTPRINT
    strategy: str = GCS_STRATEGY
    np_steps: int = GCS_NP
    improve: bool | None = None

    def command_line(self) -> str:
        """The `gcs plan` options a crew would pass for the same plan."""
        improve = " --no-improve" if self.improve is False else ""
        return (f"gcs plan --area FILE --cell-size {self.cell_m:g} --footprint {self.footprint} --pc {self.pc:g} "
                f"--pf {self.pf:g} --np {self.np_steps} --strategy {self.strategy}{improve}")


def plan_gcs(scenario: Scenario, drones: int, budget_m: float, seed: int, out_dir: Path,
             settings: GcsSettings = GcsSettings()) -> list[LineString]:
    """gcs's closed paths (IPP -> mission -> IPP) in the scenario's UTM metres."""
    from gcs.plans.make import fly_with_progress
    from gcs.plans.options import AreaOptions, SearchOptions
    from gcs.plans.planning import area_outputs, build_area_search

    area_path = area_file_for(scenario, drones, budget_m, out_dir, settings.cell_m)
    options = AreaOptions(altitude_m=ALTITUDE_M, speed_m_s=12.0)
    search = SearchOptions(seed=seed, pc=settings.pc, pf=settings.pf, footprint=settings.footprint,
                           strategy=settings.strategy, np_steps=settings.np_steps, improve=settings.improve)
    setup = build_area_search(area_path, options, search)
    plan = fly_with_progress(setup.search, progress=False)
    files = area_outputs(setup, plan, seed, options.speed_m_s)
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", scenario.crs, always_xy=True)
    paths = []
    for feature in json.loads(files["paths.geojson"])["features"]:
        coords = np.asarray(feature["geometry"]["coordinates"])
        x, y = to_utm.transform(coords[:, 0], coords[:, 1])
        paths.append(LineString(zip(x.tolist(), y.tolist())))
    (out_dir / "plan.json").write_text(files["plan.json"])
    if len(paths) != drones:
        raise BenchError(f"scenario {scenario.ident}: gcs flew {len(paths)} of {drones} UAVs")
    return paths


def run_scenario(sarenv: Sarenv, scenario: Scenario, drones: int, budget_m: float, seed: int, victims: int,
                 baselines: tuple[str, ...] = BASELINES, settings: GcsSettings = GcsSettings(),
                 repeats: int = 1) -> list[Score]:
    """Every baseline and gcs on one scenario, scored by SAREnv's evaluator; a baseline that draws
    random numbers (`RANDOM_BASELINES`) runs `repeats` times (seeds seed, seed + 1, ...) and scores
    their mean, its likelihood's least and greatest kept in `spread`."""
    victims_xy = draw_victims(scenario, victims, seed)
    scores = []
    for name in baselines:
        runs = []
        for k in range(repeats if name in RANDOM_BASELINES else 1):
            t0 = time.process_time()
            paths = baseline_paths(sarenv, scenario, name, drones, budget_m, seed + k)
            runs.append(score(sarenv, scenario, victims_xy, name, paths, seconds=time.process_time() - t0))
        published = sarenv.published.get((scenario.ident, name, scenario.size, drones, int(budget_m)))
        likelihoods = [r.likelihood for r in runs]
        scores.append(Score(name, float(np.mean(likelihoods)), float(np.mean([r.discounted for r in runs])),
                            float(np.mean([r.victims_pct for r in runs])), float(np.mean([r.length_km for r in runs])),
                            max(r.longest_km for r in runs), published, float(np.mean([r.seconds for r in runs])),
                            (min(likelihoods), max(likelihoods)) if len(runs) > 1 else None))
    t0 = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        paths = plan_gcs(scenario, drones, budget_m, seed, Path(tmp), settings)
    scores.append(score(sarenv, scenario, victims_xy, "gcs", paths, None, time.process_time() - t0))
    return scores


def likelihood_bound(scenario: Scenario, drones: int, budget_m: float) -> float:
    """No paths of `budget_m` metres in all score a higher likelihood under SAREnv's evaluator:
    the mass of the richest bins as many as they can see. A bin is seen when its centre lies within
    the detection radius (33.1 m) of the path; a straight path along a row of bin centres sees 3
    bins each 30 m, the most of any direction (a strip 66.3 m wide holds at most 3 rows of
    centres 30 m apart, 4 rows 21.2 m apart along a diagonal: 4 / 42.4 m), so at most 0.1 bins a
    metre, and each path's first point sees at most 5 (radius / 30 m < 1.11)."""
    radius = ALTITUDE_M * math.tan(math.radians(FOV_DEG / 2))
    reach = math.floor(radius / METRES_PER_BIN)
    first = sum(1 for i in range(-reach, reach + 1) for j in range(-reach, reach + 1)
                if math.hypot(i, j) * METRES_PER_BIN <= radius)
    bins = math.ceil(budget_m * 3 / METRES_PER_BIN) + drones * first
    return float(np.sort(scenario.heatmap.ravel())[::-1][:bins].sum())


def camera_bound(scenario: Scenario, budget_m: float) -> float:
    """The most probability the camera can image with `budget_m` metres of path: its swath (66.3 m)
    times the budget is at most that much ground, and no ground holds more than the richest bins
    of its area (each bin's mass spread over its 30 m x 30 m; the last bin in part). Paths that
    score more under the evaluator are credited with bins whose centres are within 33.1 m but
    whose ground the camera did not image (a pass along a row of centres counts three rows, 90 m)."""
    swath = 2 * ALTITUDE_M * math.tan(math.radians(FOV_DEG / 2))
    bins = budget_m * swath / METRES_PER_BIN ** 2
    richest = np.sort(scenario.heatmap.ravel())[::-1]
    whole = min(int(bins), richest.size)
    return float(richest[:whole].sum() + (richest[whole] * (bins - whole) if whole < richest.size else 0.0))


@dataclass(frozen=True)
class Ratios:
    """gcs over the best baseline per scenario: likelihood and time-discounted score."""

    likelihood: list[float]
    discounted: list[float]

    def line(self) -> str:
        def fmt(r: list[float]) -> str:
            return f"mean {np.mean(r):.2f}x, min {np.min(r):.2f}x"

        return f"gcs vs the best baseline: likelihood {fmt(self.likelihood)}; time-discounted {fmt(self.discounted)}"


def ratios(results: dict[int, list[Score]]) -> Ratios:
    like, disc = [], []
    for scores in results.values():
        gcs = next(s for s in scores if s.algorithm == "gcs")
        base = [s for s in scores if s.algorithm != "gcs"]
        like.append(gcs.likelihood / max(s.likelihood for s in base))
        disc.append(gcs.discounted / max(s.discounted for s in base))
    return Ratios(like, disc)


def table(results: dict[int, list[Score]], bounds: dict[int, tuple[float, float]], drones: int, budget_m: float,
          settings: GcsSettings = GcsSettings()) -> str:
    head = (f"{'id':>3} {'planner':<11} {'likelihood':>10} {'published':>9} {'diff':>6} {'discounted':>10} "
            f"{'published':>9} {'victims %':>9} {'km':>6} {'longest km':>10} {'CPU s':>6}")
    lines = [head]
    for ident, scores in results.items():
        for s in scores:
            pub_l = pub_d = diff = ""
            if s.published is not None:
                pub_l, pub_d = f"{s.published[0]:.4f}", f"{s.published[1]:.5f}"
                diff = f"{100 * (s.likelihood / s.published[0] - 1):+.1f}%"
            spread = "" if s.spread is None else f"  ({s.spread[0]:.4f}-{s.spread[1]:.4f})"
            lines.append(f"{ident:>3} {s.algorithm:<11} {s.likelihood:>10.4f} {pub_l:>9} {diff:>6} "
                         f"{s.discounted:>10.5f} {pub_d:>9} {s.victims_pct:>9.0f} {s.length_km:>6.1f} "
                         f"{s.longest_km:>10.2f} {s.seconds:>6.1f}{spread}")
        if ident in bounds:
            lines.append(f"{ident:>3} {'bound':<11} {bounds[ident][0]:>10.4f}")
            lines.append(f"{ident:>3} {'seen':<11} {bounds[ident][1]:>10.4f}")
    planner = "DTSCS alone, --no-improve" if settings.improve is False else "DTSCS and the improvement, the default"
    lines.append(f"({drones} UAVs, {budget_m:g} m in all, {budget_m / drones:g} m each; gcs: {planner}, "
                 f"{settings.command_line()}; "
                 "published: SAREnv's "
                 "results/*.csv where it has the same runs; Greedy and RandomWalk: the mean of --repeats seeds, "
                 "their least and greatest likelihood in brackets; bound: the most any paths of the budget can "
                 "score, likelihood_bound; seen: the most probability the camera can image with the budget, "
                 "camera_bound)")
    return "\n".join(lines)


def parse_ids(text: str) -> tuple[int, ...]:
    try:
        ids = tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError:
        raise BenchError(f"--ids must be comma-separated dataset ids, got {text!r}") from None
    if not ids:
        raise BenchError("--ids names no dataset")
    return ids


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--datasets", type=Path, default=DEFAULT_DATASETS, help="folder of ID/heatmap.npy")
    parser.add_argument("--source", type=Path, default=DEFAULT_SOURCE, help="SAREnv's source tree")
    parser.add_argument("--ids", default=",".join(map(str, SHIPPED_IDS)), help="dataset ids, comma-separated")
    parser.add_argument("--drones", type=int, default=5)
    parser.add_argument("--budget", type=float, default=100_000, help="metres in all, shared by the UAVs")
    parser.add_argument("--size", choices=SIZES, default="medium")
    parser.add_argument("--victims", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--baselines", default=",".join(BASELINES), help="SAREnv baselines to run, comma-separated")
    parser.add_argument("--repeats", type=int, default=5, help="runs (seeds) of the baselines that draw random numbers")
    parser.add_argument("--no-improve", dest="improve", action="store_false", default=None,
                        help="gcs without the whole-mission improvement (gcs plan --no-improve): as before issue 37")
    parser.add_argument("--cell-m", type=float, default=CELL_M,
                        help=f"gcs's cell side in metres (gcs plan --cell-size; {CELL_M:g}: a third of the swath)")
    parser.add_argument("--footprint", type=int, default=GCS_FOOTPRINT,
                        help="gcs's sensor footprint radius in cells (gcs plan --footprint)")
    parser.add_argument("--np", dest="np_steps", type=int, default=GCS_NP, help="gcs's Np (gcs plan --np)")
    parser.add_argument("--strategy", default=GCS_STRATEGY, help="gcs's search strategy (gcs plan --strategy)")
    args = parser.parse_args(argv)
    try:
        ids = parse_ids(args.ids)
        if args.drones < 1 or not (args.budget > 0) or args.victims < 1 or args.repeats < 1:
            raise BenchError("--drones, --budget, --victims and --repeats must be positive")
        if not (args.cell_m > 0) or args.footprint < 0 or args.np_steps < 1:
            raise BenchError("--cell-m and --np must be positive, --footprint not negative")
        from planner.search import STRATEGIES
        if args.strategy not in STRATEGIES:
            raise BenchError(f"--strategy: unknown {args.strategy} (of {', '.join(sorted(STRATEGIES))})")
        chosen = tuple(b for b in args.baselines.split(",") if b)
        unknown = sorted(set(chosen) - set(BASELINES))
        if unknown or not chosen:
            raise BenchError(f"--baselines: unknown {', '.join(unknown) or 'none given'} (of {', '.join(BASELINES)})")
        sarenv = load_sarenv(args.source)
        scenarios = [load_scenario(sarenv, args.datasets, ident, args.size) for ident in ids]
        settings = GcsSettings(args.cell_m, footprint=args.footprint, strategy=args.strategy, np_steps=args.np_steps,
                               improve=args.improve)
        results, bounds = {}, {}
        for scenario in scenarios:
            results[scenario.ident] = run_scenario(sarenv, scenario, args.drones, args.budget, args.seed, args.victims,
                                                   chosen, settings, repeats=args.repeats)
            bounds[scenario.ident] = (likelihood_bound(scenario, args.drones, args.budget),
                                      camera_bound(scenario, args.budget))
            rows = table({scenario.ident: results[scenario.ident]}, bounds, args.drones, args.budget, settings)
            print("\n".join(rows.splitlines()[1:-1]), file=sys.stderr, flush=True)
    except BenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(table(results, bounds, args.drones, args.budget, settings))
    seen = [bounds[i][1] / max(s.likelihood for s in scores if s.algorithm != "gcs") for i, scores in results.items()]
    print(f"the most the camera can image vs the best baseline: mean {np.mean(seen):.2f}x, min {np.min(seen):.2f}x")
    print(ratios(results).line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
