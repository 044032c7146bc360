"""Polygons -> cells: a hand-computed case, and the move check against a slow reference."""

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon, box

from planner.georef import Grid
from planner.rasterise import block_unsafe_moves, free_cells, unsafe_moves

GRID = Grid(0.0, 0.0, 10.0, 4, 3)   # centres at x = 5, 15, 25, 35 and y = 5, 15, 25


def test_free_cells_of_a_hand_computed_polygon():
    # A right triangle (0,0)-(40,0)-(0,30): centre (x, y) is inside when 3x + 4y < 120.
    triangle = Polygon([(0, 0), (40, 0), (0, 30)])
    expected = np.array([[True, True, True],     # x = 5: y 5, 15, 25 -> 35, 75, 115 < 120
                         [True, True, False],    # x = 15: 65, 105, 145
                         [True, False, False],   # x = 25: 95, 135
                         [False, False, False]])  # x = 35: 125
    assert (free_cells(triangle, GRID) == expected).all()


def test_a_centre_on_a_no_fly_edge_is_not_free():
    safe = box(0, 0, 40, 30).difference(box(15, 0, 40, 30))   # edge through the centres x = 15
    assert free_cells(safe, GRID)[:, 0].tolist() == [True, False, False, False]


def test_a_thin_strip_between_two_centres_blocks_one_of_them():
    safe = box(0, 0, 40, 30).difference(box(9, -1, 11, 31))   # 2 m wide strip between x = 5 and x = 15
    free = free_cells(safe, GRID)
    assert free.all()
    moves = unsafe_moves(free, safe, GRID)
    assert len(moves) == 3 * 1 + 2 * 2                        # 3 straight and 4 diagonal moves cross it
    blocked_free, n = block_unsafe_moves(free, safe, GRID)
    assert n == 3 and not unsafe_moves(blocked_free, safe, GRID)


def test_a_diagonal_cutting_a_no_fly_corner_is_caught_but_touching_it_is_not():
    cut = box(0, 0, 40, 30).difference(box(9, 9, 30, 30))      # zone corner at (9, 9)
    free = free_cells(cut, GRID)
    assert not free[1, 1]
    assert (0, 1, 1, 0) in unsafe_moves(free, cut, GRID)      # (5,15)->(15,5) passes (10,10), inside the zone
    touch = box(0, 0, 40, 30).difference(box(10, 10, 40, 30))  # corner exactly on that diagonal
    assert (0, 1, 1, 0) not in unsafe_moves(free_cells(touch, GRID), touch, GRID)


def _slow_unsafe_moves(free, safe, grid):
    out = set()
    for x in range(grid.nx):
        for y in range(grid.ny):
            for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
                x2, y2 = x + dx, y + dy
                if 0 <= x2 < grid.nx and 0 <= y2 < grid.ny and free[x, y] and free[x2, y2]:
                    a, b = grid.centre_m(x, y), grid.centre_m(x2, y2)
                    if not safe.covers(LineString([(float(a[0]), float(a[1])), (float(b[0]), float(b[1]))])):
                        out.add((x, y, x2, y2))
    return out


def test_unsafe_moves_match_the_slow_reference_on_random_shapes():
    rng = np.random.default_rng(7)
    grid = Grid(0.0, 0.0, 10.0, 20, 16)
    for _ in range(6):
        outline = shapely.convex_hull(shapely.multipoints(rng.uniform(0, [200, 160], size=(9, 2)))).buffer(3)
        zones = [shapely.Point(*rng.uniform(0, [200, 160])).buffer(rng.uniform(3, 25), quad_segs=2)
                 for _ in range(4)]
        zones.append(LineString(rng.uniform(0, [200, 160], size=(2, 2))).buffer(0.8))
        safe = outline.difference(shapely.union_all(zones))
        free = free_cells(safe, grid)
        assert set(unsafe_moves(free, safe, grid)) == _slow_unsafe_moves(free, safe, grid)
        blocked, _ = block_unsafe_moves(free, safe, grid)
        assert not _slow_unsafe_moves(blocked, safe, grid)
