"""Improve a whole closed plan after DTSCS: windows of each UAV's path cut out and re-solved
exactly between fixed poses, against the other UAVs' fixed paths, in rounds until no window
gains.

DTSCS decides Np steps at a time, greedy beyond them, one UAV after another; nothing looks at a
mission once it is planned. This pass does, with the objective the plan reports:
`planner.success`'s expected finds E = sum over cells of P0 (1 - (1 - Pc)^n), n the readings of
the cell (every pose of every UAV, its footprint included, the airport at step 0). E depends on
how often each cell is read, not on when, so a window's worth is exact: the readings it adds,
given every other reading of the plan.

First, in rounds until no UAV gains (`ResponseSettings.rounds`), each UAV's whole path is
re-planned as its best response to every other reading of the plan (`planner.best_response`: a
time-indexed programme over (step, cell, heading) from its airport pose home, the other UAVs'
cells at each step forbidden, mu per unit of cost on a ladder, every candidate scored exactly; a
UAV is asked again only when some path changed since its last response: else it would answer the
same readings; a UAV whose programme is too large answers in a tube around its path); then the
windows polish what it left, long windows by dynamic programming (`_dp_sweep`; not for a UAV
whose path a tube changed, and a window whose unpenalised answer cannot beat the old one is not
fitted to the range by bisection), then two moves, each solved by a depth-first search over
every path under the OC (kernel `_improve_uav`):

- a **window** of L steps between two fixed poses of a path: every path of L steps from the
  first pose to the cell of the second whose heading allows the move after it. Times are kept,
  so the other UAVs' paths need only be checked step by step (never one cell at one step);
- the **tail**, the last L steps into the airport: any path of at most L + `extra` steps from
  the pose that starts it home, so a UAV whose DTSCS path left range unflown (the switch is
  myopic: under 3OC a UAV near home with a few cells of range left has no loop that fits)
  spends it where it reads most.

Every candidate keeps the safety invariants: in the grid and out of no-fly cells, turns the OC
allows (into and out of the window), no cell shared with another UAV at a step, and the path's
cost (its metres in move-cost units) within the range less the reserve. A window is replaced only
when its readings gain more than `MIN_GAIN`, so E never falls. L is the most steps whose paths
number at most `ImproveSettings.paths` (3OC: L = 8, 3^8 = 6561 paths per window).

A multicopter pays for its seconds, not its metres, and a corner costs it the time it loses
braking and speeding up again (`planner.path_time`). A UAV whose spec has a time pricing
(`UavSpec.time_pricing`, `planner.time_pricing`) keeps a second bound: its path's time-priced
cost, its moves plus, at each pose between two moves, a charge indexed by the heading change
((h' - h) mod 8), plus the stops at its ends, an upper bound of its seconds at cruise speed,
within what its range less the reserve buys in that currency (the charge the range was sized
with, flown at cruise), or within its DTSCS path's cost when that is more: the improvement never
makes a path take longer than the charge its range was sized with pays for, or than DTSCS's.
The exact windows check it step by step (the turn into the window, inside it and out of it);
the long windows penalise turns as they penalise diagonals when the path's time is what does
not fit. Without a time pricing (a plane) every turn costs 0 and the second bound is the first:
the plans are the ones the metres alone give, bit for bit."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from planner.best_response import ResponseSettings, backtrace, in_tube, read_footprint, respond
from planner.config import njit
from planner.motion import HEADING_DX, HEADING_DY, MoveCosts, OrientationConstraint
from planner.plan import Plan, Stage, TargetOutcome, TrajectoryPoint, UavPlan
from planner.return_exact import return_table
from planner.scenario import Scenario, UavSpec
from planner.sensor_noise import reading_draw
from planner.success import plan_looks, success_of_looks

__all__ = ["ImproveSettings", "improve_plan"]

#: Gains below this (expected targets) are not worth a change.
MIN_GAIN = 1e-9
#: Readings of one cell past this count add nothing a float can hold.
MAX_LOOKS = 64


@dataclass(frozen=True)
class ImproveSettings:
    """`paths`: at most this many paths per exact window (fixes L); `stride`: steps between the
    starts of two windows of a sweep; `rounds`: sweeps over every UAV at most (fewer when one
    gains nothing); `extra`: steps a tail may grow by; `dp_steps`, `dp_stride`: the long windows
    solved by dynamic programming (0: none); `response`: each UAV's whole path re-planned first,
    in rounds, as its best response to the others' (`planner.best_response`; None: not)."""

    paths: int = 6561
    stride: int = 2
    rounds: int = 2
    extra: int = 4
    dp_steps: int = 36
    dp_stride: int = 9
    response: ResponseSettings | None = ResponseSettings()

    def __post_init__(self) -> None:
        if self.paths < 2 or self.stride < 1 or self.rounds < 0 or self.extra < 0 or self.dp_steps < 0 \
                or self.dp_stride < 1:
            raise ValueError(f"bad improvement settings {self}")

    def window(self, branching: int) -> int:
        """L: the most steps whose `branching`^L paths stay within `paths`."""
        return max(2, int(math.floor(math.log(self.paths) / math.log(max(branching, 2)) + 1e-9)))


