"""A boustrophedon (lawnmower) sweep: the plan a survey tool would give, as a baseline for the
optimisers (Fig. 8). It ignores the probability map.

The free cells are shared out among the UAVs by nearest airport (a Voronoi partition, fixed at
the first decision). Each UAV sweeps its sector in east-west lanes `lane_spacing` rows apart
(2r+1 for a sensor footprint of radius r), alternating direction, starting with the lane
nearest its airport and moving away from it. The UAV heads for the next lane cell it has not
visited by the lowest-cost move under the OC (the exact table of `planner.return_exact`),
steps off cells another vehicle holds, and skips cells it cannot reach. The range check and the
return are DTSCS's, as for every strategy."""

from __future__ import annotations

import numpy as np

from planner.motion import HEADING_DX, HEADING_DY, OrientationConstraint
from planner.return_exact import UNREACHABLE, return_table
from planner.search.competition import compete
from planner.search.flock import choices_along, decision_from_choices, turn_ordered
from planner.search.problem import Decision, Searcher, StepProblem


def sweep_lanes(blocked: np.ndarray, airports: dict[int, tuple[int, int]],
                lane_spacing: int) -> dict[int, list[tuple[int, int]]]:
    """Each UAV's lane cells in visiting order."""
    nx, ny = blocked.shape
    ids = sorted(airports)
    xs, ys = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    distances = np.stack([np.hypot(xs - airports[i][0], ys - airports[i][1]) for i in ids])
    owner = np.argmin(distances, axis=0)
    out: dict[int, list[tuple[int, int]]] = {}
    for k, uid in enumerate(ids):
        mine = (owner == k) & ~blocked
        ax, ay = airports[uid]
        rows = [y for y in range(lane_spacing // 2, ny, lane_spacing) if mine[:, y].any()]
        if not rows:
            out[uid] = []
            continue
        rows = outward(rows, ay)
        cells: list[tuple[int, int]] = []
        x_end = ax
        for y in rows:
            lane = [int(x) for x in np.flatnonzero(mine[:, y])]
            if abs(lane[-1] - x_end) < abs(lane[0] - x_end):
                lane.reverse()
            cells += [(x, y) for x in lane]
            x_end = lane[-1]
        out[uid] = cells
    return out


def outward(rows: list[int], ay: int) -> list[int]:
    """Lane rows from the one nearest the airport row to the edge with more lanes, then back
    over the lanes on the other side."""
    rows = sorted(rows)
    i = min(range(len(rows)), key=lambda k: abs(rows[k] - ay))
    if len(rows) - i >= i + 1:
        return rows[i:] + rows[:i][::-1]
    return rows[: i + 1][::-1] + rows[i + 1:]


class LawnmowerStrategy:
    """Boustrophedon sweep per UAV sector, with the shared competition rule for conflicts."""

    name = "lawnmower"

    def __init__(self, lane_spacing: int = 1) -> None:
        if lane_spacing < 1:
            raise ValueError("lane spacing must be at least 1 row")
        self.lane_spacing = lane_spacing
        self._lanes: dict[int, list[tuple[int, int]]] | None = None
        self._cursor: dict[int, int] = {}
        self._visited: dict[int, set[tuple[int, int]]] = {}
        self._tables: dict[tuple[int, int], np.ndarray] = {}
        self._oc: OrientationConstraint | None = None

    def _table(self, problem: StepProblem, cell: tuple[int, int]) -> np.ndarray:
        if cell not in self._tables:
            if self._oc is None:
                allowed = tuple(tuple(bool(g in row) for g in range(8)) for row in problem.successors)
                self._oc = OrientationConstraint("sweep", allowed)
            self._tables[cell] = return_table(problem.blocked, cell, self._oc)
        return self._tables[cell]

    def _target(self, problem: StepProblem, s: Searcher) -> tuple[int, int] | None:
        lanes = self._lanes.get(s.uav_id, []) if self._lanes else []
        seen = self._visited.setdefault(s.uav_id, set())
        seen.add((s.x, s.y))
        i = self._cursor.get(s.uav_id, 0)
        while i < len(lanes):
            cell = lanes[i]
            if cell not in seen and self._table(problem, cell)[s.heading, s.x, s.y] < UNREACHABLE:
                break
            i += 1
        self._cursor[s.uav_id] = i
        return lanes[i] if i < len(lanes) else None

    def best_path(self, problem: StepProblem, searcher: Searcher, others: np.ndarray,
                  others_hard: np.ndarray) -> Decision | None:
        target = self._target(problem, searcher)
        if target is None:
            airport = np.argwhere(searcher.home_table[0] == 0)[0]
            target = (int(airport[0]), int(airport[1]))
        table = self._table(problem, target)
        nx, ny = problem.blocked.shape
        x, y, h = searcher.x, searcher.y, searcher.heading
        cells = np.full((problem.np_steps, 2), -1, dtype=np.int64)
        for q in range(problem.np_steps):
            best, best_cost = None, None
            for g in problem.successors[h]:
                if g < 0:
                    break
                qx, qy = x + int(HEADING_DX[g]), y + int(HEADING_DY[g])
                if not (0 <= qx < nx and 0 <= qy < ny) or problem.blocked[qx, qy]:
                    continue
                if searcher.home_table[g, qx, qy] >= UNREACHABLE:
                    continue
                if any(others_hard[j] and others[j, q, 0] == qx and others[j, q, 1] == qy for j in range(len(others))):
                    continue
                cost = int(table[g, qx, qy])
                if best_cost is None or cost < best_cost:
                    best, best_cost = (qx, qy, int(g)), cost
            if best is None:
                break
            x, y, h = best
            cells[q] = (x, y)
            if (x, y) == target:
                break
        choices = choices_along(turn_ordered(problem.successors), (searcher.x, searcher.y, searcher.heading), cells,
                                problem.np_steps)
        if choices is None:
            return None
        return decision_from_choices(problem, searcher, others, others_hard, choices, 0, None)

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        if self._lanes is None:
            airports = {}
            for s in problem.searchers:
                cell = np.argwhere(s.home_table[0] == 0)[0]
                airports[s.uav_id] = (int(cell[0]), int(cell[1]))
            self._lanes = sweep_lanes(problem.blocked, airports, self.lane_spacing)
        return compete(problem, self.best_path)
