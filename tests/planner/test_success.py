"""Probability of success (`planner.success`) against a slow, obviously-correct reference, its
per-UAV parts, repeated looks, and the figures a closed search reports."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.dtscs import ClosedSearch, MissionConfig
from planner.environment import Sensor
from planner.scenario import paper_scenario
from planner.success import SuccessTally, expected_finds, plan_looks, success_of_looks
from tests.planner.helpers import random_scenario


def reference_expected(prior, searchable, pc, looks):
    """Each searchable cell's target is found unless every look at it misses: P0 (1 - (1-Pc)^n)."""
    counts = {}
    for _step, _uid, x, y in looks:
        counts[(x, y)] = counts.get((x, y), 0) + 1
    total = 0.0
    for (x, y), n in counts.items():
        if searchable[x, y]:
            total += prior[x, y] * (1.0 - (1.0 - pc) ** n)
    return total


@st.composite
def looks_on_a_grid(draw):
    nx, ny = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    prior = rng.random((nx, ny))
    searchable = rng.random((nx, ny)) > 0.2
    pc = draw(st.floats(0.05, 1.0))
    n = draw(st.integers(0, 40))
    steps = np.sort(rng.integers(0, 10, n))
    looks = [(int(s), int(rng.integers(1, 4)), int(rng.integers(nx)), int(rng.integers(ny))) for s in steps]
    return prior, searchable, pc, looks