@njit
def _free_at(others: np.ndarray, step: int, x: int, y: int) -> bool:
    """No other UAV stands on (x, y) at `step` (others[u, step] = (x, y), -1 when not flying)."""
    if step >= others.shape[1]:
        return True
    for u in range(others.shape[0]):
        if others[u, step, 0] == x and others[u, step, 1] == y:
            return False
    return True


@njit
def _turn_at(path: np.ndarray, p: int, n_poses: int, turns: np.ndarray) -> int:
    """What the turn at pose `p` of path[:n_poses] adds to its time-priced cost: `turns` by the
    heading change between the move into it and the move out of it ((h' - h) mod 8); nothing at
    the path's first and last poses (the stops, priced apart)."""
    if p < 1 or p >= n_poses - 1:
        return 0
    turn: int = turns[(path[p + 1, 2] - path[p, 2]) & 7]
    return turn


@njit
def _span_units(path: np.ndarray, lo: int, hi: int, n_poses: int, move_costs: np.ndarray, turns: np.ndarray) -> int:
    """The time-priced cost of path[lo .. hi] (of path[:n_poses]): the moves into those poses and
    the turns at poses lo - 1 .. hi, every one a change of those poses' headings changes."""
    cost = 0
    for i in range(lo, hi + 1):
        cost += move_costs[path[i, 2]]
    for p in range(lo - 1, hi + 1):
        cost += _turn_at(path, p, n_poses, turns)
    return cost


@njit
def _best_window(path: np.ndarray, a: int, steps: int, tail: bool, max_steps: int, budget: int, time_room: int,
                 counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float, radius: int,
                 others: np.ndarray, blocked: np.ndarray, successors: np.ndarray, allowed: np.ndarray,
                 table: np.ndarray, dx: np.ndarray, dy: np.ndarray, move_costs: np.ndarray, turns: np.ndarray,
                 out: np.ndarray) -> tuple[float, int]:
    """The best replacement of path[a + 1 .. a + steps] (rows x, y, heading) whose readings are
    already taken out of `counts`: (its gain, its number of poses in `out`), (-1, 0) when none.

    Not a tail: exactly `steps` poses, the last on the cell of path[a + steps] with a heading
    from which path[a + steps + 1]'s heading is allowed (any heading at the plan's last pose).
    A tail: 1 to `max_steps` poses ending on the airport, the last pose of the path. Cost at most
    `budget`, and time-priced cost (its moves, and `turns` at poses a to a + steps: into, inside
    and out of the window) at most `time_room`; every pose off the other UAVs' cells at its step."""
    nx, ny = blocked.shape
    ex = path[a + steps, 0]
    ey = path[a + steps, 1]
    last = path.shape[0] - 1
    next_h = -1 if tail or a + steps == last else path[a + steps + 1, 2]
    depth_max = max_steps if tail else steps
    width = successors.shape[1]
    xs = np.empty(depth_max + 1, dtype=np.int64)
    ys = np.empty(depth_max + 1, dtype=np.int64)
    hs = np.empty(depth_max + 1, dtype=np.int64)
    cost = np.zeros(depth_max + 1, dtype=np.int64)
    timed = np.zeros(depth_max + 1, dtype=np.int64)
    gain = np.zeros(depth_max + 1, dtype=np.float64)
    choice = np.zeros(depth_max + 1, dtype=np.int64)
    xs[0] = path[a, 0]
    ys[0] = path[a, 1]
    hs[0] = path[a, 2]
    best = -1.0
    best_n = 0
    cheapest = move_costs.min()
    d = 0
    while d >= 0:
        if d == depth_max or choice[d] >= width or successors[hs[d], choice[d]] < 0:
            if d > 0:
                read_footprint(counts, base, qpow, pc, xs[d], ys[d], radius, -1)
            choice[d] = 0
            d -= 1
            continue
        g = successors[hs[d], choice[d]]
        choice[d] += 1
        qx = xs[d] + dx[g]
        qy = ys[d] + dy[g]
        if qx < 0 or qy < 0 or qx >= nx or qy >= ny or blocked[qx, qy]:
            continue
        c = cost[d] + move_costs[g]
        t = timed[d] + move_costs[g] + (turns[(g - hs[d]) & 7] if a + d >= 1 else 0)
        left = depth_max - d - 1
        if tail:
            if c + table[g, qx, qy] > budget or t + table[g, qx, qy] > time_room:
                continue
        else:
            if max(abs(qx - ex), abs(qy - ey)) > left or c + left * cheapest > budget \
                    or t + left * cheapest > time_room:
                continue
        if not _free_at(others, a + d + 1, qx, qy):
            continue
        d += 1
        xs[d] = qx
        ys[d] = qy
        hs[d] = g
        cost[d] = c
        timed[d] = t
        choice[d] = 0
        gain[d] = gain[d - 1] + read_footprint(counts, base, qpow, pc, qx, qy, radius, 1)
        end = qx == ex and qy == ey and (tail or (d == steps and (next_h < 0 or allowed[g, next_h])))
        if end and next_h >= 0:
            end = t + turns[(next_h - g) & 7] <= time_room
        if end and gain[d] > best:
            best = gain[d]
            best_n = d
            for i in range(1, d + 1):
                out[i - 1, 0] = xs[i]
                out[i - 1, 1] = ys[i]
                out[i - 1, 2] = hs[i]
    return best, best_n


