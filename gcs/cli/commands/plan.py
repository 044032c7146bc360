"""`gcs plan`: run the closed search (DTSCS) and write the plan.

With `--area area.geojson` the search runs over a real area (docs/areas.md): the output folder
gets plan.json, uav<id>.waypoints (QGC WPL 110), uav<id>.plan (QGroundControl) and paths.geojson."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from gcs.atomic import write_json_atomic
from gcs.background import Background
from gcs.display.overview import draw_overview, warm_up as warm_up_picture
from gcs.errors import UserError
from gcs.plans import planning as area_plan
from gcs.plans.plan_file import plan_to_dict
from gcs.recording.background import BackgroundPlanRecorder
from planner.dtscs import RETURN_PLANNERS, ClosedSearch, MissionConfig, StepRecord
from planner.environment import Sensor
from planner.horizon import HorizonValue
from planner.motion import constraint_by_name
from planner.plan import Plan
from planner.scenario import SCENARIOS, Scenario
from planner.search import STRATEGIES

if TYPE_CHECKING:
    from gcs.plans.campaign import DrawPictures
    from gcs.recording.plan import PlanRecorder


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plan", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("--scenario", default="paper", help=f"built-in scenario ({', '.join(SCENARIOS)})")
    p.add_argument("--seed", type=int, default=0, help="seed for targets, sensor draws and optimisers")
    p.add_argument("--np", dest="np_steps", type=int, default=5, help="Np, steps of look-ahead (Definition 4)")
    p.add_argument("--oc", default="3", help="orientation constraint: 3, 4, 5 or 8")
    p.add_argument("--range", dest="range_steps", type=int, default=130, help="range T_i of every UAV, in steps")
    p.add_argument("--strategy", default="cpio", help=f"search strategy ({', '.join(sorted(STRATEGIES))})")
    p.add_argument("--return", dest="return_planner", default="exact",
                   help=f"return planner ({', '.join(RETURN_PLANNERS)})")
    p.add_argument("--reserve", type=int, default=0, help="steps of range kept in reserve by every range check")
    p.add_argument("--range-aware-search", action="store_true",
                   help="prune search moves by range (eq. 8) instead of the paper's switch (Algorithm 3)")
    p.add_argument("--horizon-value", action=argparse.BooleanOptionalAction, default=None,
                   help="add to J1 the value of where each Np-step path ends: the likely ground the UAV can "
                        "still reach and come back from, discounted by distance (docs/success.md); default: "
                        "on for --area plans, off for built-in scenarios (the paper's J1)")
    p.add_argument("--pc", type=float, default=0.9, help="sensor detection probability")
    p.add_argument("--pf", type=float, default=0.1, help="sensor false-alarm rate")
    p.add_argument("--footprint", type=int, default=0, help="sensor footprint radius in cells (0: the cell below)")
    p.add_argument("--out", default=None,
                   help="plan JSON file, or a folder to hold plan.json (default runs/plan.json; with --area a "
                        "folder, default runs/<area file name>)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.add_argument("--rrd", metavar="PATH", help="Rerun recording of the run (default: next to the plan, plan.rrd)")
    p.add_argument("--no-rrd", action="store_true", help="write no Rerun recording")
    p.add_argument("--rerun-connect", nargs="?", const="rerun+http://127.0.0.1:9876/proxy", metavar="ADDR",
                   help="also stream the run to a running Rerun viewer (ADDR default: %(const)s)")
    area_plan.add_arguments(p)
    g = p.add_argument_group("campaigns of sorties (docs/campaigns.md)")
    g.add_argument("--continue", dest="continue_from", metavar="FOLDER", default=None,
                   help="plan the next sortie from the posterior a finished gcs fly left in FOLDER, with fresh "
                        "batteries and FOLDER's area and options (default --out: FOLDER-sortie<N+1>)")
    g.add_argument("--sorties", type=int, metavar="N", default=None,
                   help="plan N closed sorties in a row, each from the belief the one before is predicted to leave "
                        "(its looks reporting nothing), into --out/sortie<k>/ with campaign.json")
    p.set_defaults(func=run)


def plan_path(out: str) -> Path:
    path = Path(out)
    return path if path.suffix == ".json" else path / "plan.json"


def build_search(args: argparse.Namespace) -> ClosedSearch:
    """Scenario, configuration and search from the arguments; bad values raise UserError."""
    if args.scenario not in SCENARIOS:
        raise UserError(f"unknown scenario {args.scenario!r} (choose from {', '.join(SCENARIOS)})")
    try:
        sensor = Sensor(args.pc, args.pf, args.footprint)
        config = MissionConfig(np_steps=args.np_steps, oc=constraint_by_name(args.oc), strategy=args.strategy,
                               return_planner=args.return_planner, reserve_steps=args.reserve,
                               range_aware_search=args.range_aware_search,
                               horizon=HorizonValue() if args.horizon_value else None)
        if args.range_steps < 1:
            raise ValueError(f"range must be at least 1 step, got {args.range_steps}")
        scenario: Scenario = SCENARIOS[args.scenario](seed=args.seed, range_steps=args.range_steps, sensor=sensor)
        return ClosedSearch(scenario, config, seed=args.seed)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def fly_with_progress(search: ClosedSearch, quiet: bool, on_step: Callable[[StepRecord], None] | None = None) -> Plan:
    horizon = max(u.range_steps for u in search.uavs.values())
    with tqdm(total=horizon, unit="step", desc="planning", disable=quiet or None, leave=False,
              file=sys.stderr) as bar:
        for record in search.run():
            if on_step is not None:
                on_step(record)
            bar.update(1)
            bar.set_postfix(found=sum(s is not None for s in search.found_step))
    return search.plan()


def recording_path(args: argparse.Namespace, default: Path) -> Path | None:
    """Where the Rerun recording goes: `--rrd`, else `default`; None with `--no-rrd`."""
    if args.no_rrd:
        return None
    rrd = Path(args.rrd) if args.rrd else default
    if rrd.suffix != ".rrd":
        raise UserError(f"--rrd must name a .rrd file, got {rrd}")
    return rrd


def fly_and_record(search: ClosedSearch, args: argparse.Namespace, rrd: Path | None, name: str,
                   cells_to_lat_lon: Callable | None = None, helper: Background | None = None) -> Plan:
    """Fly the search with a progress bar, recording every step to Rerun unless disabled: by
    `helper` when it records to a file only, here when it also streams to a viewer."""
    if rrd is None and args.rerun_connect is None:
        return fly_with_progress(search, args.quiet)
    recorder: PlanRecorder | BackgroundPlanRecorder
    if helper is not None and args.rerun_connect is None:
        recorder = BackgroundPlanRecorder(helper, rrd, search.scenario, cells_to_lat_lon=cells_to_lat_lon, name=name)
    else:
        from gcs.recording.plan import PlanRecorder  # rerun takes ~0.45 s to import: only when recording

        recorder = PlanRecorder(rrd, args.rerun_connect, search.scenario, cells_to_lat_lon=cells_to_lat_lon, name=name)
    with recorder as rec:
        plan = fly_with_progress(search, args.quiet, rec.log_step)
        rec.log_plan(plan)
    return plan


def summary_table(plan: Plan) -> str:
    """Per UAV its legs, range use and probability of success (expected targets found, and that
    as a share of what the prior puts in the area); then the totals, and the simulated finds."""
    found_by: dict[int, int] = {}
    for t in plan.targets:
        if t.found_by is not None:
            found_by[t.found_by] = found_by.get(t.found_by, 0) + 1
    pos = plan.success
    rows = [f"{'UAV':>3}  {'airport':>9}  {'search':>6}  {'return':>6}  {'range':>5}  {'eta':>6}  {'E[found]':>8}  "
            f"{'PoS':>6}  {'found':>5}  return reason"]
    for u in plan.uavs:
        airport = f"({u.airport[0] + 1},{u.airport[1] + 1})"
        reason = u.return_reason.value if u.return_reason else "-"
        expected = (f"{pos.by_uav.get(u.uav_id, 0.0):>8.2f}  {pos.share_of(u.uav_id):>6.1%}" if pos
                    else f"{'-':>8}  {'-':>6}")
        found = found_by.get(u.uav_id, 0) if len(plan.targets) else "-"
        rows.append(f"{u.uav_id:>3}  {airport:>9}  {u.search_steps:>6}  {u.return_steps:>6}  {u.range_steps:>5}  "
                    f"{u.eta:>6.1%}  {expected}  {found:>5}  {reason}")
    if pos is not None:
        rows.append(f"probability of success {pos.share:.1%}: expected targets found {pos.expected:.2f} of the "
                    f"{pos.available:.2f} the prior puts in the area")
    simulated = (f"targets found {plan.targets_found}/{len(plan.targets)}" if len(plan.targets)
                 else "no targets placed (none to find)")
    rows.append(f"simulated: {simulated}, false alarms {plan.false_alarms}, mean eta {plan.mean_eta:.1%}")
    return "\n".join(rows)


def run(args: argparse.Namespace) -> int:
    """Plan, with two helper processes beside the search (`gcs.background`): one loads matplotlib
    and draws the pictures, one loads rerun and writes the recording (when it goes to a file only)."""
    with ExitStack() as stack:
        pictures = stack.enter_context(Background(warm_up_picture))
        recordings = None
        if not args.no_rrd and args.rerun_connect is None:
            recordings = stack.enter_context(Background(warm_up_recording))
        return _run(args, pictures, recordings)


def warm_up_recording() -> None:
    """In the helper: rerun and the recorder, loaded while the search runs."""
    import gcs.recording.plan  # noqa: F401


def picture_drawer(pictures: Background, recordings: Background | None) -> DrawPictures:
    """Draws each (plan, scenario, path) in `pictures` and waits for them and the recordings."""
    def draw(jobs: list[tuple[Plan, Scenario, Path]]) -> list[Path]:
        indices = [pictures.submit(draw_overview, *job) for job in jobs]
        if recordings is not None:
            recordings.results()
        drawn = pictures.results()
        return [drawn[i] for i in indices]
    return draw


def _run(args: argparse.Namespace, pictures: Background, recordings: Background | None) -> int:
    draw = picture_drawer(pictures, recordings)
    if args.area is not None or args.continue_from is not None:
        from gcs.plans.campaign import run_area

        return run_area(args, lambda search, rrd, name, geo: fly_and_record(search, args, rrd, name, geo, recordings),
                        summary_table, recording_path, draw)
    if args.sorties is not None:
        raise UserError("--sorties needs --area (or --continue): sorties are flown over a real area")
    search = build_search(args)
    out = plan_path(args.out or "runs/plan.json")
    rrd = recording_path(args, out.with_suffix(".rrd"))
    plan = fly_and_record(search, args, rrd, f"{args.scenario} seed {args.seed}", helper=recordings)
    write_json_atomic(out, plan_to_dict(plan, seed=args.seed))
    [picture] = draw([(plan, search.scenario, out.with_suffix(".png"))])
    if not args.quiet:
        print(summary_table(plan))
        print(f"plan written to {out}, picture {picture}" + (f", recording {rrd}" if rrd else ""))
    return 0
