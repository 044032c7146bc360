"""An upper bound on the expected targets any closed plan can find (`planner.success`), from a
time-expanded team-orienteering model of the same grid, airports and ranges, solved by HiGHS
(the `bench` extra: `pip install -e .[bench]`).

What it bounds: the expected finds sum P0(c) (1 - (1 - Pc)^n(c)) of every set of closed
trajectories in which UAV i leaves its airport cell, flies at most T_i one-cell steps (8
neighbours, never into a no-fly cell) and is back on its airport cell by step T_i, reading every
cell it is on (the airport at step 0 too), with the one-cell sensor (footprint radius 0). The
plans DTSCS makes are such trajectories, with more rules (the OC, no two UAVs in one cell), so
none can find more. It is a bound, not an achievable value.

The model. Cells are grouped into b x b blocks and time into windows of b steps. In b steps a
UAV moves at most b cells, so its block at the start of consecutive windows differs by at most
one (Chebyshev), and every cell it reads during a window lies in the 3 x 3 blocks around its
block at the window's start. Per UAV, a unit flow runs through (window, block) nodes from its
airport's block at time 0 to the same block at time T_i; a node exists only where some free cell
of the block is within t steps of the airport and T_i - t steps of home (fewest 8-connected
steps out, the OC-free exact table home: both lower bounds). The b reads of a window go to
blocks next to the node the flow occupies and that hold a cell readable then (same test). A
block read m times is worth at most the sum of the m largest marginal gains P0(c) Pc (1-Pc)^(k-1)
over its cells c and looks k, a concave function modelled exactly by one [0, 1] variable per
gain (looks beyond the listed ones are all credited with the largest unlisted gain). Every
trajectory above maps to a solution worth at least its expected finds, so the optimum is an
upper bound; so is the LP relaxation, and so is a time-limited MIP's dual bound. Reported: the
smaller of the LP optimum and the MIP's dual bound."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from planner.horizon import steps_from
from planner.motion import OC8
from planner.return_exact import UNREACHABLE, return_table
from planner.scenario import Scenario

#: Looks per cell listed as separate gains; later ones are credited with the largest unlisted gain.
MAX_LOOKS_LISTED = 12


@dataclass(frozen=True)
class Bound:
    """`value`: the upper bound on expected finds; `lp`: the LP relaxation's optimum; `mip`: the
    MIP's dual bound (inf if its time ran out before one); `block`: b; sizes and time."""

    value: float
    lp: float
    mip: float
    mip_gap: float
    block: int
    columns: int
    rows: int
    seconds: float


