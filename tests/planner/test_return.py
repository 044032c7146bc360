import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.motion import HEADING_DX, HEADING_DY, OC3, OC4, OC5, OC8, cell_lengths
from planner.return_exact import UNREACHABLE, follow_table, return_around_reservations, return_table
from planner.return_st import astar_cells, key_cell_map, st_return
from planner.search.exhaustive import ExhaustiveStrategy
from tests.planner.helpers import brute_force_cost_home, brute_force_steps_home

OCS = [OC3, OC4, OC5, OC8]


def _grid(seed, nx=8, ny=7, fraction=0.2):
    rng = np.random.default_rng(seed)
    blocked = rng.random((nx, ny)) < fraction
    free = np.argwhere(~blocked)
    goal = tuple(int(v) for v in free[rng.integers(len(free))])
    return blocked, goal


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), oc_index=st.integers(0, 3))
def test_table_equals_brute_force_bfs(seed, oc_index):
    oc = OCS[oc_index]
    blocked, goal = _grid(seed)
    table = return_table(blocked, goal, oc)
    nx, ny = blocked.shape
    for x in range(nx):
        for y in range(ny):
            if blocked[x, y]:
                continue
            for h in range(8):
                assert table[h, x, y] == brute_force_steps_home(blocked, goal, oc, (x, y, h)), (x, y, h)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), oc_index=st.integers(0, 3), units=st.sampled_from([1000, 7, 2]))
def test_length_table_equals_brute_force_dijkstra(seed, oc_index, units):
    """Charged by length (a diagonal costs sqrt 2 axis moves, rounded up), the table is the
    lowest cost home under the OC from every pose."""
    oc, costs = OCS[oc_index], cell_lengths(units)
    blocked, goal = _grid(seed)
    table = return_table(blocked, goal, oc, costs)
    nx, ny = blocked.shape
    for x in range(nx):
        for y in range(ny):
            if blocked[x, y]:
                continue
            for h in range(8):
                assert table[h, x, y] == brute_force_cost_home(blocked, goal, oc, (x, y, h), costs), (x, y, h)


@pytest.mark.parametrize("oc", OCS, ids=lambda o: o.name)
@pytest.mark.parametrize("seed", range(5))
def test_a_followed_length_path_costs_what_the_table_says(oc, seed):
    costs = cell_lengths()
    blocked, goal = _grid(seed, 12, 10)
    table = return_table(blocked, goal, oc, costs)
    for x, y in np.argwhere(~blocked)[::3]:
        for h in (0, 3, 6):
            if table[h, x, y] >= UNREACHABLE:
                continue
            path = follow_table(table, (int(x), int(y), h), oc.successors, blocked, costs)
            assert sum(costs.of(g) for _, _, g in path) == table[h, x, y]
            assert path == [] or path[-1][:2] == goal
            _assert_valid_path(path, (x, y, h), blocked, oc)


def test_a_length_return_prefers_the_shorter_path_to_the_fewer_steps():
    """Across an open field to a goal 4 east, 2 north: 4 steps either way under 8OC, but two
    diagonals and two axis moves are shorter than a staircase that ends further off; the weighted
    table charges 2 x 1415 + 2 x 1000."""
    blocked = np.zeros((9, 9), bool)
    table = return_table(blocked, (6, 4), OC8, cell_lengths())
    assert table[2, 2, 2] == 2 * 1415 + 2 * 1000
    assert return_table(blocked, (6, 4), OC8)[2, 2, 2] == 4


def _assert_valid_path(path, start, blocked, oc):
    x, y, h = start
    for qx, qy, g in path:
        assert oc.allows(h, g)
        assert (qx - x, qy - y) == (HEADING_DX[g], HEADING_DY[g])
        assert not blocked[qx, qy]
        x, y, h = qx, qy, g


