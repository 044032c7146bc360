"""The result of a closed search: one closed trajectory per UAV plus what was found."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from planner.motion import STEPS, MoveCosts
from planner.success import Success


class Stage(str, Enum):
    SEARCH = "search"
    RETURN = "return"
    LANDED = "landed"


class ReturnReason(str, Enum):
    """Why a UAV switched to the return stage."""

    RANGE = "range"              # eq. (24): one more search step would leave it unable to get home
    ORDER = "order"              # a return order
    RANGE_CUT = "range_cut"      # the range was cut below what the way home needs
    BOXED_IN = "boxed_in"        # no feasible search step (every move blocked or claimed)
    SEPARATION = "separation"    # one more search step would leave no way home clear of the others'


@dataclass(frozen=True)
class TrajectoryPoint:
    step: int
    x: int
    y: int
    heading: int
    stage: Stage


@dataclass
class UavPlan:
    """One UAV's closed trajectory. `range_units` is its range T_i and `used_units` what the
    trajectory spends of it, both in the plan's move-cost units (`Plan.move_costs`)."""

    uav_id: int
    airport: tuple[int, int]
    start_heading: int
    range_units: int
    trajectory: list[TrajectoryPoint]
    search_steps: int
    return_steps: int
    return_reason: ReturnReason | None
    return_step: int | None
    tracking_efficiency: float | None = None
    used_units: int | None = None

    @property
    def spent(self) -> int:
        """Range the trajectory spends: `used_units`, or one unit per step when not given."""
        return self.search_steps + self.return_steps if self.used_units is None else self.used_units

    @property
    def eta(self) -> float:
        """Range utilisation of eq. (25): (T_i1 + T_i2) / T_i, over what the steps cost."""
        return self.spent / self.range_units

    @property
    def closed(self) -> bool:
        last = self.trajectory[-1]
        return (last.x, last.y) == self.airport


@dataclass(frozen=True)
class TargetOutcome:
    x: int
    y: int
    found_step: int | None
    found_by: int | None


@dataclass
class Plan:
    """Every UAV's closed trajectory and what was found. Ranges are in `move_costs` units, each
    `unit_m` metres long over a real area (None: abstract steps, as in the paper). `targets` are
    the ones this sortie could find; `found_before` (x, y, sortie) those earlier sorties found."""

    scenario: str
    nx: int
    ny: int
    no_fly: np.ndarray
    uavs: list[UavPlan]
    targets: list[TargetOutcome]
    false_alarms: int
    settings: dict[str, object] = field(default_factory=dict)
    success: Success | None = None
    move_costs: MoveCosts = STEPS
    unit_m: float | None = None
    found_before: list[tuple[int, int, int]] = field(default_factory=list)

    def metres(self, units: float) -> float | None:
        """Move-cost units in metres; None for a plan without a scale (the paper's steps)."""
        return None if self.unit_m is None else units * self.unit_m

    @property
    def targets_found(self) -> int:
        return sum(t.found_step is not None for t in self.targets)

    @property
    def mean_eta(self) -> float:
        return float(np.mean([u.eta for u in self.uavs])) if self.uavs else 0.0

    @property
    def steps(self) -> int:
        return max(len(u.trajectory) - 1 for u in self.uavs) if self.uavs else 0