@njit
def _dp_window(path: np.ndarray, a: int, steps: int, penalty: float, turn_weight: np.ndarray, counts: np.ndarray,
               base: np.ndarray, qpow: np.ndarray, pc: float, radius: int, others: np.ndarray, blocked: np.ndarray,
               successors: np.ndarray, allowed: np.ndarray, dx: np.ndarray, dy: np.ndarray,
               out: np.ndarray) -> bool:
    """The path of exactly `steps` poses after path[a] to the cell of path[a + steps] (heading
    allowing path[a + steps + 1]'s) that maximises the sum of its poses' first-reading gains
    (`counts` without the window's own readings; a cell met twice counted twice) less `penalty`
    per diagonal move and `penalty` times `turn_weight` of each turn at poses a to a + steps (by
    heading change, (h' - h) mod 8; none at the path's first pose), off the other UAVs' cells at
    each step: dynamic programming over (step, cell, heading) in the box the window can reach.
    Writes `out[:steps]`; False when none."""
    nx, ny = blocked.shape
    sx = path[a, 0]
    sy = path[a, 1]
    ex = path[a + steps, 0]
    ey = path[a + steps, 1]
    last = path.shape[0] - 1
    next_h = -1 if a + steps >= last or path[a + steps + 1, 0] < 0 else path[a + steps + 1, 2]
    reach = (steps - max(abs(sx - ex), abs(sy - ey))) // 2 + 1
    x0 = max(0, min(sx, ex) - reach)
    y0 = max(0, min(sy, ey) - reach)
    x1 = min(nx - 1, max(sx, ex) + reach)
    y1 = min(ny - 1, max(sy, ey) + reach)
    bw = x1 - x0 + 1
    bh = y1 - y0 + 1
    reward = np.zeros((bw, bh), dtype=np.float64)
    for i in range(bw):
        for j in range(bh):
            x = x0 + i
            y = y0 + j
            if blocked[x, y]:
                continue
            for cx in range(x - radius, x + radius + 1):
                for cy in range(y - radius, y + radius + 1):
                    if 0 <= cx < nx and 0 <= cy < ny:
                        reward[i, j] += base[cx, cy] * qpow[min(counts[cx, cy], qpow.shape[0] - 1)] * pc
    value = np.full((steps + 1, bw, bh, 8), -np.inf)
    parent = np.full((steps + 1, bw, bh, 8), -1, dtype=np.int8)
    value[0, sx - x0, sy - y0, path[a, 2]] = 0.0
    width = successors.shape[1]
    for t in range(steps):
        left = steps - t - 1
        i0 = max(0, max(sx - t, ex - left - 1) - x0)
        i1 = min(bw - 1, min(sx + t, ex + left + 1) - x0)
        j0 = max(0, max(sy - t, ey - left - 1) - y0)
        j1 = min(bh - 1, min(sy + t, ey + left + 1) - y0)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                for h in range(8):
                    v = value[t, i, j, h]
                    if v == -np.inf:
                        continue
                    for k in range(width):
                        g = successors[h, k]
                        if g < 0:
                            break
                        qi = i + dx[g]
                        qj = j + dy[g]
                        if qi < 0 or qj < 0 or qi >= bw or qj >= bh:
                            continue
                        qx = x0 + qi
                        qy = y0 + qj
                        if blocked[qx, qy] or max(abs(qx - ex), abs(qy - ey)) > left:
                            continue
                        if not _free_at(others, a + t + 1, qx, qy):
                            continue
                        w = v + reward[qi, qj] - (penalty if g % 2 == 1 else 0.0)
                        if a + t >= 1:
                            w -= penalty * turn_weight[(g - h) & 7]
                        if w > value[t + 1, qi, qj, g]:
                            value[t + 1, qi, qj, g] = w
                            parent[t + 1, qi, qj, g] = h
    best = -np.inf
    bh_end = -1
    for h in range(8):
        if next_h >= 0 and not allowed[h, next_h]:
            continue
        end = value[steps, ex - x0, ey - y0, h]
        if next_h >= 0:
            end -= penalty * turn_weight[(next_h - h) & 7]
        if end > best:
            best = end
            bh_end = h
    if bh_end < 0:
        return False
    backtrace(parent, steps, ex, ey, bh_end, np.full(steps + 1, x0), np.full(steps + 1, y0), dx, dy, out)
    return True


