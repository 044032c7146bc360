"""DTSCS's range check (Section 5, eq. 23-24): the one rule by which the planner's switch
(`planner.dtscs`) and the live return trigger (`gcs.flight.return_trigger`, on battery state) decide
that a searching UAV must turn home.

Keep searching while one more step and the lowest-cost return from the pose it reaches still fit
in the range left (eq. 23 at step k+1, read as T_i1(k+1) + T_i2(k+1) <= T_i); otherwise return
now (eq. 24). All quantities share one unit: the planner's move-cost units (steps in the paper,
lengths over a real area), metres in the live trigger, which adds the landing; both may keep
some range in reserve."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ReturnCheck", "check_return"]


@dataclass(frozen=True, slots=True)
class ReturnCheck:
    """`cost` = the next step + the return from the pose it reaches + the descent + the reserve;
    `margin` = range_left - cost; `must_return` when the margin is negative."""

    range_left: float
    cost: float
    margin: float
    must_return: bool


def check_return(range_left: float, return_after_step: float, descent: float = 0.0, reserve: float = 0.0,
                 step: float = 1.0) -> ReturnCheck:
    """Eq. (23) at k+1: return now unless one more `step` and the way home after it still fit.
    An unknown (NaN) range or return cost returns."""
    if math.isnan(range_left) or math.isnan(return_after_step):
        return ReturnCheck(range_left, math.inf, -math.inf, True)
    cost = step + return_after_step + descent + reserve
    margin = range_left - cost
    return ReturnCheck(range_left, cost, margin, margin < 0)
