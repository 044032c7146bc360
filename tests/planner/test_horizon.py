"""The horizon value (`planner.horizon`): its kernels against slow references, J1 untouched when
it is off, safe plans when it is on, and a UAV that heads for a likely region past its horizon."""

import dataclasses
import itertools
import math
from collections import deque

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from planner.dtscs import ClosedSearch, MissionConfig, fly
from planner.environment import SearchMap, Sensor
from planner.horizon import (
    Flyer,
    HorizonValue,
    block_size,
    box_mean,
    discounted_max,
    horizon_window,
    reachable_cells,
    steps_from,
    team_fields,
    team_shares,
)
from planner.motion import OC3, OC4, OC8, STEPS
from planner.reward import add_terminal_value, score_paths
from planner.scenario import Scenario, UavSpec, paper_scenario
from planner.search import STRATEGIES
from planner.search.exhaustive import all_choices
from planner.search.problem import PathScorer
from tests.planner.helpers import assert_plan_safe, jit_off_examples, random_scenario, without_jit

OPTIMISERS = ("cpio", "pio", "pso", "ga", "exhaustive")


def reference_steps(blocked, start):
    """Breadth-first search over the 8 neighbours, written plainly."""
    nx, ny = blocked.shape
    steps = {start: 0}
    queue = deque([start])
    while queue:
        x, y = queue.popleft()
        for dx, dy in itertools.product((-1, 0, 1), repeat=2):
            q = (x + dx, y + dy)
            if (dx, dy) != (0, 0) and 0 <= q[0] < nx and 0 <= q[1] < ny and not blocked[q] and q not in steps:
                steps[q] = steps[(x, y)] + 1
                queue.append(q)
    return steps


@st.composite
def grids(draw, max_side=9):
    nx, ny = draw(st.integers(1, max_side)), draw(st.integers(1, max_side))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    blocked = rng.random((nx, ny)) < draw(st.floats(0.0, 0.4))
    mass = rng.random((nx, ny)) * (rng.random((nx, ny)) < draw(st.floats(0.05, 1.0)))
    return blocked, mass, rng


@settings(max_examples=150, deadline=None)
@given(case=grids(), length=st.floats(0.3, 30.0))
def test_discounted_max_is_the_best_discounted_source(case, length):
    blocked, mass, _ = case
    got = discounted_max(mass, blocked, length)
    want = np.zeros(mass.shape)
    for c in zip(*np.nonzero(~blocked & (mass > 0))):
        for s, d in reference_steps(blocked, c).items():
            want[s] = max(want[s], mass[c] * math.exp(-d / length))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-300)


@settings(max_examples=100, deadline=None)
@given(case=grids())
def test_steps_from_is_breadth_first_search(case):
    blocked, _, rng = case
    free = np.argwhere(~blocked)
    if not len(free):
        return
    start = tuple(int(v) for v in free[rng.integers(len(free))])
    got = steps_from(blocked, start)
    want = reference_steps(blocked, start)
    for cell in itertools.product(range(blocked.shape[0]), range(blocked.shape[1])):
        assert got[cell] == want.get(cell, -1)


@settings(max_examples=100, deadline=None)
@given(case=grids(), radius=st.integers(0, 4))
def test_box_mean_is_the_window_mean(case, radius):
    _, values, _ = case
    nx, ny = values.shape
    got = box_mean(values, radius)
    for x, y in itertools.product(range(nx), range(ny)):
        window = values[max(0, x - radius): x + radius + 1, max(0, y - radius): y + radius + 1]
        assert got[x, y] == pytest.approx(window.sum() / (2 * radius + 1) ** 2, abs=1e-12)


def test_team_shares_split_what_several_reach_and_leave_the_rest_whole():
    blocked = np.zeros((7, 1), bool)
    a, b = steps_from(blocked, (0, 0)), steps_from(blocked, (6, 0))
    reach_a = a <= 4                       # UAV a reaches cells 0..4, b all of them
    reach_b = np.ones((7, 1), bool)
    share_a, share_b = team_shares([a, b], [reach_a, reach_b], [2.0, 2.0])
    np.testing.assert_allclose(share_a + share_b, 1.0)
    assert share_a[3, 0] == pytest.approx(0.5)                       # halfway: equal
    assert share_a[1, 0] > 0.5 > share_a[4, 0] > 0 and share_a[5, 0] == 0.0 and share_b[6, 0] == 1.0
    assert team_shares([], [], []) == []


