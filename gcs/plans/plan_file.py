"""The plan JSON file: the planner's `Plan` with the paper's 1-based cell numbers.

The schema is `gcs/schemas/plan.schema.json`; `plan_to_dict` output always validates. The
probability of success (`planner.success`) is in `summary` and per UAV when the plan has it. Plans
made from an area file (`gcs plan --area`) also carry the grid's geo-reference (`grid.georef`), the
latitude/longitude of every trajectory step's cell centre, and each UAV's mission waypoints."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

import numpy as np

from planner.area_grid import AreaGrid
from planner.plan import Plan

SCHEMA_VERSION = 1


@lru_cache(maxsize=1)
def plan_schema() -> dict:
    return json.loads(resources.files("gcs").joinpath("schemas/plan.schema.json").read_text())


def georef_dict(area: AreaGrid) -> dict:
    """Where the grid lies on the Earth: cell (x, y) (1-based) has its centre at local
    (east0 + (x - 0.5) * cell, north0 + (y - 0.5) * cell) metres in `projection`."""
    return {
        "crs": "EPSG:4326",
        "projection": area.frame.proj_string,
        "origin": {"lat": area.frame.lat0_deg, "lon": area.frame.lon0_deg},
        "cell_size_m": area.grid.cell_size_m,
        "east0_m": area.grid.east0_m,
        "north0_m": area.grid.north0_m,
        "margin_m": area.margin_m,
        "edge_blocked_cells": area.edge_blocked,
    }


def plan_to_dict(plan: Plan, seed: int | None = None, area: AreaGrid | None = None,
                 uav_extra: dict[int, dict] | None = None, bound: dict | None = None) -> dict:
    """The JSON form of a plan (cells 1-based, x east, y north). With `area`, the grid's
    geo-reference and every step's lat/lon are added; `uav_extra[uav_id]` adds members to a UAV;
    `bound` is `summary.bound` (`gcs.plans.plan_bound.bound_summary`)."""
    no_fly = [[int(x) + 1, int(y) + 1] for x, y in np.argwhere(plan.no_fly)]
    data = _core_dict(plan, seed, no_fly)
    if bound is not None:
        data["summary"]["bound"] = bound
    if area is not None:
        data["grid"]["georef"] = georef_dict(area)
        for uav, u in zip(data["uavs"], plan.uavs):
            latlon = area.cells_lonlat(np.array([(p.x, p.y) for p in u.trajectory]))
            for point, (lat, lon) in zip(uav["trajectory"], latlon):
                point["lat"] = round(float(lat), 9)
                point["lon"] = round(float(lon), 9)
    for uav in data["uavs"]:
        uav.update((uav_extra or {}).get(uav["id"], {}))
    return data


def _core_dict(plan: Plan, seed: int | None, no_fly: list[list[int]]) -> dict:
    data = {
        "schema_version": SCHEMA_VERSION,
        "scenario": plan.scenario,
        "seed": seed,
        "settings": dict(plan.settings),
        "grid": {"nx": plan.nx, "ny": plan.ny, "no_fly": no_fly},
        "uavs": [
            {
                "id": u.uav_id,
                "airport": [u.airport[0] + 1, u.airport[1] + 1],
                "start_heading": u.start_heading,
                "range": u.range_units,
                "search_steps": u.search_steps,
                "return_steps": u.return_steps,
                "eta": round(u.eta, 6),
                "return_reason": u.return_reason.value if u.return_reason else None,
                "return_step": u.return_step,
                "tracking_efficiency": u.tracking_efficiency,
                "trajectory": [
                    {"step": p.step, "x": p.x + 1, "y": p.y + 1, "heading": p.heading, "stage": p.stage.value}
                    for p in u.trajectory
                ],
            }
            for u in plan.uavs
        ],
        "targets": [
            {"x": t.x + 1, "y": t.y + 1, "found_step": t.found_step, "found_by": t.found_by} for t in plan.targets
        ],
        **({"targets_found_before": [{"x": x + 1, "y": y + 1, "sortie": k} for x, y, k in plan.found_before]}
           if plan.found_before else {}),
        "summary": {
            "targets_found": plan.targets_found,
            "targets": len(plan.targets),
            "false_alarms": plan.false_alarms,
            "mean_eta": round(plan.mean_eta, 6),
            "steps": plan.steps,
        },
    }
    pos = plan.success
    if pos is not None:
        data["summary"].update({"expected_targets_found": round(pos.expected, 6),
                                "expected_targets_in_area": round(pos.available, 6),
                                "probability_of_success": round(pos.share, 6)})
        for uav in data["uavs"]:
            uav["expected_targets_found"] = round(pos.by_uav.get(uav["id"], 0.0), 6)
            uav["probability_of_success"] = round(pos.share_of(uav["id"]), 6)
    return data


def validate_plan_dict(data: dict) -> None:
    """Raise jsonschema.ValidationError when `data` does not follow the plan schema."""
    import jsonschema  # ~0.1 s to import: only where a plan is checked, never while one is made

    jsonschema.validate(data, plan_schema())
