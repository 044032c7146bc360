"""Coevolution PIO with the cooperation-competition mechanism (Section 3.3).

One subgroup of C1 pigeons per searching UAV, all run in lock-step by one kernel
(`planner.search.pio.pio_flocks`).

Cooperation: every subgroup scores its pigeons against the shared map and against the other
subgroups' *current* best paths (re-read every iteration), so F_r of eq. (10) steers the UAVs
apart while they are being optimised. Each subgroup's row starts as its UAV's previous prediction,
and its first pigeon on the rest of that path (warm start, as for PIO, PSO and GA).

Competition: two best paths conflict when, at the same future step, they claim the same cell or
come within `proximity` (sqrt 2, where F_r turns into the -100 penalty). In order of falling J1
each subgroup keeps its path unless it conflicts with a path already kept; then it re-optimises
(a fresh basic-PIO run) with the kept paths as hard constraints (no shared cell) and the
undecided ones as soft (F_r). Every kept path is final, so one pass leaves no shared cell;
a re-optimised path may stay within sqrt 2 only when no path avoids it."""

from __future__ import annotations

import numpy as np

from planner.search.competition import padded_cells
from planner.search.flock import (
    decision_from_choices,
    path_cells,
    turn_ordered,
)
from planner.search.pio import PioParams, PioStrategy, run_pio
from planner.search.problem import Decision, StepProblem

PROXIMITY = float(np.sqrt(2.0))


def paths_conflict(a: np.ndarray, b: np.ndarray, proximity: float = PROXIMITY) -> bool:
    """True when two (Np, 2) futures come within `proximity` cells at the same step."""
    limit = proximity * proximity + 1e-9
    for (ax, ay), (bx, by) in zip(a.tolist(), b.tolist()):
        if ax >= 0 and bx >= 0 and (ax - bx) ** 2 + (ay - by) ** 2 <= limit:
            return True
    return False


def fixed_others(problem: StepProblem, group: set[int], hard_paths: dict[int, np.ndarray] | None = None,
                 soft_paths: dict[int, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Vehicles outside the optimised group: committed futures and `hard_paths` as hard rows,
    `soft_paths` and the remaining predictions as soft rows."""
    rows, hard = [], []
    hard_paths = hard_paths or {}
    soft_paths = soft_paths or {}
    for uid, cells in problem.committed.items():
        if uid not in group:
            rows.append(cells)
            hard.append(True)
    for uid, cells in hard_paths.items():
        if uid not in group and uid not in problem.committed:
            rows.append(cells)
            hard.append(True)
    for uid, cells in soft_paths.items():
        if uid not in group and uid not in problem.committed and uid not in hard_paths:
            rows.append(cells)
            hard.append(False)
    for uid, cells in problem.predicted.items():
        if uid not in group and uid not in problem.committed and uid not in hard_paths and uid not in soft_paths:
            rows.append(cells)
            hard.append(False)
    if not rows:
        return np.full((0, problem.np_steps, 2), -1, dtype=np.int64), np.zeros(0, dtype=np.bool_)
    return np.ascontiguousarray(np.stack(rows), dtype=np.int64), np.array(hard, dtype=np.bool_)


class CpioStrategy(PioStrategy):
    """CPIO: coevolving subgroups (cooperation), then the competition rule. `best_path` (one
    subgroup alone against fixed others) is basic PIO."""

    name = "cpio"

    def __init__(self, params: PioParams | None = None, seed: int = 0, proximity: float = PROXIMITY,
                 warm_start: bool = True) -> None:
        super().__init__(params, seed, warm_start)
        self.proximity = proximity

    def coevolve(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        """Cooperation: all subgroups optimised together, each against the others' current bests."""
        searchers = problem.searchers
        ids = {s.uav_id for s in searchers}
        fixed, fixed_hard = fixed_others(problem, ids)
        start = [problem.predicted.get(s.uav_id) for s in searchers]
        warm = None
        if self.memory is not None:
            table = turn_ordered(problem.successors)
            warm = [self.memory.warm_row(s, table, problem.np_steps) for s in searchers]
        best, others, trace, evaluations = run_pio(problem, searchers, fixed, fixed_hard, self.params, rng, start,
                                                   warm)
        n_fixed = fixed.shape[0]
        out: dict[int, Decision | None] = {}
        for g, s in enumerate(searchers):
            keep = np.ones(others.shape[0], dtype=np.bool_)
            keep[n_fixed + g] = False
            o = np.ascontiguousarray(others[keep])
            h = np.concatenate([fixed_hard, np.zeros(len(searchers) - 1, dtype=np.bool_)])
            out[s.uav_id] = decision_from_choices(problem, s, o, h, best[g], evaluations // len(searchers), trace[g])
        return out

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        first = self.coevolve(problem, rng)
        by_id = {s.uav_id: s for s in problem.searchers}
        order = sorted(problem.searchers, key=lambda s: -(first[s.uav_id].j1 if first[s.uav_id] else -np.inf))
        kept: dict[int, np.ndarray] = {}
        decided: dict[int, Decision | None] = {}
        for s in order:
            d = first[s.uav_id]
            cells = path_cells(d, problem.np_steps)
            if d is not None and any(paths_conflict(cells, w, self.proximity) for w in kept.values()):
                undecided = {uid: path_cells(first[uid], problem.np_steps) for uid in by_id
                             if uid not in kept and uid != s.uav_id and first[uid] is not None}
                others, hard = fixed_others(problem, {s.uav_id}, kept, undecided)
                redo = self.best_path(problem, s, others, hard, rng)
                if redo is not None:
                    redo.evaluations += d.evaluations
                d = redo
            decided[s.uav_id] = d
            if d is not None:
                kept[s.uav_id] = padded_cells(d.path, problem.np_steps)
            if self.memory is not None:
                self.memory.remember(s.uav_id, d)
        return decided
