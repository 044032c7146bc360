"""Campaigns of sorties over one area (docs/campaigns.md): `gcs plan --area` (sortie 1),
`gcs plan --area X --sorties N` (N closed sorties, each from the belief the one before is
predicted to leave) and `gcs plan --continue FOLDER` (the next sortie from a flown sortie's
posterior, `gcs.flight.sortie`); `gcs.plans.make` runs them.

Every area plan folder holds `belief.json`, the belief its sortie was planned from, and a
`campaign` section in plan.json: the sortie number, the area file and its hash, the planning
options (`gcs.plans.options.options_record`; a continued sortie is planned with the same ones),
and the campaign's probability of success per sortie and cumulative (`planner.campaign`)."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from gcs.errors import UserError
from gcs.plans.belief_file import BELIEF_FILE, SORTIE_FILE, belief_from_dict, belief_to_dict, file_sha256
from gcs.plans.charge_fit import fit_ranges_to_paths
from gcs.plans.gis_formats import area_sha256
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions, options_from_record, options_record
from gcs.plans.plan_bound import bound_summary
from gcs.plans.planning import AreaSetup, area_out_dir, area_outputs, build_area_search, write_outputs
from gcs.plans.segments import SortieSegments, sortie_segments
from gcs.plans.vehicle_file import VEHICLES_FILE, load_vehicles
from planner.campaign import Belief, predicted_after
from planner.dtscs import ClosedSearch
from planner.plan import Plan
from planner.scenario import Scenario

MAX_SORTIES = 100
CAMPAIGN_FILE = "campaign.json"


class Planning(Protocol):
    """How each sortie's search is run and recorded, and pictures drawn (`gcs.plans.make.Planning`)."""

    output: OutputOptions

    def fly(self, search: ClosedSearch, rrd: Path | None, name: str, cells_to_lat_lon: Callable | None = None,
            segments: SortieSegments | None = None) -> Plan: ...

    def caption(self, plan: Plan, bound: dict | None) -> None: ...

    def draw(self, jobs: list[tuple[Plan, Scenario, Path]]) -> list[Path]: ...


@dataclass
class SortieStart:
    """Where a sortie starts: its belief, where that came from (`prior`, `flight`, `predicted`),
    the campaign rows of the sorties before it, and the flown folder it continues."""

    belief: Belief
    source: str
    history: list[dict]
    continued_from: str | None = None


@dataclass(frozen=True)
class PlannedSortie:
    """One sortie as planned: its folder, setup and plan, the files written there (name ->
    text), its recording and its picture."""

    folder: Path
    setup: AreaSetup
    plan: Plan
    files: dict[str, str]
    rrd: Path | None
    picture: Path


@dataclass(frozen=True)
class CampaignResult:
    """What an area plan made: its sorties, the campaign's rows (`campaign_section`), what the
    prior puts in the area, and campaign.json when several sorties were planned in a row."""

    out_dir: Path
    sorties: list[PlannedSortie]
    rows: list[dict]
    available: float
    campaign_file: Path | None


def _share(value: float, available: float) -> float:
    return value / available if available > 0 else 0.0


def _row(sortie: int, status: str, belief: str, folder: Path, expected: float, cumulative: float, available: float,
         **more) -> dict:
    return {"sortie": sortie, "status": status, "belief": belief, "folder": str(folder), **more,
            "expected_targets_found": round(expected, 6),
            "probability_of_success": round(_share(expected, available), 6),
            "cumulative_expected": round(cumulative, 6), "cumulative_pos": round(_share(cumulative, available), 6)}