@pytest.mark.parametrize("oc", OCS, ids=lambda o: o.name)
@pytest.mark.parametrize("seed", range(5))
def test_followed_path_is_valid_and_as_long_as_the_table(oc, seed):
    blocked, goal = _grid(seed, 12, 10)
    table = return_table(blocked, goal, oc)
    for x, y in np.argwhere(~blocked)[::3]:
        for h in (0, 3, 6):
            if table[h, x, y] >= UNREACHABLE:
                continue
            path = follow_table(table, (int(x), int(y), h), oc.successors, blocked)
            assert len(path) == table[h, x, y]
            assert path == [] or path[-1][:2] == goal
            _assert_valid_path(path, (x, y, h), blocked, oc)


def test_a_return_detours_around_cells_other_uavs_reserved():
    blocked = np.zeros((10, 10), bool)
    table = return_table(blocked, (5, 9), OC3)
    free = return_around_reservations(table, (5, 1, 0), 0, 30, OC3.successors, blocked, set())
    assert len(free) == table[0, 5, 1] == 8
    reserved = {(t + 1, c[0], c[1]) for t, c in enumerate(free[:4])}
    detour = return_around_reservations(table, (5, 1, 0), 0, 30, OC3.successors, blocked, reserved)
    assert detour is not None and detour[-1][:2] == (5, 9)
    assert all((t + 1, c[0], c[1]) not in reserved for t, c in enumerate(detour))
    _assert_valid_path(detour, (5, 1, 0), blocked, OC3)
    assert return_around_reservations(table, (5, 1, 0), 0, 7, OC3.successors, blocked, set()) is None


def test_astar_is_fewest_steps_and_key_cells_follow_eq_20():
    blocked = np.zeros((8, 8), bool)
    blocked[3, 0:6] = True
    cells = astar_cells(blocked, (0, 0), (7, 0))
    assert cells[0] == (0, 0) and cells[-1] == (7, 0)
    assert len(cells) - 1 == brute_force_steps_home(blocked, (7, 0), OC8, (0, 0, 0))
    key = key_cell_map(blocked.shape, cells)
    assert key[7, 0] == 1.0 and key[0, 0] == 0.0
    assert all(key[c] == pytest.approx(0.2) for c in cells[1:-1])
    assert key.sum() == pytest.approx(1.0 + 0.2 * (len(cells) - 2))
    with pytest.raises(ValueError):
        astar_cells(np.array([[False, True, False]]), (0, 0), (0, 2))


@pytest.mark.parametrize("oc", OCS, ids=lambda o: o.name)
@pytest.mark.parametrize("seed", range(6))
def test_st_is_never_shorter_than_exact_and_reaches_home(oc, seed):
    blocked, goal = _grid(seed, 14, 12, 0.1)
    table = return_table(blocked, goal, oc)
    rng = np.random.default_rng(seed)
    free = np.argwhere(~blocked)
    for _ in range(4):
        x, y = (int(v) for v in free[rng.integers(len(free))])
        h = int(rng.integers(8))
        if table[h, x, y] >= UNREACHABLE or (x, y) == goal:
            continue
        budget = int(table[h, x, y]) + 10
        result = st_return(blocked, (x, y, h), goal, oc.successors, table, 4, budget, ExhaustiveStrategy().best_path)
        assert result is not None
        assert len(result.path) >= table[h, x, y]
        assert len(result.path) <= budget
        assert result.path[-1][:2] == goal
        _assert_valid_path(result.path, (x, y, h), blocked, oc)
        assert 0 < result.tracking_efficiency <= 1


def test_st_tracks_a_straight_corridor_perfectly():
    blocked = np.zeros((12, 3), bool)
    table = return_table(blocked, (11, 1), OC3)
    result = st_return(blocked, (0, 1, 2), (11, 1), OC3.successors, table, 5, 20, ExhaustiveStrategy().best_path)
    assert [p[:2] for p in result.path] == [(x, 1) for x in range(1, 12)]
    assert result.tracking_efficiency == 1.0