@settings(max_examples=200, deadline=None)
@given(case=looks_on_a_grid())
def test_expected_finds_match_the_reference_and_the_parts_add_up(case):
    prior, searchable, pc, looks = case
    success = success_of_looks(prior, searchable, pc, looks, uav_ids=[1, 2, 3])
    assert success.expected == pytest.approx(reference_expected(prior, searchable, pc, looks), abs=1e-12)
    assert sum(success.by_uav.values()) == pytest.approx(success.expected, abs=1e-12)
    assert success.available == pytest.approx(prior[searchable].sum())
    counts = np.zeros(prior.shape)
    for _s, _u, x, y in looks:
        counts[x, y] += 1
    assert success.expected == pytest.approx(expected_finds(prior, searchable, pc, counts), abs=1e-12)
    if looks:
        assert success.cumulative[-1] == pytest.approx(success.expected)
        assert list(success.steps) == sorted({s for s, *_ in looks})
        assert np.all(np.diff(success.cumulative) >= 0)
        for uid, series in success.cumulative_by_uav.items():
            assert series[-1] == pytest.approx(success.by_uav[uid])
        parts = sum(success.cumulative_by_uav.values())
        np.testing.assert_allclose(parts, success.cumulative, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(case=looks_on_a_grid(), extra=st.tuples(st.integers(0, 5), st.integers(0, 5), st.integers(1, 3)))
def test_never_above_the_area_total_and_never_lower_with_one_more_look(case, extra):
    prior, searchable, pc, looks = case
    x, y, uid = extra[0] % prior.shape[0], extra[1] % prior.shape[1], extra[2]
    before = success_of_looks(prior, searchable, pc, looks)
    step = looks[-1][0] if looks else 0
    after = success_of_looks(prior, searchable, pc, looks + [(step, uid, x, y)])
    assert before.expected <= before.available + 1e-12
    assert after.expected <= after.available + 1e-12
    assert after.expected >= before.expected
    assert after.expected - before.expected == pytest.approx(
        prior[x, y] * searchable[x, y] * pc * (1 - pc) ** sum((lx, ly) == (x, y) for *_, lx, ly in looks), abs=1e-12)


def test_a_second_look_adds_what_the_first_missed():
    prior = np.array([[0.5]])
    one = success_of_looks(prior, np.ones((1, 1), bool), 0.9, [(0, 1, 0, 0)])
    two = success_of_looks(prior, np.ones((1, 1), bool), 0.9, [(0, 1, 0, 0), (1, 2, 0, 0)])
    assert one.expected == pytest.approx(0.45)
    assert two.expected == pytest.approx(0.5 * 0.99)
    assert two.by_uav == pytest.approx({1: 0.45, 2: 0.045})
    assert two.share == pytest.approx(0.99) and two.share_of(2) == pytest.approx(0.09)


def test_no_fly_cells_hold_nothing_and_an_empty_prior_has_no_share():
    prior = np.full((2, 2), 0.5)
    searchable = np.array([[True, False], [True, True]])
    success = success_of_looks(prior, searchable, 0.9, [(0, 1, 0, 1), (1, 1, 0, 0)])
    assert success.expected == pytest.approx(0.45) and success.available == pytest.approx(1.5)
    empty = success_of_looks(np.zeros((2, 2)), searchable, 0.9, [(0, 1, 0, 0)])
    assert empty.expected == 0.0 and empty.share == 0.0 and empty.share_of(1) == 0.0


@settings(max_examples=50, deadline=None)
@given(case=looks_on_a_grid(), cut=st.integers(0, 40))
def test_a_campaign_is_the_sum_of_its_sorties(case, cut):
    prior, searchable, pc, looks = case
    first, second = looks[:cut], looks[cut:]
    counts = np.zeros(prior.shape)
    for *_, x, y in first:
        counts[x, y] += 1
    whole = success_of_looks(prior, searchable, pc, looks)
    a = success_of_looks(prior, searchable, pc, first)
    b = success_of_looks(prior, searchable, pc, second, looks_before=counts)
    assert a.expected + b.expected == pytest.approx(whole.expected, abs=1e-12)


def test_looks_out_of_step_order_are_refused():
    with pytest.raises(ValueError, match="step order"):
        success_of_looks(np.ones((2, 2)), np.ones((2, 2), bool), 0.9, [(3, 1, 0, 0), (2, 1, 1, 1)])


def test_plan_looks_cover_the_footprint_in_grid_step_by_step():
    looks = plan_looks({2: [(0, 0, 0), (1, 1, 0)], 1: [(0, 3, 3)]}, 1, (4, 4))
    assert looks[:4] == [(0, 2, 0, 0), (0, 2, 0, 1), (0, 2, 1, 0), (0, 2, 1, 1)]
    assert [r for r in looks if r[0] == 0 and r[1] == 1] == [(0, 1, 2, 2), (0, 1, 2, 3), (0, 1, 3, 2), (0, 1, 3, 3)]
    assert [r for r in looks if r[0] == 1] == [(1, 2, 0, 0), (1, 2, 0, 1), (1, 2, 1, 0), (1, 2, 1, 1), (1, 2, 2, 0),
                                               (1, 2, 2, 1)]


@pytest.mark.parametrize("footprint", [0, 1])
def test_a_closed_search_reports_the_success_of_the_cells_it_flew(footprint):
    scenario = paper_scenario(3, range_steps=50, sensor=Sensor(0.9, 0.1, footprint))
    search = ClosedSearch(scenario, MissionConfig(np_steps=3), seed=3)
    records = list(search.run())
    plan = search.plan()
    looks = []
    for u in plan.uavs:
        for p in u.trajectory:
            for cx in range(p.x - footprint, p.x + footprint + 1):
                for cy in range(p.y - footprint, p.y + footprint + 1):
                    if 0 <= cx < 50 and 0 <= cy < 50:
                        looks.append((p.step, u.uav_id, cx, cy))
    prior = scenario.search_map
    assert plan.success.expected == pytest.approx(reference_expected(prior.tep, ~prior.no_fly, 0.9, looks))
    assert plan.success.available == pytest.approx(prior.tep[~prior.no_fly].sum())
    assert sum(plan.success.by_uav.values()) == pytest.approx(plan.success.expected)
    for record in records:
        j = list(plan.success.steps).index(record.step)
        assert record.expected_found == pytest.approx({uid: s[j] for uid, s in plan.success.cumulative_by_uav.items()})
    assert plan.success.steps[0] == 0
    assert plan.success.cumulative[0] == pytest.approx(sum(prior.tep[u.airport] * 0.9 for u in scenario.uavs)
                                                       if footprint == 0 else plan.success.cumulative[0])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_random_plans_expect_no_more_than_the_area_holds(seed):
    scenario = random_scenario(seed, n_uavs=2, range_steps=30)
    if scenario is None:
        return
    try:
        search = ClosedSearch(scenario, MissionConfig(np_steps=2), seed=seed)
    except ValueError:
        return
    for _ in search.run():
        pass
    success = search.plan().success
    assert 0.0 < success.expected <= success.available
    tally = SuccessTally(scenario.search_map.tep, ~scenario.search_map.no_fly, scenario.sensor.pc)
    assert tally.available == pytest.approx(success.available)