def campaign_section(setup: AreaSetup, start: SortieStart, plan: Plan, folder: Path, seed: int, options: dict,
                     area: dict) -> dict:
    """plan.json's `campaign`: this sortie, the area, the options and the probability of success
    per sortie (earlier ones as recorded, this one as planned) and cumulative."""
    pc = setup.search.scenario.sensor.pc
    belief = start.belief
    available = belief.available()
    before = belief.expected(pc)
    after = before + plan.success.expected
    row = _row(belief.sortie, "planned", start.source, folder, plan.success.expected, after, available)
    return {"sortie": belief.sortie, "seed": seed, "area": area, "options": options,
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


@dataclass(frozen=True)
class NextSortie:
    """The sortie after a flown one: the area file and options it was planned with, the folder
    the next sortie goes to, and where it starts."""

    area_file: Path
    area: AreaOptions
    search: SearchOptions
    out: str
    start: SortieStart


def continued_start(folder: str | Path, out: str | Path | None = None) -> NextSortie:
    """The sortie after the flight in `folder`, into `out` (default `folder`-sortie<N+1>);
    UserError with the reason when that folder is not a finished flight of an unchanged plan
    over an unchanged area file. The energy profiles the flight learned (its `vehicles.json`)
    give the next sortie's ranges."""
    folder = Path(folder)
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
    if not area_file.exists():
        raise UserError(f"--continue {folder}: the area file {area_file} is gone; put it back to continue")
    if area_sha256(area_file) != campaign["area"].get("sha256"):
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
        area, search = options_from_record(campaign["options"])
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise UserError(f"--continue {folder}: {SORTIE_FILE} or plan.json is damaged ({type(exc).__name__}: {exc})") \
            from None
    learned = folder / VEHICLES_FILE
    if learned.is_file():  # the energy profiles the flight learned price the next sortie's ranges
        area = replace(area, vehicles=str(learned.resolve()))
    available = flown.available()
    rows.append(_row(flown.sortie, "flown", str(campaign.get("belief", "prior")), folder,
                     float(done["expected_targets_found"]), float(done["expected_after"]), available,
                     readings=int(record["readings"]["count"]), positive=int(record["readings"]["positive"])))
    nxt = flown.next_sortie()
    base = re.sub(r"-sortie\d+$", "", folder.resolve().name)
    given = out
    out = str(out) if out else str(folder.resolve().parent / f"{base}-sortie{nxt.sortie}")
    if Path(out).resolve() == folder.resolve():
        raise UserError(f"--out {given}: that is the folder being continued; give the next sortie its own folder")
    return NextSortie(area_file, area, search, out, SortieStart(nxt, "flight", rows, str(folder)))


# ---- planning the sorties ----------------------------------------------------------------------


def _recording(output: OutputOptions, folder: Path, sortie: int, several: bool) -> Path | None:
    rrd = output.recording_path(folder / "plan.rrd")
    if rrd is not None and several and output.rrd:
        rrd = rrd.with_name(f"{rrd.stem}-sortie{sortie}.rrd")
    return rrd


def plan_sorties(area_file: str | Path, area: AreaOptions, search: SearchOptions, out: str | Path | None,
                 planning: Planning, *, sorties: int | None = None, start: SortieStart | None = None
                 ) -> CampaignResult:
    """Sortie 1 of `area_file` (or the sortie `start` says) into the folder `out` (default
    runs/<area file name>); with `sorties` N, N sorties in `sortie<k>/` sub-folders and
    `campaign.json`. `planning` runs and records each sortie's search; every file is published
    together, then the pictures (drawn while the searches ran and the files were written) are saved."""
    count = sorties
    if count is not None and not 1 <= count <= MAX_SORTIES:
        raise UserError(f"--sorties must be 1..{MAX_SORTIES}, got {count}")
    out_dir = area_out_dir(area_file, out)
    if start is not None:
        first = start.belief.sortie
        for folder in [out_dir] if count is None else [out_dir / f"sortie{k}" for k in range(first, first + count)]:
            if (folder / SORTIE_FILE).exists():
                raise UserError(f"--out {folder} holds a flown sortie ({SORTIE_FILE}): a new plan there would "
                                f"orphan its record; give another --out")
    setup = build_area_search(area_file, area, search, start.belief if start else None)
    if area.vehicles:
        setup, _ = fit_ranges_to_paths(setup, load_vehicles(area.vehicles))
    start = start or SortieStart(setup.belief, "prior", [])
    area_record = {"file": str(Path(area_file).resolve()), "sha256": area_sha256(area_file)}
    options = options_record(area, search)
    files: dict[str, str] = {}
    planned = []
    for i in range(count or 1):
        if i:
            setup = setup.for_belief(start.belief, search.seed)
        sortie = start.belief.sortie
        prefix = f"sortie{sortie}/" if count is not None else ""
        folder = out_dir / prefix
        rrd = _recording(planning.output, folder, sortie, count is not None)
        name = Path(area_file).stem + (f" sortie {sortie}" if sortie > 1 else "")
        segments = sortie_segments(setup)  # plan.json's, the picture's and the recording's, reckoned once
        plan = planning.fly(setup.search, rrd, name, setup.area.cells_lonlat, segments)
        section = campaign_section(setup, start, plan, folder, search.seed, options, area_record)
        bound = bound_summary(plan, setup.search.scenario, setup.search.config.oc, planning.output.bound_time_s)
        planning.caption(plan, bound)  # the picture's last line, drawn while the files are made
        mine = area_outputs(setup, plan, setup.search.seed, area.speed_m_s, section, bound, segments)
        mine[BELIEF_FILE] = json.dumps(belief_to_dict(start.belief, start.source)) + "\n"
        files.update({prefix + name: text for name, text in mine.items()})
        planned.append((folder, setup, plan, mine, rrd))
        if i + 1 < (count or 1):  # the next sortie starts from the belief this one is predicted to leave
            start = SortieStart(predicted_after(start.belief, plan, setup.search.scenario.sensor), "predicted",
                                section["sorties"])
    rows, available = section["sorties"], section["expected_targets_in_area"]
    campaign_file = None
    if count is not None:
        campaign_file = out_dir / CAMPAIGN_FILE
        files[CAMPAIGN_FILE] = json.dumps({"area": area_record, "seed": search.seed, "options": options,
                                           "expected_targets_in_area": available, "sorties": rows,
                                           "pos": rows[-1]["cumulative_pos"]}, indent=1) + "\n"
    write_outputs(out_dir, files)
    drawn = planning.draw([(plan, setup.search.scenario, folder / "plan.png") for folder, setup, plan, *_ in planned])
    return CampaignResult(out_dir, [PlannedSortie(*done, picture) for done, picture in zip(planned, drawn)], rows,
                          available, campaign_file)
