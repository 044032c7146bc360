"""Terminal rendering of the fleet: the live status table and the end-of-flight summary, pure
text from the controller's state; and `LiveTable`, which redraws the table on a terminal while
a flight runs. The flight never imports this module: whoever starts the flight gives it a
`LiveTable` (as the controller's output channel and as a watcher)."""

from __future__ import annotations

import asyncio
import contextlib
import math
import sys
from collections import deque
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController
    from gcs.plans.plan_folder import FleetPlan
    from gcs.telemetry.status import VehicleStatus

__all__ = ["LiveTable", "render_summary", "render_table", "targets_found"]

CLEAR_SCREEN = "\x1b[H\x1b[2J"


def _num(value: float | None, fmt: str, none: str = "-") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return none
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return format(value, fmt)


def _cell(plan: FleetPlan, st: VehicleStatus) -> str:
    if not st.has_position:
        return "-"
    cell = plan.cell_of(st.lat_deg, st.lon_deg)
    return f"({cell[0] + 1},{cell[1] + 1})" if cell else "outside"


def render_table(controller: FlightController) -> str:
    """One row per vehicle: stage, mode, position, altitude, cell, battery, range left and
    return margin (metres of cruise: what the charge above the reserve still buys, and what is left of
    it once the way home is paid), detections."""
    plan = controller.plan
    head = (f"{'UAV':>3} {'stage':<10} {'mode':<9} {'lat':>11} {'lon':>12} {'alt m':>6} {'cell':>9} "
            f"{'batt %':>6} {'range m':>7} {'margin m':>8} {'hits':>4}  note")
    rows = [head]
    for uid, st in sorted(controller.status.items()):
        hits = sum(d.hit for d in st.detections)
        lat = _num(st.lat_deg, ".6f") if st.has_position else "-"
        lon = _num(st.lon_deg, ".6f") if st.has_position else "-"
        rows.append(f"{uid:>3} {st.stage.value:<10} {st.mode_name[:9]:<9} {lat:>11} {lon:>12} "
                    f"{st.rel_alt_m:>6.1f} {_cell(plan, st):>9} {_num(st.battery_pct, '.0f'):>6} "
                    f"{_num(st.range_left, '.0f'):>7} {_num(st.margin, '.0f'):>8} {hits:>4}  {st.note[:60]}")
    return "\n".join(rows)


def targets_found(controller: FlightController) -> tuple[set[tuple[int, int]], int]:
    """Plan targets whose cell got a positive reading, and the positive readings elsewhere."""
    plan = controller.plan
    targets = set(plan.targets)
    found: set[tuple[int, int]] = set()
    false_alarms = 0
    for st in controller.status.values():
        for d in st.detections:
            if not d.hit:
                continue
            cell = plan.cell_of(d.lat_deg, d.lon_deg)
            if cell in targets:
                found.add(cell)
            else:
                false_alarms += 1
    return found, false_alarms


def render_summary(controller: FlightController) -> str:
    """Per vehicle: how it ended, where (distance from its own airport), battery at landing, why
    it returned, the charge it used from launch to touch-down against what its energy profile
    predicted at launch for what it flew, readings; a row for each UAV the plan left on the ground
    (plan.json's `grounded`); then the fleet's landings and targets."""
    plan = controller.plan
    header = (f"{'UAV':>3} {'name':<12} {'end':<11} {'from airport m':>14} {'batt %':>6} {'returned':<10} "
              f"{'used mAh':>8} {'predicted':>9} {'looks':>5} {'hits':>4}  note")
    by_uav: dict[int, str] = {}
    for uid, st in controller.status.items():
        task = plan.uavs[uid]
        away = "-"
        if st.has_position:
            e0, n0 = plan.local_m(*task.airport_lat_lon)
            e1, n1 = plan.local_m(st.lat_deg, st.lon_deg)
            away = f"{math.hypot(e1 - e0, n1 - n0):.1f}"
        batt = st.battery_at_landing if st.battery_at_landing is not None else st.battery_pct
        account = controller.vehicles[uid].energy.energy_account()
        used = f"{account.used_mah:>8.0f} {account.predicted_mah:>5.0f} {account.error:>+4.0%}" if account \
            else f"{'-':>8} {'-':>9}"
        by_uav[uid] = (f"{uid:>3} {task.name[:12]:<12} {st.stage.value:<11} {away:>14} {_num(batt, '.0f'):>6} "
                       f"{st.return_reason or 'plan':<10} {used} {len(st.detections):>5} "
                       f"{sum(d.hit for d in st.detections):>4}  {st.note[:70]}")
    grounded = plan.raw.get("grounded", [])
    for uav in grounded:  # planned without: never flown, never in the flight's status
        name = str(uav.get("name", ""))[:12]
        by_uav[int(uav["id"])] = (f"{uav['id']:>3} {name:<12} {'grounded':<11} {'0.0':>14} {'-':>6} {'-':<10} "
                                  f"{'-':>8} {'-':>9} {0:>5} {0:>4}  planned without it: {uav['reason'][:50]}")
    rows = [header, *(by_uav[uid] for uid in sorted(by_uav))]
    found, false_alarms = targets_found(controller)
    landed = sum(st.stage.value == "landed" for st in controller.status.values())
    away_ids = [str(uid) for uid, st in sorted(controller.status.items()) if st.stage.value == "landed away"]
    rows.append(f"{landed}/{len(controller.status)} landed at their airports"
                + (f"; LANDED AWAY: UAV {', '.join(away_ids)}" if away_ids else "")
                + (f"; left on the ground by the plan: UAV {', '.join(str(u['id']) for u in grounded)}"
                   if grounded else "")
                + f"; targets found {len(found)}/{len(plan.targets)}, positive readings elsewhere {false_alarms}")
    return "\n".join(rows)


def _to_stdout(text: str) -> None:
    sys.stdout.write(text)
    sys.stdout.flush()


class LiveTable:
    """The fleet's table on a terminal, redrawn every `every_s` while a flight runs, with the
    controller's last `lines` lines under it:

        table = LiveTable()
        await fly_async(plan, connections, options, out=table.line, watchers=[table])

    `line` is the controller's output channel (`FlightController(out=...)`); `attach(controller)`
    draws while the block runs and once more, the final state, as it ends. A line said while
    the table is not drawn (before, after) is also printed as it comes."""

    def __init__(self, every_s: float = 0.5, *, lines: int = 8, write: Callable[[str], None] | None = None) -> None:
        self.every_s = every_s
        self.recent: deque[str] = deque(maxlen=lines)
        self.write = write or _to_stdout
        self.drawing = False

    def line(self, text: str) -> None:
        """One line from the controller: shown under the table."""
        self.recent.append(text)
        if not self.drawing:
            self.write(text + "\n")

    def draw(self, controller: FlightController) -> None:
        """Clear the screen, then the table and the recent lines."""
        self.write(CLEAR_SCREEN + render_table(controller) + "\n\n" + "\n".join(self.recent) + "\n")

    @contextlib.asynccontextmanager
    async def attach(self, controller: FlightController) -> AsyncIterator[LiveTable]:
        """Redraw every `every_s` while the block runs, and the final state when it ends."""
        async def redraw() -> None:
            while True:
                self.draw(controller)
                await asyncio.sleep(self.every_s)

        self.drawing = True
        task = asyncio.create_task(redraw(), name="live-table")
        try:
            yield self
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            try:
                self.draw(controller)
            finally:
                self.drawing = False