def _block_gains(p0: np.ndarray, free: np.ndarray, pc: float, b: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Per block (row-major over blocks): its sorted marginal gains, and the tail gain."""
    nx, ny = p0.shape
    bx, by = -(-nx // b), -(-ny // b)
    looks = max(1, min(MAX_LOOKS_LISTED, math.ceil(math.log(1e-9) / math.log(1 - pc)) if pc < 1 else 1))
    factors = pc * (1 - pc) ** np.arange(looks)
    gains, tails = [], np.zeros(bx * by)
    for i in range(bx):
        for j in range(by):
            cells = p0[i * b:(i + 1) * b, j * b:(j + 1) * b][free[i * b:(i + 1) * b, j * b:(j + 1) * b]]
            g = np.sort(np.outer(cells, factors).ravel())[::-1]
            gains.append(g[g > 0])
            tails[i * by + j] = cells.max(initial=0.0) * pc * (1 - pc) ** looks
    return gains, tails


def _block_min(values: np.ndarray, free: np.ndarray, b: int) -> np.ndarray:
    nx, ny = values.shape
    bx, by = -(-nx // b), -(-ny // b)
    big = np.iinfo(np.int64).max // 4
    padded = np.full((bx * b, by * b), big, dtype=np.int64)
    padded[:nx, :ny] = np.where(free & (values >= 0), values, big)
    return padded.reshape(bx, b, by, b).min(axis=(1, 3))


def choose_block(scenario: Scenario, max_arcs: int = 150_000) -> int:
    """The smallest b whose model has about `max_arcs` flow arcs or fewer (upper estimate)."""
    nx, ny = scenario.search_map.shape
    b = 1
    while True:
        blocks = -(-nx // b) * -(-ny // b)
        arcs = sum(9 * blocks * math.ceil(u.range_steps / b) for u in scenario.uavs)
        if arcs <= max_arcs:
            return b
        b += 1


def success_bound(scenario: Scenario, block: int | None = None, time_limit_s: float = 60.0,
                  mip: bool = True) -> Bound:
    """The upper bound of the module docstring for `scenario` (one-cell sensor only)."""
    import highspy

    if scenario.sensor.footprint_radius != 0:
        raise ValueError("the bound models the one-cell sensor (footprint radius 0) only")
    start = time.perf_counter()
    m = scenario.search_map
    free = ~m.no_fly
    pc = scenario.sensor.pc
    b = block or choose_block(scenario)
    nx, ny = m.shape
    bx, by = -(-nx // b), -(-ny // b)
    n_blocks = bx * by
    gains, tails = _block_gains(np.where(free, m.tep, 0.0), free, pc, b)

    cost: list[float] = []
    upper: list[float] = []
    integer: list[int] = []
    rows_lo: list[float] = []
    rows_hi: list[float] = []
    entries: list[tuple[int, int, float]] = []     # (row, column, value)

    def column(c: float, ub: float, is_int: bool) -> int:
        cost.append(c)
        upper.append(ub)
        integer.append(1 if is_int else 0)
        return len(cost) - 1

    def row(lo: float, hi: float) -> int:
        rows_lo.append(lo)
        rows_hi.append(hi)
        return len(rows_lo) - 1

    block_looks: dict[int, list[int]] = {k: [] for k in range(n_blocks)}
    airport_looks = np.zeros(n_blocks)

    def bid(i: int, j: int) -> int:
        return i * by + j

    for u in scenario.uavs:
        T = u.range_steps
        ax, ay = u.airport
        a_block = bid(ax // b, ay // b)
        airport_looks[a_block] += 1
        out_min = _block_min(steps_from(m.no_fly, u.airport), free, b)
        table = return_table(m.no_fly, u.airport, OC8).min(axis=0).astype(np.int64)
        home_min = _block_min(np.where(table >= UNREACHABLE, -1, table), free, b)
        windows = math.ceil(T / b)
        times = [min(w * b, T) for w in range(windows + 1)]
        nodes: list[dict[int, int]] = []      # per time point: block -> occupancy column
        for t in times:
            ok = np.argwhere((out_min <= t) & (home_min <= T - t))
            nodes.append({bid(i, j): column(0.0, 1.0, False) for i, j in ok})
        if a_block not in nodes[0] or a_block not in nodes[-1]:
            raise ValueError(f"UAV {u.uav_id}: its airport block is not a node")
        # occupancy = outflow (w < W) = inflow (w > 0); source and sink fixed to 1
        inflow: list[dict[int, list[int]]] = [{k: [] for k in layer} for layer in nodes]
        for w in range(windows):
            here, there = nodes[w], nodes[w + 1]
            for k, occupied in here.items():
                i, j = divmod(k, by)
                out_row = row(0.0, 0.0)
                entries.append((out_row, occupied, -1.0))
                for di in (-1, 0, 1):
                    for dj in (-1, 0, 1):
                        ii, jj = i + di, j + dj
                        if 0 <= ii < bx and 0 <= jj < by and bid(ii, jj) in there:
                            arc = column(0.0, 1.0, True)
                            entries.append((out_row, arc, 1.0))
                            inflow[w + 1][bid(ii, jj)].append(arc)
        for w in range(1, windows + 1):
            for k, occupied in nodes[w].items():
                r = row(0.0, 0.0)
                entries.append((r, occupied, -1.0))
                for arc in inflow[w][k]:
                    entries.append((r, arc, 1.0))
        for w in (0, windows):
            r = row(1.0, 1.0)
            entries.append((r, nodes[w][a_block], 1.0))
        # reads of window w: into blocks next to the occupied node, readable in the window
        for w in range(windows):
            length = times[w + 1] - times[w]
            readable = (out_min <= times[w + 1]) & (home_min <= T - times[w] - 1)
            total = row(length, length)
            for i, j in np.argwhere(readable):
                k = bid(i, j)
                reads = column(0.0, float(length), False)
                entries.append((total, reads, 1.0))
                block_looks[k].append(reads)
                near = row(-np.inf, 0.0)
                entries.append((near, reads, 1.0))
                for di in (-1, 0, 1):
                    for dj in (-1, 0, 1):
                        ii, jj = i + di, j + dj
                        if 0 <= ii < bx and 0 <= jj < by and bid(ii, jj) in nodes[w]:
                            entries.append((near, nodes[w][bid(ii, jj)], -float(length)))
    # each block's reads are spread over its gains, largest first (concave, so the LP does it)
    for k in range(n_blocks):
        if not block_looks[k] and airport_looks[k] == 0:
            continue
        r = row(-airport_looks[k], -airport_looks[k])     # reads + airport reads = sum of gain variables
        for reads in block_looks[k]:
            entries.append((r, reads, 1.0))
        for g in gains[k]:
            entries.append((r, column(-float(g), 1.0, False), -1.0))
        entries.append((r, column(-float(tails[k]), np.inf, False), -1.0))

    lp_value, _, _ = _solve(highspy, cost, upper, None, rows_lo, rows_hi, entries, time_limit_s)
    mip_value, gap = np.inf, np.inf
    if mip:
        _, mip_value, gap = _solve(highspy, cost, upper, integer, rows_lo, rows_hi, entries, time_limit_s)
    return Bound(min(lp_value, mip_value), lp_value, mip_value, gap, b, len(cost), len(rows_lo),
                 time.perf_counter() - start)


def _solve(highspy, cost, upper, integer, rows_lo, rows_hi, entries, time_limit_s) -> tuple[float, float, float]:
    """Solve min cost.x (the negated gains); returns the LP optimum (as a gain), the MIP's dual
    bound (as a gain) and its relative gap."""
    r, c, v = (np.array(a) for a in zip(*entries))
    order = np.lexsort((r, c))
    r, c, v = r[order].astype(np.int32), c[order], v[order]
    n = len(cost)
    starts = np.searchsorted(c, np.arange(n + 1)).astype(np.int32)
    lp = highspy.HighsLp()
    lp.num_col_ = n
    lp.num_row_ = len(rows_lo)
    lp.col_cost_ = np.array(cost)
    lp.col_lower_ = np.zeros(n)
    lp.col_upper_ = np.array(upper)
    lp.row_lower_ = np.array(rows_lo)
    lp.row_upper_ = np.array(rows_hi)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = starts
    lp.a_matrix_.index_ = r
    lp.a_matrix_.value_ = v
    if integer is not None:
        lp.integrality_ = [highspy.HighsVarType.kInteger if i else highspy.HighsVarType.kContinuous for i in integer]
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("time_limit", float(time_limit_s))
    h.setOptionValue("random_seed", 0)
    h.setOptionValue("threads", 1)
    if integer is None:
        h.setOptionValue("solver", "ipm")     # the interior point method: several times faster here
    h.passModel(lp)
    h.run()
    info = h.getInfo()
    if integer is None:
        if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
            raise RuntimeError(f"the LP relaxation did not solve: {h.modelStatusToString(h.getModelStatus())}")
        return -info.objective_function_value, np.inf, 0.0
    dual = info.mip_dual_bound
    bound = -dual if np.isfinite(dual) else np.inf
    return np.inf, bound, info.mip_gap
