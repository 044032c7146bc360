"""The whole-mission improvement (`planner.improve`): its kernels against plain-Python references,
and improved plans keep every safety invariant and never expect fewer finds."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import planner.best_response as best_response
import planner.improve as improve
from planner.best_response import ResponseSettings, _walk_dp, read_footprint, respond
from planner.dtscs import ClosedSearch, MissionConfig
from planner.energy import Airframe, EnergyProfile
from planner.improve import (
    MAX_LOOKS,
    ImproveSettings,
    _best_window,
    _dp_window,
    _with_outcomes,
    improve_plan,
)
from planner.motion import HEADING_DX, HEADING_DY, OC3, OC4, OC8, STEPS, cell_lengths
from planner.path_time import ARDUCOPTER_CORNERING, path_time_s
from planner.return_exact import return_table
from planner.time_pricing import TimePricing, time_pricing
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
    blocked[3, 3] = blocked[n // 2, n // 2] = False
    base = np.where(blocked, 0.0, rng.random((n, n)))
    counts = rng.integers(0, 3, (n, n))
    return blocked, base, counts


#: a turn's time-priced units by heading change ((h' - h) mod 8), as `planner.time_pricing` gives them
TURNS = np.array([0, 389, 635, 953, 1334, 953, 635, 389], dtype=np.int64)


def _turns_of(headings, turns=TURNS):
    """Reference: what the turns between consecutive `headings` add."""
    return sum(int(turns[(b - a) % 8]) for a, b in zip(headings, headings[1:]))


@pytest.mark.parametrize("seed, oc, radius, timed", [(0, OC3, 0, False), (1, OC8, 0, False), (2, OC4, 1, False),
                                                     (3, OC3, 1, False), (3, OC3, 0, True), (1, OC8, 1, True)])
def test_a_window_is_the_best_of_every_path_between_its_poses(seed, oc, radius, timed):
    """Against every path of the window's steps; `timed`: each turn priced (`TURNS`), from the
    pose before the window into it and out of it into the fixed pose after it, within a time
    room just short of what the best path without it costs."""
    n = 11 if timed else 7
    blocked, base, counts = _case(seed, n)
    costs = cell_lengths()
    steps = 3 if oc is OC8 else 6 if timed else 4
    start = (5, 5, 2) if timed else (3, 3, 2)
    # a path whose window ends where a reference path ends, so the window has a solution; timed,
    # the one most paths of the window can end as, and a pose before it, so the turn into the
    # window counts (none at a path's first pose)
    rows = next(iter(_all_paths(start, steps + 1, oc, blocked)))
    if timed:
        ends = [(tuple(c[-1][:2]), c[-1][2]) for c in _all_paths(start, steps, oc, blocked)]
        rows = max(_all_paths(start, steps + 1, oc, blocked), key=lambda r: sum(
            cell == r[steps - 1][:2] and oc.allows(h, r[steps][2]) for cell, h in ends))
    before = [(4, 5, 2)] if timed else []
    a = len(before)
    path = np.array([*before, start, *rows], dtype=np.int64)
    others = np.full((1, len(path), 2), -1, dtype=np.int64)
    others[0, a + 2] = path[a + 2, :2] + (1, 0)
    turns = TURNS if timed else np.zeros(8, dtype=np.int64)
    room = 10**9

    def time_cost(cand):
        headings = [start[2], *(c[2] for c in cand), int(path[a + steps + 1, 2])]
        return sum(costs.of(c[2]) for c in cand) + _turns_of(headings if timed else [], turns)

    candidates = []
    for cand in _all_paths(start, steps, oc, blocked):
        end = cand[-1]
        if end[:2] != tuple(path[a + steps, :2]) or not oc.allows(end[2], int(path[a + steps + 1, 2])):
            continue
        if any(tuple(others[0, a + t + 1]) == c[:2] for t, c in enumerate(cand)):
            continue
        candidates.append(cand)
    def gain_of(cand):
        return _gain_of([c[:2] for c in cand], counts, base, radius)

    time_room = time_cost(max(candidates, key=gain_of)) - 1 if timed else room
    out = np.zeros((steps, 3), dtype=np.int64)
    gain, n = _best_window(path, a, steps, False, steps, room, time_room, counts.copy(), base, QPOW, PC, radius, others,
                           blocked, oc.successors, np.array(oc.allowed), np.zeros((8, n, n), np.int32), HEADING_DX,
                           HEADING_DY, costs.by_heading, turns, out)
    fitting = [c for c in candidates if time_cost(c) <= time_room]
    assert fitting and (len(fitting) < len(candidates) or not timed)
    best = max(gain_of(cand) for cand in fitting)
    assert n == steps and gain == pytest.approx(best, rel=1e-12)
    assert _gain_of([tuple(c[:2]) for c in out[:n]], counts, base, radius) == pytest.approx(gain, rel=1e-12)
    assert time_cost([tuple(r) for r in out]) <= time_room


@pytest.mark.parametrize("seed, oc, penalty, timed", [(4, OC3, 0.0, False), (5, OC8, 0.3, False), (6, OC4, 0.0, False),
                                                      (4, OC8, 0.05, True), (8, OC8, 0.1, True)])
def test_the_dynamic_programme_finds_the_best_additive_path(seed, oc, penalty, timed):
    """Against every path of the window's steps; `timed`: a pose before the window, and each turn
    into, inside and out of it penalised `penalty` times its weight (cases where the best path
    with only the turn out of the window penalised is not the best with all of them)."""
    blocked, base, counts = _case(seed)
    steps = 5 if oc is not OC8 else 3
    start = (3, 3, 0)
    rows = next(iter(_all_paths(start, steps + 1, oc, blocked)))
    before = [(3, 2, 0)] if timed else []
    a = len(before)
    path = np.array([*before, start, *rows], dtype=np.int64)
    others = np.full((1, len(path), 2), -1, dtype=np.int64)
    weight = TURNS / 415.0 if timed else np.zeros(8)
    out = np.zeros((steps, 3), dtype=np.int64)
    assert _dp_window(path, a, steps, penalty, weight, counts.copy(), base, QPOW, PC, 0, others, blocked,
                      oc.successors, np.array(oc.allowed), HEADING_DX, HEADING_DY, out)

    def value(cand):
        first = sum(base[x, y] * (1 - PC) ** counts[x, y] * PC for x, y, _ in cand)
        headings = [start[2], *(h for *_, h in cand), int(path[a + steps + 1, 2])] if timed else []
        turned = sum(weight[(b - h) % 8] for h, b in zip(headings, headings[1:]))
        return first - penalty * (sum(h % 2 for *_, h in cand) + turned)

    best = max(value(c) for c in _all_paths(start, steps, oc, blocked)
               if c[-1][:2] == tuple(path[a + steps, :2]) and oc.allows(c[-1][2], int(path[a + steps + 1, 2])))
    assert value([tuple(r) for r in out]) == pytest.approx(best, rel=1e-12)


def test_a_reading_taken_back_gives_back_what_it_added():
    _, base, counts = _case(7)
    before = counts.copy()
    added = read_footprint(counts, base, QPOW, PC, 2, 5, 1, 1)
    assert added == pytest.approx(_gain_of([(2, 5)], before, base, 1))
    assert read_footprint(counts, base, QPOW, PC, 2, 5, 1, -1) == pytest.approx(added)
    assert np.array_equal(counts, before)


# ---- the best response: one UAV's whole path re-planned against the others (`planner.best_response`) -----------


def _closed_walks(pose, steps, oc, blocked, home_cell):
    """Reference: every walk of exactly `steps` moves from `pose` that ends on `home_cell`."""
    for rows in _all_paths(pose, steps, oc, blocked):
        if rows and rows[-1][:2] == home_cell:
            yield rows


@pytest.mark.parametrize("seed, oc", [(0, OC3), (1, OC8), (2, OC4), (3, OC3)])
def test_the_walk_programme_finds_the_best_additive_closed_walk_at_every_step(seed, oc):
    """Axis and diagonal moves alike cost one step and no turn is priced, so at mu = 0 the
    programme is exact: at every step t its best end on the airport is the largest prize sum of
    any walk of t moves from the airport pose back to it, off another UAV's cell at each step."""
    n = 7
    blocked, base, _ = _case(seed, n)
    start = (3, 3, 2)
    steps = 6 if oc is OC3 else 4
    prize = base * PC
    others = np.full((1, steps + 1, 2), -1, dtype=np.int64)
    others[0, 2] = (4, 3)
    home = return_table(blocked, start[:2], oc, STEPS)
    parent = np.zeros((steps + 1, n, n, 8), dtype=np.int8)
    end_value = np.empty((steps + 1, 8))
    end_cost = np.zeros((steps + 1, 8), dtype=np.int64)
    end_turns = np.zeros((steps + 1, 8), dtype=np.int64)
    _walk_dp(*start, steps, steps, steps, prize, 0, 0, np.zeros(steps + 1, dtype=np.int64),
             np.zeros(steps + 1, dtype=np.int64), blocked, others, home, oc.successors, HEADING_DX, HEADING_DY,
             STEPS.by_heading, np.zeros(8, dtype=np.int64), 0.0, 0.0, parent, end_value, end_cost, end_turns)
    for t in range(1, steps + 1):
        walks = [w for w in _closed_walks(start, t, oc, blocked, start[:2])
                 if not any(tuple(others[0, s + 1]) == c[:2] for s, c in enumerate(w) if s + 1 < others.shape[1])]
        best = max((sum(prize[x, y] for x, y, _ in w) for w in walks), default=-np.inf)
        assert end_value[t].max() == pytest.approx(best, rel=1e-12)
        if walks:
            assert end_cost[t, int(np.argmax(end_value[t]))] == t


