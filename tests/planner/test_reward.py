import math

import numpy as np
import pytest

from planner.motion import HEADING_DX, HEADING_DY, OC3, OC4, OC8, STEPS, cell_lengths
from planner.return_exact import UNREACHABLE, return_table
from planner.reward import airport_reward_map, best_two, others_near, score_paths
from planner.search.exhaustive import all_choices


def reference_score(choice, pose, succ, tep, eu, blocked, fa, others, hard, w, flown, budget, costs, table, tep_once):
    """J1 of eq. (7)-(11) written plainly, one path at a time; the first step must leave
    flown + its cost + the way home within `budget` (eq. 8)."""
    x, y, h = pose
    nx, ny = tep.shape
    total, cells = 0.0, []
    for q, c in enumerate(choice):
        g = succ[h, c]
        if g < 0:
            break
        qx, qy = x + HEADING_DX[g], y + HEADING_DY[g]
        if not (0 <= qx < nx and 0 <= qy < ny) or blocked[qx, qy] or table[g, qx, qy] >= UNREACHABLE:
            break
        if q == 0 and budget >= 0 and flown + costs.of(int(g)) + table[g, qx, qy] > budget:
            break
        dists = [math.dist((o[q][0], o[q][1]), (qx, qy)) for o in others if o[q][0] >= 0]
        if any(o[q][0] == qx and o[q][1] == qy and hd for o, hd in zip(others, hard)):
            break
        earlier = sum((cx, cy) == (qx, qy) for cx, cy, _ in cells)
        p = 0.0 if (tep_once and earlier) else tep[qx, qy]
        fr = 1.0 if not dists else (-100.0 if min(dists) <= math.sqrt(2) else math.exp(-1 / min(dists)))
        total += w[0] * p + w[1] * eu[qx, qy] / 2 ** earlier / 2 + w[2] * fr + w[3] * fa[qx, qy]
        cells.append((qx, qy, g))
        x, y, h = qx, qy, g
    return total, len(cells), cells


@pytest.mark.parametrize("costs", [STEPS, cell_lengths()], ids=["steps", "lengths"])
@pytest.mark.parametrize("oc", [OC3, OC4, OC8])
@pytest.mark.parametrize("seed", range(4))
def test_score_paths_matches_reference(oc, seed, costs):
    rng = np.random.default_rng(seed)
    nx, ny, np_steps = 9, 8, 4
    blocked = rng.random((nx, ny)) < 0.15
    blocked[4, 4] = False
    tep, eu = rng.random((nx, ny)), rng.random((nx, ny))
    table = return_table(blocked, (0, 0) if not blocked[0, 0] else (4, 4), oc, costs)
    fa = airport_reward_map((nx, ny), np.array([[0, 0], [8, 7]]))
    others = rng.integers(-1, 8, size=(2, np_steps, 2))
    hard = np.array([True, False])
    w = np.array([0.3, 0.3, 0.3, 0.1])
    succ = oc.successors
    choices = all_choices(succ.shape[1], np_steps)
    n = len(choices)
    scores, depths, cells = np.empty(n), np.empty(n, np.int64), np.zeros((n, np_steps, 3), np.int64)
    for tep_once in (False, True):
        for budget in (-1, 12 * costs.straight):
            score_paths(choices, 4, 4, 2, succ, tep, eu, blocked, fa, others, hard, w, 3 * costs.straight, budget,
                        costs.by_heading, table, tep_once, scores, depths, cells)
            for i, choice in enumerate(choices):
                ref_total, ref_depth, ref_cells = reference_score(choice, (4, 4, 2), succ, tep, eu, blocked, fa,
                                                                 others, hard, w, 3 * costs.straight, budget, costs,
                                                                 table, tep_once)
                assert depths[i] == ref_depth
                assert scores[i] == pytest.approx(ref_total)
                assert [tuple(c) for c in cells[i, :ref_depth]] == ref_cells


