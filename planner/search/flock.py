"""What the population optimisers (PIO, CPIO, PSO, GA) share: the continuous-to-choice encoding,
the scalar fitness, and the scoring of one flock of candidate paths with `score_paths`.

Encoding. A pigeon (particle, chromosome) is Np numbers, one per predicted step. Each is a turn
choice index into a *turn-ordered* successor table: column 0 is the sharpest left turn the OC
allows, the middle column straight on, the last column the sharpest right turn (eq. 18 reads the
position as the orientation L-1, L, L+1). Ordering by turn angle, rather than by heading number
as `OrientationConstraint.successors` does, makes neighbouring positions neighbouring turns, so a
continuous move means something. A continuous position x becomes choice
clamp(floor(x + 0.5), 0, K-1) when evaluated; positions are kept inside [-0.5, K-0.5].

Fitness. `best_two` ranks paths by the length of their valid prefix first (eq. 8 cuts a path where
it leaves the region, meets a hard vehicle or loses its way home) and J1 second; the scalar
fitness `depth * DEPTH_WEIGHT + J1` gives the same order, since |J1| < 31 per step.

Flock layout (arrays only, so every kernel can use it): `poses[g] = (x, y, heading, range flown)`,
`budgets[g]`, `home_tables[g]` and `horizons[g]` (the horizon-value window around the UAV,
G x 0 x 0 when the option is off) per subgroup g; `others` holds first `n_fixed` rows of other
vehicles' cells (committed or predicted), then one row per subgroup for its current best path,
which the other subgroups score against (cooperation) and its own scoring ignores."""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from planner.config import njit
from planner.motion import HEADING_DX, HEADING_DY
from planner.reward import add_terminal_value, score_paths
from planner.search.competition import compete, padded_cells
from planner.search.problem import Decision, PathScorer, Searcher, StepProblem

DEPTH_WEIGHT = 1000.0


@lru_cache(maxsize=16)
def _turn_ordered(table_bytes: bytes, width: int) -> np.ndarray:
    successors = np.frombuffer(table_bytes, dtype=np.int64).reshape(8, width)
    out = np.full_like(successors, -1)
    for h in range(8):
        valid = [int(g) for g in successors[h] if g >= 0]
        signed = [((g - h) % 8) - 8 if (g - h) % 8 > 4 else (g - h) % 8 for g in valid]
        out[h, : len(valid)] = [g for _, g in sorted(zip(signed, valid))]
    out.setflags(write=False)
    return out


def turn_ordered(successors: np.ndarray) -> np.ndarray:
    """The successor table with each row sorted by signed turn, left (-) to right (+); a U-turn
    (8OC) sorts last."""
    table = np.ascontiguousarray(successors, dtype=np.int64)
    return _turn_ordered(table.tobytes(), table.shape[1])


@njit
def clamp_position(x: float, branching: int) -> float:
    """Keep a continuous position inside [-0.5, K-0.5], the span that rounds to a valid choice."""
    if x < -0.5:
        return -0.5
    if x > branching - 0.5:
        return branching - 0.5
    return x


@njit
def decode_positions(positions: np.ndarray, branching: int, choices: np.ndarray) -> None:
    """Round and clamp every continuous position (n x Np) to a turn choice index."""
    for i in range(positions.shape[0]):
        for q in range(positions.shape[1]):
            c = int(np.floor(positions[i, q] + 0.5))
            if c < 0:
                c = 0
            elif c >= branching:
                c = branching - 1
            choices[i, q] = c


@njit
def evaluate_flock(g: int, choices: np.ndarray, n: int, poses: np.ndarray, budgets: np.ndarray,
                   move_costs: np.ndarray, home_tables: np.ndarray, horizons: np.ndarray, successors: np.ndarray,
                   tep: np.ndarray, eu: np.ndarray, blocked: np.ndarray, fa_map: np.ndarray, others: np.ndarray,
                   others_hard: np.ndarray, n_fixed: int, weights: np.ndarray, tep_once: bool, scores: np.ndarray,
                   depths: np.ndarray, cells: np.ndarray, fitness: np.ndarray) -> None:
    """Score the first n rows of `choices` for subgroup g against everything in `others` but
    its own best row; `fitness[i] = depth * DEPTH_WEIGHT + J1` (+ the horizon value of the
    path's last cell when `horizons[g]` is not empty)."""
    row = n_fixed + g
    saved = others[row].copy()
    for q in range(others.shape[1]):
        others[row, q, 0] = -1
    score_paths(choices[:n], poses[g, 0], poses[g, 1], poses[g, 2], successors, tep, eu, blocked, fa_map, others,
                others_hard, weights, poses[g, 3], budgets[g], move_costs, home_tables[g], tep_once, scores[:n],
                depths[:n], cells[:n])
    add_terminal_value(scores[:n], depths[:n], cells[:n], poses[g, 0], poses[g, 1], horizons[g])
    others[row] = saved
    for i in range(n):
        fitness[i] = depths[i] * DEPTH_WEIGHT + scores[i]