def _pushed_walk_dp(sx, sy, sh, steps, budget, time_budget, prize, x0, y0, blocked, others, home, successors,
                    move_costs, turns, mu, turn_weight, tube=None):
    """Reference: the programme pushing every live state to each successor (in order of cell and
    heading, the first best kept), as `_walk_dp` did before it pulled; its parents and ends.
    `tube` (side, ox, oy): the states of step t only in the side x side cells from (ox[t], oy[t])."""
    bw, bh = prize.shape
    value = np.full((steps + 1, bw, bh, 8), -np.inf)
    cost = np.zeros((steps + 1, bw, bh, 8), dtype=np.int64)
    turned = np.zeros((steps + 1, bw, bh, 8), dtype=np.int64)
    parent = np.zeros((steps + 1, bw, bh, 8), dtype=np.int8)
    value[0, sx - x0, sy - y0, sh] = 0.0
    for t in range(steps):
        held = {tuple(others[u, t + 1]) for u in range(others.shape[0])} if t + 1 < others.shape[1] else set()
        for i, j, h in itertools.product(range(bw), range(bh), range(8)):
            v = value[t, i, j, h]
            if v == -np.inf:
                continue
            for g in successors[h]:
                if g < 0:
                    break
                qi, qj = i + int(HEADING_DX[g]), j + int(HEADING_DY[g])
                if not (0 <= qi < bw and 0 <= qj < bh) or (x0 + qi, y0 + qj) in held or blocked[x0 + qi, y0 + qj]:
                    continue
                if tube is not None and not (0 <= x0 + qi - tube[1][t + 1] < tube[0]
                                             and 0 <= y0 + qj - tube[2][t + 1] < tube[0]):
                    continue
                c = cost[t, i, j, h] + move_costs[g]
                turn = turns[(g - h) & 7] if t >= 1 else 0
                back = home[g, x0 + qi, y0 + qj]
                if c + back > budget or c + turned[t, i, j, h] + turn + back > time_budget:
                    continue
                w = v + prize[qi, qj] - mu * (move_costs[g] + turn_weight * turn)
                if w > value[t + 1, qi, qj, g]:
                    value[t + 1, qi, qj, g] = w
                    cost[t + 1, qi, qj, g] = c
                    turned[t + 1, qi, qj, g] = turned[t, i, j, h] + turn
                    parent[t + 1, qi, qj, g] = h
    si, sj = sx - x0, sy - y0
    return parent, value[:, si, sj, :], cost[:, si, sj, :], turned[:, si, sj, :], np.isfinite(value)


