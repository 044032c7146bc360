"""The paper's search-tracking (ST) return approach of Section 4.

Operator 1: A* on the 8-connected grid without the OC. Operator 2: its cells become key cells
for this UAV only (eq. 20). Operators 3-4: fly Np-step-ahead prediction under the OC with the
key-cell values as fitness (eq. 21), one step at a time, until the airport is reached. A small
pull toward home (`homing_map`) breaks the ties between paths that collect the same key cells.

The tracker is any `best_path` of a search strategy: basic PIO as in the paper (MissionConfig's
default), or exhaustive choice, the exact optimum of eq. (21) at each step. Each step keeps the way
home feasible within the budget (the exact table's check, in the table's units: steps or
lengths), so ST never runs out of range."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from planner.motion import HEADING_DX, HEADING_DY, STEPS, MoveCosts
from planner.return_exact import UNREACHABLE
from planner.search.competition import BestPath, others_for
from planner.search.problem import Searcher, StepProblem

KEY_CELL_VALUE = 0.2
GOAL_VALUE = 1.0
HOMING_TIE_BREAK = 0.01


@dataclass
class StReturn:
    """An ST return: poses after the start, the A* cells it tracked, and phi (Definition 6)."""

    path: list[tuple[int, int, int]]
    astar_cells: list[tuple[int, int]]
    tracked_key_cells: int

    @property
    def tracking_efficiency(self) -> float:
        return self.tracked_key_cells / len(self.path) if self.path else 1.0


def astar_cells(blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]]:
    """Operator 1: fewest-step 8-connected path from start to goal (both included), ignoring
    the OC; ties go to the shorter Euclidean length, so the path looks like a straight line."""
    nx, ny = blocked.shape

    def h(c: tuple[int, int]) -> int:
        return max(abs(c[0] - goal[0]), abs(c[1] - goal[1]))

    best = {start: (0, 0.0)}
    parent: dict[tuple[int, int], tuple[int, int] | None] = {start: None}
    frontier = [(h(start), 0.0, start)]
    while frontier:
        f, length, cell = heapq.heappop(frontier)
        steps = best[cell][0]
        if (f - h(cell), length) != (steps, best[cell][1]):
            continue
        if cell == goal:
            out = []
            node: tuple[int, int] | None = cell
            while node is not None:
                out.append(node)
                node = parent[node]
            return out[::-1]
        for g in range(8):
            nxt = (cell[0] + int(HEADING_DX[g]), cell[1] + int(HEADING_DY[g]))
            if not (0 <= nxt[0] < nx and 0 <= nxt[1] < ny) or blocked[nxt]:
                continue
            cost = (steps + 1, length + (math.sqrt(2) if g % 2 else 1.0))
            if nxt not in best or cost < best[nxt]:
                best[nxt] = cost
                parent[nxt] = cell
                heapq.heappush(frontier, (cost[0] + h(nxt), cost[1], nxt))
    raise ValueError(f"no path from cell ({start[0] + 1}, {start[1] + 1}) to ({goal[0] + 1}, {goal[1] + 1})")


def homing_map(home_table: np.ndarray) -> np.ndarray:
    """A tie-break added to eq. (21): -HOMING_TIE_BREAK * (steps home from the cell, over the
    largest finite one). Many Np-step paths collect the same key cells (e.g. every path that
    reaches the goal within the horizon), and without it the tracker may put the goal off step
    after step and circle until the budget forces it home. At most Np * 0.01 per path, it never
    outweighs one key cell (0.2)."""
    steps = home_table.min(axis=0).astype(np.float64)
    finite = steps < UNREACHABLE
    top = steps[finite].max() if finite.any() else 1.0
    return np.where(finite, -HOMING_TIE_BREAK * steps / max(top, 1.0), -HOMING_TIE_BREAK)


def key_cell_map(shape: tuple[int, int], cells: list[tuple[int, int]]) -> np.ndarray:
    """Operator 2, eq. (20): 1/5 on the path's inner cells, 1 on the goal, 0 elsewhere."""
    key = np.zeros(shape)
    for c in cells[1:-1]:
        key[c] = KEY_CELL_VALUE
    key[cells[-1]] = GOAL_VALUE
    return key


def st_return(blocked: np.ndarray, pose: tuple[int, int, int], goal: tuple[int, int], successors: np.ndarray,
              home_table: np.ndarray, np_steps: int, budget: int, best_path: BestPath,
              reserved: dict[int, list[tuple[int, int]]] | None = None, start_step: int = 0,
              costs: MoveCosts = STEPS) -> StReturn | None:
    """Track the A* path home from `pose` under the OC (Operators 1-4), spending at most
    `budget` (units of `costs`, as `home_table`). `reserved[uav]` lists another vehicle's cells
    from step start_step+1 on; they are never shared. None when the tracker finds no feasible
    step (boxed in by reservations)."""
    x, y, h = pose
    if home_table[h, x, y] >= UNREACHABLE or home_table[h, x, y] > budget:
        return None
    cells = astar_cells(blocked, (x, y), goal)
    key = key_cell_map(blocked.shape, cells)
    key_set = set(cells[1:])
    zeros = np.zeros(blocked.shape)
    homing = homing_map(home_table)
    weights = np.array([1.0, 0.0, 0.0, 1.0])
    path: list[tuple[int, int, int]] = []
    tracked = 0
    spent = 0
    move_costs = costs.by_heading
    while (x, y) != goal:
        flown = len(path)
        future = {}
        for uav, rows in (reserved or {}).items():
            block = np.full((np_steps, 2), -1, dtype=np.int64)
            for q in range(np_steps):
                if flown + q < len(rows):
                    block[q] = rows[flown + q]
            future[uav] = block
        problem = StepProblem(key, zeros, blocked, homing, weights, successors, np_steps,
                              [], future, {}, tep_once=True, move_costs=move_costs)
        searcher = Searcher(-1, x, y, h, spent, budget, home_table)
        others, hard = others_for(problem, -1, {})
        decision = best_path(problem, searcher, others, hard)
        if decision is None:
            return None
        x, y, h = decision.first_step()
        spent += int(move_costs[h])
        path.append((x, y, h))
        if (x, y) in key_set and key[x, y] > 0:
            tracked += 1
        key[x, y] = 0.0
    return StReturn(path, cells, tracked)