@njit
def _window_cost(out: np.ndarray, steps: int, move_costs: np.ndarray) -> int:
    cost = 0
    for i in range(steps):
        cost += move_costs[out[i, 2]]
    return cost


@njit
def _window_units(path: np.ndarray, a: int, steps: int, out: np.ndarray, move_costs: np.ndarray,
                  turns: np.ndarray) -> int:
    """The time-priced cost of `out[:steps]` in place of path[a + 1 .. a + steps]: its moves and
    the turns at poses a (none at the path's first) to a + steps (none at its last)."""
    cost = _window_cost(out, steps, move_costs)
    if a >= 1:
        cost += turns[(out[0, 2] - path[a, 2]) & 7]
    for i in range(1, steps):
        cost += turns[(out[i, 2] - out[i - 1, 2]) & 7]
    if a + steps < path.shape[0] - 1 and path[a + steps + 1, 0] >= 0:
        cost += turns[(path[a + steps + 1, 2] - out[steps - 1, 2]) & 7]
    return cost


@njit
def _fits(path: np.ndarray, a: int, steps: int, out: np.ndarray, room: int, time_room: int, move_costs: np.ndarray,
          turns: np.ndarray) -> bool:
    return _window_cost(out, steps, move_costs) <= room and _window_units(path, a, steps, out, move_costs,
                                                                          turns) <= time_room


