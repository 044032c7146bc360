"""The exact return planner: the lowest-cost path to the airport under an orientation
constraint, by shortest-path search over (cell, heading) states.

The paper (Section 1) notes that A* over cells cannot honour the OC; over (cell, heading) states
it can, and a reverse breadth-first search from the airport gives, for every pose, the number of
steps home. That table makes the DTSCS range check of eq. (23)-(24) a look-up.

`return_around_reservations` is the same lowest-cost return when other UAVs hold cells at given
steps: an A* over (cell, heading, step) that steps around their reservations, with the table as its
heuristic. (Not to be confused with the paper's search-tracking (ST) return, `planner.return_st`.)"""

from __future__ import annotations

import heapq

import numpy as np

from planner.config import njit
from planner.motion import HEADING_DX, HEADING_DY, OrientationConstraint

UNREACHABLE = np.int32(2**30)


def predecessors_of(successors: np.ndarray) -> np.ndarray:
    """`pred[g]` lists the headings h from which heading g may be taken (padded with -1)."""
    lists = [[h for h in range(8) if g in successors[h]] for g in range(8)]
    width = max(len(p) for p in lists)
    pred = np.full((8, width), -1, dtype=np.int64)
    for g, p in enumerate(lists):
        pred[g, : len(p)] = p
    return pred


@njit
def _return_table(blocked: np.ndarray, goal_x: int, goal_y: int, predecessors: np.ndarray, dx: np.ndarray,
                  dy: np.ndarray) -> np.ndarray:
    """Reverse BFS: table[h, x, y] = fewest steps from pose (x, y, h) to the goal cell."""
    nx, ny = blocked.shape
    table = np.full((8, nx, ny), 2**30, dtype=np.int32)
    queue = np.empty(8 * nx * ny, dtype=np.int64)
    head = 0
    tail = 0
    for h in range(8):
        table[h, goal_x, goal_y] = 0
        queue[tail] = (h * nx + goal_x) * ny + goal_y
        tail += 1
    while head < tail:
        state = queue[head]
        head += 1
        g = state // (nx * ny)
        x = (state // ny) % nx
        y = state % ny
        d = table[g, x, y] + 1
        px = x - dx[g]
        py = y - dy[g]
        if px < 0 or py < 0 or px >= nx or py >= ny or blocked[px, py]:
            continue
        if px == goal_x and py == goal_y:
            continue
        for k in range(predecessors.shape[1]):
            h = predecessors[g, k]
            if h < 0:
                break
            if table[h, px, py] > d:
                table[h, px, py] = d
                queue[tail] = (h * nx + px) * ny + py
                tail += 1
    return table


def return_table(blocked: np.ndarray, goal: tuple[int, int], oc: OrientationConstraint) -> np.ndarray:
    """Steps home from every pose, shape (8, nx, ny); `UNREACHABLE` where there is no way home."""
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    return _return_table(blocked, int(goal[0]), int(goal[1]), predecessors_of(oc.successors),
                         HEADING_DX, HEADING_DY)


@njit
def _follow_table(table: np.ndarray, x: int, y: int, h: int, successors: np.ndarray, blocked: np.ndarray,
                  dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """Descend the table from pose (x, y, h): rows (x, y, heading) of the poses after it."""
    nx, ny = blocked.shape
    remaining = table[h, x, y]
    path = np.empty((remaining, 3), dtype=np.int64)
    for i in range(remaining):
        for k in range(successors.shape[1]):
            g = successors[h, k]
            if g < 0:
                break
            qx = x + dx[g]
            qy = y + dy[g]
            if 0 <= qx < nx and 0 <= qy < ny and not blocked[qx, qy] and table[g, qx, qy] == remaining - 1 - i:
                x, y, h = qx, qy, g
                break
        path[i, 0] = x
        path[i, 1] = y
        path[i, 2] = h
    return path


def follow_table(table: np.ndarray, pose: tuple[int, int, int], successors: np.ndarray,
                 blocked: np.ndarray) -> list[tuple[int, int, int]]:
    """A lowest-cost path home from `pose` by descending the table; poses after `pose`."""
    x, y, h = pose
    if table[h, x, y] >= UNREACHABLE:
        raise ValueError(f"no way home from cell ({x + 1}, {y + 1}) heading {h}")
    rows = _follow_table(table, int(x), int(y), int(h), successors, blocked, HEADING_DX, HEADING_DY)
    return [tuple(r) for r in rows.tolist()]


def return_around_reservations(table: np.ndarray, pose: tuple[int, int, int], start_step: int, budget: int,
                               successors: np.ndarray, blocked: np.ndarray,
                               reserved: set[tuple[int, int, int]]) -> list[tuple[int, int, int]] | None:
    """The lowest-cost path home from `pose` at `start_step` that never stands on a cell
    reserved by another vehicle at the same step (`reserved` holds (step, x, y)), in at most
    `budget` steps. A* over (cell, heading, step) with the exact table as its heuristic, so it
    returns the table's path whenever that path is free. None when no such path exists."""
    x0, y0, h0 = pose
    if table[h0, x0, y0] > budget:
        return None
    if table[h0, x0, y0] == 0:
        return []
    nx, ny = blocked.shape
    start = (x0, y0, h0, 0)
    parents: dict[tuple[int, int, int, int], tuple[int, int, int, int] | None] = {start: None}
    frontier = [(int(table[h0, x0, y0]), 0, start)]  # (f, -steps, state): deepest first on ties
    while frontier:
        _, _, state = heapq.heappop(frontier)
        x, y, h, t = state
        if table[h, x, y] == 0:
            path = []
            parent = parents[state]
            while parent is not None:
                path.append(state[:3])
                state, parent = parent, parents[parent]
            return path[::-1]
        for g in successors[h]:
            if g < 0:
                break
            qx, qy = x + int(HEADING_DX[g]), y + int(HEADING_DY[g])
            if not (0 <= qx < nx and 0 <= qy < ny) or blocked[qx, qy]:
                continue
            nt = t + 1
            rest = int(table[g, qx, qy])
            if nt + rest > budget or (start_step + nt, qx, qy) in reserved:
                continue
            nxt = (qx, qy, int(g), nt)
            if nxt in parents:
                continue
            parents[nxt] = state
            heapq.heappush(frontier, (nt + rest, -nt, nxt))
    return None
