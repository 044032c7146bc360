"""The result of a closed search: one closed trajectory per UAV plus what was found."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

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
    uav_id: int
    airport: tuple[int, int]
    start_heading: int
    range_steps: int
    trajectory: list[TrajectoryPoint]
    search_steps: int
    return_steps: int
    return_reason: ReturnReason | None
    return_step: int | None
    tracking_efficiency: float | None = None

    @property
    def eta(self) -> float:
        """Range utilisation of eq. (25)."""
        return (self.search_steps + self.return_steps) / self.range_steps

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
    scenario: str
    nx: int
    ny: int
    no_fly: np.ndarray
    uavs: list[UavPlan]
    targets: list[TargetOutcome]
    false_alarms: int
    settings: dict[str, object] = field(default_factory=dict)
    success: Success | None = None

    @property
    def targets_found(self) -> int:
        return sum(t.found_step is not None for t in self.targets)

    @property
    def mean_eta(self) -> float:
        return float(np.mean([u.eta for u in self.uavs])) if self.uavs else 0.0

    @property
    def steps(self) -> int:
        return max(len(u.trajectory) - 1 for u in self.uavs) if self.uavs else 0
