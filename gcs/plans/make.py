"""Make a plan, start to finish: what `gcs plan` and `gcs fly --area` call, and a Python user may.

    plan_scenario("paper", SearchOptions(seed=7), "runs/plan.json")     # a built-in scenario
    plan_area("missions/paper.geojson", AreaOptions(), SearchOptions()) # a real area: runs/paper/
    continue_campaign("runs/paper")                                     # the sortie after a flight

Each runs the closed search with a progress bar (on stderr), records it to Rerun unless told not
to, writes the plan files and draws the picture, and returns what it made; printing it is the
caller's (`gcs.display.plan_tables`). Two helper processes work beside the search
(`gcs.background`): one loads matplotlib and draws the pictures, one loads rerun and writes the
recording (when it goes to a file only), so the planning process imports neither. The pictures
helper starts first, before this process loads the planner (it is sent plain arrays and text,
`gcs.display.overview.MapLayers` and `PlanLayers`, and never loads numba), and draws each
sortie's map while its search runs, its plan while the bound on it is solved here, and the
caption with the bound (one line) while the files are made; the recordings helper starts once
the planner is loaded, whose step records it reads. This module itself loads neither the
planner nor numba."""

from __future__ import annotations

import gc
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gcs.atomic import write_json_atomic
from gcs.background import Background, Remote
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions
from gcs.recording.background import BackgroundPlanRecorder

if TYPE_CHECKING:
    from gcs.plans.campaign import CampaignResult
    from gcs.plans.segments import SortieSegments
    from gcs.recording.plan import PlanRecorder
    from planner.dtscs import ClosedSearch, StepRecord
    from planner.plan import Plan
    from planner.scenario import Scenario
    from planner.search_theory import SearchTheory

DEFAULT_PLAN_FILE = "runs/plan.json"


def fly_with_progress(search: ClosedSearch, progress: bool = True,
                      on_step: Callable[[StepRecord], None] | None = None) -> Plan:
    """Run `search` to the end with a progress bar on stderr (none when `progress` is False or
    stderr is no terminal), calling `on_step` with every step's record; the plan."""
    if not progress or not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):  # no bar: tqdm not needed
        for record in search.run():
            if on_step is not None:
                on_step(record)
        return search.plan()
    from tqdm import tqdm

    horizon = max(u.range_units for u in search.uavs.values()) // search.costs.cheapest
    with tqdm(total=horizon, unit="step", desc="planning", leave=False, file=sys.stderr) as bar:
        for record in search.run():
            if on_step is not None:
                on_step(record)
            bar.update(1)
            bar.set_postfix(found=sum(s is not None for s in search.found_step))
    if search.config.improve is None:
        return search.plan()
    with tqdm(desc="improving the whole mission", bar_format="{desc}: {elapsed}", leave=False,
              file=sys.stderr) as bar:
        ticking = threading.Event()
        ticker = threading.Thread(target=_tick, args=(bar, ticking), daemon=True)
        ticker.start()
        try:
            return search.plan()
        finally:
            ticking.set()
            ticker.join()


def _tick(bar, stop: threading.Event) -> None:
    """Refresh `bar`'s elapsed time every half second until `stop`."""
    while not stop.wait(0.5):
        bar.refresh()


def warm_up_picture() -> None:
    """In the helper: matplotlib loaded and warmed up while the planner loads and the search runs."""
    from gcs.display.overview import warm_up

    warm_up()


def warm_up_recording() -> None:
    """In the helper: rerun and the recorder, loaded while the search runs."""
    import gcs.recording.plan  # noqa: F401


def load_planner() -> None:
    """Load the planner and the modules that write its files (numba, shapely, pyproj: about half a
    second)."""
    import gcs.plans.campaign  # noqa: F401


