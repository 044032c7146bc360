"""Particle swarm optimisation on the same turn-choice encoding and fitness, the paper's PSO
baseline (Section 6.1, Fig. 8).

Constriction-factor PSO (Clerc and Kennedy 2002): V = w V + c1 r1 (P - X) + c2 r2 (G - X),
w = 0.7298, c1 = c2 = 1.49618, |V| <= K - 1, X clamped like a pigeon; P is a particle's best
position, G the swarm's. 40 particles and 27 iterations score 1120 paths, about what PIO scores
with Table 1's parameters (1109), so the comparison is at equal cost."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.config import njit
from planner.search.flock import (
    PopulationOptimiser,
    clamp_position,
    decode_positions,
    evaluate_flock,
    flock_inputs,
    others_with_groups,
)
from planner.search.problem import Searcher, StepProblem


@dataclass(frozen=True)
class PsoParams:
    particles: int = 40
    iterations: int = 27
    inertia: float = 0.7298
    c_personal: float = 1.49618
    c_social: float = 1.49618

    def evaluations(self) -> int:
        return self.particles * (1 + self.iterations)


@njit
def pso_swarm(poses: np.ndarray, budgets: np.ndarray, move_costs: np.ndarray, home_tables: np.ndarray,
              horizons: np.ndarray, successors: np.ndarray, tep: np.ndarray, eu: np.ndarray, blocked: np.ndarray,
              fa_map: np.ndarray, others: np.ndarray, others_hard: np.ndarray, n_fixed: int, weights: np.ndarray,
              tep_once: bool,
              positions: np.ndarray, velocities: np.ndarray, r_personal: np.ndarray, r_social: np.ndarray,
              inertia: float, c_personal: float, c_social: float, best_choice: np.ndarray, trace: np.ndarray) -> int:
    """One swarm (subgroup 0 of the flock layout); positions and velocities: C x Np, updated in
    place; r_personal, r_social: T x C x Np uniform draws. Writes the best turn choices and
    `trace[t]` = J1 of the swarm's best after iteration t. Returns the number of paths scored."""
    n, m = positions.shape
    branching = successors.shape[1]
    v_max = branching - 1.0
    choices = np.empty((n, m), dtype=np.int64)
    scores = np.empty(n)
    depths = np.empty(n, dtype=np.int64)
    cells = np.zeros((n, m, 3), dtype=np.int64)
    fitness = np.empty(n)
    personal = positions.copy()
    personal_fitness = np.full(n, -np.inf)
    social = np.zeros(m)
    social_fitness = -np.inf
    social_score = 0.0
    evaluations = 0
    for t in range(r_personal.shape[0] + 1):
        if t > 0:
            for a in range(n):
                for q in range(m):
                    v = (inertia * velocities[a, q]
                         + c_personal * r_personal[t - 1, a, q] * (personal[a, q] - positions[a, q])
                         + c_social * r_social[t - 1, a, q] * (social[q] - positions[a, q]))
                    v = min(v_max, max(-v_max, v))
                    velocities[a, q] = v
                    positions[a, q] = clamp_position(positions[a, q] + v, branching)
        decode_positions(positions, branching, choices)
        evaluate_flock(0, choices, n, poses, budgets, move_costs, home_tables, horizons, successors, tep, eu, blocked,
                       fa_map, others, others_hard, n_fixed, weights, tep_once, scores, depths, cells, fitness)
        evaluations += n
        for a in range(n):
            if fitness[a] > personal_fitness[a]:
                personal_fitness[a] = fitness[a]
                personal[a] = positions[a]
            if fitness[a] > social_fitness:
                social_fitness = fitness[a]
                social[:] = positions[a]
                social_score = scores[a]
                best_choice[:] = choices[a]
        trace[t] = social_score
    return evaluations


class PsoStrategy(PopulationOptimiser):
    """PSO per UAV against the others' predicted paths, then the shared competition rule; with
    `warm_start` the first particle starts on the rest of the UAV's previous path."""

    name = "pso"
    params_type = PsoParams

    def optimise(self, problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray,
                 rng: np.random.Generator, successors: np.ndarray,
                 warm: np.ndarray | None) -> tuple[np.ndarray, int, np.ndarray]:
        p = self.params
        k = successors.shape[1]
        shape = (p.particles, problem.np_steps)
        positions = rng.uniform(-0.5, k - 0.5, shape)
        velocities = rng.uniform(-1.0, 1.0, shape)
        r_personal = rng.random((p.iterations, *shape))
        r_social = rng.random((p.iterations, *shape))
        if warm is not None:
            positions[0] = warm
        poses, ranges, tables, horizons = flock_inputs([searcher])
        rows, hard = others_with_groups(others, others_hard, 1, problem.np_steps)
        best = np.zeros(problem.np_steps, dtype=np.int64)
        trace = np.empty(p.iterations + 1)
        evaluations = pso_swarm(poses, ranges, problem.move_costs, tables, horizons, successors, problem.tep,
                                problem.eu, problem.blocked, problem.fa_map, rows, hard, others.shape[0],
                                problem.weights, problem.tep_once, positions, velocities, r_personal, r_social,
                                p.inertia, p.c_personal, p.c_social, best, trace)
        return best, int(evaluations), trace
