"""Campaigns of sorties over one area (docs/campaigns.md): `gcs plan --area` (sortie 1),
`gcs plan --area X --sorties N` (N closed sorties, each from the belief the one before is
predicted to leave) and `gcs plan --continue FOLDER` (the next sortie from a flown sortie's
posterior, `gcs.flight.sortie`).

Every area plan folder holds `belief.json`, the belief its sortie was planned from, and a
`campaign` section in plan.json: the sortie number, the area file and its hash, the planning
options (a continued sortie is planned with the same ones), and the campaign's probability of
success per sortie and cumulative (`planner.campaign`)."""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gcs.errors import UserError
from gcs.flight.sortie import BELIEF_FILE, SORTIE_FILE, belief_from_dict, belief_to_dict, file_sha256
from gcs.plans.planning import AreaSetup, area_out_dir, area_outputs, build_area_search, mission_table, write_outputs
from planner.campaign import Belief, predicted_after
from planner.plan import Plan
from planner.scenario import Scenario

#: Draws the picture of each (plan, scenario, path) and waits for every output still being written
#: (`gcs.cli.commands.plan.picture_drawer`); returns the pictures' paths.
DrawPictures = Callable[[list[tuple[Plan, Scenario, Path]]], list[Path]]

#: Plan command options that say where outputs go or what is shown, not how to plan.
NOT_PLANNING = frozenset({"func", "command", "argv", "area", "scenario", "out", "quiet", "rrd", "no_rrd",
                          "rerun_connect", "continue_from", "sorties"})
MAX_SORTIES = 100
CAMPAIGN_FILE = "campaign.json"


@dataclass
class SortieStart:
    """Where a sortie starts: its belief, where that came from (`prior`, `flight`, `predicted`),
    the campaign rows of the sorties before it, and the flown folder it continues."""

    belief: Belief
    source: str
    history: list[dict]
    continued_from: str | None = None


def planning_options(args: argparse.Namespace) -> dict:
    """The planning options of a plan command's arguments (what a continued sortie reuses)."""
    return {k: v for k, v in sorted(vars(args).items()) if k not in NOT_PLANNING}


def _share(value: float, available: float) -> float:
    return value / available if available > 0 else 0.0


def _row(sortie: int, status: str, belief: str, folder: Path, expected: float, cumulative: float, available: float,
         **more) -> dict:
    return {"sortie": sortie, "status": status, "belief": belief, "folder": str(folder), **more,
            "expected_targets_found": round(expected, 6),
            "probability_of_success": round(_share(expected, available), 6),
            "cumulative_expected": round(cumulative, 6), "cumulative_pos": round(_share(cumulative, available), 6)}


def campaign_section(setup: AreaSetup, start: SortieStart, plan: Plan, folder: Path, args: argparse.Namespace,
                     area: dict) -> dict:
    """plan.json's `campaign`: this sortie, the area, the options and the probability of success
    per sortie (earlier ones as recorded, this one as planned) and cumulative."""
    pc = setup.search.scenario.sensor.pc
    belief = start.belief
    available = belief.available()
    before = belief.expected(pc)
    after = before + plan.success.expected
    row = _row(belief.sortie, "planned", start.source, folder, plan.success.expected, after, available)
    return {"sortie": belief.sortie, "seed": args.seed, "area": area, "options": planning_options(args),
            "belief": start.source, "continued_from": start.continued_from,
            "expected_targets_in_area": round(available, 6), "expected_before": round(before, 6),
            "expected_after": round(after, 6), "pos_before": round(_share(before, available), 6),
            "pos_after": round(_share(after, available), 6), "sorties": [*start.history, row]}


# ---- --continue ------------------------------------------------------------------------------


def _read_json(path: Path, folder: Path, missing: str) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"--continue {folder}: {missing}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UserError(f"--continue {folder}: {path.name} is not readable JSON ({exc})") from None
    if not isinstance(data, dict):
        raise UserError(f"--continue {folder}: {path.name} is not a JSON object")
    return data


def _given_options(args: argparse.Namespace) -> dict[str, str]:
    """The plan command's options given on the command line (`args.argv`, else those that differ
    from their defaults), destination -> option string (`np_steps` -> `--np`)."""
    from gcs.cli import command_parser

    parser = command_parser("plan")
    actions = [a for a in parser._actions if a.option_strings and a.dest != "help"]
    flags = {a.dest: a.option_strings[0] for a in actions}
    if getattr(args, "argv", None) is None:
        return {k: flags[k] for k in flags if hasattr(args, k) and getattr(args, k) != parser.get_default(k)}
    for action in actions:
        action.default = argparse.SUPPRESS
    given = parser.parse_args(args.argv[1:])  # the words after `plan`
    return {k: flags[k] for k in flags if hasattr(given, k)}


