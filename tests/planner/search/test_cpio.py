"""CPIO's cooperation-competition rule on hand-built conflicts."""

import numpy as np
import pytest

from planner.reward import RewardWeights
from planner.search.competition import paths_conflict
from planner.search.cpio import PROXIMITY, CpioStrategy
from tests.planner.search.conftest import make_problem


def test_paths_conflict_within_sqrt2_at_the_same_step_only():
    a = np.array([[4, 4], [6, 4], [-1, -1]])
    assert paths_conflict(a, np.array([[4, 4], [0, 0], [0, 0]]), PROXIMITY)          # same cell
    assert paths_conflict(a, np.array([[0, 0], [7, 5], [0, 0]]), PROXIMITY)          # diagonal neighbour
    assert not paths_conflict(a, np.array([[6, 4], [0, 0], [0, 0]]), PROXIMITY)      # 2 cells apart
    assert not paths_conflict(a, np.array([[0, 0], [4, 4], [0, 0]]), PROXIMITY)      # a's cell one step later
    assert not paths_conflict(a, np.array([[0, 0], [0, 0], [0, 0]]), PROXIMITY)      # unknown cells never conflict


def test_the_basic_rule_conflicts_on_a_shared_cell_only():
    a = np.array([[4, 4], [6, 4], [-1, -1]])
    assert paths_conflict(a, np.array([[0, 0], [6, 4], [0, 0]]))
    assert not paths_conflict(a, np.array([[0, 0], [7, 5], [0, 0]]))                 # diagonal neighbour
    assert not paths_conflict(a, np.array([[5, 4], [0, 0], [0, 0]]))                 # next cell
    assert not paths_conflict(a, np.array([[-1, -1], [-1, -1], [-1, -1]]))


def two_uavs_aimed_at_one_cell(left_bonus: float, right_bonus: float):
    """UAV 1 at (3,4) heading E and UAV 2 at (5,4) heading W both want (4,4) at step 1; what
    lies behind it decides who gains more."""
    tep = np.full((9, 9), 0.05)
    tep[4, 4] = 0.9
    tep[5, 3:6] = left_bonus      # where UAV 1 goes next
    tep[3, 3:6] = right_bonus     # where UAV 2 goes next
    weights = RewardWeights(1.0, 0.0, 0.0, 0.0)
    return make_problem(tep, [(1, 3, 4, 2, (0, 4)), (2, 5, 4, 6, (8, 4))], np_steps=2, weights=weights)


@pytest.mark.parametrize("left, right, winner, loser", [(0.8, 0.2, 1, 2), (0.2, 0.8, 2, 1)])
def test_the_lower_reward_uav_gives_way(left, right, winner, loser):
    problem = two_uavs_aimed_at_one_cell(left, right)
    strategy = CpioStrategy()
    first = strategy.coevolve(problem, np.random.default_rng(0))
    assert first[1].first_step()[:2] == first[2].first_step()[:2] == (4, 4)      # the conflict
    decided = strategy.decide(problem, np.random.default_rng(0))
    assert decided[winner].first_step()[:2] == (4, 4)
    assert decided[loser].first_step()[:2] != (4, 4)
    assert decided[winner].j1 == pytest.approx(0.9 + max(left, right))
    assert decided[loser].evaluations > first[loser].evaluations                 # it re-optimised


def test_cooperation_steers_subgroups_apart_through_f_r():
    """UAV 2 wants (4,4); UAV 1's best cell alone, (3,5), is its diagonal neighbour. Planned
    independently (basic PIO, nothing predicted yet) they end within sqrt 2 of each other;
    coevolved, each subgroup sees the other's current best and they do not."""
    from planner.search.pio import PioStrategy

    tep = np.full((9, 9), 0.05)
    tep[4, 4], tep[3, 5], tep[3, 6] = 0.9, 0.6, 0.5
    problem = make_problem(tep, [(1, 2, 6, 3, (0, 8)), (2, 4, 3, 0, (8, 0))], np_steps=1,
                           weights=RewardWeights(0.3, 0.0, 0.3, 0.0))
    alone = PioStrategy().decide(problem, np.random.default_rng(0))
    assert paths_conflict(alone[1].path[:, :2], alone[2].path[:, :2], PROXIMITY)
    together = CpioStrategy().coevolve(problem, np.random.default_rng(0))
    assert not paths_conflict(together[1].path[:, :2], together[2].path[:, :2], PROXIMITY)