@njit
def _fitting_window(path: np.ndarray, a: int, steps: int, room: int, time_room: int, counts: np.ndarray,
                    base: np.ndarray, qpow: np.ndarray, pc: float, radius: int, others: np.ndarray,
                    blocked: np.ndarray, successors: np.ndarray, allowed: np.ndarray, dx: np.ndarray, dy: np.ndarray,
                    move_costs: np.ndarray, turns: np.ndarray, turn_weight: np.ndarray, out: np.ndarray,
                    spare: np.ndarray, floor: float) -> bool:
    """`_dp_window`'s path into `out` at the least penalty (to within a bisection) whose cost fits
    in `room` and whose time-priced cost fits in `time_room`; False when none does, or when no
    window can read more than `floor` (the unpenalised path's first-reading gains over its first
    steps - 1 poses are the most any window's, and so its exact gain, can be: then no penalty is
    sought). The penalty is per diagonal move, and, when the unpenalised path's time is what does
    not fit, per turn too (`turn_weight`: a turn's units per diagonal's extra units)."""
    if not _dp_window(path, a, steps, 0.0, turn_weight, counts, base, qpow, pc, radius, others, blocked, successors,
                      allowed, dx, dy, out):
        return False
    if _fits(path, a, steps, out, room, time_room, move_costs, turns):
        return True
    most = 0.0
    for i in range(steps - 1):
        most += read_footprint(counts, base, qpow, pc, out[i, 0], out[i, 1], radius, 0)
    if most <= floor:
        return False
    timed = _window_units(path, a, steps, out, move_costs, turns) > time_room
    weight = turn_weight if timed else np.zeros(turn_weight.shape[0])
    low = 0.0
    high = 1e-3
    while True:
        if not _dp_window(path, a, steps, high, weight, counts, base, qpow, pc, radius, others, blocked, successors,
                          allowed, dx, dy, spare):
            return False
        if _fits(path, a, steps, spare, room, time_room, move_costs, turns):
            break
        if high > 100.0:
            return False
        low = high
        high *= 4.0
    out[:] = spare
    for _ in range(6):
        mid = (low + high) / 2.0
        _dp_window(path, a, steps, mid, weight, counts, base, qpow, pc, radius, others, blocked, successors, allowed,
                   dx, dy, spare)
        if _fits(path, a, steps, spare, room, time_room, move_costs, turns):
            high = mid
            out[:] = spare
        else:
            low = mid
    return True


@njit
def _dp_sweep(path: np.ndarray, n_poses: int, budget: int, time_budget: int, steps: int, stride: int,
              counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float, radius: int, others: np.ndarray,
              blocked: np.ndarray, successors: np.ndarray, allowed: np.ndarray, dx: np.ndarray, dy: np.ndarray,
              move_costs: np.ndarray, turns: np.ndarray, turn_weight: np.ndarray, min_gain: float) -> float:
    """One sweep of `_dp_window` windows of `steps` steps over one UAV's path, each kept only
    when its exact gain (self-overlaps and footprints counted as `planner.success` counts them)
    beats the window's and its cost fits the range and its time-priced cost `time_budget`
    (`_improve_uav`): the penalty is raised by bisection until they do (`_fitting_window`).
    Changes the path and `counts` in place; the gain."""
    spent = 0
    for i in range(1, n_poses):
        spent += move_costs[path[i, 2]]
    timed = _span_units(path, 1, n_poses - 1, n_poses, move_costs, turns)
    out = np.empty((steps, 3), dtype=np.int64)
    spare = np.empty((steps, 3), dtype=np.int64)
    total = 0.0
    a = 0
    while a + steps < n_poses - 1:
        old_cost = 0
        old_gain = 0.0
        for i in range(a + 1, a + steps + 1):
            old_cost += move_costs[path[i, 2]]
        for i in range(a + steps - 1, a, -1):
            old_gain += read_footprint(counts, base, qpow, pc, path[i, 0], path[i, 1], radius, -1)
        old_timed = _span_units(path, a + 1, a + steps, n_poses, move_costs, turns)
        room = budget - spent + old_cost
        found = _fitting_window(path, a, steps, room, time_budget - timed + old_timed, counts, base, qpow, pc, radius,
                                others, blocked, successors, allowed, dx, dy, move_costs, turns, turn_weight, out,
                                spare, old_gain + min_gain)
        gain = 0.0
        cost = 0
        if found:
            for i in range(steps):
                cost += move_costs[out[i, 2]]
            for i in range(steps - 1):
                gain += read_footprint(counts, base, qpow, pc, out[i, 0], out[i, 1], radius, 1)
            for i in range(steps - 2, -1, -1):
                read_footprint(counts, base, qpow, pc, out[i, 0], out[i, 1], radius, -1)
        better = found and gain > old_gain + min_gain
        if better:
            for i in range(steps):
                path[a + 1 + i, 0] = out[i, 0]
                path[a + 1 + i, 1] = out[i, 1]
                path[a + 1 + i, 2] = out[i, 2]
            spent += cost - old_cost
            timed += _span_units(path, a + 1, a + steps, n_poses, move_costs, turns) - old_timed
            total += gain - old_gain
        for i in range(a + 1, a + steps):
            read_footprint(counts, base, qpow, pc, path[i, 0], path[i, 1], radius, 1)
        a += stride
    return total