def _refuse_new_options(args: argparse.Namespace, folder: Path) -> None:
    """A continued sortie is planned with the options the campaign was: refuse others."""
    given = _given_options(args)
    if "area" in given:
        raise UserError("--continue plans over the area of the folder it continues: leave out --area")
    changed = [flag for k, flag in sorted(given.items()) if k not in NOT_PLANNING or k == "scenario"]
    if changed:
        raise UserError(f"--continue plans with the options {folder} was planned with (its plan.json): leave out "
                        f"{', '.join(changed)}")


def continued_start(args: argparse.Namespace) -> tuple[argparse.Namespace, SortieStart]:
    """The plan arguments and start of the sortie after the flight in `args.continue_from`;
    UserError with the reason when that folder is not a finished flight of an unchanged plan
    over an unchanged area file."""
    from gcs.cli import build_parser

    folder = Path(args.continue_from)
    _refuse_new_options(args, folder)
    if not folder.is_dir():
        raise UserError(f"--continue {folder}: no such folder")
    plan_data = _read_json(folder / "plan.json", folder, "no plan.json in it (not a gcs plan --area folder)")
    campaign = plan_data.get("campaign")
    if not isinstance(campaign, dict) or not {"area", "options", "sortie", "sorties"} <= set(campaign) \
            or not isinstance(campaign["area"], dict) or not isinstance(campaign["options"], dict):
        raise UserError(f"--continue {folder}: its plan.json has no campaign record (made before campaigns, or not "
                        f"from an area file); plan the area again with gcs plan --area")
    from gcs.flight.journal import check_no_flight_in_progress  # loads the flight code: only here

    check_no_flight_in_progress(folder)
    record = _read_json(folder / SORTIE_FILE, folder,
                        f"no flight record ({SORTIE_FILE}): this plan was never flown; fly it first (gcs fly --plan "
                        f"{folder} ...)")
    if record.get("finished") is not True:
        reason = record.get("reason") or "no reason recorded"
        raise UserError(f"--continue {folder}: the flight did not finish ({reason})"
                        f"; only a finished flight can be continued")
    if record.get("plan_sha256") != file_sha256(folder / "plan.json"):
        raise UserError(f"--continue {folder}: plan.json changed since the flight (it is not the plan that was flown)")
    area_file = Path(str(campaign["area"].get("file")))
    if not area_file.is_file():
        raise UserError(f"--continue {folder}: the area file {area_file} is gone; put it back to continue")
    if file_sha256(area_file) != campaign["area"].get("sha256"):
        raise UserError(f"--continue {folder}: the area file {area_file} changed since the plan was made; its grid "
                        f"and priors may no longer match the flight's belief (plan it again with gcs plan --area)")
    if record.get("belief") is None:
        raise UserError(f"--continue {folder}: the flight record has no belief map ({record.get('no_belief')})")
    try:
        grid = plan_data["grid"]
        no_fly = np.zeros((int(grid["nx"]), int(grid["ny"])), dtype=bool)
        for x, y in grid["no_fly"]:
            no_fly[x - 1, y - 1] = True
        flown = belief_from_dict(record["belief"], no_fly)
        rows = list(campaign["sorties"])[:-1]
        done = record["campaign"]
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise UserError(f"--continue {folder}: {SORTIE_FILE} or plan.json is damaged ({type(exc).__name__}: {exc})") \
            from None
    available = flown.available()
    rows.append(_row(flown.sortie, "flown", str(campaign.get("belief", "prior")), folder,
                     float(done["expected_targets_found"]), float(done["expected_after"]), available,
                     readings=int(record["readings"]["count"]), positive=int(record["readings"]["positive"])))
    ns = build_parser().parse_args(["plan", "--area", str(area_file)])
    for name, value in campaign["options"].items():
        if name not in NOT_PLANNING and hasattr(ns, name):
            setattr(ns, name, value)
    for name in ("quiet", "rrd", "no_rrd", "rerun_connect", "sorties"):
        setattr(ns, name, getattr(args, name))
    nxt = flown.next_sortie()
    base = re.sub(r"-sortie\d+$", "", folder.resolve().name)
    ns.out = args.out or str(folder.resolve().parent / f"{base}-sortie{nxt.sortie}")
    if Path(ns.out).resolve() == folder.resolve():
        raise UserError(f"--out {args.out}: that is the folder being continued; give the next sortie its own folder")
    return ns, SortieStart(nxt, "flight", rows, str(folder))


# ---- the command -------------------------------------------------------------------------------


