"""How close a plan is to the best any plan could do: the upper bound on its expected finds
(`planner.bound`, HiGHS) as `gcs plan` reports it, in plan.json's `summary.bound` and the summary
table (`gcs.display.plan_tables`). A bound not had within the time allowed is said, not guessed.
The seconds it took are not written: the same seed writes the same plan.json."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from planner.motion import OrientationConstraint
    from planner.plan import Plan
    from planner.scenario import Scenario

#: `gcs plan --bound-time`'s default: seconds for the bound, building the model included.
DEFAULT_BOUND_TIME_S = 5.0

#: Flow arcs of the model per second allowed: HiGHS solves the LP of 5,000 arcs in about 0.3 s
#: of one core (a 20 x 20 area, the paper's 50 x 50), so the model fits the time on a loaded machine.
ARCS_PER_SECOND = 1000


def _number(value: float) -> float | None:
    return round(value, 6) if math.isfinite(value) else None


def bound_summary(plan: Plan, scenario: Scenario, oc: OrientationConstraint, seconds: float) -> dict[str, Any] | None:
    """plan.json's `summary.bound` for `plan` of `scenario` under `oc`, the bound given
    `seconds` (None when `seconds` is 0: no bound asked for). The LP relaxation only: the MIP's
    dual bound never improved on it on the examples but for `large` (docs/success.md), and it
    would take all the time given (benchmarks/success_bound.py reports both); where the
    per-heading LP is too large, the Lagrangian dual of it too when it fits the time, the smaller
    reported."""
    if seconds <= 0 or plan.success is None:
        return None
    from planner.bound import success_bound

    b = success_bound(scenario, oc, seconds, mip=False, max_arcs=max(1000, int(ARCS_PER_SECOND * seconds)))
    out: dict[str, Any] = {"time_limit_s": seconds, "finished": b.finished, "model": b.model.value, "block": b.block}
    share = b.share(plan.success.expected)
    if share is not None:
        available = plan.success.available
        out.update({"expected_targets_found_max": _number(b.value),
                    "probability_of_success_max": round(b.value / available, 6) if available > 0 else 0.0,
                    "share_of_max": round(share, 6)})
    return out
