"""Each optimiser kernel against its plain-Python reference, on the same draws, with and without
the horizon value."""

import dataclasses

import numpy as np
import pytest

from planner.search.flock import flock_inputs, others_with_groups, turn_ordered
from planner.search.ga import ga_population
from planner.search.pio import PioParams, pio_draws, pio_flocks
from planner.search.pso import pso_swarm
from tests.planner.search.references import Scorer, reference_ga, reference_pio, reference_pso


def with_horizons(problem, searchers, seed):
    """The searchers with random horizon windows (the horizon value on)."""
    rng = np.random.default_rng(1000 + seed)
    side = 2 * problem.np_steps + 1
    return [dataclasses.replace(s, horizon=rng.random((side, side))) for s in searchers]


def scorer_for(problem, searchers):
    successors = turn_ordered(problem.successors)
    poses, ranges, tables, horizons = flock_inputs(searchers)
    fixed = np.full((0, problem.np_steps, 2), -1, dtype=np.int64)
    scorer = Scorer(poses, ranges, tables, successors, problem, fixed, np.zeros(0, bool), horizons)
    return successors, poses, ranges, tables, horizons, fixed, scorer


@pytest.mark.parametrize("horizon", [False, True])
@pytest.mark.parametrize("seed, groups, compass", [(1, 1, 6), (2, 1, 2), (3, 2, 6), (4, 2, 2), (5, 2, 0)])
def test_pio_kernel_matches_reference(random_problem, seed, groups, compass, horizon):
    problem = random_problem(seed)
    searchers = problem.searchers[:groups]
    if horizon:
        searchers = with_horizons(problem, searchers, seed)
    successors, poses, ranges, tables, horizons, fixed, scorer = scorer_for(problem, searchers)
    params = PioParams(pigeons=12, compass_iterations=compass, landmark_iterations=5)
    rng = np.random.default_rng(seed)
    positions, compass, landmark = pio_draws(params, groups, problem.np_steps, successors.shape[1], rng)
    others, hard = others_with_groups(fixed, np.zeros(0, bool), groups, problem.np_steps)
    best = np.zeros((groups, problem.np_steps), dtype=np.int64)
    trace = np.empty((groups, 1 + compass.shape[0] + 5))
    moved = positions.copy()
    evaluations = pio_flocks(poses, ranges, problem.move_costs, tables, horizons, successors, problem.tep, problem.eu,
                             problem.blocked, problem.fa_map, others, hard, 0, problem.weights, False, moved, compass,
                             landmark, params.compass_coefficient, params.min_flock, best, np.empty(groups),
                             np.empty(groups, dtype=np.int64), trace)
    ref_best, ref_trace, ref_evaluations, ref_positions = reference_pio(
        scorer, successors.shape[1], positions, compass, landmark, params.compass_coefficient, params.min_flock)
    assert best.tolist() == ref_best
    np.testing.assert_allclose(trace, ref_trace)
    np.testing.assert_allclose(moved, ref_positions, rtol=1e-12, atol=1e-12)
    assert evaluations == ref_evaluations
    if groups == 1:
        assert evaluations == params.evaluations()


@pytest.mark.parametrize("horizon", [False, True])
@pytest.mark.parametrize("seed", [5, 6, 7])
def test_pso_kernel_matches_reference(random_problem, seed, horizon):
    problem = random_problem(seed)
    searchers = with_horizons(problem, problem.searchers[:1], seed) if horizon else problem.searchers[:1]
    successors, poses, ranges, tables, horizons, fixed, scorer = scorer_for(problem, searchers)
    rng = np.random.default_rng(seed)
    n, m, t, k = 10, problem.np_steps, 8, successors.shape[1]
    positions = rng.uniform(-0.5, k - 0.5, (n, m))
    velocities = rng.uniform(-1, 1, (n, m))
    r1, r2 = rng.random((t, n, m)), rng.random((t, n, m))
    others, hard = others_with_groups(fixed, np.zeros(0, bool), 1, m)
    best = np.zeros(m, dtype=np.int64)
    trace = np.empty(t + 1)
    moved = positions.copy()
    evaluations = pso_swarm(poses, ranges, problem.move_costs, tables, horizons, successors, problem.tep, problem.eu,
                            problem.blocked, problem.fa_map, others, hard, 0, problem.weights, False, moved,
                            velocities.copy(), r1, r2, 0.7298, 1.49618, 1.49618, best, trace)
    ref_best, ref_trace, ref_evaluations, ref_positions = reference_pso(scorer, k, positions, velocities, r1, r2,
                                                                        0.7298, 1.49618, 1.49618)
    assert best.tolist() == ref_best
    np.testing.assert_allclose(moved, ref_positions, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(trace, ref_trace)
    assert evaluations == ref_evaluations


@pytest.mark.parametrize("horizon", [False, True])
@pytest.mark.parametrize("seed", [8, 9, 10])
def test_ga_kernel_matches_reference(random_problem, seed, horizon):
    problem = random_problem(seed)
    searchers = with_horizons(problem, problem.searchers[:1], seed) if horizon else problem.searchers[:1]
    successors, poses, ranges, tables, horizons, fixed, scorer = scorer_for(problem, searchers)
    rng = np.random.default_rng(seed)
    n, m, t, k = 10, problem.np_steps, 7, successors.shape[1]
    population = rng.integers(0, k, (n, m))
    tournaments = rng.integers(0, n, (t, n, 4))
    crossover, masks, mutations = rng.random((t, n)), rng.random((t, n, m)), rng.random((t, n, m))
    values = rng.integers(0, k, (t, n, m))
    others, hard = others_with_groups(fixed, np.zeros(0, bool), 1, m)
    best = np.zeros(m, dtype=np.int64)
    trace = np.empty(t + 1)
    evaluations = ga_population(poses, ranges, problem.move_costs, tables, horizons, successors, problem.tep,
                                problem.eu, problem.blocked, problem.fa_map, others, hard, 0, problem.weights, False,
                                population.copy(), tournaments, crossover, masks, mutations, values, 0.9, 0.25, 2,
                                best, trace)
    ref_best, ref_trace, ref_evaluations = reference_ga(scorer, population, tournaments, crossover, masks, mutations,
                                                        values, 0.9, 0.25, 2)
    assert best.tolist() == ref_best
    np.testing.assert_allclose(trace, ref_trace)
    assert evaluations == ref_evaluations