def campaign_table(rows: list[dict], available: float) -> str:
    lines = [f"campaign: the prior puts {available:.2f} targets in the area",
             f"{'sortie':>6}  {'status':<8} {'planned from':<12} {'readings':>8}  {'E[found]':>8}  {'PoS':>6}  "
             f"{'cumulative PoS':>14}"]
    for r in rows:
        readings = f"{r['readings']}" if "readings" in r else "-"
        lines.append(f"{r['sortie']:>6}  {r['status']:<8} {r['belief']:<12} {readings:>8}  "
                     f"{r['expected_targets_found']:>8.2f}  {r['probability_of_success']:>6.1%}  "
                     f"{r['cumulative_pos']:>14.1%}")
    return "\n".join(lines)


def _recording(recording_path: Callable, args: argparse.Namespace, folder: Path, sortie: int, several: bool):
    rrd = recording_path(args, folder / "plan.rrd")
    if rrd is not None and several and args.rrd:
        rrd = rrd.with_name(f"{rrd.stem}-sortie{sortie}.rrd")
    return rrd


def run_area(args: argparse.Namespace, fly: Callable[..., Plan], summary: Callable[[Plan], str],
             recording_path: Callable[[argparse.Namespace, Path], Path | None], draw: DrawPictures) -> int:
    """`gcs plan --area` and `--continue`: `fly(search, rrd, name, cells_to_lat_lon)` runs and
    records each sortie's search. With `--sorties N`, N sorties in `sortie<k>/` sub-folders and
    `campaign.json`; every file published together, then the pictures (`draw`)."""
    start = None
    if args.continue_from is not None:
        args, start = continued_start(args)
    count = args.sorties
    if count is not None and not 1 <= count <= MAX_SORTIES:
        raise UserError(f"--sorties must be 1..{MAX_SORTIES}, got {count}")
    out_dir = area_out_dir(args)
    if start is not None:
        first = start.belief.sortie
        for folder in [out_dir] if count is None else [out_dir / f"sortie{k}" for k in range(first, first + count)]:
            if (folder / SORTIE_FILE).exists():
                raise UserError(f"--out {folder} holds a flown sortie ({SORTIE_FILE}): a new plan there would "
                                f"orphan its record; give another --out")
    setup = build_area_search(args, start.belief if start else None)
    start = start or SortieStart(setup.belief, "prior", [])
    area = {"file": str(Path(args.area).resolve()), "sha256": file_sha256(args.area)}
    files: dict[str, str] = {}
    sorties = []
    for i in range(count or 1):
        if i:
            setup = setup.for_belief(start.belief, args.seed)
        sortie = start.belief.sortie
        prefix = f"sortie{sortie}/" if count is not None else ""
        folder = out_dir / prefix
        rrd = _recording(recording_path, args, folder, sortie, count is not None)
        name = Path(args.area).stem + (f" sortie {sortie}" if sortie > 1 else "")
        plan = fly(setup.search, rrd, name, setup.area.cells_lonlat)
        section = campaign_section(setup, start, plan, folder, args, area)
        mine = area_outputs(setup, plan, setup.search.seed, args.speed_m_s, section)
        mine[BELIEF_FILE] = json.dumps(belief_to_dict(start.belief, start.source)) + "\n"
        files.update({prefix + name: text for name, text in mine.items()})
        sorties.append((folder, setup, plan, mine, rrd))
        start = SortieStart(predicted_after(start.belief, plan, setup.search.scenario.sensor), "predicted",
                            section["sorties"])
    rows, available = section["sorties"], section["expected_targets_in_area"]
    if count is not None:
        files[CAMPAIGN_FILE] = json.dumps({"area": area, "seed": args.seed, "options": planning_options(args),
                                           "expected_targets_in_area": available, "sorties": rows,
                                           "pos": rows[-1]["cumulative_pos"]}, indent=1) + "\n"
    write_outputs(out_dir, files)
    drawn = draw([(plan, setup.search.scenario, folder / "plan.png") for folder, setup, plan, *_ in sorties])
    if not args.quiet:
        for (folder, setup, plan, mine, rrd), picture in zip(sorties, drawn):
            if count is not None or len(rows) > 1:
                print(f"-- sortie {setup.belief.sortie} ({folder}) --")
            print(summary(plan))
            print(mission_table(setup, plan, mine))
            print(f"plan, missions and paths written to {folder}/ ({', '.join(sorted(mine))}), picture "
                  f"{picture.name}" + (f", recording {rrd}" if rrd else ""))
        if len(rows) > 1:
            print(campaign_table(rows, available))
        if count is not None:
            print(f"campaign summary written to {out_dir / CAMPAIGN_FILE}")
    return 0