def test_a_team_field_peaks_on_the_reachable_likely_ground():
    blocked = np.zeros((30, 5), bool)
    reward = np.full((30, 5), 0.05)
    reward[20:25] = 0.5                                    # likely ground 17..21 cells east
    home = steps_from(blocked, (2, 2))
    far = team_fields(reward, blocked, [Flyer((2, 2), 60, home)], 2, 1.0)[0]
    assert far[5, 2] > far[3, 2] > far[1, 2]                # rising toward it
    near = team_fields(reward, blocked, [Flyer((2, 2), 30, home)], 2, 1.0)[0]
    assert near[5, 2] <= near[3, 2] + 1e-12                 # out of reach with 30 steps: no pull east
    assert not reachable_cells(steps_from(blocked, (2, 2)), home, 30)[22, 2]


def test_pooled_fields_on_big_grids_are_block_constant():
    rng = np.random.default_rng(1)
    blocked = rng.random((300, 200)) < 0.05
    blocked[10, 10] = False
    b = block_size(blocked.shape)
    assert b == 2
    home = np.maximum(steps_from(blocked, (10, 10)), 0)
    field = team_fields(rng.random((300, 200)), blocked, [Flyer((10, 10), 400, home)], 5, 1.0, b)[0]
    assert field.shape == (300, 200) and (field >= 0).all() and field.max() > 0
    assert np.array_equal(field[0::2, 0::2], field[1::2, 1::2])


def test_window_scales_and_pads_the_field():
    field = np.arange(20.0).reshape(4, 5)
    window = horizon_window(field, (0, 4), 2, 3.0)
    assert window.shape == (5, 5)
    assert window[2, 2] == 3.0 * field[0, 4] and window[3, 1] == 3.0 * field[1, 3]
    assert (window[:2] == 0).all() and (window[:, 3:] == 0).all()


def test_terminal_value_reads_the_last_cell_and_an_empty_window_adds_nothing():
    rng = np.random.default_rng(0)
    tep, eu = rng.random((9, 9)), rng.random((9, 9))
    blocked = np.zeros((9, 9), bool)
    table = np.zeros((8, 9, 9), np.int32)
    choices = all_choices(3, 3)
    n = len(choices)
    args = (choices, 4, 4, 2, OC3.successors, tep, eu, blocked, np.zeros((9, 9)), np.full((0, 3, 2), -1, np.int64),
            np.zeros(0, bool), np.array([0.3, 0.3, 0.3, 0.1]), 0, -1, STEPS.by_heading, table, False)
    scores, depths, cells = np.empty(n), np.empty(n, np.int64), np.zeros((n, 3, 3), np.int64)
    score_paths(*args, scores, depths, cells)
    plain = scores.copy()
    add_terminal_value(scores, depths, cells, 4, 4, np.zeros((0, 0)))
    assert np.array_equal(scores, plain)
    window = rng.random((7, 7))
    add_terminal_value(scores, depths, cells, 4, 4, window)
    for i in range(n):
        x, y = cells[i, depths[i] - 1, :2]
        assert scores[i] == plain[i] + window[x - 4 + 3, y - 4 + 3]


@pytest.mark.parametrize("strategy", sorted(STRATEGIES))
def test_off_is_the_paper_and_a_zero_weight_changes_nothing(strategy):
    """Off, the searchers carry no window and the scorer's J1 is score_paths' own; a zero weight
    (every path gets + 0.0) flies the same plan bit for bit."""
    scenario = paper_scenario(4, range_steps=without_jit(45, 15))
    off = fly(scenario, MissionConfig(strategy=strategy, return_planner="st"), seed=4)
    zero = fly(scenario, MissionConfig(strategy=strategy, return_planner="st", horizon=HorizonValue(weight=0.0)),
               seed=4)
    assert [u.trajectory for u in off.uavs] == [u.trajectory for u in zero.uavs]
    assert off.targets == zero.targets and off.false_alarms == zero.false_alarms
    assert "horizon_value" not in off.settings and zero.settings["horizon_value"]["weight"] == 0.0


def test_off_searchers_carry_no_window_and_score_plain_j1():
    search = ClosedSearch(paper_scenario(1, range_steps=60), MissionConfig(np_steps=3), seed=1)
    problem = search._problem(list(search.uavs.values()))
    s = problem.searchers[0]
    assert all(t.horizon is None for t in problem.searchers)
    choices = all_choices(3, 3)
    others = np.full((0, 3, 2), -1, np.int64)
    scores, depths, cells = PathScorer(problem, s, others, np.zeros(0, bool))(choices)
    want = np.empty(len(choices)), np.empty(len(choices), np.int64), np.zeros((len(choices), 3, 3), np.int64)
    score_paths(choices, s.x, s.y, s.heading, problem.successors, problem.tep, problem.eu, problem.blocked,
                problem.fa_map, others, np.zeros(0, bool), problem.weights, s.flown, s.budget, problem.move_costs,
                s.home_table, False, *want)
    assert np.array_equal(scores, want[0]) and np.array_equal(depths, want[1])
    on = ClosedSearch(paper_scenario(1, range_steps=60), MissionConfig(np_steps=3, horizon=HorizonValue()), seed=1)
    windows = [t.horizon for t in on._problem(list(on.uavs.values())).searchers]
    assert all(w.shape == (7, 7) and (w >= 0).all() and w.max() > 0 for w in windows)


