"""Watching a `FlightController` from beside it: its events as they happen, and its vehicle
states sampled while a block runs (the Rerun recorder, the sortie log and the flight journal
all do); and the event log's lines, one text for each event wherever it is written."""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gcs.flight.events import LinkChanged, ModeChanged, ReadingReceived, Reattached, StageChanged, TookOff

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController
    from gcs.flight.events import FlightEvent, FlightListener
    from gcs.plans.plan_folder import FleetPlan
    from gcs.telemetry.status import VehicleStatus

_RETURN_STAGES = ("return", "rtl")


@contextlib.asynccontextmanager
async def watching(controller: FlightController, on_event: FlightListener, sample: Callable[[bool], None],
                   period_s: float, name: str,
                   on_end: Callable[[BaseException | None], None] | None = None) -> AsyncIterator[None]:
    """Subscribe `on_event` and call `sample(False)` every `period_s` while the block runs; on
    the way out, however it ends, unsubscribe, stop sampling, call `sample(True)` once, then
    `on_end(the exception that ended the block, or None)`."""
    unsubscribe = controller.subscribe(on_event)

    async def poll() -> None:
        while True:
            sample(False)
            await asyncio.sleep(period_s)

    task = asyncio.create_task(poll(), name=name)
    failure: BaseException | None = None
    try:
        yield
    except BaseException as exc:
        failure = exc
        raise
    finally:
        unsubscribe()
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        try:
            sample(True)
        finally:
            if on_end is not None:
                on_end(failure)


@dataclass(frozen=True, slots=True)
class EventLine:
    """One line of the flight's event log; `level` as Rerun's TextLog takes it."""

    uav_id: int | None
    text: str
    level: str = "INFO"

    @property
    def line(self) -> str:
        return f"UAV {self.uav_id}: {self.text}" if self.uav_id is not None else self.text


def event_lines(event: FlightEvent, status: dict[int, VehicleStatus], plan: FleetPlan) -> list[EventLine]:
    """The event log's lines for one controller event (none for the ones it leaves out),
    written as the event happens: `status` is the vehicles' state at that moment."""
    if isinstance(event, LinkChanged):
        return [EventLine(uid, str(event.status), "WARN") for uid in event.uav_ids or (None,)]
    uid = event.uav_id
    if isinstance(event, TookOff):
        return [EventLine(uid, f"take-off: airborne, {event.alt_m:.0f} m, mode {event.mode}")]
    if isinstance(event, ModeChanged):
        return [EventLine(uid, f"flight mode {event.before} -> {event.after}", "DEBUG")] if event.after != "-" else []
    if isinstance(event, ReadingReceived):
        d = event.detection
        if not d.hit:
            return []
        cell = plan.cell_of(d.lat_deg, d.lon_deg)
        where = f"cell ({cell[0] + 1}, {cell[1] + 1})" if cell is not None else f"({d.lat_deg:.6f}, {d.lon_deg:.6f})"
        return [EventLine(uid, f"detection: positive reading at {where}")]
    if isinstance(event, StageChanged):
        return [EventLine(uid, *_stage_text(event, status[uid]))]
    if isinstance(event, Reattached):
        return [EventLine(uid, f"reattached after the station's restart: {event.stage.value}, {event.found}", "WARN")]
    return []


def _finite(value: float | None) -> bool:
    return value is not None and math.isfinite(value)


def _stage_text(event: StageChanged, st: VehicleStatus) -> tuple[str, str]:
    stage, before = event.after.value, event.before.value
    note = f" - {event.note}" if event.note else ""
    if stage in _RETURN_STAGES:
        why = f" (reason: {st.return_reason})" if st.return_reason else ""
        trigger = ""
        if _finite(st.range_left):
            trigger = f"; range left {st.range_left:.0f} m"
            if _finite(st.margin):
                trigger += f", margin {st.margin:.0f} m"
        battery = f", battery {st.battery_pct:.0f}%" if st.battery_pct is not None else ""
        return f"return triggered{why}: {stage}{note}{trigger}{battery}", "WARN"
    if stage == "landed":
        return f"landed{note}", "INFO"
    if stage == "lost":
        return f"lost link{note}", "WARN"
    if stage == "failed":
        return f"failed{note}", "ERROR"
    if before == "lost":
        return f"link back: {stage}{note}", "INFO"
    return f"{stage}{note}", "INFO"
