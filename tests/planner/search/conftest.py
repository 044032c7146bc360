"""Small hand-built decision states for the optimiser tests."""

from __future__ import annotations

import numpy as np
import pytest

from planner.motion import OC3
from planner.return_exact import return_table
from planner.reward import RewardWeights, airport_reward_map
from planner.search.problem import Searcher, StepProblem


def make_problem(tep, searchers, np_steps=3, oc=OC3, weights=None, eu=None, blocked=None, airports=None,
                 committed=None, predicted=None) -> StepProblem:
    """A StepProblem over `tep` with searchers given as (uav_id, x, y, heading, airport)."""
    tep = np.ascontiguousarray(tep, dtype=np.float64)
    blocked = np.zeros(tep.shape, dtype=np.bool_) if blocked is None else np.ascontiguousarray(blocked)
    eu = np.zeros(tep.shape) if eu is None else np.ascontiguousarray(eu, dtype=np.float64)
    airports = np.array([s[4] for s in searchers], dtype=np.int64)
    states = [Searcher(uid, x, y, h, 0, -1, return_table(blocked, home, oc)) for uid, x, y, h, home in searchers]
    if not isinstance(weights, np.ndarray):
        weights = (weights if weights is not None else RewardWeights()).as_array()
    return StepProblem(tep, eu, blocked, airport_reward_map(tep.shape, airports), weights, oc.successors, np_steps,
                       states, committed or {}, predicted or {})


@pytest.fixture
def random_problem():
    """A 12 x 10 random map with two searchers facing each other."""
    def build(seed: int, np_steps: int = 4, oc=OC3):
        rng = np.random.default_rng(seed)
        tep = rng.random((12, 10))
        eu = rng.random((12, 10))
        blocked = rng.random((12, 10)) < 0.1
        blocked[2, 5] = blocked[9, 4] = False
        blocked[0, 0] = blocked[11, 9] = False
        return make_problem(tep, [(1, 2, 5, 2, (0, 0)), (2, 9, 4, 6, (11, 9))], np_steps=np_steps, oc=oc, eu=eu,
                            blocked=blocked)
    return build