@njit
def share_best_cells(others: np.ndarray, row: int, cells_row: np.ndarray, depth: int) -> None:
    """Publish a subgroup's best path (cells padded with -1) in its row of `others`."""
    for q in range(others.shape[1]):
        if q < depth:
            others[row, q, 0] = cells_row[q, 0]
            others[row, q, 1] = cells_row[q, 1]
        else:
            others[row, q, 0] = -1
            others[row, q, 1] = -1


def flock_inputs(searchers: list[Searcher]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`poses`, `budgets`, `home_tables` and `horizons` for the flock layout."""
    poses = np.array([[s.x, s.y, s.heading, s.flown] for s in searchers], dtype=np.int64).reshape(-1, 4)
    ranges = np.array([s.budget for s in searchers], dtype=np.int64)
    return poses, ranges, _stacked_tables(tuple(s.home_table for s in searchers)), stacked_horizons(searchers)


def stacked_horizons(searchers: list[Searcher]) -> np.ndarray:
    """Every searcher's horizon window stacked (G x w x w); zeros for a searcher without one,
    G x 0 x 0 when none has one (J1 alone)."""
    windows = [s.horizon for s in searchers if s.horizon is not None]
    if not windows:
        return np.zeros((len(searchers), 0, 0))
    shape = windows[0].shape
    return np.stack([np.zeros(shape) if s.horizon is None else s.horizon for s in searchers])


_STACKS: list[tuple[tuple[np.ndarray, ...], np.ndarray]] = []


def _stacked_tables(tables: tuple[np.ndarray, ...]) -> np.ndarray:
    """The return tables stacked into one array, kept for reuse: a mission's tables never change,
    and copying them every step would cost 8 * nx * ny * 4 bytes per UAV per step."""
    if len(tables) == 1:
        return np.ascontiguousarray(tables[0][None])
    for key, stacked in _STACKS:
        if len(key) == len(tables) and all(a is b for a, b in zip(key, tables)):
            return stacked
    stacked = np.stack(tables)
    _STACKS.insert(0, (tables, stacked))
    del _STACKS[4:]
    return stacked


def others_with_groups(fixed: np.ndarray, fixed_hard: np.ndarray, groups: int, np_steps: int,
                       group_cells: list[np.ndarray | None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """`fixed` other vehicles followed by one soft row per subgroup (its known future, or -1)."""
    rows = np.full((fixed.shape[0] + groups, np_steps, 2), -1, dtype=np.int64)
    rows[: fixed.shape[0]] = fixed
    for g, cells in enumerate(group_cells or []):
        if cells is not None:
            rows[fixed.shape[0] + g] = cells
    hard = np.zeros(rows.shape[0], dtype=np.bool_)
    hard[: fixed.shape[0]] = fixed_hard
    return rows, hard


def decision_from_choices(problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray,
                          best: np.ndarray, evaluations: int, trace: np.ndarray | None) -> Decision | None:
    """Turn an optimiser's best turn-choice row (turn-ordered table) into a `Decision`, scored
    against `others`; None when even its first step is infeasible."""
    ordered = StepProblem(problem.tep, problem.eu, problem.blocked, problem.fa_map, problem.weights,
                          turn_ordered(problem.successors), problem.np_steps, problem.searchers, problem.committed,
                          problem.predicted, problem.tep_once)
    scorer = PathScorer(ordered, searcher, others, others_hard)
    decision = scorer.decision(*scorer(best.reshape(1, -1)), trace)
    if decision is not None:
        decision.evaluations = int(evaluations)
    return decision


def path_cells(decision: Decision | None, np_steps: int) -> np.ndarray:
    """A decision's future cells padded to (Np, 2), all -1 without a decision."""
    if decision is None:
        return np.full((np_steps, 2), -1, dtype=np.int64)
    return padded_cells(decision.path, np_steps)


def choices_along(successors: np.ndarray, pose: tuple[int, int, int], cells: np.ndarray | None,
                  np_steps: int) -> np.ndarray | None:
    """The turn choices (in `successors`' column order) that fly from `pose` through the known
    prefix of `cells` (Np x 2, -1 where unknown), then straight on; None when the first cell is
    unknown or a move is not allowed."""
    if cells is None or cells[0, 0] < 0:
        return None
    x, y, h = pose
    width = successors.shape[1]
    out = np.empty(np_steps, dtype=np.int64)
    for q in range(np_steps):
        if cells[q, 0] < 0:
            ahead = np.flatnonzero(successors[h] == h)
            out[q:] = ahead[0] if len(ahead) else width // 2
            break
        dx, dy = int(cells[q, 0]) - x, int(cells[q, 1]) - y
        g = next((g for g in range(8) if HEADING_DX[g] == dx and HEADING_DY[g] == dy), -1)
        matches = np.flatnonzero(successors[h] == g) if g >= 0 else np.zeros(0, dtype=np.int64)
        if len(matches) == 0:
            return None
        out[q] = matches[0]
        x, y, h = x + dx, y + dy, g
    return out


@lru_cache(maxsize=16)
def _columns(table_bytes: bytes, width: int) -> tuple[tuple[int, ...], ...]:
    successors = np.frombuffer(table_bytes, dtype=np.int64).reshape(8, width)
    return tuple(tuple(int(np.flatnonzero(successors[h] == g)[0]) if g in successors[h] else -1 for g in range(8))
                 for h in range(8))


def column_of(successors: np.ndarray) -> tuple[tuple[int, ...], ...]:
    """`column_of(table)[h][g]`: the turn choice that takes heading g from heading h, -1 if none."""
    table = np.ascontiguousarray(successors, dtype=np.int64)
    return _columns(table.tobytes(), table.shape[1])


class PathMemory:
    """Each UAV's last chosen path, to warm-start the next decision (receding horizon): when the
    UAV stands where that path's first step put it, the first candidate of the new population is
    the rest of the path, then straight on."""

    def __init__(self) -> None:
        self._paths: dict[int, list[tuple[int, int, int]]] = {}

    def remember(self, uav_id: int, decision: Decision | None) -> None:
        if decision is None:
            self._paths.pop(uav_id, None)
        else:
            self._paths[uav_id] = [tuple(row) for row in decision.path.tolist()]

    def warm_row(self, searcher: Searcher, successors: np.ndarray, np_steps: int) -> np.ndarray | None:
        path = self._paths.get(searcher.uav_id)
        if not path or path[0] != (searcher.x, searcher.y, searcher.heading):
            return None
        columns = column_of(successors)
        h = searcher.heading
        row = []
        for _, _, g in path[1: np_steps + 1]:
            if columns[h][g] < 0:
                return None
            row.append(columns[h][g])
            h = g
        ahead = columns[h][h] if columns[h][h] >= 0 else successors.shape[1] // 2
        return np.array(row + [ahead] * (np_steps - len(row)), dtype=np.int64)


class PopulationOptimiser:
    """Base of the population optimisers (PIO, PSO, GA): one UAV's best path by a search over
    turn-choice rows, warm-started from the UAV's previous path when `warm_start` is on, then the
    shared competition rule between UAVs. `best_path` without an rng (the ST tracker calls it)
    draws from the strategy's own generator, seeded with `seed`, so repeated runs agree."""

    name = ""
    params_type: type = object

    def __init__(self, params: Any = None, seed: int = 0, warm_start: bool = True) -> None:
        self.params = params or self.params_type()
        self._rng = np.random.default_rng(seed)
        self.memory = PathMemory() if warm_start else None

    def optimise(self, problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray,
                 rng: np.random.Generator, successors: np.ndarray,
                 warm: np.ndarray | None) -> tuple[np.ndarray, int, np.ndarray]:
        """Best turn-choice row (over the turn-ordered `successors`), paths scored, best fitness per iteration."""
        raise NotImplementedError

    def best_path(self, problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray,
                  rng: np.random.Generator | None = None) -> Decision | None:
        successors = turn_ordered(problem.successors)
        warm = self.memory.warm_row(searcher, successors, problem.np_steps) if self.memory else None
        best, evaluations, trace = self.optimise(problem, searcher, others, others_hard, rng or self._rng,
                                                 successors, warm)
        decision = decision_from_choices(problem, searcher, others, others_hard, best, evaluations, trace)
        if self.memory is not None:
            self.memory.remember(searcher.uav_id, decision)
        return decision

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        return compete(problem, lambda p, s, o, h: self.best_path(p, s, o, h, rng))