@pytest.mark.parametrize("seed, oc, mu, timed, tubed", [
    (0, OC3, 0.0, False, False), (1, OC8, 0.3, True, False), (2, OC3, 0.05, True, False), (4, OC4, 0.2, False, False),
    (5, OC3, 0.0, True, False), (0, OC3, 0.0, False, True), (1, OC8, 0.3, True, True), (4, OC4, 0.2, False, True)])
def test_the_walk_programme_pulling_keeps_what_pushing_finds_bit_for_bit(seed, oc, mu, timed, tubed):
    """`_walk_dp` pulls each state from its predecessors: the same values, costs, turn charges and
    parents as pushing every state to its successors (`_pushed_walk_dp`), with diagonals dearer,
    turns priced and a time budget that binds, another UAV's cells held, in a box off the grid's
    corner; `tubed`, in a tube of 5 x 5 cells that moves a cell east and back."""
    n = 9
    blocked, base, _ = _case(seed, n)
    blocked[4, 4] = False
    costs = cell_lengths()
    turns = TURNS if timed else np.zeros(8, dtype=np.int64)
    steps = 16
    budget = 13 * costs.straight
    time_budget = budget + (2 * int(TURNS.max()) if timed else 0)
    start = (4, 4, 2)
    x0, y0 = 1, 2
    prize = np.round(base[x0:, y0:] * 4) / 4  # ties, which the order of the predecessors breaks
    others = np.full((1, steps + 1, 2), -1, dtype=np.int64)
    others[0, 3:6] = [(5, 5), (6, 5), (6, 6)]
    home = return_table(blocked, start[:2], oc, costs)
    ox, oy = np.full(steps + 1, x0), np.full(steps + 1, y0)
    side = None
    if tubed:
        side = 5
        ox = start[0] - 2 + np.array([0, 0, 1, 1, 2, 2, 1, 1, 0, 0, 1, 1, 2, 2, 1, 1, 0])[: steps + 1]
        oy = np.full(steps + 1, start[1] - 2)
    parent = np.zeros((steps + 1, side or prize.shape[0], side or prize.shape[1], 8), dtype=np.int8)
    end_value = np.empty((steps + 1, 8))
    end_cost = np.zeros((steps + 1, 8), dtype=np.int64)
    end_turns = np.zeros((steps + 1, 8), dtype=np.int64)
    _walk_dp(*start, steps, budget, time_budget, prize, x0, y0, ox, oy, blocked, others, home, oc.successors,
             HEADING_DX, HEADING_DY, costs.by_heading, turns, mu, 1.0 if timed else 0.0, parent, end_value, end_cost,
             end_turns)
    want_parent, want_value, want_cost, want_turns, live = _pushed_walk_dp(
        *start, steps, budget, time_budget, prize, x0, y0, blocked, others, home, oc.successors, costs.by_heading,
        turns, mu, 1.0 if timed else 0.0, (side, ox, oy) if tubed else None)
    assert np.isfinite(want_value[1:]).any()
    if tubed:
        free = _pushed_walk_dp(*start, steps, budget, time_budget, prize, x0, y0, blocked, others, home,
                               oc.successors, costs.by_heading, turns, mu, 1.0 if timed else 0.0)[4]
        assert live.sum() < free.sum()  # the tube drops states
        for t, i, j, h in zip(*np.nonzero(live)):
            assert parent[t, x0 + i - ox[t], y0 + j - oy[t], h] == want_parent[t, i, j, h]
    else:
        assert np.array_equal(parent[live], want_parent[live])
    assert np.array_equal(end_value[1:], want_value[1:])
    ends = np.isfinite(want_value)
    assert np.array_equal(end_cost[ends], want_cost[ends]) and np.array_equal(end_turns[ends], want_turns[ends])


