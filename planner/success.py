"""Probability of success of a plan: the expected number of targets it finds under the paper's
model, and that number as a share of the targets the area is expected to hold.

Section 2.1 gives each cell a target existence probability P0 (the prior TEP) and the sensor a
detection probability Pc; a target is found at the first report in its cell (a false alarm finds
nothing). Readings are independent, so a target in a cell looked at n times is found with
probability 1 - (1 - Pc)^n, and the expected number found is

    E = sum over searchable cells c of P0(c) * (1 - (1 - Pc)^n(c)),

where n(c) counts every reading that covers c: every cell flown (search and return), the airport
as the UAV climbs out of it (step 0), and with a footprint of radius r every cell within r of
the UAV's cell. The area is expected to hold sum P0(c) over searchable cells (not in a no-fly
cell); E over that is the share. Pf does not enter: a false report finds no target.

Each look is credited with its marginal gain P0(c) Pc (1 - Pc)^(k-1) (k-th look at c), in the
order the looks happen (by step, then in plan order within a step), so the parts of the UAVs add
up to E exactly (the sum telescopes) and a second look at a cell is worth a tenth of the first
(Pc = 0.9). A later sortie over the same area starts from `looks_before`, the earlier sorties'
counts, so a campaign's expected finds is the sum of its sorties'."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from planner.environment import footprint_cells

__all__ = ["Success", "SuccessTally", "expected_finds", "plan_looks", "success_of_looks"]


@dataclass(frozen=True)
class Success:
    """Expected targets found, in total and per UAV, and after every step.

    `steps[j]` is a step number and `cumulative[j]` the expected finds of all looks up to and
    including that step (`cumulative_by_uav[uid][j]` the part of UAV uid)."""

    expected: float
    available: float
    by_uav: dict[int, float]
    steps: np.ndarray = field(repr=False)
    cumulative: np.ndarray = field(repr=False)
    cumulative_by_uav: dict[int, np.ndarray] = field(repr=False)

    @property
    def share(self) -> float:
        """Expected finds over the targets the area is expected to hold (0 when it holds none)."""
        return self.expected / self.available if self.available > 0 else 0.0

    def share_of(self, uav_id: int) -> float:
        return self.by_uav.get(uav_id, 0.0) / self.available if self.available > 0 else 0.0


def expected_finds(prior: np.ndarray, searchable: np.ndarray, pc: float, looks: np.ndarray) -> float:
    """E = sum P0 (1 - (1 - Pc)^n) over searchable cells, `looks[x, y]` = n."""
    p0 = np.where(searchable, prior, 0.0)
    return float(np.sum(p0 * (1.0 - (1.0 - pc) ** np.asarray(looks))))


class SuccessTally:
    """Expected finds added up look by look, each look credited with its marginal gain
    P0(c) Pc (1 - Pc)^(k-1) (k-th look at c, counting `looks_before`)."""

    def __init__(self, prior: np.ndarray, searchable: np.ndarray, pc: float, uav_ids: Iterable[int] = (),
                 looks_before: np.ndarray | None = None) -> None:
        prior = np.asarray(prior, dtype=np.float64)
        self.p0 = np.where(np.asarray(searchable, dtype=bool), prior, 0.0)
        self.pc = float(pc)
        before = np.zeros(prior.shape) if looks_before is None else np.asarray(looks_before, dtype=float)
        self.missed = (1.0 - self.pc) ** before
        self.expected = 0.0
        self.by_uav: dict[int, float] = dict.fromkeys(uav_ids, 0.0)

    @property
    def available(self) -> float:
        return float(self.p0.sum())

    def look(self, uav_id: int, x: int, y: int) -> float:
        """Count one reading of cell (x, y) by UAV `uav_id`; returns its gain."""
        gain = float(self.p0[x, y] * self.missed[x, y] * self.pc)
        self.missed[x, y] *= 1.0 - self.pc
        self.expected += gain
        self.by_uav[uav_id] = self.by_uav.get(uav_id, 0.0) + gain
        return gain


def success_of_looks(prior: np.ndarray, searchable: np.ndarray, pc: float,
                     looks: Iterable[tuple[int, int, int, int]], uav_ids: Iterable[int] = (),
                     looks_before: np.ndarray | None = None) -> Success:
    """The `Success` of `looks`, rows (step, uav_id, x, y) in the order they happen (steps
    non-decreasing), each row one reading of one cell. `looks_before[x, y]` counts readings of
    earlier sorties: they lower what this one can add, and are not part of its finds."""
    tally = SuccessTally(prior, searchable, pc, uav_ids, looks_before)
    steps: list[int] = []
    totals: list[float] = []
    per_uav: dict[int, list[float]] = {uid: [] for uid in tally.by_uav}
    for step, uid, x, y in looks:
        if steps and step < steps[-1]:
            raise ValueError(f"looks must come in step order: step {step} after step {steps[-1]}")
        if not steps or step != steps[-1]:
            steps.append(step)
            totals.append(tally.expected)
            for u in per_uav:
                per_uav[u].append(tally.by_uav[u])
        if uid not in per_uav:
            per_uav[uid] = [0.0] * len(steps)
        tally.look(uid, x, y)
        totals[-1] = tally.expected
        per_uav[uid][-1] = tally.by_uav[uid]
    return Success(tally.expected, tally.available, dict(tally.by_uav), np.array(steps, dtype=np.int64),
                   np.array(totals), {uid: np.array(v) for uid, v in per_uav.items()})


def plan_looks(trajectories: dict[int, list[tuple[int, int, int]]], footprint_radius: int,
               shape: tuple[int, int]) -> list[tuple[int, int, int, int]]:
    """Every reading of a plan as rows (step, uav_id, x, y): per step, the UAVs in the order of
    `trajectories` (uav_id -> [(step, x, y), ...]), each reading its footprint's in-grid cells."""
    by_step: dict[int, list[tuple[int, int, int]]] = {}
    for uid, points in trajectories.items():
        for step, x, y in points:
            by_step.setdefault(step, []).append((uid, x, y))
    rows = []
    for step in sorted(by_step):
        for uid, x, y in by_step[step]:
            rows += [(step, uid, cx, cy) for cx, cy in footprint_cells(x, y, footprint_radius, shape)]
    return rows