@pytest.mark.parametrize("seed", range(4))
def test_a_big_fleet_scores_as_if_every_vehicle_were_read(seed):
    """`score_paths` reads only the vehicles `others_near` keeps at each step (those that can be
    the nearest to a cell a path reaches): J1, depths and cells are still those of the reference,
    which reads every vehicle, with 60 of them near and far, hard and soft, known and unknown."""
    rng = np.random.default_rng(seed)
    nx, ny, np_steps, x0, y0 = 40, 40, 5, 20, 20
    blocked = np.zeros((nx, ny), dtype=np.bool_)
    tep, eu = rng.random((nx, ny)), rng.random((nx, ny))
    table = return_table(blocked, (0, 0), OC3, STEPS)
    fa = airport_reward_map((nx, ny), np.array([[0, 0], [39, 39]]))
    others = rng.integers(0, nx, size=(60, np_steps, 2))
    others[:12] = rng.integers(x0 - 7, x0 + 8, size=(12, np_steps, 2))  # some close enough to matter
    others[rng.random((60, np_steps)) < 0.2] = -1                       # some cells unknown
    hard = rng.random(60) < 0.3
    _, n_near = others_near(others, x0, y0, np_steps)
    assert 0 < n_near.sum() < (others[:, :, 0] >= 0).sum()               # the pruning is exercised
    w = np.array([0.3, 0.3, 0.3, 0.1])
    choices = all_choices(OC3.successors.shape[1], np_steps)
    n = len(choices)
    scores, depths, cells = np.empty(n), np.empty(n, np.int64), np.zeros((n, np_steps, 3), np.int64)
    score_paths(choices, x0, y0, 2, OC3.successors, tep, eu, blocked, fa, others, hard, w, 0, -1, STEPS.by_heading,
                table, False, scores, depths, cells)
    for i, choice in enumerate(choices):
        ref_total, ref_depth, ref_cells = reference_score(choice, (x0, y0, 2), OC3.successors, tep, eu, blocked, fa,
                                                         others, hard, w, 0, -1, STEPS, table, False)
        assert depths[i] == ref_depth
        assert scores[i] == pytest.approx(ref_total)
        assert [tuple(c) for c in cells[i, :ref_depth]] == ref_cells


def test_revisit_on_one_path_earns_halved_eu():
    tep = np.zeros((5, 5))
    eu = np.full((5, 5), 0.8)
    blocked = np.zeros((5, 5), bool)
    table = np.zeros((8, 5, 5), np.int32)
    choices = np.array([[0, 0]])  # 8OC choice 0 = north twice
    scores, depths, cells = np.empty(1), np.empty(1, np.int64), np.zeros((1, 2, 3), np.int64)
    w = np.array([0.0, 1.0, 0.0, 0.0])
    score_paths(choices, 2, 2, 0, OC8.successors, tep, eu, blocked, np.zeros((5, 5)),
                np.full((0, 2, 2), -1, np.int64), np.zeros(0, bool), w, 0, -1, STEPS.by_heading, table, False, scores,
                depths, cells)
    assert scores[0] == pytest.approx(0.4 + 0.4)
    # north, then back south onto the start, then north again onto the first cell: 0.4 + 0.4 + 0.2
    choices = np.array([[0, 4, 0]])
    scores, depths, cells = np.empty(1), np.empty(1, np.int64), np.zeros((1, 3, 3), np.int64)
    score_paths(choices, 2, 2, 0, OC8.successors, tep, eu, blocked, np.zeros((5, 5)),
                np.full((0, 3, 2), -1, np.int64), np.zeros(0, bool), w, 0, -1, STEPS.by_heading, table, False, scores,
                depths, cells)
    assert scores[0] == pytest.approx(0.4 + 0.4 + 0.2)


def test_best_two_prefers_depth_then_score():
    best, second = best_two(np.array([5.0, 1.0, 3.0, 9.0]), np.array([2, 3, 3, 0]))
    assert (best, second) == (2, 1)
    assert best_two(np.array([1.0]), np.array([0])) == (-1, -1)


def test_airport_reward_grows_away_from_airports():
    fa = airport_reward_map((10, 10), np.array([[0, 0]]))
    assert fa[0, 0] == 0.0
    assert fa[9, 9] > fa[5, 5] > fa[1, 1] > 0
    assert fa[3, 4] == pytest.approx(math.exp(-1 / 5))