def _pocket(others=None):
    """One UAV at (1, 7) heading east under 3OC, 40 steps of range, a loop of 8 moves near its
    airport as its path; nothing to find but three cells far east, (10..12, 7)."""
    n = 16
    blocked = np.zeros((n, n), dtype=np.bool_)
    base = np.zeros((n, n))
    base[10:13, 7] = 1.0
    loop = [(2, 7, 2), (3, 8, 1), (3, 9, 0), (2, 10, 7), (1, 10, 6), (0, 9, 5), (0, 8, 4), (1, 7, 3)]
    path = np.full((41, 3), -1, dtype=np.int64)
    path[0] = (1, 7, 2)
    path[1:9] = loop
    counts = np.zeros((n, n), dtype=np.int64)
    for x, y, _ in path[:9]:
        counts[x, y] += 1
    others = np.full((1, 41, 2), -1, dtype=np.int64) if others is None else others
    home = return_table(blocked, (1, 7), OC3, STEPS)
    return path, counts, base, blocked, others, home


@pytest.mark.parametrize("held", [False, True])
def test_the_best_response_flies_to_a_rich_far_pocket_and_home(held):
    """The loop reads nothing; the walk east along row 7 reads the three rich cells and comes
    home within the 40 steps. `held`: another UAV stands on (10, 7) at step 9, when the straight
    line would get there: the walk reads the pocket at other steps."""
    others = None
    if held:
        others = np.full((1, 41, 2), -1, dtype=np.int64)
        others[0, 9] = (10, 7)
    path, counts, base, blocked, others, home = _pocket(others)
    before = counts.copy()
    gain, n, _ = respond(path, 9, 40, 40, counts, base, QPOW, PC, 0, others, blocked, OC3.successors,
                         np.array(OC3.allowed), home, HEADING_DX, HEADING_DY, STEPS.by_heading,
                         np.zeros(8, dtype=np.int64), ResponseSettings())
    walk = [tuple(int(v) for v in r) for r in path[:n]]
    assert {(x, 7) for x in range(10, 13)} <= {(x, y) for x, y, _ in walk}
    assert gain >= 3 * PC
    assert walk[0] == (1, 7, 2) and walk[-1][:2] == (1, 7) and n - 1 <= 40
    for (x, y, h), (qx, qy, g) in zip(walk, walk[1:]):
        assert OC3.allows(h, g) and (qx - x, qy - y) == (HEADING_DX[g], HEADING_DY[g])
    assert all(tuple(others[0, s]) != (x, y) for s, (x, y, _) in enumerate(walk))
    expect = before.copy()
    for x, y, _ in _pocket()[0][1:9]:
        expect[x, y] -= 1
    assert gain == pytest.approx(_gain_of([c[:2] for c in walk[1:]], expect, base, 0), rel=1e-12)
    for x, y, _ in walk[1:]:
        expect[x, y] += 1
    assert np.array_equal(counts, expect)


