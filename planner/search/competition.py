"""The cooperation-competition rule shared by every strategy (Section 3.3).

Cooperation: each UAV scores its paths against the shared map and the others' current paths.
Competition: when best paths claim the same cell at the same step, the UAV with the higher J1
keeps it and the others re-optimise with the winners' paths as hard constraints."""

from __future__ import annotations

from typing import Callable

import numpy as np

from planner.search.problem import Decision, Searcher, StepProblem

BestPath = Callable[[StepProblem, Searcher, np.ndarray, np.ndarray], "Decision | None"]


def others_for(problem: StepProblem, uav_id: int, winners: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every other vehicle's future cells (n x Np x 2) and whether each is hard."""
    rows, hard = [], []
    for other_id, cells in problem.committed.items():
        if other_id != uav_id:
            rows.append(cells)
            hard.append(True)
    for other_id, cells in winners.items():
        if other_id != uav_id and other_id not in problem.committed:
            rows.append(cells)
            hard.append(True)
    for other_id, cells in problem.predicted.items():
        if other_id != uav_id and other_id not in problem.committed and other_id not in winners:
            rows.append(cells)
            hard.append(False)
    if not rows:
        return np.full((0, problem.np_steps, 2), -1, dtype=np.int64), np.zeros(0, dtype=np.bool_)
    return np.ascontiguousarray(np.stack(rows), dtype=np.int64), np.array(hard, dtype=np.bool_)


def padded_cells(path: np.ndarray, np_steps: int) -> np.ndarray:
    """A decision's (x, y) cells padded with -1 to Np rows."""
    out = np.full((np_steps, 2), -1, dtype=np.int64)
    out[: len(path)] = path[:, :2]
    return out


def claimed_cells(path: np.ndarray) -> set[tuple[int, int, int]]:
    """(step, x, y) of a decision's path, step 0 being the next step."""
    return {(q, x, y) for q, (x, y, _h) in enumerate(path.tolist())}


def compete(problem: StepProblem, best_path: BestPath) -> dict[int, Decision | None]:
    """Decide every searcher's path: independent best paths first, then, in order of falling
    J1, each keeps its path unless it claims a winner's cell, in which case it re-optimises."""
    first: dict[int, Decision | None] = {}
    for s in problem.searchers:
        others, hard = others_for(problem, s.uav_id, {})
        first[s.uav_id] = best_path(problem, s, others, hard)
    order = sorted(problem.searchers, key=lambda s: -(first[s.uav_id].j1 if first[s.uav_id] else -np.inf))
    winners: dict[int, np.ndarray] = {}
    claimed: set[tuple[int, int, int]] = set()
    decided: dict[int, Decision | None] = {}
    for s in order:
        d = first[s.uav_id]
        if d is not None and claimed & claimed_cells(d.path):
            others, hard = others_for(problem, s.uav_id, winners)
            redo = best_path(problem, s, others, hard)
            if redo is not None:
                redo.evaluations += d.evaluations
            d = redo
        decided[s.uav_id] = d
        if d is not None:
            winners[s.uav_id] = padded_cells(d.path, problem.np_steps)
            claimed |= claimed_cells(d.path)
    return decided
