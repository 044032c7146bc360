"""An upper bound on the expected targets any closed plan can find (`planner.success`), in the
plan's own units (metres over a real area), from a time-expanded team-orienteering model solved
by HiGHS (`highspy`).

What it bounds: E = sum P0(c) (1 - (1 - Pc)^n(c)) (the expected finds of `planner.success`, after
`looks_before` in a campaign) of every set of closed trajectories in which UAV i leaves its
airport cell at step 0, moves one cell a step among the 8 neighbours, never into a no-fly cell or
off the grid, each step charging its cost (`Scenario.move_costs`: an axis step one cell side, a
diagonal sqrt 2 of them over a real area), spends at most its range T_i (eq. 23: the planner's
`range_units`), ends on its airport cell, and reads the sensor footprint (the in-grid cells
within `footprint_radius` of its cell) at every point of its trajectory, the airport at step 0
included (`planner.success.plan_looks`). DTSCS plans (`planner.dtscs`) are such trajectories with
more rules (the start heading, the OC on every turn, no two UAVs in one cell at a step), so none
can expect more. Three LP models, tightest first, and a dual one; `success_bound` takes the
tightest LP model whose flow arcs fit `max_arcs`, and when that is not `HEADINGS`, also the
`LAGRANGIAN` dual when its DP fits the time (`lagrangian_fits`), reporting the smaller:

- `HEADINGS`: one node per (step, cell, heading), arcs the OC's turns from the start pose on,
  and the metre budget as a knapsack row (sum of the arcs' costs <= T_i). Its integer optimum is
  the exact optimum over the trajectories above with the OC kept (separation dropped):
  `exact_optimum`.
- `CELLS`: one node per (step, cell), any of the 8 moves, the same budget row: the OC dropped.
- `BLOCKS`: b x b blocks and windows of b steps (b the smallest that fits). In b steps a UAV
  moves at most b cells, so its block changes by at most one per window, and every cell its
  footprint reads in a window lies within 1 + ceil(r / b) blocks of its block at the window's
  start. A unit flow per UAV runs through (window, block) nodes from its airport's block back to
  it; a window's at most b (2r + 1)^2 readings go to blocks that near the occupied one. The
  budget counts steps (T_i // the axis step's cost), diagonals as cheap as axis moves.
- `LAGRANGIAN`: the Lagrangian relaxation of `HEADINGS` (the cells' read rows and the metre
  rows relaxed with multipliers), each UAV's part a DP over (step, cell, heading) instead of
  arcs, minimised by column generation (`planner.bound_lagrange`). Every value bounds the
  `HEADINGS` LP from above, and their infimum equals it; in the time given it stops above.

In every model a node or a reading exists only where some free cell can be reached and left
within the budget: out + home <= T_i, with home the exact OC return table's cost (Section 4's
lowest-cost return, `planner.return_exact`) and out its mirror image (a path out, reversed, is a
way home under a symmetric OC), and the steps spent so far costing at least one axis step each.
A cell (a block in `BLOCKS`) read m times is credited with its m largest marginal gains
P0 (1 - Pc)^before Pc (1 - Pc)^(k-1), a concave function the LP takes in order (looks beyond
`MAX_LOOKS_LISTED` all get the largest unlisted gain, which only loosens it). Every trajectory
set above is a feasible solution worth at least its E, so the optimum is an upper bound; so are
the LP relaxation and a time-limited MIP's dual bound. `Bound.value` is the smaller of the two.

Pure computation: no printing, no files. HiGHS runs on one thread within the time given."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from planner.environment import footprint_cells
from planner.highs_solver import quiet_highs
from planner.horizon import steps_from
from planner.motion import HEADING_DX, HEADING_DY, OC3, OrientationConstraint
from planner.return_exact import UNREACHABLE, return_table
from planner.scenario import Scenario

if TYPE_CHECKING:
    from planner.bound_lagrange import Dual

__all__ = ["Bound", "BoundModel", "MAX_LOOKS_LISTED", "bound_model_size", "exact_optimum", "lagrangian_fits",
           "scenario_dual", "success_bound"]

#: Looks per cell listed as separate gains; later ones are credited with the largest unlisted gain.
MAX_LOOKS_LISTED = 12

#: The share of `success_bound`'s time its iterations of the `LAGRANGIAN` dual are sized to (the
#: LP model before it takes the rest: its arcs are sized to the time too).
DUAL_SHARE = 0.7

#: The flow arcs a model may have by default: HiGHS solves its LP in a few seconds on one core.
DEFAULT_MAX_ARCS = 15_000


class BoundModel(str, Enum):
    HEADINGS = "headings"
    CELLS = "cells"
    BLOCKS = "blocks"
    LAGRANGIAN = "lagrangian"


@dataclass(frozen=True)
class Bound:
    """The bound on expected finds and how it was had.

    `value` = min(`lp`, `mip_dual`): the upper bound (inf when the LP did not finish in time);
    `lp`: the LP relaxation's optimum; `mip_dual`: the MIP's dual bound (inf without one);
    `mip_best`: the best integer solution's worth (-inf without one; in `HEADINGS` a set of
    trajectories that keeps the OC and the budgets, separation aside); `mip_gap` its relative gap;
    `finished`: a bound was had within the time (the LP solved, or an iterate of the Lagrangian
    dual); `optimal`: the MIP solved to optimality (then `mip_best` is the exact optimum of the
    model); `model` the model `value` comes from, `block` (b; 1 for the other models), the LP
    model's size and the seconds it took, building included; `lagrangian` the smallest value of
    the `LAGRANGIAN` dual (inf when it did not run), `floor` what its master LP reached (the
    `HEADINGS` LP is at least that: no bound of that model can be below it; -inf without one)
    and `iterations` its evaluations of L."""

    value: float
    lp: float
    mip_dual: float
    mip_best: float
    mip_gap: float
    finished: bool
    optimal: bool
    model: BoundModel
    block: int
    columns: int
    rows: int
    seconds: float
    lagrangian: float = math.inf
    floor: float = -math.inf
    iterations: int = 0

    def share(self, expected: float) -> float | None:
        """`expected` over the bound (a plan's share of the most any plan could expect); None
        without a bound; 1 when the bound is 0."""
        if not (self.finished and math.isfinite(self.value)):
            return None
        return 1.0 if self.value <= 0 else expected / self.value


class _Model:
    """A sparse LP/MIP in the making: maximise gains . x, columns with bounds, rows lo <= a.x <= hi."""

    def __init__(self) -> None:
        self.gain: list[np.ndarray] = []
        self.upper: list[np.ndarray] = []
        self.integer: list[np.ndarray] = []
        self.columns = 0
        self.lo: list[float] = []
        self.hi: list[float] = []
        self.r: list[np.ndarray] = []
        self.c: list[np.ndarray] = []
        self.v: list[np.ndarray] = []

    def add_columns(self, n: int, gain: float | np.ndarray = 0.0, upper: float | np.ndarray = 1.0,
                    integer: bool = False) -> np.ndarray:
        ids = np.arange(self.columns, self.columns + n, dtype=np.int64)
        self.gain.append(np.full(n, gain) if np.isscalar(gain) else np.asarray(gain, dtype=float))
        self.upper.append(np.full(n, upper) if np.isscalar(upper) else np.asarray(upper, dtype=float))
        self.integer.append(np.full(n, integer))
        self.columns += n
        return ids

    def add_rows(self, n: int, lo: float, hi: float) -> np.ndarray:
        ids = np.arange(len(self.lo), len(self.lo) + n, dtype=np.int64)
        self.lo += [lo] * n
        self.hi += [hi] * n
        return ids

    def set_bounds(self, row: int, lo: float, hi: float) -> None:
        self.lo[row], self.hi[row] = lo, hi

    def entries(self, rows: np.ndarray | int, cols: np.ndarray | int, values: np.ndarray | float) -> None:
        r = np.asarray(rows, dtype=np.int64).ravel()
        c = np.asarray(cols, dtype=np.int64).ravel()
        if r.size == 0 or c.size == 0:
            return
        n = max(r.size, c.size)
        self.r.append(r if r.size == n else np.full(n, r[0]))
        self.c.append(c if c.size == n else np.full(n, c[0]))
        self.v.append(np.full(n, values, dtype=float) if np.isscalar(values)
                      else np.asarray(values, dtype=float).ravel())

    def solve(self, integral: bool, time_limit_s: float, mip_nodes: int | None = None
              ) -> tuple[str, float, float, float]:
        """(status, objective, dual bound, gap) of the LP (`integral` False) or the MIP (at most
        `mip_nodes` branch-and-bound nodes)."""
        import highspy

        r = np.concatenate(self.r) if self.r else np.zeros(0, np.int64)
        c = np.concatenate(self.c) if self.c else np.zeros(0, np.int64)
        v = np.concatenate(self.v) if self.v else np.zeros(0)
        order = np.lexsort((r, c))
        r, c, v = r[order], c[order], v[order]
        n = self.columns
        lp = highspy.HighsLp()
        lp.num_col_ = n
        lp.num_row_ = len(self.lo)
        lp.col_cost_ = -np.concatenate(self.gain)
        lp.col_lower_ = np.zeros(n)
        lp.col_upper_ = np.concatenate(self.upper)
        lp.row_lower_ = np.array(self.lo, dtype=float)
        lp.row_upper_ = np.array(self.hi, dtype=float)
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = np.searchsorted(c, np.arange(n + 1)).astype(np.int32)
        lp.a_matrix_.index_ = r.astype(np.int32)
        lp.a_matrix_.value_ = v
        if integral:
            kinds = np.concatenate(self.integer)
            lp.integrality_ = [highspy.HighsVarType.kInteger if k else highspy.HighsVarType.kContinuous
                               for k in kinds]
        h = quiet_highs()
        h.setOptionValue("time_limit", max(float(time_limit_s), 0.01))
        if integral:
            h.setOptionValue("mip_rel_gap", 1e-6)
            if mip_nodes is not None:
                h.setOptionValue("mip_max_nodes", int(mip_nodes))
        else:
            h.setOptionValue("solver", "ipm")     # the interior point method: faster than simplex here
        h.passModel(lp)
        h.run()
        status = h.getModelStatus()
        info = h.getInfo()
        name = "optimal" if status == highspy.HighsModelStatus.kOptimal else h.modelStatusToString(status)
        objective = -info.objective_function_value if info.primal_solution_status == 2 else -math.inf
        if not integral:
            return name, objective, -math.inf, math.inf
        dual = -info.mip_dual_bound if math.isfinite(info.mip_dual_bound) else math.inf
        return name, objective, dual, info.mip_gap


@dataclass(frozen=True)
class _Uav:
    airport: tuple[int, int]
    heading: int
    budget: int          # T_i in move-cost units
    steps: int           # the most steps the budget pays for
    home: np.ndarray     # (8, nx, ny): the exact OC return table
    out: np.ndarray      # (8, nx, ny): a lower bound on the cost of arriving at (x, y) with heading h
    cheb: np.ndarray     # (nx, ny): fewest 8-connected steps from the airport (-1: unreachable)


def _symmetric(oc: OrientationConstraint) -> bool:
    """Whether a path allowed under `oc`, flown backwards, is allowed too (every OC the planner has)."""
    return all(oc.allows(h, g) == oc.allows((g + 4) % 8, (h + 4) % 8) for h in range(8) for g in range(8))


def _uavs(scenario: Scenario, oc: OrientationConstraint) -> list[_Uav]:
    no_fly = scenario.search_map.no_fly
    costs = scenario.move_costs
    out = []
    for u in scenario.uavs:
        home = return_table(no_fly, u.airport, oc, costs).astype(np.int64)
        mirror = home[[(h + 4) % 8 for h in range(8)]] if _symmetric(oc) else np.zeros_like(home)
        out.append(_Uav(u.airport, u.heading, int(u.range_units), int(u.range_units) // costs.straight, home,
                        mirror, steps_from(no_fly, u.airport)))
    return out


def _marginal(scenario: Scenario) -> np.ndarray:
    """P0 (1 - Pc)^before per cell, 0 on no-fly cells: what a cell's next look is worth over Pc."""
    free = ~scenario.search_map.no_fly
    before = 0 if scenario.looks_before is None else np.asarray(scenario.looks_before, dtype=float)
    return np.where(free, scenario.success_prior, 0.0) * (1.0 - scenario.sensor.pc) ** before


def _listed_looks(pc: float) -> int:
    if pc >= 1.0:
        return 1
    return max(1, min(MAX_LOOKS_LISTED, math.ceil(math.log(1e-9) / math.log(1.0 - pc))))


def _add_gains(model: _Model, groups: list[np.ndarray], read_group: np.ndarray, read_col: np.ndarray,
               fixed: np.ndarray, pc: float) -> None:
    """One row per group of cells (a cell, or a block): the columns that read it (`read_col[j]`
    reads group `read_group[j]`, once) + its `fixed` reads = the sum of its gain variables, the
    largest gain first (concave: the LP takes them in order)."""
    looks = _listed_looks(pc)
    factors = pc * (1.0 - pc) ** np.arange(looks)
    row_of = np.full(len(groups), -1, dtype=np.int64)
    read = np.zeros(len(groups), dtype=bool)
    read[read_group] = True
    for k, cells in enumerate(groups):
        if not (read[k] or fixed[k]) or cells.size == 0 or cells.max() <= 0:
            continue
        gains = np.sort(np.outer(cells[cells > 0], factors).ravel())[::-1]
        row_of[k] = model.add_rows(1, -float(fixed[k]), -float(fixed[k]))[0]
        z = model.add_columns(len(gains), gains, 1.0)
        tail = model.add_columns(1, float(cells.max()) * pc * (1.0 - pc) ** looks, np.inf)
        model.entries(row_of[k], np.concatenate([z, tail]), -1.0)
    kept = row_of[read_group] >= 0
    model.entries(row_of[read_group[kept]], read_col[kept], 1.0)


def _cell_states(u: _Uav, oc: OrientationConstraint, no_fly: np.ndarray, straight: int, headings: bool,
                 limit: float = math.inf) -> list[np.ndarray] | None:
    """Per step t, the (8, nx, ny) mask of poses the UAV can hold at t and still get home within
    its budget, reachable from its start pose (without `headings`: one layer, any heading); None
    once the states times the moves out of each pass `limit`."""
    free = ~no_fly
    nx, ny = no_fly.shape
    home = u.home if headings else u.home.min(axis=0)[None]
    out = u.out if headings else u.out.min(axis=0)[None]
    fit = (home < UNREACHABLE) & (out < UNREACHABLE) & free[None]
    layers = home.shape[0]
    start = np.zeros((layers, nx, ny), dtype=bool)
    start[u.heading if headings else 0, u.airport[0], u.airport[1]] = True
    states = [start]
    moves = oc.branching if headings else 8
    count = 1
    for t in range(1, u.steps + 1):
        ok = fit & (np.maximum(t * straight, out) + home <= u.budget)
        nxt = np.zeros_like(start)
        prev = states[-1]
        for g in range(8):
            src = np.asarray(prev[[h for h in range(8) if oc.allows(h, g)]].any(axis=0) if headings else prev[0])
            moved = _shift(src, int(HEADING_DX[g]), int(HEADING_DY[g]))
            nxt[g if headings else 0] |= moved
        nxt &= ok
        count += int(nxt.sum())
        if count * moves > limit:
            return None
        if not nxt.any():
            break
        states.append(nxt)
    return states


def _shift(mask: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """`mask` moved by (dx, dy): out[x + dx, y + dy] = mask[x, y], cells leaving the grid dropped."""
    out = np.zeros_like(mask)
    nx, ny = mask.shape
    out[max(dx, 0):nx + min(dx, 0), max(dy, 0):ny + min(dy, 0)] = mask[max(-dx, 0):nx - max(dx, 0),
                                                                       max(-dy, 0):ny - max(dy, 0)]
    return out


def _cell_arcs(states: list[np.ndarray], oc: OrientationConstraint, headings: bool) -> int:
    """The flow arcs of a cell model over `states` (`_cell_states`)."""
    arcs = 0
    for t in range(len(states) - 1):
        for g in range(8):
            dst = _shift(states[t + 1][g if headings else 0], -int(HEADING_DX[g]), -int(HEADING_DY[g]))
            for h in ([h for h in range(8) if oc.allows(h, g)] if headings else [0]):
                arcs += int((states[t][h] & dst).sum())
    return arcs


def _build_cells(scenario: Scenario, oc: OrientationConstraint, uavs: list[_Uav], headings: bool,
                 integral: bool) -> _Model:
    """The `HEADINGS` or `CELLS` model of the module docstring."""
    m = scenario.search_map
    nx, ny = m.shape
    costs = scenario.move_costs
    r = scenario.sensor.footprint_radius
    marginal = _marginal(scenario)
    model = _Model()
    read_group: list[np.ndarray] = []
    read_col: list[np.ndarray] = []
    fixed = np.zeros(nx * ny)
    offsets = [(ox, oy) for ox in range(-r, r + 1) for oy in range(-r, r + 1)]
    for u in uavs:
        for cx, cy in footprint_cells(*u.airport, r, (nx, ny)):
            fixed[cx * ny + cy] += 1
        states = _cell_states(u, oc, m.no_fly, costs.straight, headings)
        assert states is not None
        layers = states[0].shape[0]
        ids = []
        for mask in states:
            node = np.full(mask.shape, -1, dtype=np.int64)
            node[mask] = model.add_rows(int(mask.sum()), 0.0, 0.0)
            ids.append(node)
        model.set_bounds(int(ids[0].max()), -1.0, -1.0)      # the start: outflow 1
        budget_row = model.add_rows(1, -np.inf, float(u.budget))[0]
        sink = model.add_rows(1, 1.0, 1.0)[0]
        for t in range(len(states) - 1):
            for g in range(8):
                dx, dy = int(HEADING_DX[g]), int(HEADING_DY[g])
                preds = [h for h in range(8) if oc.allows(h, g)] if headings else [0]
                dst_layer = g if headings else 0
                for h in preds:
                    src = states[t][h] & _shift(states[t + 1][dst_layer], -dx, -dy)
                    if not src.any():
                        continue
                    xs, ys = np.nonzero(src)
                    arcs = model.add_columns(len(xs), 0.0, 1.0, integer=True)
                    model.entries(ids[t][h][xs, ys], arcs, -1.0)
                    qx, qy = xs + dx, ys + dy
                    model.entries(ids[t + 1][dst_layer][qx, qy], arcs, 1.0)
                    model.entries(budget_row, arcs, float(costs.of(g)))
                    for ox, oy in offsets:
                        fx, fy = qx + ox, qy + oy
                        inside = (fx >= 0) & (fx < nx) & (fy >= 0) & (fy < ny)
                        read_group.append((fx * ny + fy)[inside])
                        read_col.append(arcs[inside])
        ax, ay = u.airport
        for t in range(1, len(states)):
            for h in range(layers):
                if states[t][h, ax, ay]:
                    land = model.add_columns(1, 0.0, 1.0, integer=True)
                    model.entries(ids[t][h, ax, ay], land, -1.0)
                    model.entries(sink, land, 1.0)
    _add_gains(model, list(marginal.reshape(-1, 1)), *_joined(read_group, read_col), fixed, scenario.sensor.pc)
    return model


def _joined(groups: list[np.ndarray], cols: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    empty = np.zeros(0, dtype=np.int64)
    return np.concatenate([empty, *groups]), np.concatenate([empty, *cols])


def _block_reduce(mask: np.ndarray, b: int) -> np.ndarray:
    nx, ny = mask.shape
    bx, by = -(-nx // b), -(-ny // b)
    padded = np.zeros((bx * b, by * b), dtype=bool)
    padded[:nx, :ny] = mask
    return np.asarray(padded.reshape(bx, b, by, b).any(axis=(1, 3)))


def _dilate(mask: np.ndarray, r: int) -> np.ndarray:
    out = mask.copy()
    for ox in range(-r, r + 1):
        for oy in range(-r, r + 1):
            out |= _shift(mask, ox, oy)
    return out


def _build_blocks(scenario: Scenario, uavs: list[_Uav], b: int, integral: bool) -> _Model:
    """The `BLOCKS` model of the module docstring."""
    m = scenario.search_map
    nx, ny = m.shape
    free = ~m.no_fly
    s = scenario.move_costs.straight
    r = scenario.sensor.footprint_radius
    per_read = (2 * r + 1) ** 2
    near = 1 + -(-r // b)
    bx, by = -(-nx // b), -(-ny // b)
    marginal = _marginal(scenario)
    model = _Model()
    read_group: list[np.ndarray] = []
    read_col: list[np.ndarray] = []
    fixed = np.zeros(bx * by)
    for u in uavs:
        home = u.home.min(axis=0)
        out = u.out.min(axis=0)
        ok = free & (home < UNREACHABLE) & (u.cheb >= 0)
        for cx, cy in footprint_cells(*u.airport, r, (nx, ny)):
            fixed[(cx // b) * by + cy // b] += 1
        a_block = (u.airport[0] // b, u.airport[1] // b)
        windows = -(-u.steps // b)
        times = [min(w * b, u.steps) for w in range(windows + 1)]
        nodes: list[np.ndarray] = []
        for t in times:
            here = ok & (u.cheb <= t) & (np.maximum(t * s, out) + home <= u.budget)
            mask = _block_reduce(here, b)
            node = np.full((bx, by), -1, dtype=np.int64)
            node[mask] = model.add_columns(int(mask.sum()), 0.0, 1.0)
            nodes.append(node)
        if nodes[0][a_block] < 0 or nodes[-1][a_block] < 0:
            raise ValueError("its airport block is not a node")
        for w in (0, windows):
            model.entries(model.add_rows(1, 1.0, 1.0)[0], nodes[w][a_block], 1.0)
        inflow: list[list[int]] = [[] for _ in range(bx * by)]
        for w in range(windows):
            here, there = nodes[w], nodes[w + 1]
            nxt_inflow: list[list[int]] = [[] for _ in range(bx * by)]
            for i, j in np.argwhere(here >= 0):
                targets = [(i + di, j + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)
                           if 0 <= i + di < bx and 0 <= j + dj < by and there[i + di, j + dj] >= 0]
                arcs = model.add_columns(len(targets), 0.0, 1.0, integer=True)
                row = model.add_rows(1, 0.0, 0.0)[0]
                model.entries(row, here[i, j], -1.0)
                model.entries(row, arcs, 1.0)
                for (ti, tj), arc in zip(targets, arcs.tolist()):
                    nxt_inflow[ti * by + tj].append(arc)
            if w > 0:
                _close_inflow(model, nodes[w], inflow)
            inflow = nxt_inflow
        _close_inflow(model, nodes[windows], inflow)
        for w in range(windows):
            length = times[w + 1] - times[w]
            readable = ok & (u.cheb <= times[w + 1]) & (np.maximum((times[w] + 1) * s, out) + home <= u.budget)
            blocks = _block_reduce(_dilate(readable, r) if r else readable, b)
            total = model.add_rows(1, -np.inf, float(length * per_read))[0]
            for i, j in np.argwhere(blocks):
                col = model.add_columns(1, 0.0, float(length * per_read))
                model.entries(total, col, 1.0)
                read_group.append(np.array([i * by + j]))
                read_col.append(col)
                cap = model.add_rows(1, -np.inf, 0.0)[0]
                model.entries(cap, col, 1.0)
                occ = nodes[w][max(i - near, 0):i + near + 1, max(j - near, 0):j + near + 1]
                model.entries(cap, occ[occ >= 0], -float(length * per_read))
    groups = []
    for i in range(bx):
        for j in range(by):
            groups.append(marginal[i * b:(i + 1) * b, j * b:(j + 1) * b].ravel())
    _add_gains(model, groups, *_joined(read_group, read_col), fixed, scenario.sensor.pc)
    return model


def _close_inflow(model: _Model, node: np.ndarray, inflow: list[list[int]]) -> None:
    """Each node's occupancy equals the flow into it."""
    by = node.shape[1]
    for i, j in np.argwhere(node >= 0):
        row = model.add_rows(1, 0.0, 0.0)[0]
        model.entries(row, node[i, j], -1.0)
        if inflow[i * by + j]:
            model.entries(row, np.array(inflow[i * by + j]), 1.0)


def _block_arcs(scenario: Scenario, b: int) -> int:
    nx, ny = scenario.search_map.shape
    blocks = -(-nx // b) * -(-ny // b)
    return sum(9 * blocks * -(-(u.range_units // scenario.move_costs.straight) // b) for u in scenario.uavs)


def bound_model_size(scenario: Scenario, oc: OrientationConstraint = OC3, max_arcs: int = DEFAULT_MAX_ARCS
                     ) -> tuple[BoundModel, int, int]:
    """The tightest model whose flow arcs fit `max_arcs`: (model, b, its arcs); the cell models
    are counted exactly, the block model's arcs estimated from above."""
    uavs = _uavs(scenario, oc)
    no_fly, s = scenario.search_map.no_fly, scenario.move_costs.straight
    for model, headings in ((BoundModel.HEADINGS, True), (BoundModel.CELLS, False)):
        arcs = 0
        for u in uavs:
            states = _cell_states(u, oc, no_fly, s, headings, 4 * max_arcs)
            arcs += max_arcs + 1 if states is None else _cell_arcs(states, oc, headings)
            if arcs > max_arcs:
                break
        if arcs <= max_arcs:
            return model, 1, arcs
    b = 2
    while _block_arcs(scenario, b) > max_arcs:
        b += 1
    return BoundModel.BLOCKS, b, _block_arcs(scenario, b)


def lagrangian_fits(scenario: Scenario, oc: OrientationConstraint, time_limit_s: float) -> bool:
    """Whether the `LAGRANGIAN` dual (its DP steps x cells x 8 headings x the OC's branching per
    UAV and evaluation, and its master LP: `planner.bound_lagrange.dual_seconds`) makes its
    first evaluations within `time_limit_s` and its choice table fits the memory."""
    from planner.bound_lagrange import dual_fits

    return dual_fits(_uavs(scenario, oc), scenario.search_map.no_fly.size, oc, time_limit_s)


def scenario_dual(scenario: Scenario, oc: OrientationConstraint, time_limit_s: float, max_iterations: int = 100_000,
                  trace: list[float] | None = None) -> Dual:
    """`planner.bound_lagrange.minimise_dual` over `scenario`'s UAVs, prior and sensor (this
    module's reading of them)."""
    from planner.bound_lagrange import minimise_dual

    return minimise_dual(_uavs(scenario, oc), oc, scenario.search_map.no_fly, _marginal(scenario),
                         scenario.sensor.pc, _listed_looks(scenario.sensor.pc), scenario.sensor.footprint_radius,
                         scenario.move_costs.by_heading, scenario.move_costs.straight, time_limit_s,
                         max_iterations, trace)


def _lagrangian(scenario: Scenario, oc: OrientationConstraint, uavs: list[_Uav], time_limit_s: float,
                planned_s: float, iterations: int | None) -> tuple[float, float, int]:
    """(the smallest value of the `LAGRANGIAN` dual within `time_limit_s`, the floor its master LP
    reached, its iterations): `iterations` of them, by default as many as its work estimate fits
    in `planned_s`, the same figure every run."""
    from planner.bound_lagrange import dual_seconds

    if iterations is None:
        iterations = max(2, int(planned_s / dual_seconds(uavs, scenario.search_map.no_fly.size, oc)))
    dual = scenario_dual(scenario, oc, time_limit_s, iterations)
    return float(dual.value), float(dual.floor), dual.iterations


def success_bound(scenario: Scenario, oc: OrientationConstraint = OC3, time_limit_s: float = 5.0, mip: bool = True,
                  max_arcs: int = DEFAULT_MAX_ARCS, model: BoundModel | None = None, block: int | None = None,
                  mip_nodes: int | None = None, dual_iterations: int | None = None) -> Bound:
    """The upper bound of the module docstring on the expected finds of any closed plan of
    `scenario` under `oc`, within `time_limit_s` seconds (building the model included): the LP
    first, then with `mip` the MIP in the time left (at most `mip_nodes` branch-and-bound nodes:
    its dual bound comes mostly from the cuts at the root). `model` (and `block` for `BLOCKS`) forces a
    model; by default the tightest LP model whose arcs fit `max_arcs`, and when that is not
    `HEADINGS` and the `LAGRANGIAN` dual fits the time, the LP and then, instead of the MIP, the
    dual in the time left (as many iterations as its work estimate fits in that time, so the
    same scenario gives the same bound; the time is still a hard stop), the smaller reported.
    `lower`: a value the optimum is known to reach (a plan's expected finds), the dual's target."""
    start = time.perf_counter()
    if not scenario.uavs:
        return Bound(0.0, 0.0, 0.0, 0.0, 0.0, True, True, BoundModel.CELLS, 1, 0, 0, 0.0)
    if model is BoundModel.LAGRANGIAN:
        value, floor, iterations = _lagrangian(scenario, oc, _uavs(scenario, oc), time_limit_s, time_limit_s,
                                                dual_iterations)
        return Bound(value, math.inf, math.inf, -math.inf, math.inf, math.isfinite(value), False, model, 1, 0, 0,
                     time.perf_counter() - start, value, floor, iterations)
    dual = False
    if model is None:
        model, b, _ = bound_model_size(scenario, oc, max_arcs)
        dual = model is not BoundModel.HEADINGS and lagrangian_fits(scenario, oc, time_limit_s)
    else:
        b = 1 if model is not BoundModel.BLOCKS else (block or bound_model_size(scenario, oc, max_arcs)[1])
    uavs = _uavs(scenario, oc)
    if model is BoundModel.BLOCKS:
        built = _build_blocks(scenario, uavs, max(b, 1), mip)
    else:
        built = _build_cells(scenario, oc, uavs, model is BoundModel.HEADINGS, mip)
    left = time_limit_s - (time.perf_counter() - start)
    lp = -math.inf
    finished = False
    if left > 0:
        status, lp, _, _ = built.solve(False, left)
        finished = status == "optimal"
    if dual:
        left = time_limit_s - (time.perf_counter() - start)
        value, floor, iterations = (_lagrangian(scenario, oc, uavs, left, DUAL_SHARE * time_limit_s, dual_iterations)
                                    if left > 0
                                    else (math.inf, -math.inf, 0))
        lp = lp if finished else math.inf
        tighter = value < lp
        return Bound(min(lp, value), lp, math.inf, -math.inf, math.inf, finished or math.isfinite(value), False,
                     BoundModel.LAGRANGIAN if tighter else model, 1 if tighter else b, built.columns, len(built.lo),
                     time.perf_counter() - start, value, floor, iterations)
    if not finished:
        return Bound(math.inf, math.inf, math.inf, -math.inf, math.inf, False, False, model, b, built.columns,
                     len(built.lo), time.perf_counter() - start)
    dual_bound, best, gap, optimal = math.inf, -math.inf, math.inf, False
    left = time_limit_s - (time.perf_counter() - start)
    if mip and left > 0:
        status, best, dual_bound, gap = built.solve(True, left, mip_nodes)
        optimal = status == "optimal"
    return Bound(min(lp, dual_bound), lp, dual_bound, best, gap, True, optimal, model, b, built.columns, len(built.lo),
                 time.perf_counter() - start)


def exact_optimum(scenario: Scenario, oc: OrientationConstraint = OC3, time_limit_s: float = 60.0) -> Bound:
    """The `HEADINGS` model solved as a MIP: with `Bound.optimal`, `mip_best` is the most any set
    of trajectories of the module docstring can expect with the OC kept (separation aside), and
    so at least what any plan of the planner's expects. For tiny areas: the model grows with
    cells x headings x steps."""
    return success_bound(scenario, oc, time_limit_s, mip=True, model=BoundModel.HEADINGS)
