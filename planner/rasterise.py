"""Polygons (in local metres) -> cells of a `Grid`.

A cell is free (searchable) when its centre lies strictly inside the safe region, the area less
every no-fly zone. Every planner step flies the straight segment between two neighbouring cell
centres, and two free centres do not make a safe segment: a diagonal may cut a no-fly corner, a
no-fly strip thinner than a cell may lie between two centres, a notch of the area may fall between
them. `block_unsafe_moves` therefore checks every one-cell move between free cells against the
exact geometry and blocks one end of each move that leaves the safe region, so every path the
planner can fly over free cells stays in the safe region by construction."""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from planner.georef import Grid

#: The four one-cell moves that, with their reverses, make the 8-neighbourhood: E, N, NE, SE.
HALF_NEIGHBOURHOOD = ((1, 0), (0, 1), (1, 1), (1, -1))


def cells_inside(geometry: BaseGeometry, grid: Grid) -> np.ndarray:
    """Boolean (nx, ny) mask of cells whose centre lies strictly inside `geometry`."""
    east, north = grid.centres_m()
    shapely.prepare(geometry)
    return shapely.contains_xy(geometry, east, north)


def free_cells(safe: BaseGeometry, grid: Grid) -> np.ndarray:
    """Cells whose centre is strictly inside the safe region (touching a no-fly edge is not)."""
    return cells_inside(safe, grid)


def unsafe_moves(free: np.ndarray, safe: BaseGeometry, grid: Grid) -> list[tuple[int, int, int, int]]:
    """Every one-cell move (x, y) -> (x2, y2) between free cells whose segment is not covered by
    the safe region, each listed once.

    Only moves touching a cell within a cell diagonal of the region's boundary are tested: a
    segment between two centres each farther than half a diagonal from the boundary cannot reach
    it (every point of the segment is within half a diagonal of one of its ends)."""
    shapely.prepare(safe)
    east, north = grid.centres_m()
    deep_region = safe.buffer(-grid.cell_size_m * math.sqrt(0.5) * (1 + 1e-9))
    shapely.prepare(deep_region)
    deep = shapely.contains_xy(deep_region, east, north) & free
    out: list[tuple[int, int, int, int]] = []
    nx, ny = free.shape
    for dx, dy in HALF_NEIGHBOURHOOD:
        xs = np.arange(max(0, -dx), nx - max(0, dx))
        ys = np.arange(max(0, -dy), ny - max(0, dy))
        if len(xs) == 0 or len(ys) == 0:
            continue
        a = (slice(xs[0], xs[-1] + 1), slice(ys[0], ys[-1] + 1))
        b = (slice(xs[0] + dx, xs[-1] + dx + 1), slice(ys[0] + dy, ys[-1] + dy + 1))
        candidate = free[a] & free[b] & ~(deep[a] & deep[b])
        ia, ja = np.nonzero(candidate)
        if len(ia) == 0:
            continue
        x1, y1 = ia + xs[0], ja + ys[0]
        x2, y2 = x1 + dx, y1 + dy
        e1, n1 = grid.centre_m(x1, y1)
        e2, n2 = grid.centre_m(x2, y2)
        segments = shapely.linestrings(np.stack([np.column_stack([e1, n1]), np.column_stack([e2, n2])], axis=1))
        bad = ~shapely.covers(safe, segments)
        out += [(int(p), int(q), int(r), int(s)) for p, q, r, s in zip(x1[bad], y1[bad], x2[bad], y2[bad])]
    return out


def block_unsafe_moves(free: np.ndarray, safe: BaseGeometry, grid: Grid) -> tuple[np.ndarray, int]:
    """`free` less one end of every unsafe move (the end whose centre is nearer the region's
    boundary); returns the new mask and how many cells were blocked."""
    free = free.copy()
    moves = unsafe_moves(free, safe, grid)
    if not moves:
        return free, 0
    boundary = safe.boundary
    shapely.prepare(boundary)
    blocked = 0
    for x1, y1, x2, y2 in moves:
        if not (free[x1, y1] and free[x2, y2]):
            continue
        e, n = grid.centre_m(np.array([x1, x2]), np.array([y1, y2]))
        d = np.asarray(shapely.distance(boundary, shapely.points(e, n)))
        x, y = (x1, y1) if d[0] <= d[1] else (x2, y2)
        free[x, y] = False
        blocked += 1
    return free, blocked
