"""Cell paths -> short waypoint lists whose straight legs are checked against the safe region."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry


def turn_points(cells: np.ndarray) -> np.ndarray:
    """Indices of the cells to keep as waypoints: the first, the last, and every cell where the
    direction of travel changes. A straight run of any length collapses to its two ends; a cell
    flown twice in a row (a hold) is dropped."""
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    n = len(cells)
    if n <= 2:
        return np.arange(n)
    keep = [0]
    direction = None
    for i in range(1, n):
        step = tuple(cells[i] - cells[i - 1])
        if step == (0, 0):
            continue
        if direction is not None and step != direction:
            keep.append(i - 1)
        direction = step
    if keep[-1] != n - 1:
        keep.append(n - 1)
    return np.asarray(sorted(set(keep)), dtype=np.int64)


def legs_inside(points: np.ndarray, safe: BaseGeometry) -> np.ndarray:
    """For each leg points[i] -> points[i+1] (local metres), whether the safe region covers it."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return np.ones(0, dtype=bool)
    shapely.prepare(safe)
    segments = shapely.linestrings(np.stack([points[:-1], points[1:]], axis=1))
    return np.asarray(shapely.covers(safe, segments), dtype=bool)


def legs_clear(points: np.ndarray, keep_out: BaseGeometry) -> np.ndarray:
    """For each leg points[i] -> points[i+1] (local metres), whether it stays out of `keep_out`."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return np.ones(0, dtype=bool)
    shapely.prepare(keep_out)
    segments = shapely.linestrings(np.stack([points[:-1], points[1:]], axis=1))
    return ~np.asarray(shapely.intersects(keep_out, segments), dtype=bool)


def merge_waypoints(points: np.ndarray, safe: BaseGeometry, keep: np.ndarray | None = None) -> np.ndarray:
    """Indices into `points` (a flown path in local metres) of the waypoints to fly: the turn
    points `keep`, plus, for every leg between them that leaves the safe region, the intermediate
    points again (split in halves until each leg is covered or is a single step).

    Raises ValueError when a single step of the path itself leaves the safe region."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if keep is None:
        keep = np.arange(len(points))
    kept = [int(keep[0])]
    pending = [(int(a), int(b)) for a, b in zip(keep[:-1], keep[1:])][::-1]
    while pending:
        a, b = pending.pop()
        if legs_inside(points[[a, b]], safe)[0]:
            kept.append(b)
        elif b - a <= 1:
            raise ValueError(f"path step {a} -> {b} leaves the safe region")
        else:
            mid = (a + b) // 2
            pending += [(mid, b), (a, mid)]
    return np.asarray(kept, dtype=np.int64)


def path_length_m(points: np.ndarray) -> float:
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0