class Planning:
    """The helpers of one planning run: `fly` runs and records a search (its picture's map drawn
    meanwhile, the plan over it as soon as the search ends), `caption` finishes a picture with
    the plan's bound, `draw` saves the pictures."""

    def __init__(self, output: OutputOptions, pictures: Background, recordings: Background | None,
                 collect: bool = True) -> None:
        self.output = output
        self._pictures = pictures
        self._recordings = recordings
        self._rendered: dict[int, tuple[Plan, Scenario, Remote]] = {}  # id(plan) -> its rendered picture
        self._captions: dict[int, str | None] = {}  # id(plan) -> its picture's caption, the picture finished
        self._collect = collect  # the garbage collector to be resumed when the first search starts

    def _resume_collection(self) -> None:
        """Start collecting garbage again (`planning` paused it), what the set-up made (modules,
        kernels, the area) moved to the oldest generation first: it lives as long as the run, and
        young collections need not look at it again."""
        if self._collect and not gc.isenabled():
            gc.freeze()
            gc.unfreeze()
            gc.enable()

    def fly(self, search: ClosedSearch, rrd: Path | None, name: str, cells_to_lat_lon: Callable | None = None,
            segments: SortieSegments | None = None) -> Plan:
        """Run the search with a progress bar, recording every step to Rerun unless disabled: by
        the recordings helper when it records to a file only, here when it also streams to a viewer.
        The pictures helper draws the map meanwhile, `segments` (the search team's: the area
        file's, else the grid's blocks) outlined on it, and the plan over it once it is made, the
        segments labelled with the plan's figures (`segments.figures`, plan.json's
        `search_theory`), which a recording ends with."""
        from gcs.display.overview import OverviewPicture, map_layers, plan_layers

        scenario = search.scenario
        layers = map_layers(scenario, segments.segments if segments is not None else ())
        picture = self._pictures.create(OverviewPicture, layers)
        self._resume_collection()
        plan, theory = self._fly(search, rrd, name, cells_to_lat_lon, segments)
        picture.call("render", plan_layers(plan, scenario, layers.places, theory))
        self._rendered[id(plan)] = (plan, scenario, picture)
        return plan

    def caption(self, plan: Plan, bound: dict | None) -> None:
        """Finish the picture of `plan` with its caption: the expected finds against `bound`
        (plan.json's `summary.bound`; `gcs.display.overview.bound_caption`), drawn last in the
        pictures helper while this process writes the files."""
        from gcs.display.overview import bound_caption

        text = bound_caption(plan.success.expected if plan.success is not None else None, bound)
        self._captions[id(plan)] = text
        rendered = self._rendered.get(id(plan))
        if rendered is not None:
            rendered[2].call("finish", text)

    def _fly(self, search: ClosedSearch, rrd: Path | None, name: str, cells_to_lat_lon: Callable | None,
             segments: SortieSegments | None = None) -> tuple[Plan, SearchTheory | None]:
        """The plan and its figures over `segments` (None without segments)."""
        output = self.output
        if rrd is None and output.rerun_connect is None:
            plan = fly_with_progress(search, output.progress)
            return plan, None if segments is None else segments.figures(plan)
        recorder: PlanRecorder | BackgroundPlanRecorder
        if self._recordings is not None and output.rerun_connect is None:
            recorder = BackgroundPlanRecorder(self._recordings, rrd, search.scenario, cells_to_lat_lon=cells_to_lat_lon,
                                              name=name)
        else:
            from gcs.recording.plan import PlanRecorder  # rerun takes ~0.45 s to import: only when recording

            recorder = PlanRecorder(rrd, output.rerun_connect, search.scenario, cells_to_lat_lon=cells_to_lat_lon,
                                    name=name)
        theory = None
        with recorder as rec:
            plan = fly_with_progress(search, output.progress, rec.log_step)
            rec.log_plan(plan)
            if segments is not None:
                theory = segments.figures(plan)
                rec.log_segments(segments.segments, theory)
        return plan, theory

    def draw(self, jobs: list[tuple[Plan, Scenario, Path]]) -> list[Path]:
        """Save the picture of each (plan, scenario, path) (drawn in the pictures helper: by `fly`
        and `caption`, or now, without segments; without a caption when `caption` was not
        called), wait for them and the recordings; the pictures' paths."""
        from gcs.display.overview import OverviewPicture, map_layers, plan_layers

        indices = []
        for plan, scenario, path in jobs:
            rendered = self._rendered.pop(id(plan), None)
            captioned = id(plan) in self._captions
            caption = self._captions.pop(id(plan), None)
            if rendered is not None and rendered[1] is scenario:
                picture = rendered[2]
                if not captioned:
                    picture.call("finish", None)
            else:
                picture = self._pictures.create(OverviewPicture, map_layers(scenario))
                picture.call("render", plan_layers(plan, scenario))
                picture.call("finish", caption)
            indices.append(picture.submit("save", path))
        if self._recordings is not None:
            self._recordings.results()
        drawn = self._pictures.results()
        return [drawn[i] for i in indices]


