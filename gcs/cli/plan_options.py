"""Command-line options of planning, shared by `gcs plan` and `gcs fly`: each option is defined
once here, its default taken from the typed options (`gcs.plans.options`), and
`plan_options_from` is the one place a Namespace becomes them."""

from __future__ import annotations

import argparse
import math
from dataclasses import fields

from gcs.cli import BooleanOption
from gcs.missions.items import Vehicle
from gcs.plans.options import DEFAULT_CELL_SIZE_M, AreaOptions, OutputOptions, SearchOptions
from gcs.plans.plan_bound import DEFAULT_BOUND_TIME_S

VIEWER = "rerun+http://127.0.0.1:9876/proxy"

#: The names the planner knows for `--strategy`, `--return` and `--scenario`
#: (`planner.search.STRATEGIES`, `planner.dtscs.RETURN_PLANNERS`, `planner.scenario.SCENARIOS`), spelt
#: out for the help texts so that building a parser does not load the planner and numba (`gcs plan`
#: starts its picture helper before it loads them); a test checks that they agree with the planner's.
STRATEGIES = ("cpio", "exhaustive", "ga", "lawnmower", "pio", "pso")
RETURN_PLANNERS = ("exact", "st")
SCENARIOS = ("paper",)


def add_search_arguments(p: argparse._ActionsContainer) -> None:
    """How the closed search runs (`SearchOptions`)."""
    d = SearchOptions
    p.add_argument("--seed", type=int, default=d.seed, help="seed for targets, sensor draws and optimisers")
    p.add_argument("--np", dest="np_steps", type=int, default=d.np_steps, help="Np, steps of look-ahead (Definition 4)")
    p.add_argument("--oc", default=d.oc, help="orientation constraint: 3, 4, 5 or 8")
    p.add_argument("--range", dest="range_steps", type=int, default=d.range_steps,
                   help="range T_i of every UAV of a built-in scenario, in steps (an area's ranges come from its "
                        "airports, --range-m or --endurance)")
    p.add_argument("--strategy", default=d.strategy, help=f"search strategy ({', '.join(sorted(STRATEGIES))})")
    p.add_argument("--return", dest="return_planner", default=d.return_planner,
                   help=f"return planner ({', '.join(RETURN_PLANNERS)})")
    p.add_argument("--reserve", type=int, default=d.reserve, help="steps of range kept in reserve by every range check")
    p.add_argument("--range-aware-search", action="store_true", default=d.range_aware_search,
                   help="prune search moves by range (eq. 8) instead of the paper's switch (Algorithm 3)")
    p.add_argument("--horizon-value", action=BooleanOption, default=d.horizon_value,
                   help="add to J1 the value of where each Np-step path ends: the likely ground the UAV can "
                        "still reach and come back from, discounted by distance (docs/success.md); default: "
                        "on for --area plans, off for built-in scenarios (the paper's J1)")
    p.add_argument("--improve", action=BooleanOption, default=d.improve,
                   help="after DTSCS, re-solve windows of every UAV's path against the whole mission for more "
                        "expected finds (docs/planner.md); default: on for --area plans, off for built-in scenarios")
    p.add_argument("--pc", type=float, default=d.pc, help="sensor detection probability")
    p.add_argument("--pf", type=float, default=d.pf, help="sensor false-alarm rate")
    p.add_argument("--footprint", type=int, default=d.footprint,
                   help="sensor footprint radius in cells (0: the cell below)")
    p.add_argument("--camera-fov", dest="camera_fov_deg", metavar="DEG", type=float, default=d.camera_fov_deg,
                   help="with --area: a downward camera's field of view across track; its swath at the altitude "
                        "gives the footprint and Pc instead of --footprint and --pc (docs/plan.md)")
    p.add_argument("--camera-pixels", dest="camera_pixels", metavar="N", type=int, default=d.camera_pixels,
                   help="the camera's pixels across track (detection falls where a person gets under 2)")
    p.add_argument("--camera-pd", dest="camera_pd", metavar="P", type=float, default=d.camera_pd,
                   help="probability of detecting a person in the camera's image")


