"""The plan's Rerun recording made beside the planner: `BackgroundPlanRecorder` hands each step
record to a `gcs.recording.plan.PlanRecorder` living in a `gcs.background` helper process, which has
imported rerun while the parent planned. The recording is the same; the parent never imports
rerun. Also the rules both sides share: how often the maps are logged, how an interruption reads."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gcs.background import Background
    from planner.dtscs import StepRecord
    from planner.plan import Plan
    from planner.scenario import Scenario

#: Grids up to this many cells log their maps every step; bigger ones every ceil(cells / this)
#: steps, so a 1000 x 1000 area logs 2 x 3 MB of images every 100 steps, not every step.
MAP_CELLS_EVERY_STEP = 10_000


def map_interval(cells: int) -> int:
    """Steps between the TEP and EU maps logged on a grid of `cells` cells, by default."""
    return max(1, math.ceil(cells / MAP_CELLS_EVERY_STEP))


def interruption(exc_type: type[BaseException], exc: BaseException | None) -> str:
    """What stopped a run, as its recording's last event says it."""
    return "Ctrl-C" if issubclass(exc_type, KeyboardInterrupt) else f"{exc_type.__name__}: {exc}"


def _plan_recorder(*args: Any, **kwargs: Any) -> Any:
    from gcs.recording.plan import PlanRecorder

    return PlanRecorder(*args, **kwargs)


class BackgroundPlanRecorder:
    """`PlanRecorder(rrd_path, None, scenario, ...)` run by `helper`, used the same way. A step's
    maps travel only on the steps the recorder logs them, and the last step's at the end."""

    def __init__(self, helper: Background, rrd_path: str | Path, scenario: Scenario, *,
                 cells_to_lat_lon: Any = None, name: str | None = None) -> None:
        self.map_every = map_interval(scenario.search_map.tep.size)
        self._remote = helper.create(_plan_recorder, rrd_path, None, scenario, cells_to_lat_lon=cells_to_lat_lon,
                                     name=name, map_every=self.map_every)
        self._last: StepRecord | None = None

    def __enter__(self) -> BackgroundPlanRecorder:
        self._remote.call("open")
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: object) -> None:
        last = self._last
        if last is not None and last.step % self.map_every:
            self._remote.call("log_maps", last.step, last.tep, last.eu)
        if exc_type is not None:
            self._remote.call("log_interruption", interruption(exc_type, exc))
        self._remote.call("close")

    def log_step(self, record: StepRecord) -> None:
        due = record.step % self.map_every == 0
        self._remote.call("log_step", record if due else replace(record, tep=None, eu=None))
        self._last = record

    def log_plan(self, plan: Plan) -> None:
        self._remote.call("log_plan", plan)