@contextmanager
def planning(output: OutputOptions) -> Iterator[Planning]:
    """The helper processes of a run, started now so that they load their libraries while the
    planner is loaded, the area read and the search run: the pictures helper first, then (the
    planner loaded) the recordings helper; stopped on leaving. The garbage collector pauses
    until the first search starts: loading modules and kernels and reading the area allocate
    much and free little."""
    collect = gc.isenabled()
    gc.disable()
    try:
        with ExitStack() as stack:
            import gcs.display.overview  # noqa: F401  (and numpy, which both processes use: loaded once)

            pictures = stack.enter_context(Background(warm_up_picture))
            load_planner()
            recordings = None
            if output.record and output.rerun_connect is None:
                recordings = stack.enter_context(Background(warm_up_recording))
            yield Planning(output, pictures, recordings, collect)
    finally:
        if collect:
            gc.enable()


@dataclass(frozen=True)
class ScenarioResult:
    """A built-in scenario's plan, the file it was written to, its picture and its recording."""

    plan: Plan
    scenario: Scenario
    path: Path
    picture: Path
    rrd: Path | None
    bound: dict | None = None   # plan.json's summary.bound (`gcs.plans.plan_bound`)


def plan_path(out: str | Path) -> Path:
    """The plan file `out` names: a `.json` file, else `plan.json` in that folder."""
    path = Path(out)
    return path if path.suffix == ".json" else path / "plan.json"


def plan_scenario(scenario: str = "paper", search: SearchOptions | None = None, out: str | Path = DEFAULT_PLAN_FILE,
                  output: OutputOptions | None = None) -> ScenarioResult:
    """Plan built-in scenario `scenario` (`planner.scenario.SCENARIOS`) into `out` (a `.json`
    file, or a folder that receives plan.json), with the picture and, unless `output` says
    otherwise, the Rerun recording beside it. Bad options raise UserError before anything is written."""
    search = search or SearchOptions()
    output = output or OutputOptions()
    with planning(output) as run:
        from gcs.plans.plan_bound import bound_summary
        from gcs.plans.plan_file import plan_to_dict
        from gcs.plans.planning import build_scenario_search

        closed = build_scenario_search(scenario, search)
        path = plan_path(out)
        rrd = output.recording_path(path.with_suffix(".rrd"))
        plan = run.fly(closed, rrd, f"{scenario} seed {search.seed}")
        bound = bound_summary(plan, closed.scenario, closed.config.oc, output.bound_time_s)
        run.caption(plan, bound)
        write_json_atomic(path, plan_to_dict(plan, seed=search.seed, bound=bound))
        [picture] = run.draw([(plan, closed.scenario, path.with_suffix(".png"))])
    return ScenarioResult(plan, closed.scenario, path, picture, rrd, bound)


def plan_area(area_file: str | Path, area: AreaOptions | None = None, search: SearchOptions | None = None,
              out: str | Path | None = None, output: OutputOptions | None = None,
              sorties: int | None = None) -> CampaignResult:
    """Plan the area of `area_file` (docs/areas.md) into the folder `out` (default runs/<area
    file name>): plan.json, the missions, paths, belief and picture, and the recording unless
    `output` says otherwise. With `sorties` N, N closed sorties in a row into `out`/sortie<k>/
    and campaign.json (docs/campaigns.md). Bad input raises UserError before anything is written."""
    output = output or OutputOptions()
    with planning(output) as run:
        from gcs.plans.campaign import plan_sorties

        return plan_sorties(area_file, area or AreaOptions(), search or SearchOptions(), out, run, sorties=sorties)


def continue_campaign(folder: str | Path, out: str | Path | None = None, output: OutputOptions | None = None,
                      sorties: int | None = None) -> CampaignResult:
    """Plan the sortie after the finished flight in `folder` from the posterior it left, with
    fresh batteries and the area and options `folder` was planned with, into `out` (default
    `folder`-sortie<N+1>); with `sorties` N, N sorties. UserError when `folder` is not a finished
    flight of an unchanged plan over an unchanged area file."""
    output = output or OutputOptions()
    with planning(output) as run:
        from gcs.plans.campaign import continued_start, plan_sorties

        nxt = continued_start(folder, out)
        return plan_sorties(nxt.area_file, nxt.area, nxt.search, nxt.out, run, sorties=sorties, start=nxt.start)
