"""Basic pigeon-inspired optimisation (Section 3.2) on the turn-choice encoding.

Map-and-compass operator, eq. (14), for Nc1 iterations: V = V * exp(-R * u) + rand * (X_best - X),
X = X + V, with X_best the best position found so far (elitist reading of "the best pigeon of
iteration u-1"), one uniform draw per pigeon and coordinate, velocities starting at zero.

Landmark operator, eq. (15)-(16), for Nc2 iterations: sort by fitness, keep the better half, but
never fewer than `min_flock` pigeons (default 2: a centre of one pigeon is that pigeon, and the
flock would stop moving), move each toward the fitness-weighted centre
X_c = sum(X * w) / sum(w), X = X + rand * (X_c - X). The printed centre divides by C2 * sum(f);
we read it as the weighted mean. Fitness can be negative (F_r = -100), so the weights are the
fitness shifted so the worst kept pigeon weighs nothing: w = f - min(f) (all equal: plain mean).

With Table 1 (C1 = 40, Nc1 = 25, Nc2 = 20, floor 2) one run scores 40 + 25 * 40 + 69 = 1109
paths. `pio_flocks` runs G subgroups in lock-step in one kernel; with G > 1 each subgroup
scores against the others' current best paths, re-scored every iteration (CPIO's cooperation).
Random draws are passed in as arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.config import njit
from planner.search.flock import (
    DEPTH_WEIGHT,
    PopulationOptimiser,
    clamp_position,
    decode_positions,
    evaluate_flock,
    flock_inputs,
    others_with_groups,
    share_best_cells,
    turn_ordered,
)
from planner.search.problem import Searcher, StepProblem


@dataclass(frozen=True)
class PioParams:
    """Table 1: C1 pigeons per (sub)group, R (map-and-compass coefficient), Nc1, Nc2."""

    pigeons: int = 40
    compass_coefficient: float = 0.5
    compass_iterations: int = 25
    landmark_iterations: int = 20
    min_flock: int = 2

    def __post_init__(self) -> None:
        if self.pigeons < 2 or self.min_flock < 1 or self.min_flock > self.pigeons:
            raise ValueError("PIO needs at least 2 pigeons and 1 <= min_flock <= pigeons")
        if self.compass_iterations < 0 or self.landmark_iterations < 0:
            raise ValueError("PIO iteration counts must be >= 0")

    def landmark_sizes(self) -> list[int]:
        """Flock size in each landmark iteration (halving with the floor)."""
        sizes, n = [], self.pigeons
        for _ in range(self.landmark_iterations):
            n = landmark_flock_size(n, self.min_flock)
            sizes.append(n)
        return sizes

    def evaluations(self) -> int:
        return self.pigeons * (1 + self.compass_iterations) + sum(self.landmark_sizes())


@njit
def landmark_flock_size(n: int, min_flock: int) -> int:
    """C2^v = C2^(v-1) / 2, never below min_flock (nor above the flock there is)."""
    half = n // 2
    if half < min_flock:
        return min(min_flock, n)
    return half


@njit
def landmark_centre(positions: np.ndarray, fitness: np.ndarray, n: int) -> np.ndarray:
    """Eq. (15) read as the fitness-weighted mean of the first n pigeons, fitness shifted so the
    worst weighs zero (equal weights when all are equal)."""
    m = positions.shape[1]
    f_min = fitness[0]
    for a in range(n):
        f_min = min(f_min, fitness[a])
    total = 0.0
    for a in range(n):
        total += fitness[a] - f_min
    centre = np.zeros(m)
    for a in range(n):
        w = (fitness[a] - f_min) / total if total > 0.0 else 1.0 / n
        for q in range(m):
            centre[q] += w * positions[a, q]
    return centre


@njit
def _refresh_best(g: int, poses: np.ndarray, budgets: np.ndarray, move_costs: np.ndarray, home_tables: np.ndarray,
                  horizons: np.ndarray, successors: np.ndarray, tep: np.ndarray, eu: np.ndarray, blocked: np.ndarray,
                  fa_map: np.ndarray, others: np.ndarray, others_hard: np.ndarray, n_fixed: int, weights: np.ndarray,
                  tep_once: bool,
                  best_choices: np.ndarray, best_fitness: np.ndarray, best_scores: np.ndarray,
                  best_depths: np.ndarray, one_choice: np.ndarray, one_score: np.ndarray, one_depth: np.ndarray,
                  one_cells: np.ndarray, one_fitness: np.ndarray) -> None:
    """Re-score subgroup g's best path against the others' current bests (their moves change it)."""
    one_choice[0] = best_choices[g]
    evaluate_flock(g, one_choice, 1, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu, blocked,
                   fa_map, others, others_hard, n_fixed, weights, tep_once, one_score, one_depth, one_cells,
                   one_fitness)
    best_fitness[g] = one_fitness[0]
    best_scores[g] = one_score[0]
    best_depths[g] = one_depth[0]
    share_best_cells(others, n_fixed + g, one_cells[0], one_depth[0])


@njit
def _keep_best(g: int, n: int, choices: np.ndarray, positions: np.ndarray, fitness: np.ndarray, scores: np.ndarray,
               depths: np.ndarray, cells: np.ndarray, others: np.ndarray, n_fixed: int, best_positions: np.ndarray,
               best_choices: np.ndarray, best_fitness: np.ndarray, best_scores: np.ndarray, best_depths: np.ndarray
) -> None:
    for a in range(n):
        if fitness[a] > best_fitness[g]:
            best_fitness[g] = fitness[a]
            best_scores[g] = scores[a]
            best_depths[g] = depths[a]
            best_choices[g] = choices[a]
            best_positions[g] = positions[a]
            share_best_cells(others, n_fixed + g, cells[a], depths[a])


@njit
def pio_flocks(poses: np.ndarray, budgets: np.ndarray, move_costs: np.ndarray, home_tables: np.ndarray,
               horizons: np.ndarray, successors: np.ndarray, tep: np.ndarray, eu: np.ndarray, blocked: np.ndarray,
               fa_map: np.ndarray, others: np.ndarray, others_hard: np.ndarray, n_fixed: int, weights: np.ndarray,
               tep_once: bool,
               positions: np.ndarray, compass_draws: np.ndarray, landmark_draws: np.ndarray,
               compass_coefficient: float, min_flock: int, best_choices: np.ndarray, best_scores: np.ndarray,
               best_depths: np.ndarray, trace: np.ndarray) -> int:
    """Run PIO for G subgroups (positions: G x C x Np, updated in place) in lock-step.

    compass_draws: Nc1 x G x C x Np, landmark_draws: Nc2 x G x C x Np, uniform in [0, 1).
    Writes each subgroup's best turn choices, J1 and valid depth, and `trace[g, t]` = J1 of the
    best path after iteration t (t = 0: the initial flock). Returns the number of paths scored."""
    groups, flock, m = positions.shape
    branching = successors.shape[1]
    nc1 = compass_draws.shape[0]
    nc2 = landmark_draws.shape[0]
    velocities = np.zeros_like(positions)
    choices = np.empty((flock, m), dtype=np.int64)
    scores = np.empty(flock)
    depths = np.empty(flock, dtype=np.int64)
    cells = np.zeros((flock, m, 3), dtype=np.int64)
    fitness = np.empty((groups, flock))
    best_fitness = np.full(groups, -np.inf)
    best_positions = np.zeros((groups, m))
    one_choice = np.empty((1, m), dtype=np.int64)
    one_score = np.empty(1)
    one_depth = np.empty(1, dtype=np.int64)
    one_cells = np.zeros((1, m, 3), dtype=np.int64)
    one_fitness = np.empty(1)
    kept = np.empty((flock, m))
    kept_fitness = np.empty(flock)
    evaluations = 0

    for g in range(groups):
        decode_positions(positions[g], branching, choices)
        evaluate_flock(g, choices, flock, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu,
                       blocked, fa_map, others, others_hard, n_fixed, weights, tep_once, scores, depths, cells,
                       fitness[g])
        evaluations += flock
        _keep_best(g, flock, choices, positions[g], fitness[g], scores, depths, cells, others, n_fixed,
                   best_positions, best_choices, best_fitness, best_scores, best_depths)
        trace[g, 0] = best_scores[g]

    for u in range(1, nc1 + 1):
        decay = np.exp(-compass_coefficient * u)
        for g in range(groups):
            if groups > 1:
                _refresh_best(g, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu, blocked,
                              fa_map, others, others_hard, n_fixed, weights, tep_once, best_choices, best_fitness,
                              best_scores, best_depths, one_choice, one_score, one_depth, one_cells, one_fitness)
                evaluations += 1
            for a in range(flock):
                for q in range(m):
                    v = velocities[g, a, q] * decay + compass_draws[u - 1, g, a, q] * (
                        best_positions[g, q] - positions[g, a, q])
                    velocities[g, a, q] = v
                    positions[g, a, q] = clamp_position(positions[g, a, q] + v, branching)
            decode_positions(positions[g], branching, choices)
            evaluate_flock(g, choices, flock, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu,
                           blocked, fa_map, others, others_hard, n_fixed, weights, tep_once, scores, depths, cells,
                           fitness[g])
            evaluations += flock
            _keep_best(g, flock, choices, positions[g], fitness[g], scores, depths, cells, others, n_fixed,
                       best_positions, best_choices, best_fitness, best_scores, best_depths)
            trace[g, u] = best_scores[g]

    n = flock
    for v in range(nc2):
        n_new = landmark_flock_size(n, min_flock)
        for g in range(groups):
            if groups > 1:
                _refresh_best(g, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu, blocked,
                              fa_map, others, others_hard, n_fixed, weights, tep_once, best_choices, best_fitness,
                              best_scores, best_depths, one_choice, one_score, one_depth, one_cells, one_fitness)
                evaluations += 1
            order = np.argsort(-fitness[g, :n], kind="mergesort")
            for a in range(n_new):
                kept[a] = positions[g, order[a]]
                kept_fitness[a] = fitness[g, order[a]]
            for a in range(n_new):
                positions[g, a] = kept[a]
                fitness[g, a] = kept_fitness[a]
            centre = landmark_centre(positions[g], fitness[g], n_new)
            for a in range(n_new):
                for q in range(m):
                    positions[g, a, q] = clamp_position(
                        positions[g, a, q] + landmark_draws[v, g, a, q] * (centre[q] - positions[g, a, q]), branching)
            decode_positions(positions[g, :n_new], branching, choices)
            evaluate_flock(g, choices, n_new, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu,
                           blocked, fa_map, others, others_hard, n_fixed, weights, tep_once, scores, depths, cells,
                           fitness[g])
            evaluations += n_new
            _keep_best(g, n_new, choices, positions[g], fitness[g], scores, depths, cells, others, n_fixed,
                       best_positions, best_choices, best_fitness, best_scores, best_depths)
            trace[g, 1 + nc1 + v] = best_scores[g]
        n = n_new
    return evaluations


def pio_draws(params: PioParams, groups: int, np_steps: int, branching: int,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial positions (uniform over the choices) and the compass and landmark draws."""
    shape = (groups, params.pigeons, np_steps)
    positions = rng.uniform(-0.5, branching - 0.5, shape)
    compass = rng.random((params.compass_iterations, *shape))
    landmark = rng.random((params.landmark_iterations, *shape))
    return positions, compass, landmark


