"""The exact return planner: the lowest-cost path to the airport under an orientation
constraint, by shortest-path search over (cell, heading) states.

The paper (Section 1) notes that A* over cells cannot honour the OC; over (cell, heading) states
it can, and a reverse search from the airport gives, for every pose, the lowest cost home: the
number of steps (the paper's unit) or, over a real area, the path's length (`MoveCosts`). That
table makes the DTSCS range check of eq. (23)-(24) a look-up.

`return_around_reservations` is the same lowest-cost return when other UAVs hold cells at given
steps: an A* over (cell, heading, step) that steps around their reservations, with the table as its
heuristic. (Not to be confused with the paper's search-tracking (ST) return, `planner.return_st`.)"""

from __future__ import annotations

import heapq

import numpy as np

from planner.config import njit
from planner.motion import HEADING_DX, HEADING_DY, STEPS, MoveCosts, OrientationConstraint

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
                  dy: np.ndarray, move_costs: np.ndarray, capacity: int) -> tuple[np.ndarray, bool]:
    """Reverse Dijkstra: table[h, x, y] = lowest cost from pose (x, y, h) to the goal cell.

    A move's cost depends only on whether it is an axis or a diagonal move, so two FIFO queues,
    one per kind, replace the heap: states leave in rising cost, each queue's costs rise as they
    are pushed, and the next state is the cheaper of the two heads (with unit costs this is the
    breadth-first search of the paper's steps). False with the table when a queue would take
    more than `capacity` entries (the caller asks again with more room)."""
    nx, ny = blocked.shape
    table = np.full((8, nx, ny), 2**30, dtype=np.int32)
    states = np.empty((2, capacity), dtype=np.int32)
    costs = np.empty((2, capacity), dtype=np.int32)
    head = np.zeros(2, dtype=np.int64)
    tail = np.zeros(2, dtype=np.int64)
    for h in range(8):
        table[h, goal_x, goal_y] = 0
        states[0, tail[0]] = (h * nx + goal_x) * ny + goal_y
        costs[0, tail[0]] = 0
        tail[0] += 1
    while head[0] < tail[0] or head[1] < tail[1]:
        k = 0
        if head[0] >= tail[0] or (head[1] < tail[1] and costs[1, head[1]] < costs[0, head[0]]):
            k = 1
        state = states[k, head[k]]
        cost = costs[k, head[k]]
        head[k] += 1
        g = state // (nx * ny)
        x = (state // ny) % nx
        y = state % ny
        if cost > table[g, x, y]:
            continue
        d = cost + move_costs[g]
        px = x - dx[g]
        py = y - dy[g]
        if px < 0 or py < 0 or px >= nx or py >= ny or blocked[px, py]:
            continue
        if px == goal_x and py == goal_y:
            continue
        kind = g % 2
        for i in range(predecessors.shape[1]):
            h = predecessors[g, i]
            if h < 0:
                break
            if table[h, px, py] > d:
                if tail[kind] == capacity:
                    return table, False
                table[h, px, py] = d
                states[kind, tail[kind]] = (h * nx + px) * ny + py
                costs[kind, tail[kind]] = d
                tail[kind] += 1
    return table, True


def return_table(blocked: np.ndarray, goal: tuple[int, int], oc: OrientationConstraint,
                 costs: MoveCosts = STEPS) -> np.ndarray:
    """Lowest cost home from every pose under the OC (Definition 3), shape (8, nx, ny), in the
    units of `costs` (steps by default); `UNREACHABLE` where there is no way home."""
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    capacity = 8 * blocked.size + 8
    while True:
        table, complete = _return_table(blocked, int(goal[0]), int(goal[1]), predecessors_of(oc.successors),
                                        HEADING_DX, HEADING_DY, costs.by_heading, capacity)
        if complete:
            return table
        capacity *= 2


@njit
def _follow_table(table: np.ndarray, x: int, y: int, h: int, successors: np.ndarray, blocked: np.ndarray,
                  dx: np.ndarray, dy: np.ndarray, move_costs: np.ndarray, max_steps: int) -> np.ndarray:
    """Descend the table from pose (x, y, h): rows (x, y, heading) of the poses after it."""
    nx, ny = blocked.shape
    path = np.empty((max_steps, 3), dtype=np.int64)
    n = 0
    while table[h, x, y] > 0 and n < max_steps:
        remaining = table[h, x, y]
        for k in range(successors.shape[1]):
            g = successors[h, k]
            if g < 0:
                break
            qx = x + dx[g]
            qy = y + dy[g]
            if 0 <= qx < nx and 0 <= qy < ny and not blocked[qx, qy] and table[g, qx, qy] == remaining - move_costs[g]:
                x, y, h = qx, qy, g
                break
        path[n, 0] = x
        path[n, 1] = y
        path[n, 2] = h
        n += 1
    return path[:n]


def follow_table(table: np.ndarray, pose: tuple[int, int, int], successors: np.ndarray,
                 blocked: np.ndarray, costs: MoveCosts = STEPS) -> list[tuple[int, int, int]]:
    """A lowest-cost path home from `pose` by descending the table; poses after `pose`."""
    x, y, h = pose
    if table[h, x, y] >= UNREACHABLE:
        raise ValueError(f"no way home from cell ({x + 1}, {y + 1}) heading {h}")
    max_steps = int(table[h, x, y]) // costs.cheapest + 1
    rows = _follow_table(table, int(x), int(y), int(h), successors, blocked, HEADING_DX, HEADING_DY,
                         costs.by_heading, max_steps)
    return [tuple(r) for r in rows.tolist()]


def return_around_reservations(table: np.ndarray, pose: tuple[int, int, int], start_step: int, budget: int,
                               successors: np.ndarray, blocked: np.ndarray, reserved: set[tuple[int, int, int]],
                               costs: MoveCosts = STEPS) -> list[tuple[int, int, int]] | None:
    """The lowest-cost path home from `pose` at `start_step` that never stands on a cell
    reserved by another vehicle at the same step (`reserved` holds (step, x, y)), costing at most
    `budget` (units of `costs`). A* over (cell, heading, step) with the exact table as its
    heuristic, so it returns the table's path whenever that path is free. None when no such path
    exists."""
    x0, y0, h0 = pose
    if table[h0, x0, y0] > budget:
        return None
    if table[h0, x0, y0] == 0:
        return []
    nx, ny = blocked.shape
    move_costs = costs.by_heading
    start = (x0, y0, h0, 0)
    parents: dict[tuple[int, int, int, int], tuple[int, int, int, int] | None] = {start: None}
    spent = {start: 0}
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
            cost = spent[state] + int(move_costs[g])
            rest = int(table[g, qx, qy])
            if cost + rest > budget or (start_step + nt, qx, qy) in reserved:
                continue
            nxt = (qx, qy, int(g), nt)
            if nxt in parents:
                continue
            parents[nxt] = state
            spent[nxt] = cost
            heapq.heappush(frontier, (cost + rest, -nt, nxt))
    return None
