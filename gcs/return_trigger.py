"""The fuel-based return trigger: DTSCS's range check (eq. 23-24) on live battery state.

Pure functions, no I/O. Ranges are counted in planner steps (cells). One step is charged
`step_m` metres of flight: the planner charges cell * sqrt(2) (every step as if diagonal, see
docs/areas.md), so the same charge here keeps the estimate on the safe side.

The remaining range comes from the battery: the usable charge (remaining % above the reserve)
divided by the drain rate gives seconds of flight, times the cruise speed gives metres, over
`step_m` gives steps. The drain rate is the larger of the autopilot's own estimate
(BATTERY_STATUS.time_remaining, when it sends one) and the rate observed over recent samples,
so a battery draining faster than planned shortens the range as soon as it shows.

The decision (eq. 23 at step k+1, Algorithm 3): keep searching while, after one more step, the
lowest-cost return from the next pose (the exact table under the OC), plus the descent, plus a
reserve, is still covered; otherwise return now."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["RangeModel", "ReturnCheck", "check_return", "drain_rate_pct_s", "landing_steps", "range_left_steps",
           "battery_drain_pct_s"]


@dataclass(frozen=True, slots=True, kw_only=True)
class RangeModel:
    """How battery turns into steps: metres charged per step, cruise and descent speed, and the
    charge (%) kept back, so a vehicle that returns on time lands with at least `reserve_pct`."""

    step_m: float
    speed_m_s: float
    reserve_pct: float = 30.0
    descent_m_s: float = 1.5

    def __post_init__(self) -> None:
        if not (self.step_m > 0 and self.speed_m_s > 0 and self.descent_m_s > 0):
            raise ValueError("step length, speed and descent rate must be positive")
        if not 0 <= self.reserve_pct < 100:
            raise ValueError(f"reserve must be in [0, 100) %, got {self.reserve_pct}")


def drain_rate_pct_s(samples: Sequence[tuple[float, float]], min_span_s: float = 5.0) -> float | None:
    """Least-squares drain (% per second, positive when draining) over (time_s, remaining_pct)
    samples; None while they span less than `min_span_s`."""
    if len(samples) < 2 or samples[-1][0] - samples[0][0] < min_span_s:
        return None
    n = len(samples)
    mt = sum(t for t, _ in samples) / n
    mp = sum(p for _, p in samples) / n
    var = sum((t - mt) ** 2 for t, _ in samples)
    if var <= 0:
        return None
    slope = sum((t - mt) * (p - mp) for t, p in samples) / var
    return max(0.0, -slope)


def battery_drain_pct_s(remaining_pct: float | None, time_remaining_s: float | None,
                        observed_pct_s: float | None) -> float | None:
    """The drain to plan with: the larger of the autopilot's estimate (remaining % over its time
    remaining, when it reports one) and the observed rate; None when neither is known."""
    candidates = []
    if remaining_pct is not None and time_remaining_s and time_remaining_s > 0:
        candidates.append(remaining_pct / time_remaining_s)
    if observed_pct_s is not None:
        candidates.append(observed_pct_s)
    return max(candidates) if candidates else None


def range_left_steps(remaining_pct: float | None, drain_pct_s: float | None, model: RangeModel) -> float:
    """Steps the charge above the reserve still buys; infinite while the drain is unknown,
    0 when the charge is at or below the reserve (or unknown with a known drain)."""
    if drain_pct_s is None or drain_pct_s <= 0:
        return math.inf
    if remaining_pct is None:
        return 0.0
    usable = remaining_pct - model.reserve_pct
    if usable <= 0:
        return 0.0
    return usable / drain_pct_s * model.speed_m_s / model.step_m


def landing_steps(altitude_m: float, model: RangeModel) -> float:
    """The descent from `altitude_m`, charged as the steps the same flight time would buy."""
    return max(0.0, altitude_m) / model.descent_m_s * model.speed_m_s / model.step_m


@dataclass(frozen=True, slots=True)
class ReturnCheck:
    """`cost` = 1 step + the return from the next pose + the descent + the reserve steps;
    `margin` = range_left - cost (steps); `must_return` when the margin is negative."""

    range_left: float
    cost: float
    margin: float
    must_return: bool


def check_return(range_left: float, return_steps_after_step: float, descent_steps: float = 0.0,
                 reserve_steps: float = 0.0) -> ReturnCheck:
    """Eq. (23) at k+1: return now unless one more step and the way home after it still fit."""
    if math.isnan(range_left) or math.isnan(return_steps_after_step):
        return ReturnCheck(range_left, math.inf, -math.inf, True)
    cost = 1.0 + return_steps_after_step + descent_steps + reserve_steps
    margin = range_left - cost
    return ReturnCheck(range_left, cost, margin, margin < 0)
