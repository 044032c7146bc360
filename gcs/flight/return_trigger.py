"""The fuel-based return trigger: DTSCS's range check (eq. 23-24) on live battery state.

Pure functions, no I/O. Ranges are counted in planner steps (cells). One step is charged
`step_m` metres of flight: the planner charges cell * sqrt(2) (every step as if diagonal, see
docs/areas.md), so the same charge here keeps the estimate on the safe side.

The remaining range comes from the battery and a consumption figure learned in flight: the
charge one planner step costs, the least-squares slope of remaining % against the steps flown
along the plan, over the samples taken since take-off. It is measured in the planner's own unit,
so it carries the vehicle's real speed on this plan's legs, its turns, wind and climb. Until the
vehicle has flown `MIN_STEPS` steps and used `MIN_DROP_PCT` (the autopilot reports whole percent),
the figure comes from time: the drain per second (the larger of the autopilot's own estimate,
when it sends one, and the observed rate) times the seconds a step takes at the cruise speed.
The descent at the airport is charged by time at the observed drain. Then

    range left = (remaining % - reserve % - descent %) / (% per step)

A battery that drains faster than planned shortens the range as soon as it shows.

The decision is the planner's own range check (`planner.range_check.check_return`, eq. 23 at
step k+1, Algorithm 3): keep searching while, after one more step, the lowest-cost return from
the next pose (the exact table under the OC) and the descent are still covered by the range left;
otherwise return now."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from planner.range_check import ReturnCheck, check_return

__all__ = ["RangeModel", "ReturnCheck", "battery_drain_pct_s", "check_return", "consumption_pct_per_step",
           "drain_rate_pct_s", "estimate_range_steps", "landing_seconds", "range_left_steps"]

MIN_STEPS = 5.0
MIN_DROP_PCT = 2.0


@dataclass(frozen=True, slots=True, kw_only=True)
class RangeModel:
    """How battery turns into steps: metres charged per step, cruise and descent speed, and the
    charge (%) kept back, so a vehicle that returns on time lands with at least `reserve_pct`."""

    step_m: float
    speed_m_s: float
    reserve_pct: float = 30.0
    descent_m_s: float = 1.5
    final_descent_m_s: float = 0.5
    final_descent_m: float = 10.0

    def __post_init__(self) -> None:
        if not (self.step_m > 0 and self.speed_m_s > 0 and self.descent_m_s > 0 and self.final_descent_m_s > 0):
            raise ValueError("step length, speed and descent rates must be positive")
        if not 0 <= self.reserve_pct < 100:
            raise ValueError(f"reserve must be in [0, 100) %, got {self.reserve_pct}")


def _falling_slope(xs: Sequence[float], ys: Sequence[float]) -> float | None:
    """Least-squares -dy/dx (positive when y falls as x grows); None when x does not vary."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    var = sum((x - mx) ** 2 for x in xs)
    if var <= 0:
        return None
    return max(0.0, -sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / var)


def drain_rate_pct_s(samples: Sequence[tuple[float, ...]], min_span_s: float = 5.0) -> float | None:
    """Least-squares drain (% per second, positive when draining) over (time_s, remaining_pct,
    ...) samples; None while they span less than `min_span_s`."""
    if len(samples) < 2 or samples[-1][0] - samples[0][0] < min_span_s:
        return None
    return _falling_slope([s[0] for s in samples], [s[1] for s in samples])


def consumption_pct_per_step(samples: Sequence[tuple[float, float, float]], min_steps: float = MIN_STEPS,
                             min_drop_pct: float = MIN_DROP_PCT) -> float | None:
    """Charge one planner step costs (% per step) over (time_s, remaining_pct, steps_flown)
    samples; None until they span `min_steps` steps and `min_drop_pct` of charge."""
    if len(samples) < 2:
        return None
    if samples[-1][2] - samples[0][2] < min_steps or samples[0][1] - samples[-1][1] < min_drop_pct:
        return None
    return _falling_slope([s[2] for s in samples], [s[1] for s in samples])


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


def estimate_range_steps(remaining_pct: float | None, time_remaining_s: float | None,
                         samples: Sequence[tuple[float, float, float]], model: RangeModel,
                         descent_s: float = 0.0) -> float:
    """Steps the charge above the reserve still buys after a descent of `descent_s` (see the
    module doc): by the learned cost per step once known, else by time at the cruise speed;
    infinite while neither is known, 0 when the charge is at or below what is kept back."""
    per_s = battery_drain_pct_s(remaining_pct, time_remaining_s, drain_rate_pct_s(samples))
    per_step = consumption_pct_per_step(samples)
    if per_step is None or per_step <= 0:
        if per_s is None or per_s <= 0:
            return math.inf
        per_step = per_s * model.step_m / model.speed_m_s
    if remaining_pct is None:
        return 0.0
    descent_pct = descent_s * per_s if per_s else 0.0
    return max(0.0, remaining_pct - model.reserve_pct - descent_pct) / per_step


def landing_seconds(altitude_m: float, model: RangeModel) -> float:
    """The descent from `altitude_m`: at `descent_m_s`, and the last `final_descent_m` at
    `final_descent_m_s` (ArduCopter lands the last 10 m at LAND_SPEED, 0.5 m/s)."""
    alt = max(0.0, altitude_m)
    final = min(alt, model.final_descent_m)
    return (alt - final) / model.descent_m_s + final / model.final_descent_m_s