@njit
def _improve_uav(path: np.ndarray, n_poses: int, budget: int, time_budget: int, window: int, stride: int,
                 extra: int, counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float, radius: int,
                 others: np.ndarray, blocked: np.ndarray, successors: np.ndarray, allowed: np.ndarray,
                 table: np.ndarray, dx: np.ndarray, dy: np.ndarray, move_costs: np.ndarray, turns: np.ndarray,
                 min_gain: float) -> tuple[float, int]:
    """One sweep of windows over one UAV's path (poses path[:n_poses], rows x, y, heading, its
    readings counted in `counts`); the path, its length and `counts` change in place. Returns
    the gain and the new number of poses. `budget`: range less reserve, in move-cost units;
    `time_budget`: the most its time-priced cost (its moves, and `turns[(h' - h) mod 8]` at each
    pose between two moves, `_span_units`) may be (`budget` with `turns` all 0: no other bound)."""
    spent = 0
    for i in range(1, n_poses):
        spent += move_costs[path[i, 2]]
    timed = _span_units(path, 1, n_poses - 1, n_poses, move_costs, turns)
    out = np.empty((window + extra + 1, 3), dtype=np.int64)
    total = 0.0
    a = 0
    while a < n_poses - 1:
        tail = a + window >= n_poses - 1
        steps = n_poses - 1 - a if tail else window
        old_cost = 0
        old_gain = 0.0
        for i in range(a + 1, a + steps + 1):
            old_cost += move_costs[path[i, 2]]
        for i in range(a + steps, a, -1):
            old_gain += read_footprint(counts, base, qpow, pc, path[i, 0], path[i, 1], radius, -1)
        old_timed = _span_units(path, a + 1, a + steps, n_poses, move_costs, turns)
        max_steps = min(steps + extra, path.shape[0] - 1 - a)
        gain, n = _best_window(path, a, steps, tail, max_steps, budget - spent + old_cost,
                               time_budget - timed + old_timed, counts, base, qpow, pc, radius, others, blocked,
                               successors, allowed, table, dx, dy, move_costs, turns, out)
        better = n > 0 and gain > old_gain + min_gain
        if better:
            new_cost = 0
            for i in range(n):
                path[a + 1 + i, 0] = out[i, 0]
                path[a + 1 + i, 1] = out[i, 1]
                path[a + 1 + i, 2] = out[i, 2]
                new_cost += move_costs[out[i, 2]]
            spent += new_cost - old_cost
            total += gain - old_gain
            if tail:
                n_poses = a + 1 + n
            timed += _span_units(path, a + 1, a + n, n_poses, move_costs, turns) - old_timed
        for i in range(a + 1, a + 1 + (n if better else steps)):
            read_footprint(counts, base, qpow, pc, path[i, 0], path[i, 1], radius, 1)
        if tail:
            break
        a += stride
    return total, n_poses


def _others(paths: np.ndarray, lengths: np.ndarray, i: int) -> np.ndarray:
    """Every UAV's cells but UAV i's by step (-1 once landed), as the kernels take them."""
    others = np.delete(paths[:, :, :2], i, axis=0)
    for j in range(len(paths) - 1):
        k = j if j < i else j + 1
        others[j, lengths[k]:] = -1
    return others


def _tail_start(path: np.ndarray, n_poses: int, table: np.ndarray, move_costs: np.ndarray) -> int:
    """The first pose from which the rest of the path is a lowest-cost way home."""
    rest = 0
    start = n_poses - 1
    for i in range(n_poses - 1, 0, -1):
        rest += int(move_costs[path[i, 2]])
        x, y, h = path[i - 1]
        if int(table[h, x, y]) != rest:
            break
        start = i - 1
    return start


@dataclass(frozen=True)
class _Budgets:
    """What one UAV's path may cost, as the kernels take it: `units` of range (move costs),
    `time_units` of its time-priced cost (moves and `turns`, the stops taken off), and
    `turn_weight`, a turn's units per diagonal move's extra units (`_fitting_window`)."""

    units: int
    time_units: int
    turns: np.ndarray
    turn_weight: np.ndarray


