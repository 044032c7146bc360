"""`gcs plan`: run the closed search (DTSCS) and write the plan.

With `--area area.geojson` (or .kml, .kmz, .gpx, .gpkg, .shp) the search runs over a real area
(docs/areas.md): the output folder gets plan.json, uav<id>.waypoints (QGC WPL 110), uav<id>.plan
(QGroundControl) and paths.geojson, paths.kml and paths.gpx."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gcs.cli import given_options
from gcs.cli.plan_options import (
    SCENARIOS,
    add_area_arguments,
    add_bound_argument,
    add_output_arguments,
    add_search_arguments,
    output_options_from,
    plan_options_from,
)
from gcs.errors import UserError

#: Options that say where outputs go or what is shown, not how to plan: the ones `--continue` takes.
NOT_PLANNING = frozenset({"out", "quiet", "rrd", "no_rrd", "rerun_connect", "continue_from", "sorties", "bound_time"})


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plan", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("--scenario", default="paper", help=f"built-in scenario ({', '.join(SCENARIOS)})")
    add_search_arguments(p)
    p.add_argument("--out", default=None,
                   help="plan JSON file, or a folder to hold plan.json (default runs/plan.json; with --area a "
                        "folder, default runs/<area file name>)")
    add_output_arguments(p, "the run", "next to the plan, plan.rrd")
    add_bound_argument(p)
    add_area_arguments(p)
    g = p.add_argument_group("campaigns of sorties (docs/campaigns.md)")
    g.add_argument("--continue", dest="continue_from", metavar="FOLDER", default=None,
                   help="plan the next sortie from the posterior a finished gcs fly left in FOLDER, with fresh "
                        "batteries and FOLDER's area and options (default --out: FOLDER-sortie<N+1>)")
    g.add_argument("--sorties", type=int, metavar="N", default=None,
                   help="plan N closed sorties in a row, each from the belief the one before is predicted to leave "
                        "(its looks reporting nothing), into --out/sortie<k>/ with campaign.json")
    p.set_defaults(func=run)


def refuse_new_options(args: argparse.Namespace) -> None:
    """A continued sortie is planned with the options the campaign was: refuse others."""
    given = given_options(args)
    if "area" in given:
        raise UserError("--continue plans over the area of the folder it continues: leave out --area")
    changed = [flag for dest, flag in sorted(given.items()) if dest not in NOT_PLANNING]
    if changed:
        raise UserError(f"--continue plans with the options {Path(args.continue_from)} was planned with (its "
                        f"plan.json): leave out {', '.join(changed)}")


def run(args: argparse.Namespace) -> int:
    from gcs.display.plan_tables import area_report, grounded_lines, scenario_report
    from gcs.plans import make

    area, search = plan_options_from(args)
    output = output_options_from(args)
    if args.continue_from is not None:
        refuse_new_options(args)
        result = make.continue_campaign(args.continue_from, args.out, output, args.sorties)
    elif args.area is not None:
        result = make.plan_area(args.area, area, search, args.out, output, args.sorties)
    elif args.sorties is not None:
        raise UserError("--sorties needs --area (or --continue): sorties are flown over a real area")
    else:
        scenario = make.plan_scenario(args.scenario, search, args.out or make.DEFAULT_PLAN_FILE, output)
        if not args.quiet:
            print(scenario_report(scenario))
        return 0
    for line in grounded_lines(result):
        print(line, file=sys.stderr)
    if not args.quiet:
        print(area_report(result))
    return 0