def test_a_uav_whose_programme_is_too_large_searches_a_tube_around_its_path():
    """Over `ResponseSettings.states`, the programme runs in a tube of 9 x 9 cells around the
    path's pose at each step: it reaches the pocket 2 cells past the loop, not one 7 cells past."""
    path, counts, base, blocked, others, home = _pocket()
    base[:] = 0.0
    base[5:7, 7] = 1.0  # within 4 cells of the loop's (3, 8)
    base[10, 7] = 5.0  # out of the tube
    tube = ResponseSettings(states=1, tube_states=9 * 9 * 41 * 8)
    gain, n, _ = respond(path, 9, 40, 40, counts, base, QPOW, PC, 0, others, blocked, OC3.successors,
                         np.array(OC3.allowed), home, HEADING_DX, HEADING_DY, STEPS.by_heading,
                         np.zeros(8, dtype=np.int64), tube)
    cells = {(int(x), int(y)) for x, y, _ in path[:n]}
    assert {(5, 7), (6, 7)} <= cells and (10, 7) not in cells and gain >= 2 * PC
    assert path[n - 1, :2].tolist() == [1, 7] and n - 1 <= 40
    narrow = ResponseSettings(states=1, tube_states=7 * 7 * 41 * 8)  # a 7-cell tube is the windows' work
    path, counts, *_ = _pocket()
    assert respond(path, 9, 40, 40, counts, base, QPOW, PC, 0, others, blocked, OC3.successors, np.array(OC3.allowed),
                   home, HEADING_DX, HEADING_DY, STEPS.by_heading, np.zeros(8, dtype=np.int64), narrow)[:2] == (0.0, 9)


