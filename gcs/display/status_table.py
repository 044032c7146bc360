"""Terminal rendering of the fleet: the live status table and the end-of-flight summary.
Pure text from the controller's state; the caller decides where and how often to print."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController
    from gcs.plans.plan_folder import FleetPlan
    from gcs.telemetry.status import VehicleStatus

__all__ = ["render_summary", "render_table", "targets_found"]


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
    return margin (planner steps), detections."""
    plan = controller.plan
    head = (f"{'UAV':>3} {'stage':<10} {'mode':<9} {'lat':>11} {'lon':>12} {'alt m':>6} {'cell':>9} "
            f"{'batt %':>6} {'range':>6} {'margin':>6} {'hits':>4}  note")
    rows = [head]
    for uid, st in sorted(controller.status.items()):
        hits = sum(d.hit for d in st.detections)
        lat = _num(st.lat_deg, ".6f") if st.has_position else "-"
        lon = _num(st.lon_deg, ".6f") if st.has_position else "-"
        rows.append(f"{uid:>3} {st.stage.value:<10} {st.mode_name[:9]:<9} {lat:>11} {lon:>12} "
                    f"{st.rel_alt_m:>6.1f} {_cell(plan, st):>9} {_num(st.battery_pct, '.0f'):>6} "
                    f"{_num(st.range_left, '.1f'):>6} {_num(st.margin, '.1f'):>6} {hits:>4}  {st.note[:60]}")
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
    it returned, readings; then the fleet's targets found."""
    plan = controller.plan
    rows = [f"{'UAV':>3} {'name':<12} {'end':<8} {'from airport m':>14} {'batt %':>6} {'returned':<10} "
            f"{'looks':>5} {'hits':>4}  note"]
    for uid, st in sorted(controller.status.items()):
        task = plan.uavs[uid]
        away = "-"
        if st.has_position:
            e0, n0 = plan.local_m(*task.airport_lat_lon)
            e1, n1 = plan.local_m(st.lat_deg, st.lon_deg)
            away = f"{math.hypot(e1 - e0, n1 - n0):.1f}"
        batt = st.battery_at_landing if st.battery_at_landing is not None else st.battery_pct
        rows.append(f"{uid:>3} {task.name[:12]:<12} {st.stage.value:<8} {away:>14} {_num(batt, '.0f'):>6} "
                    f"{st.return_reason or 'plan':<10} {len(st.detections):>5} {sum(d.hit for d in st.detections):>4}"
                    f"  {st.note[:70]}")
    found, false_alarms = targets_found(controller)
    landed = sum(st.stage.value == "landed" for st in controller.status.values())
    rows.append(f"{landed}/{len(controller.status)} landed; targets found {len(found)}/{len(plan.targets)}, "
                f"positive readings elsewhere {false_alarms}")
    return "\n".join(rows)
