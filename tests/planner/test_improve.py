"""The whole-mission improvement (`planner.improve`): its kernels against plain-Python references,
and improved plans keep every safety invariant and never expect fewer finds."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.dtscs import ClosedSearch, MissionConfig
from planner.improve import (
    MAX_LOOKS,
    ImproveSettings,
    _best_window,
    _dp_window,
    _look,
    _with_outcomes,
    improve_plan,
)
from planner.motion import HEADING_DX, HEADING_DY, OC3, OC4, OC8, STEPS, cell_lengths
from planner.return_exact import return_table
from tests.planner.helpers import assert_plan_safe, random_scenario, without_jit

PC = 0.9
QPOW = (1.0 - PC) ** np.arange(MAX_LOOKS + 1, dtype=np.float64)


def _gain_of(cells, counts, base, radius):
    """Reference: the expected finds `cells` add, read one after the other (footprint `radius`)."""
    counts = counts.copy()
    nx, ny = counts.shape
    gain = 0.0
    for x, y in cells:
        for cx in range(x - radius, x + radius + 1):
            for cy in range(y - radius, y + radius + 1):
                if 0 <= cx < nx and 0 <= cy < ny:
                    gain += base[cx, cy] * (1 - PC) ** counts[cx, cy] * PC
                    counts[cx, cy] += 1
    return gain


def _all_paths(pose, steps, oc, blocked):
    """Reference: every path of `steps` moves from `pose` under `oc` in the grid, off `blocked`."""
    nx, ny = blocked.shape
    for turns in itertools.product(range(8), repeat=steps):
        x, y, h = pose
        rows = []
        for g in turns:
            if not oc.allows(h, g):
                break
            x, y, h = x + int(HEADING_DX[g]), y + int(HEADING_DY[g]), g
            if not (0 <= x < nx and 0 <= y < ny) or blocked[x, y]:
                break
            rows.append((x, y, h))
        else:
            yield rows


def _case(seed, n=7):
    rng = np.random.default_rng(seed)
    blocked = rng.random((n, n)) < 0.1
    blocked[3, 3] = False
    base = np.where(blocked, 0.0, rng.random((n, n)))
    counts = rng.integers(0, 3, (n, n))
    return blocked, base, counts


@pytest.mark.parametrize("seed, oc, radius", [(0, OC3, 0), (1, OC8, 0), (2, OC4, 1), (3, OC3, 1)])
def test_a_window_is_the_best_of_every_path_between_its_poses(seed, oc, radius):
    blocked, base, counts = _case(seed)
    costs = cell_lengths()
    steps = 4 if oc is not OC8 else 3
    start = (3, 3, 2)
    # a path whose window ends where a reference path ends, so the window has a solution
    rows = next(iter(_all_paths(start, steps + 1, oc, blocked)))
    path = np.array([start, *rows], dtype=np.int64)
    others = np.full((1, len(path), 2), -1, dtype=np.int64)
    others[0, 2] = path[2, :2] + (1, 0)
    room = 10**9
    out = np.zeros((steps, 3), dtype=np.int64)
    gain, n = _best_window(path, 0, steps, False, steps, room, counts.copy(), base, QPOW, PC, radius, others, blocked,
                           oc.successors, np.array(oc.allowed), np.zeros((8, 7, 7), np.int32), HEADING_DX, HEADING_DY,
                           costs.by_heading, out)
    best = -1.0
    for cand in _all_paths(start, steps, oc, blocked):
        end = cand[-1]
        if end[:2] != tuple(path[steps, :2]) or not oc.allows(end[2], int(path[steps + 1, 2])):
            continue
        if any(tuple(others[0, t + 1]) == c[:2] for t, c in enumerate(cand)):
            continue
        best = max(best, _gain_of([c[:2] for c in cand], counts, base, radius))
    assert n == steps and gain == pytest.approx(best, rel=1e-12)
    assert _gain_of([tuple(c[:2]) for c in out[:n]], counts, base, radius) == pytest.approx(gain, rel=1e-12)


@pytest.mark.parametrize("seed, oc, penalty", [(4, OC3, 0.0), (5, OC8, 0.3), (6, OC4, 0.0)])
def test_the_dynamic_programme_finds_the_best_additive_path(seed, oc, penalty):
    blocked, base, counts = _case(seed)
    steps = 5 if oc is not OC8 else 3
    start = (3, 3, 0)
    rows = next(iter(_all_paths(start, steps + 1, oc, blocked)))
    path = np.array([start, *rows], dtype=np.int64)
    others = np.full((1, len(path), 2), -1, dtype=np.int64)
    out = np.zeros((steps, 3), dtype=np.int64)
    assert _dp_window(path, 0, steps, penalty, counts.copy(), base, QPOW, PC, 0, others, blocked, oc.successors,
                      np.array(oc.allowed), HEADING_DX, HEADING_DY, out)

    def value(cand):
        first = sum(base[x, y] * (1 - PC) ** counts[x, y] * PC for x, y, _ in cand)
        return first - penalty * sum(h % 2 for *_, h in cand)

    best = max(value(c) for c in _all_paths(start, steps, oc, blocked)
               if c[-1][:2] == tuple(path[steps, :2]) and oc.allows(c[-1][2], int(path[steps + 1, 2])))
    assert value([tuple(r) for r in out]) == pytest.approx(best, rel=1e-12)


def test_a_reading_taken_back_gives_back_what_it_added():
    _, base, counts = _case(7)
    before = counts.copy()
    added = _look(counts, base, QPOW, PC, 2, 5, 1, 1)
    assert added == pytest.approx(_gain_of([(2, 5)], before, base, 1))
    assert _look(counts, base, QPOW, PC, 2, 5, 1, -1) == pytest.approx(added)
    assert np.array_equal(counts, before)


def _fly(scenario, config, seed=0):
    search = ClosedSearch(scenario, config, seed)
    for _ in search.run():
        pass
    return search


@settings(max_examples=without_jit(12, 3), deadline=None)
@given(seed=st.integers(0, 10_000), oc_index=st.integers(0, 2), metres=st.booleans(), radius=st.integers(0, 1),
       reserve=st.integers(0, 2))
def test_improved_plans_are_safe_and_never_expect_less(seed, oc_index, metres, radius, reserve):
    oc = (OC3, OC4, OC8)[oc_index]
    costs = cell_lengths() if metres else STEPS
    scenario = random_scenario(seed, n_uavs=3, range_steps=without_jit(30, 16), oc=oc, costs=costs)
    if scenario is None:
        return
    scenario.sensor = type(scenario.sensor)(0.9, 0.1, radius)
    config = MissionConfig(oc=oc, np_steps=3, reserve_steps=reserve)
    try:
        search = _fly(scenario, config, seed)
    except ValueError:
        return
    before = search.plan()
    after = improve_plan(before, scenario, oc, search.reserve, seed, ImproveSettings(dp_steps=8, dp_stride=3))
    assert_plan_safe(after, scenario, oc)
    for u in after.uavs:
        assert u.spent <= u.range_units - search.reserve
    assert after.success.expected >= before.success.expected - 1e-9
    replay = _with_outcomes(before, scenario, before.uavs, seed)
    assert (replay.targets, replay.false_alarms) == (before.targets, before.false_alarms)
    assert replay.success.expected == pytest.approx(before.success.expected, rel=1e-12)


def test_the_config_improves_the_plan_it_returns_once_landed():
    scenario = random_scenario(11, nx=16, ny=14, n_uavs=3, range_steps=36, oc=OC3, costs=cell_lengths())
    plain = _fly(scenario, MissionConfig(np_steps=3), 11).plan()
    search = _fly(scenario, MissionConfig(np_steps=3, improve=ImproveSettings()), 11)
    improved = search.plan()
    assert improved is search.plan()
    assert improved.settings["improved"] is True and "improved" not in plain.settings
    assert improved.success.expected > plain.success.expected
    assert_plan_safe(improved, scenario, OC3)


def test_a_uav_left_with_range_near_home_spends_it():
    """Under 3OC a UAV that comes home with a few cells of range left has no loop that fits: its
    tail grows into the cells beside the way home."""
    scenario = random_scenario(3, nx=12, ny=12, n_uavs=1, range_steps=40, oc=OC3, costs=cell_lengths())
    search = _fly(scenario, MissionConfig(np_steps=3), 3)
    plan = search.plan()
    u = plan.uavs[0]
    short = 6 * 1000
    tables = {u.uav_id: return_table(scenario.search_map.no_fly, u.airport, OC3, scenario.move_costs)}
    widened = replace(plan, uavs=[replace(u, range_units=u.spent + short)])
    after = improve_plan(widened, scenario, OC3, 0, 3, ImproveSettings(dp_steps=0, rounds=3), tables)
    assert after.uavs[0].spent > u.spent + 2000
    assert after.success.expected > plan.success.expected
    assert_plan_safe(after, scenario, OC3)