def test_a_best_response_that_finds_nothing_better_leaves_the_path_and_counts():
    """Nothing left to find: no walk gains, and the path and the counts stay as they were."""
    path, counts, base, blocked, others, home = _pocket()
    base[:] = 0.0
    before, old = counts.copy(), path.copy()
    gain, n, _ = respond(path, 9, 40, 40, counts, base, QPOW, PC, 0, others, blocked, OC3.successors,
                         np.array(OC3.allowed), home, HEADING_DX, HEADING_DY, STEPS.by_heading,
                         np.zeros(8, dtype=np.int64), ResponseSettings())
    assert (gain, n) == (0.0, 9) and np.array_equal(path, old) and np.array_equal(counts, before)


def test_a_first_response_runs_the_whole_ladder_and_keeps_the_best_rung(monkeypatch):
    """A first response runs every rung of mu's ladder (here every walk's score rises with its
    rung) and says the best one's."""
    path, counts, base, blocked, others, home = _pocket()
    scale = PC / 1.0  # the mean positive prize over the dearest move: three cells of PC, moves of 1
    rungs = []

    def walk_dp(*args):
        mu = args[19]
        rungs.append(-1 if mu == 0 else int(round(np.log2(mu / scale))) + 2)

    def best_end(*args):
        args[-2][0] = (2, 7, 2)
        return float(rungs[-1] + 10), 1

    monkeypatch.setattr(best_response, "_walk_dp", walk_dp)
    monkeypatch.setattr(best_response, "_best_end", best_end)
    gain, n, rung = respond(path, 9, 40, 40, counts, base, QPOW, PC, 0, others, blocked, OC3.successors,
                            np.array(OC3.allowed), home, HEADING_DX, HEADING_DY, STEPS.by_heading,
                            np.zeros(8, dtype=np.int64), ResponseSettings(passes=1))
    assert rungs == list(range(-1, 9)) and rung == 8
    assert (gain, n) == (0.0, 9)  # a walk of one pose is not home: not taken


def test_a_uav_is_asked_again_only_when_a_path_changed_since_its_last_response(monkeypatch):
    """Three UAVs; the second one's response changes its path in the first round, the others'
    do not: in the second round only the first UAV is asked again (the second answered the
    others' paths as they are, the third answered after the change), nothing changes, and the
    rounds end. Every sweep over all three would ask six times."""
    scenario = random_scenario(5, n_uavs=3, range_steps=30, oc=OC3, costs=cell_lengths())
    assert scenario is not None
    before = _fly(scenario, MissionConfig(np_steps=3), 5).plan()
    airports = [u.airport for u in before.uavs]
    assert len(set(airports)) == 3
    asked = []

    def answer(path, n_poses, *args):
        asked.append(airports.index((int(path[0, 0]), int(path[0, 1]))))
        return (1.0 if len(asked) == 2 else 0.0), n_poses, None

    monkeypatch.setattr(improve, "respond", answer)
    improve_plan(before, scenario, OC3, 0, 5, ImproveSettings(rounds=0, response=ResponseSettings(rounds=5)))
    assert asked == [0, 1, 2, 0]


@pytest.mark.parametrize("tube_states", [0, 10**9])
def test_long_windows_are_left_out_for_uavs_whose_path_a_tube_changed(monkeypatch, tube_states):
    """Every UAV's programme over its box is over `states`: a UAV whose path a tube's answer
    changed gets no long windows (`_dp_sweep`), the others do; without tubes (tube_states 0) every
    UAV gets them, as before."""
    scenario = random_scenario(5, n_uavs=3, range_steps=30, oc=OC3, costs=cell_lengths())
    before = _fly(scenario, MissionConfig(np_steps=3), 5).plan()
    airports = [u.airport for u in before.uavs]
    swept, changed = set(), set()
    sweep, answer = improve._dp_sweep, improve.respond

    def counted_sweep(path, *args):
        swept.add(airports.index((int(path[0, 0]), int(path[0, 1]))))
        return sweep(path, *args)

    def counted_answer(path, *args):
        gain, n, rung = answer(path, *args)
        if gain > 0.0:
            changed.add(airports.index((int(path[0, 0]), int(path[0, 1]))))
        return gain, n, rung

    monkeypatch.setattr(improve, "_dp_sweep", counted_sweep)
    monkeypatch.setattr(improve, "respond", counted_answer)
    after = improve_plan(before, scenario, OC3, 0, 5, ImproveSettings(
        response=ResponseSettings(ladder=2, states=1, tube_states=tube_states)))
    if tube_states == 0:
        assert changed == set() and swept == {0, 1, 2}
    else:
        assert changed and swept == {0, 1, 2} - changed
    assert after.success.expected >= before.success.expected - 1e-9