def add_area_arguments(p: argparse.ArgumentParser) -> None:
    """`--area` and how an area becomes a grid, ranges and missions (`AreaOptions`)."""
    d = AreaOptions
    g = p.add_argument_group("area planning (--area)")
    g.add_argument("--area", metavar="FILE", default=None,
                   help="plan over a search area file, GeoJSON, KML/KMZ, GPX, GeoPackage or Shapefile (docs/areas.md, "
                        "docs/search-team.md) instead of a built-in scenario")
    g.add_argument("--cell-size", dest="cell_size_m", metavar="METRES", type=float, default=d.cell_size_m,
                   help=f"grid cell side (default: the file's cell_size_m, else {DEFAULT_CELL_SIZE_M:g})")
    g.add_argument("--speed", dest="speed_m_s", metavar="M/S", type=float, default=d.speed_m_s, help="cruise speed")
    g.add_argument("--range-m", dest="range_m", metavar="METRES", type=float, default=d.range_m,
                   help="range of airports that give neither range_m nor endurance_s (overrides --endurance)")
    g.add_argument("--endurance", dest="endurance_s", metavar="SECONDS", type=float, default=d.endurance_s,
                   help="endurance of airports that give neither range_m nor endurance_s")
    g.add_argument("--altitude", dest="altitude_m", metavar="METRES", type=float, default=d.altitude_m,
                   help="the lowest altitude layer, above the airport (or the ground with --terrain-follow)")
    g.add_argument("--altitude-step", dest="altitude_step_m", metavar="METRES", type=float, default=d.altitude_step_m,
                   help="vertical spacing of the altitude layers: UAVs fly one layer each, between --altitude and "
                        "--ceiling (an airport's altitude_m overrides)")
    g.add_argument("--ceiling", dest="ceiling_m", metavar="METRES", type=float, default=d.ceiling_m,
                   help="highest flight altitude allowed (120 m is the legal ceiling in the EU and the US)")
    g.add_argument("--terrain-follow", action="store_true", default=d.terrain_follow,
                   help="fly the search at its altitude above the ground below (MAV_FRAME_GLOBAL_TERRAIN_ALT_INT; "
                        "the autopilot needs terrain data or a rangefinder)")
    g.add_argument("--vehicle", choices=[v.value for v in Vehicle], default=d.vehicle.value,
                   help="copter: take-off and NAV_LAND at the airport; plane: take-off along the runway (the "
                        "airport's heading) and a landing approach lined up with it")
    g.add_argument("--approach-m", dest="approach_m", metavar="METRES", type=float, default=d.approach_m,
                   help="plane: length of the final approach on the runway axis (shortened to 250 m where the "
                        "area leaves no room); twice this is kept out of the search range")
    g.add_argument("--approach-alt", dest="approach_alt_m", metavar="METRES", type=float, default=d.approach_alt_m,
                   help="plane: altitude above the airport at the start of the final approach (lower where "
                        "the glide would be steeper than 5 degrees, PX4's FW_LND_ANG)")
    g.add_argument("--margin", dest="margin_m", metavar="METRES", type=float, default=d.margin_m,
                   help="safety buffer: shrink the area and grow the no-fly zones by this much")
    g.add_argument("--default-tep", type=float, default=d.default_tep, help="target probability outside prior regions")
    g.add_argument("--default-eu", type=float, default=d.default_eu, help="uncertainty outside prior regions")
    g.add_argument("--max-cells", type=int, default=d.max_cells, help="refuse grids with more cells than this")
    g.add_argument("--vehicles", metavar="FILE", default=d.vehicles,
                   help="vehicle energy profiles (the vehicles.json gcs fly writes): each UAV's range is what its "
                        "vehicle's battery pays for, the reserve kept back; gcs fly prices its flight with them "
                        "(default: the file its plan was made with; docs/energy.md)")
    g.add_argument("--reserve-pct", type=float, default=d.reserve_pct,
                   help="battery kept back: by the ranges planned from --vehicles, and by gcs fly's return trigger")


def add_output_arguments(p: argparse.ArgumentParser, recorded: str, default_file: str) -> None:
    """`--quiet` and where the Rerun recording of what is `recorded` goes (`OutputOptions`)."""
    p.add_argument("--quiet", action="store_true", help="print nothing but errors while planning")
    p.add_argument("--rrd", metavar="PATH", default=OutputOptions.rrd,
                   help=f"Rerun recording of {recorded} (default: {default_file})")
    p.add_argument("--no-rrd", action="store_true", help="write no Rerun recording")
    p.add_argument("--rerun-connect", nargs="?", const=VIEWER, default=OutputOptions.rerun_connect, metavar="ADDR",
                   help=f"also stream {recorded} to a running Rerun viewer (ADDR default: %(const)s)")


def add_bound_argument(p: argparse.ArgumentParser | argparse._ArgumentGroup) -> None:
    """`--bound-time`: how long the upper bound on expected finds may take (`OutputOptions.bound_time_s`)."""
    p.add_argument("--bound-time", dest="bound_time", metavar="SECONDS", type=_seconds, default=DEFAULT_BOUND_TIME_S,
                   help="seconds for the upper bound on expected finds that the summary and plan.json compare the "
                        "plan with (docs/success.md); 0: no bound")


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be 0 or more seconds, got {text}")
    return value


def add_planning_arguments(p: argparse.ArgumentParser) -> None:
    """Every option that says how to plan: the search's and the area's."""
    add_search_arguments(p)
    add_area_arguments(p)


def plan_options_from(args: argparse.Namespace) -> tuple[AreaOptions, SearchOptions]:
    """The typed planning options of parsed arguments (`add_planning_arguments`)."""
    def values(cls: type) -> dict:
        return {f.name: getattr(args, f.name) for f in fields(cls)}

    return AreaOptions(**values(AreaOptions)), SearchOptions(**values(SearchOptions))


def output_options_from(args: argparse.Namespace) -> OutputOptions:
    """What planning shows and records, from `add_output_arguments`'s options."""
    return OutputOptions(rrd=args.rrd, record=not args.no_rrd, rerun_connect=args.rerun_connect,
                         progress=not args.quiet, bound_time_s=getattr(args, "bound_time", DEFAULT_BOUND_TIME_S))
