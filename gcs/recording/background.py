"""The plan's Rerun recording made beside the planner: `BackgroundPlanRecorder` hands each step
record to a `gcs.recording.plan.PlanRecorder` living in a `gcs.background` helper process, which has
imported rerun while the parent planned. The recording is the same; the parent never imports
rerun. The rules both sides follow are `gcs.recording.plan_rules`."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gcs.recording.plan_rules import interruption, map_interval

if TYPE_CHECKING:
    from gcs.background import Background
    from planner.dtscs import StepRecord
    from planner.plan import Plan
    from planner.scenario import Scenario
    from planner.search_theory import SearchTheory, Segment


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

    def log_segments(self, segments: list[Segment], theory: SearchTheory) -> None:
        self._remote.call("log_segments", segments, theory)