OCS = [OC3, OC4, OC8]


@jit_off_examples(*({"seed": 1, "oc_index": i % 3, "np_steps": 2, "n_uavs": 2, "range_steps": 20,
                      "return_planner": ("exact", "st")[i % 2], "strategy": strategy, "weight": 1.0, "every": 2}
                     for i, strategy in enumerate(OPTIMISERS)))
@settings(max_examples=without_jit(30, 2), deadline=None,
          suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(seed=st.integers(0, 100_000), oc_index=st.integers(0, 2), np_steps=st.integers(1, 4),
       n_uavs=st.integers(1, without_jit(4, 2)), range_steps=st.integers(12, without_jit(45, 25)),
       return_planner=st.sampled_from(["exact", "st"]),
       strategy=st.sampled_from(OPTIMISERS), weight=st.floats(0.1, 5.0), every=st.integers(1, 4))
def test_plans_with_the_horizon_value_are_safe(seed, oc_index, np_steps, n_uavs, range_steps, return_planner,
                                                strategy, weight, every):
    oc = OCS[oc_index]
    scenario = random_scenario(seed, n_uavs=n_uavs, range_steps=range_steps, oc=oc)
    if scenario is None:
        return
    config = MissionConfig(np_steps=np_steps, oc=oc, return_planner=return_planner, strategy=strategy,
                           horizon=HorizonValue(weight=weight, every=every))
    plan = fly(scenario, config, seed=seed)
    assert_plan_safe(plan, scenario, oc)
    assert all(u.eta <= 1.0 for u in plan.uavs)


def test_same_seed_same_plan_with_the_horizon_value():
    scenario = paper_scenario(2, range_steps=without_jit(60, 14))
    config = MissionConfig(strategy="cpio", horizon=HorizonValue())
    a, b = fly(scenario, config, seed=2), fly(scenario, config, seed=2)
    assert [u.trajectory for u in a.uavs] == [u.trajectory for u in b.uavs]


def far_region() -> tuple[Scenario, tuple[slice, slice]]:
    """A 60 x 24 area of TEP 0.3; a likely region (TEP 0.9) 37-46 cells east of the only airport,
    whose UAV starts facing west and can fly there, search and come back within its range."""
    tep = np.full((60, 24), 0.3)
    eu = np.full((60, 24), 0.3)
    region = (slice(40, 50), slice(7, 17))
    tep[region] = eu[region] = 0.9
    uav = UavSpec(1, (3, 12), 6, 110)
    return Scenario("far region", SearchMap(tep, eu, np.zeros((60, 24), bool)), [uav], np.zeros((0, 2)),
                    Sensor()), region


def looks_in(plan, region) -> int:
    xs, ys = region
    return sum(xs.start <= p.x < xs.stop and ys.start <= p.y < ys.stop for u in plan.uavs for p in u.trajectory)


def test_paper_cpio_never_reaches_a_likely_region_past_its_horizon():
    scenario, region = far_region()
    plan = fly(scenario, MissionConfig(strategy="cpio"), seed=0)
    assert looks_in(plan, region) == 0


@pytest.mark.parametrize("strategy", OPTIMISERS)
def test_the_horizon_value_takes_every_optimiser_to_it_and_back(strategy):
    scenario, region = far_region()
    paper = fly(scenario, MissionConfig(strategy=strategy), seed=0)
    ahead = fly(scenario, MissionConfig(strategy=strategy, horizon=HorizonValue()), seed=0)
    assert looks_in(ahead, region) >= 20 > looks_in(paper, region)
    assert ahead.success.expected > paper.success.expected
    assert_plan_safe(ahead, scenario, OC3)


def test_settings_are_checked():
    with pytest.raises(ValueError):
        HorizonValue(weight=-1)
    with pytest.raises(ValueError):
        HorizonValue(length=0)
    with pytest.raises(ValueError):
        HorizonValue(every=0)
    assert HorizonValue().period((50, 50)) == 1 and HorizonValue().period((400, 400)) == 10
    assert dataclasses.asdict(HorizonValue()) == {"weight": 1.0, "length": 1.0, "radius": None, "every": None}
