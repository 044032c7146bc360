import numpy as np
import pytest

from planner.search.competition import others_for
from planner.search.cpio import CpioStrategy
from planner.search.pio import (
    PioParams,
    PioStrategy,
    landmark_centre,
    landmark_flock_size,
)


def test_landmark_centre_weights_by_fitness_shifted_positive():
    positions = np.array([[0.0, 1.0], [2.0, 1.0], [4.0, 1.0]])
    # shifted fitness: 0, 1, 3 -> centre x = (0*0 + 2*1 + 4*3) / 4 = 3.5
    centre = landmark_centre(positions, np.array([-100.0, -99.0, -97.0]), 3)
    np.testing.assert_allclose(centre, [3.5, 1.0])


def test_landmark_centre_of_equal_fitness_is_the_mean_and_uses_only_the_kept_pigeons():
    positions = np.array([[0.0], [2.0], [100.0]])
    np.testing.assert_allclose(landmark_centre(positions, np.array([5.0, 5.0, -1.0]), 2), [1.0])


def test_landmark_halves_the_flock_down_to_the_floor():
    assert PioParams().landmark_sizes() == [20, 10, 5, 2] + [2] * 16
    assert PioParams(pigeons=40, min_flock=3).landmark_sizes()[:5] == [20, 10, 5, 3, 3]
    assert landmark_flock_size(1, 2) == 1
    assert PioParams().evaluations() == 40 + 25 * 40 + 69


def test_bad_pio_parameters_are_refused():
    with pytest.raises(ValueError):
        PioParams(pigeons=1)
    with pytest.raises(ValueError):
        PioParams(min_flock=0)


@pytest.mark.parametrize("strategy", [PioStrategy(), CpioStrategy()])
def test_decision_carries_a_trace_per_iteration_ending_at_its_j1(random_problem, strategy):
    problem = random_problem(3)
    s = problem.searchers[0]
    others, hard = others_for(problem, s.uav_id, {})
    d = strategy.best_path(problem, s, others, hard, np.random.default_rng(0))
    assert d.trace.shape == (1 + 25 + 20,)
    assert d.trace[-1] == pytest.approx(d.j1)
    assert np.all(np.diff(d.trace) >= -1e-12)      # elitist: the best never gets worse against fixed others
    assert d.evaluations == PioParams().evaluations()


def test_pio_finds_the_exact_optimum_on_a_small_decision(random_problem):
    from planner.search.exhaustive import ExhaustiveStrategy
    problem = random_problem(11, np_steps=3)
    for s in problem.searchers:
        others, hard = others_for(problem, s.uav_id, {})
        exact = ExhaustiveStrategy().best_path(problem, s, others, hard)
        found = PioStrategy().best_path(problem, s, others, hard, np.random.default_rng(1))
        assert found.j1 == pytest.approx(exact.j1)