def _fly(scenario, config, seed=0):
    search = ClosedSearch(scenario, config, seed)
    for _ in search.run():
        pass
    return search


@settings(max_examples=without_jit(12, 3), deadline=None)
@given(seed=st.integers(0, 10_000), oc_index=st.integers(0, 2), metres=st.booleans(), radius=st.integers(0, 1),
       reserve=st.integers(0, 2), mode=st.integers(0, 3))
def test_improved_plans_are_safe_and_never_expect_less(seed, oc_index, metres, radius, reserve, mode):
    """`mode` 0: the windows alone; 1: the best responses (`planner.best_response`), then the
    windows; 2: the best responses alone; 3: the best responses in tubes of 11-14 cells across
    (the programme over its box too large), then the windows."""
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
    response = (None, ResponseSettings(ladder=4), ResponseSettings(ladder=4),
                ResponseSettings(ladder=4, states=1, tube_states=11 * 11 * 8 * 31))[mode]
    after = improve_plan(before, scenario, oc, search.reserve, seed,
                         ImproveSettings(dp_steps=8, dp_stride=3, response=response, rounds=0 if mode == 2 else 2))
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


# ---- a multicopter's path priced by its time (`planner.time_pricing`) --------------------------------------------

COPTER = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.03,
                       loiter_mah_per_s=7.8, launch_mah=57.0, climb_mah_per_m=3.6, landing_mah=163.0,
                       descent_mah_per_m=4.97, cornering=ARDUCOPTER_CORNERING, moving_mah_per_s=8.15)


def _priced(scenario, pricing):
    return replace(scenario, uavs=[replace(u, time_pricing=pricing) for u in scenario.uavs])


def _seconds(u, cell_m, profile=COPTER):
    """Reference: what `path_time_s` gives UAV `u`'s path through its cells' centres, from a stop
    to a stop."""
    points = [(p.x * cell_m, p.y * cell_m) for p in u.trajectory]
    return path_time_s(points, profile.cruise_speed_m_s, profile.cornering)


def _dtscs(scenario, oc, seed, reserve=0):
    try:
        search = _fly(scenario, MissionConfig(oc=oc, np_steps=3, reserve_steps=reserve), seed)
    except ValueError:
        return None
    return search


@settings(max_examples=without_jit(12, 2), deadline=None)
@given(seed=st.integers(0, 10_000), oc_index=st.integers(0, 1), cell_m=st.sampled_from([20.0, 35.0, 50.0]),
       ratio=st.floats(1.0, 1.4), reserve=st.integers(0, 1))
