"""The cooperation-competition rule shared by every strategy (Section 3.3).

Cooperation: each UAV scores its paths against the shared map and the others' paths (current
bests or last predictions, as soft constraints through F_r, eq. 10).
Competition: in order of falling J1 each UAV keeps its best path unless, at some future step, it
comes within `proximity` cells of a path already kept (0: claims the same cell); then it
re-optimises with the kept paths as hard constraints (no shared cell). Every kept path is final,
so one pass leaves no shared cell."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from planner.search.problem import Decision, Searcher, StepProblem

BestPath = Callable[[StepProblem, Searcher, np.ndarray, np.ndarray], "Decision | None"]


def fixed_others(problem: StepProblem, group: set[int], hard_paths: dict[int, np.ndarray] | None = None,
                 soft_paths: dict[int, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The future cells (n x Np x 2) of the vehicles outside the optimised `group`, and whether
    each row is hard: committed futures and `hard_paths` hard, `soft_paths` and the remaining
    predictions soft."""
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


def others_for(problem: StepProblem, uav_id: int, winners: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every other vehicle's future cells and whether each is hard (`winners` hard)."""
    return fixed_others(problem, {uav_id}, winners)


def padded_cells(path: np.ndarray, np_steps: int) -> np.ndarray:
    """A decision's (x, y) cells padded with -1 to Np rows."""
    out = np.full((np_steps, 2), -1, dtype=np.int64)
    out[: len(path)] = path[:, :2]
    return out


def paths_conflict(a: np.ndarray, b: np.ndarray, proximity: float = 0.0) -> bool:
    """True when two (Np, 2) futures come within `proximity` cells at the same step (cells
    of -1, unknown, never conflict)."""
    limit = proximity * proximity + 1e-9
    for (ax, ay), (bx, by) in zip(a.tolist(), b.tolist()):
        if ax >= 0 and bx >= 0 and (ax - bx) ** 2 + (ay - by) ** 2 <= limit:
            return True
    return False


def conflicts_with_any(a: np.ndarray, kept: np.ndarray, proximity: float = 0.0) -> bool:
    """`paths_conflict(a, b, proximity)` for any row b of `kept` (K x Np x 2, `a` Np x 2), in
    one array operation (a fleet of N UAVs checks N paths against up to N kept ones each step)."""
    if kept.shape[0] == 0:
        return False
    limit = proximity * proximity + 1e-9
    dx = kept[:, :, 0] - a[None, :, 0]
    dy = kept[:, :, 1] - a[None, :, 1]
    return bool(np.any((a[None, :, 0] >= 0) & (kept[:, :, 0] >= 0) & (dx * dx + dy * dy <= limit)))


def j1_or_none(decision: Decision | None) -> float:
    """A decision's J1; -inf without one (it competes last)."""
    return decision.j1 if decision is not None else -np.inf


def independent_paths(problem: StepProblem, best_path: BestPath) -> dict[int, Decision | None]:
    """Every searcher's best path on its own, against the others' committed and predicted cells."""
    first: dict[int, Decision | None] = {}
    for s in problem.searchers:
        others, hard = others_for(problem, s.uav_id, {})
        first[s.uav_id] = best_path(problem, s, others, hard)
    return first


def compete(problem: StepProblem, best_path: BestPath, first: dict[int, Decision | None] | None = None,
            proximity: float = 0.0, undecided_soft: bool = False) -> dict[int, Decision | None]:
    """Decide every searcher's path from its `first` one (default: `independent_paths`): in
    order of falling J1 each keeps it unless it conflicts with a path already kept, in which case
    it re-optimises (`best_path`) with the kept paths hard and, with `undecided_soft`, the first
    paths of the UAVs not yet decided soft."""
    if first is None:
        first = independent_paths(problem, best_path)
    order = sorted(problem.searchers, key=lambda s: -j1_or_none(first[s.uav_id]))
    kept: dict[int, np.ndarray] = {}
    kept_cells = np.empty((len(order), problem.np_steps, 2), dtype=np.int64)  # kept's values, in order
    decided: dict[int, Decision | None] = {}
    for s in order:
        d = first[s.uav_id]
        if d is not None:
            cells = padded_cells(d.path, problem.np_steps)
            if conflicts_with_any(cells, kept_cells[: len(kept)], proximity):
                undecided = {uid: padded_cells(p.path, problem.np_steps) for uid, p in first.items()
                             if uid not in kept and uid != s.uav_id and p is not None} if undecided_soft else None
                others, hard = fixed_others(problem, {s.uav_id}, kept, undecided)
                redo = best_path(problem, s, others, hard)
                if redo is not None:
                    redo.evaluations += d.evaluations
                d = redo
        decided[s.uav_id] = d
        if d is not None:
            kept_cells[len(kept)] = padded_cells(d.path, problem.np_steps)
            kept[s.uav_id] = kept_cells[len(kept)]
    return decided
