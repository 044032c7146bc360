"""The plan JSON file: the planner's `Plan` with the paper's 1-based cell numbers.

The schema is `gcs/schemas/plan.schema.json`; `plan_to_dict` output always validates."""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

import jsonschema
import numpy as np

from planner.plan import Plan

SCHEMA_VERSION = 1


@lru_cache(maxsize=1)
def plan_schema() -> dict:
    return json.loads(resources.files("gcs").joinpath("schemas/plan.schema.json").read_text())


def plan_to_dict(plan: Plan, seed: int | None = None) -> dict:
    """The JSON form of a plan (cells 1-based, x east, y north)."""
    no_fly = [[int(x) + 1, int(y) + 1] for x, y in np.argwhere(plan.no_fly)]
    return {
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
                "range": u.range_steps,
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
        "summary": {
            "targets_found": plan.targets_found,
            "targets": len(plan.targets),
            "false_alarms": plan.false_alarms,
            "mean_eta": round(plan.mean_eta, 6),
            "steps": plan.steps,
        },
    }


def validate_plan_dict(data: dict) -> None:
    """Raise jsonschema.ValidationError when `data` does not follow the plan schema."""
    jsonschema.validate(data, plan_schema())