def test_a_copters_improved_path_takes_no_longer_than_its_range_pays_for(seed, oc_index, cell_m, ratio, reserve):
    """A copter's improved path, flown through its cells' centres from a stop to a stop
    (`path_time_s`, computed apart from the planner's pricing), takes no more seconds than the
    charge its range was sized with pays for (the range in metres times `cruise_mah_per_m`, over
    `moving_mah_per_s`), or than its DTSCS path's time-priced cost when that is more; its metres
    stay within the range, and it expects no fewer finds."""
    oc = (OC3, OC8)[oc_index]
    costs = cell_lengths()
    scenario = random_scenario(seed, n_uavs=2, range_steps=without_jit(30, 14), oc=oc, costs=costs)
    if scenario is None:
        return
    profile = replace(COPTER, moving_mah_per_s=COPTER.cruise_mah_per_m * COPTER.cruise_speed_m_s / ratio)
    pricing = time_pricing(profile, cell_m, costs)
    assert pricing is not None and pricing.units_per_range_unit == pytest.approx(ratio)
    priced = _priced(scenario, pricing)
    search = _dtscs(priced, oc, seed, reserve)
    if search is None:
        return
    before = search.plan()
    after = improve_plan(before, priced, oc, search.reserve, seed, ImproveSettings(dp_steps=8, dp_stride=3))
    assert_plan_safe(after, priced, oc)
    assert after.success.expected >= before.success.expected - 1e-9
    v = profile.cruise_speed_m_s
    for old, new in zip(before.uavs, after.uavs):
        range_m = (new.range_units - search.reserve) * cell_m / costs.straight
        pays_s = range_m * profile.cruise_mah_per_m / profile.moving_mah_per_s
        dtscs_s = pricing.path_units([p.heading for p in old.trajectory[1:]], costs) * cell_m / costs.straight / v
        assert new.spent <= new.range_units - search.reserve
        assert _seconds(new, cell_m, profile) <= max(pays_s, dtscs_s) + 1e-9
        assert pricing.path_units([p.heading for p in new.trajectory[1:]], costs) <= max(
            pricing.budget_units(new.range_units - search.reserve), pricing.path_units(
                [p.heading for p in old.trajectory[1:]], costs))


@pytest.mark.parametrize("seed, oc", [(0, OC3), (3, OC3), (22, OC8)])
def test_zero_turn_prices_and_a_time_budget_that_never_binds_plan_as_metres_alone_do(seed, oc):
    """Without turns or stops priced, and with turns priced but a budget no path reaches, the
    improvement makes exactly the plan it makes without a time pricing (a plane's)."""
    costs = cell_lengths()
    scenario = random_scenario(seed, n_uavs=2, range_steps=without_jit(30, 14), oc=oc, costs=costs)
    search = _dtscs(scenario, oc, seed)
    assert search is not None
    before = search.plan()
    settings_ = ImproveSettings(dp_steps=8, dp_stride=3)
    plain = improve_plan(before, scenario, oc, 0, seed, settings_)
    zero = TimePricing(turn_units=(0,) * 8, stop_units=0, units_per_range_unit=1.0)
    loose = replace(time_pricing(COPTER, 50.0, costs), units_per_range_unit=100.0)
    for pricing in (zero, loose):
        again = improve_plan(before, _priced(scenario, pricing), oc, 0, seed, settings_)
        assert [u.trajectory for u in again.uavs] == [u.trajectory for u in plain.uavs]
        assert again.success.expected == plain.success.expected
    assert plain.success.expected > before.success.expected


def test_the_metre_priced_improvement_overruns_a_copters_charge_and_the_time_priced_one_does_not():
    """On 50 m cells under 3OC, UAV 1's DTSCS path fits in what its range pays for in time; the
    improvement's windows pricing only metres fill the range with corners and take longer than
    that charge flies; priced by time they do not, and still expect more than DTSCS's plan (the
    windows alone: the best responses' paths here fit the charge either way)."""
    seed, cell_m, costs = 0, 50.0, cell_lengths()
    scenario = random_scenario(seed, n_uavs=2, range_steps=30, oc=OC3, costs=costs)
    pricing = time_pricing(COPTER, cell_m, costs)
    search = _dtscs(_priced(scenario, pricing), OC3, seed)
    before = search.plan()
    settings_ = ImproveSettings(dp_steps=8, dp_stride=3, response=None)
    metres = improve_plan(before, scenario, OC3, 0, seed, settings_)
    timed = improve_plan(before, _priced(scenario, pricing), OC3, 0, seed, settings_)
    range_m = before.uavs[0].range_units * cell_m / costs.straight
    pays_s = range_m * COPTER.cruise_mah_per_m / COPTER.moving_mah_per_s
    assert _seconds(before.uavs[0], cell_m) < pays_s < _seconds(metres.uavs[0], cell_m)
    assert _seconds(timed.uavs[0], cell_m) <= pays_s
    for plan in (before, metres, timed):
        assert all(u.spent <= u.range_units for u in plan.uavs)
    assert before.success.expected < timed.success.expected < metres.success.expected