def _budgets(u: UavPlan, spec: UavSpec | None, reserve_units: int, costs: MoveCosts) -> _Budgets:
    """UAV `u`'s budgets: its range less the reserve; with a time pricing (`spec.time_pricing`)
    also what that range buys in time-priced units less the stops, or what its path costs so
    now when that is more (the improvement never makes it cost more than DTSCS's path did);
    without one, the range again with no turn charged, the same bound twice."""
    units = u.range_units - reserve_units
    pricing = None if spec is None else spec.time_pricing
    if pricing is None:
        zero = np.zeros(8, dtype=np.int64)
        return _Budgets(units, units, zero, np.zeros(8, dtype=np.float64))
    now = pricing.path_units([p.heading for p in u.trajectory[1:]], costs) - pricing.stop_units
    time_units = max(pricing.budget_units(units) - pricing.stop_units, now)
    extra = costs.diagonal - costs.straight
    turns = pricing.turn_array
    return _Budgets(units, time_units, turns, turns / float(extra if extra > 0 else costs.straight))


def improve_plan(plan: Plan, scenario: Scenario, oc: OrientationConstraint, reserve_units: int = 0, seed: int = 0,
                 settings: ImproveSettings | None = None, tables: dict[int, np.ndarray] | None = None) -> Plan:
    """`plan` (a closed DTSCS plan of `scenario` under `oc`) with its windows re-solved in rounds
    until none gains: expected finds never fall, every safety invariant holds, and a UAV whose
    spec has a time pricing (`UavSpec.time_pricing`) keeps its path's time-priced cost within
    what its range buys, or within its DTSCS path's when that is more. `tables[uav_id]` are the
    UAVs' return tables (computed when not given); `seed` replays the simulated readings of the
    new paths (`planner.sensor_noise`)."""
    settings = settings or ImproveSettings()
    costs: MoveCosts = scenario.move_costs
    shape = scenario.search_map.shape
    blocked = np.ascontiguousarray(scenario.search_map.no_fly, dtype=np.bool_)
    sensor = scenario.sensor
    q = 1.0 - sensor.pc
    before = np.zeros(shape) if scenario.looks_before is None else np.asarray(scenario.looks_before, dtype=float)
    base = np.where(blocked, 0.0, scenario.success_prior) * q ** before
    qpow = q ** np.arange(MAX_LOOKS + 1, dtype=np.float64)
    successors = oc.successors
    allowed = np.array(oc.allowed, dtype=np.bool_)
    window = settings.window(oc.branching)
    by_heading = costs.by_heading
    specs = {s.uav_id: s for s in scenario.uavs}
    tables = dict(tables or {})
    for u in plan.uavs:
        if u.uav_id not in tables:
            tables[u.uav_id] = return_table(blocked, u.airport, oc, costs)

    most = max(len(u.trajectory) for u in plan.uavs) + settings.extra * (settings.rounds + 1) + 1
    longest = max(u.range_units // costs.cheapest + 1 for u in plan.uavs)
    capacity = max(most, min(longest, most + settings.extra * 64))
    if settings.response is not None and settings.response.rounds > 0:
        capacity = max(capacity, longest)
    paths = np.full((len(plan.uavs), capacity, 3), -1, dtype=np.int64)
    lengths = np.zeros(len(plan.uavs), dtype=np.int64)
    for i, u in enumerate(plan.uavs):
        rows = [(p.x, p.y, p.heading) for p in u.trajectory]
        paths[i, : len(rows)] = rows
        lengths[i] = len(rows)
    original = paths.copy()
    budgets = [_budgets(u, specs.get(u.uav_id), reserve_units, costs) for u in plan.uavs]
    counts = np.zeros(shape, dtype=np.int64)
    for i in range(len(plan.uavs)):
        for x, y, _ in paths[i, : lengths[i]]:
            read_footprint(counts, base, qpow, sensor.pc, int(x), int(y), sensor.footprint_radius, 1)

    response = settings.response or ResponseSettings(rounds=0)
    # the long windows after a tube's new path mostly bisect penalties for walks the range cannot
    # pay for: they are left out for those UAVs (on missions/large.geojson +1.5 % for 15 s of CPU)
    in_tubes = [response.rounds > 0 and in_tube(paths[i], budgets[i].units, tables[u.uav_id], by_heading, response)
                for i, u in enumerate(plan.uavs)]
    tubed = [False] * len(plan.uavs)
    rungs: list[int | None] = [None] * len(plan.uavs)
    # a UAV's response depends only on the other paths and its own: when no path changed since
    # its last one, it would find the same walk again (`changes` counts the paths changed)
    changes = 0
    answered = [-1] * len(plan.uavs)
    for _ in range(response.rounds):
        gained = 0.0
        for i, u in enumerate(plan.uavs):
            if answered[i] == changes:
                continue
            b = budgets[i]
            gain, n, rungs[i] = respond(paths[i], int(lengths[i]), b.units, b.time_units, counts, base, qpow,
                                        sensor.pc, sensor.footprint_radius, _others(paths, lengths, i), blocked,
                                        successors, allowed, tables[u.uav_id], HEADING_DX, HEADING_DY, by_heading,
                                        b.turns, response, rungs[i])
            lengths[i] = n
            gained += gain
            changes += 1 if gain > 0.0 else 0
            tubed[i] = tubed[i] or (in_tubes[i] and gain > 0.0)
            answered[i] = changes
        if gained <= MIN_GAIN:
            break
    for _ in range(settings.rounds):
        gained = 0.0
        for i, u in enumerate(plan.uavs):
            others = _others(paths, lengths, i)
            b = budgets[i]
            if settings.dp_steps >= 2 and not tubed[i]:
                gained += _dp_sweep(paths[i], int(lengths[i]), b.units, b.time_units, settings.dp_steps,
                                    settings.dp_stride, counts, base, qpow, sensor.pc, sensor.footprint_radius, others,
                                    blocked, successors, allowed, HEADING_DX, HEADING_DY, by_heading, b.turns,
                                    b.turn_weight, MIN_GAIN)
            gain, n = _improve_uav(paths[i], int(lengths[i]), b.units, b.time_units, window, settings.stride,
                                   settings.extra, counts, base, qpow, sensor.pc, sensor.footprint_radius, others,
                                   blocked, successors, allowed, tables[u.uav_id], HEADING_DX, HEADING_DY, by_heading,
                                   b.turns, MIN_GAIN)
            lengths[i] = n
            gained += gain
        if gained <= MIN_GAIN:
            break

    uavs = []
    for i, u in enumerate(plan.uavs):
        n = int(lengths[i])
        if n == len(u.trajectory) and np.array_equal(paths[i, :n], original[i, :n]):
            uavs.append(u)
            continue
        start = _tail_start(paths[i], n, tables[u.uav_id], by_heading)
        start = max(start, 0)
        points = [TrajectoryPoint(s, int(x), int(y), int(h), Stage.RETURN if s > start else Stage.SEARCH)
                  for s, (x, y, h) in enumerate(paths[i, :n].tolist())]
        used = int(sum(by_heading[points[s].heading] for s in range(1, n)))
        uavs.append(replace(u, trajectory=points, search_steps=start, return_steps=n - 1 - start,
                            return_step=start, tracking_efficiency=None, used_units=used))
    return _with_outcomes(plan, scenario, uavs, seed)


def _with_outcomes(plan: Plan, scenario: Scenario, uavs: list[UavPlan], seed: int) -> Plan:
    """`plan` flying `uavs`: its expected finds, and its simulated finds and false alarms replayed
    from the readings of seed `seed` (first report in a target's cell finds it)."""
    trajectories = {u.uav_id: [(p.step, p.x, p.y) for p in u.trajectory] for u in uavs}
    shape = scenario.search_map.shape
    radius = scenario.sensor.footprint_radius
    looks = plan_looks(trajectories, radius, shape)
    success = success_of_looks(scenario.success_prior, ~scenario.search_map.no_fly, scenario.sensor.pc, looks,
                               trajectories, scenario.looks_before)
    targets = scenario.target_grid()
    visits: dict[tuple[int, int, int], int] = {}
    found: dict[tuple[int, int], tuple[int, int]] = {}
    false_alarms = 0
    for step, uid, x, y in looks:
        visit = visits.get((uid, x, y), 0)
        visits[(uid, x, y)] = visit + 1
        draw = reading_draw(seed, uid, x, y, visit)
        if targets[x, y]:
            if draw < scenario.sensor.pc and (x, y) not in found:
                found[(x, y)] = (step, uid)
        elif draw < scenario.sensor.pf:
            false_alarms += 1
    outcomes = []
    for tx, ty in scenario.targets:
        first = found.get((int(tx), int(ty)))
        outcomes.append(TargetOutcome(int(tx), int(ty), *(first or (None, None))))
    settings = {**plan.settings, "improved": True}
    return replace(plan, uavs=uavs, targets=outcomes, false_alarms=false_alarms, settings=settings, success=success)