def run_pio(problem: StepProblem, searchers: list[Searcher], fixed: np.ndarray, fixed_hard: np.ndarray,
            params: PioParams, rng: np.random.Generator,
            group_cells: list[np.ndarray | None] | None = None,
            warm_starts: list[np.ndarray | None] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Run `pio_flocks` for `searchers` as subgroups; returns best choices (turn-ordered table),
    the others array the subgroups ended with, traces, and the number of paths scored.
    `group_cells[g]` is subgroup g's known future before it starts (others score against it);
    `warm_starts[g]`, a turn-choice row, replaces the first pigeon of subgroup g."""
    successors = turn_ordered(problem.successors)
    groups = len(searchers)
    poses, ranges, tables, horizons = flock_inputs(searchers)
    others, hard = others_with_groups(fixed, fixed_hard, groups, problem.np_steps, group_cells)
    positions, compass, landmark = pio_draws(params, groups, problem.np_steps, successors.shape[1], rng)
    for g, row in enumerate(warm_starts or []):
        if row is not None:
            positions[g, 0] = row
    best = np.zeros((groups, problem.np_steps), dtype=np.int64)
    best_scores = np.empty(groups)
    best_depths = np.empty(groups, dtype=np.int64)
    trace = np.empty((groups, 1 + params.compass_iterations + params.landmark_iterations))
    evaluations = pio_flocks(poses, ranges, problem.move_costs, tables, horizons, successors, problem.tep, problem.eu,
                             problem.blocked, problem.fa_map, others, hard, fixed.shape[0], problem.weights,
                             problem.tep_once, positions, compass, landmark, params.compass_coefficient,
                             params.min_flock, best, best_scores, best_depths, trace)
    return best, others, trace, int(evaluations)


class PioStrategy(PopulationOptimiser):
    """Basic PIO per UAV (against the others' predicted paths), then the shared competition rule.
    With `warm_start` the first pigeon starts on the rest of the UAV's previous path."""

    name = "pio"
    params_type = PioParams

    def optimise(self, problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray,
                 rng: np.random.Generator, successors: np.ndarray,
                 warm: np.ndarray | None) -> tuple[np.ndarray, int, np.ndarray]:
        best, _, trace, evaluations = run_pio(problem, [searcher], others, others_hard, self.params, rng,
                                              warm_starts=[warm])
        return best[0], evaluations, trace[0]


__all__ = ["DEPTH_WEIGHT", "PioParams", "PioStrategy", "pio_flocks", "run_pio"]
