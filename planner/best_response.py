"""One UAV's best whole path against every other reading of the plan (issue 37, item 3): a walk
from its airport pose back to its airport, re-planned whole, the others' paths fixed.

`planner.improve` re-solves windows of a path between fixed poses; a path whose DTSCS start took
it the wrong way cannot leave its corridor by windows. This move replaces everything after the
airport pose at once. The prize of standing on cell c is what reading its footprint adds given
every other reading of the plan (the other UAVs' paths and this UAV's airport pose at step 0):
`base * (1 - Pc)^n * Pc` summed over the footprint (`read_footprint`, `planner.improve`'s too).

**The programme.** Over (step, cell, heading), time-indexed, from the airport pose: a move goes
from a pose to a successor heading the OC allows, into the grid, off no-fly cells, off every cell
another UAV holds at that step (exact: the programme knows the step), and only where the way home
still fits (`tables`, the lowest cost home from each pose: the cost so far plus it within the
range less reserve, and within the time budget with turns priced). A walk may end on the airport
at any step. The value of a state is the best sum of prizes less mu times the path's cost (its
moves, and, for a copter priced by its time where its time can bind, its turn charges,
`planner.time_pricing`): a Lagrangian relaxation of the metre (and time) budget. Each state keeps
its best penalised path's cost and turn charges, and that cost decides whether the way home
still fits, so every end on the airport fits both budgets; the path a state drops may have been
the cheaper one, so this is exact only where every move costs the same and no turn is priced
(then at mu = 0 every step's end is the best prize sum of any closed walk of that many steps,
which the tests check against every walk). For a given number of steps a larger mu trades
prizes for fewer diagonals (and corners), which leaves range for more steps: mu runs over a
ladder, 0 and then `scale * 2^(k - 2)` for k = 0 .. `ResponseSettings.ladder - 1` (`scale` the
mean prize over the dearest move), and every step's best end at every rung is a candidate. A
UAV's later responses run only the rung whose walk scored best and its two neighbours.
A UAV is asked again only when some path changed since its last response (`planner.improve`).

**Reading a cell twice** adds less than the programme counts (it sums first readings): each
candidate is scored exactly from `counts` (self-overlaps and footprints as `planner.success`
counts them), and the best kept. Then the prizes of the cells the best walk read m > 1 times are
lowered to the mean of its m readings' gains, (1 - (1 - Pc)^m) / (m Pc) of the first, and the
programme run again (`ResponseSettings.passes`); the best walk over all passes wins.

The new path replaces the old only when its exact gain beats the old path's by `MIN_GAIN` and it
keeps every invariant (`_walk_is_safe`, checked again apart from the programme): the improvement's
expected finds never fall.

Cost: O(steps x cells x 8 x OC branching) per run over the box of cells the UAV can reach and come
back from (`_walk_dp` pulls each state from its predecessors, its target's checks made once: half
the CPU of pushing each state to its successors, the same plans bit for bit), and memory of one
byte per (step, cell, heading) for the parents.

**Tubes.** A UAV whose programme over its box would exceed `ResponseSettings.states` states
(`missions/large.geojson`'s 8 UAVs of 1150 steps over 400 x 400 cells: 1.5 billion) runs it in a
tube instead: the states of step t are only the side x side cells around the pose its current
path holds at step t (past the path's end, its airport), side the widest odd number
whose (steps + 1) x side^2 x 8 states fit `ResponseSettings.tube_states` (below `MIN_TUBE` cells
the UAV is left to the windows). The new walk may stray side / 2 cells from where the old one was
at each step: more than a window re-solves, less than the whole programme; the same prizes,
ladder, passes and checks."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.config import njit

__all__ = ["ResponseSettings", "backtrace", "in_tube", "read_footprint", "respond"]

#: Gains below this (expected targets) are not worth a change (as `planner.improve.MIN_GAIN`).
MIN_GAIN = 1e-9
#: The narrowest tube (cells across) worth a programme: narrower ones are the windows' work.
MIN_TUBE = 9


@dataclass(frozen=True)
class ResponseSettings:
    """`rounds`: best-response sweeps over every UAV at most (fewer when none gains; 0: none);
    `passes`: runs of the programme per response (the first with first-reading prizes, each next
    with the prizes of cells the best walk re-read lowered); `ladder`: rungs of mu above 0
    (module docstring); `states`: the most (step, cell, heading) states one programme over the
    UAV's box may have; above it the programme runs in a tube of at most `tube_states` states
    (0: none, the UAV is left to the windows)."""

    rounds: int = 3
    passes: int = 2
    ladder: int = 9
    states: int = 60_000_000
    tube_states: int = 5_000_000

    def __post_init__(self) -> None:
        if self.rounds < 0 or self.passes < 1 or self.ladder < 0 or self.states < 1 or self.tube_states < 0:
            raise ValueError(f"bad best-response settings {self}")


@njit
def read_footprint(counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float, x: int, y: int, radius: int,
          sign: int) -> float:
    """Add (sign 1) or take back (sign -1) one reading of cell (x, y)'s footprint, or neither
    (sign 0); the gain of the reading (as it was when added, or would be)."""
    nx, ny = counts.shape
    gain = 0.0
    for cx in range(x - radius, x + radius + 1):
        for cy in range(y - radius, y + radius + 1):
            if cx < 0 or cy < 0 or cx >= nx or cy >= ny:
                continue
            if sign < 0:
                counts[cx, cy] -= 1
            n = min(counts[cx, cy], qpow.shape[0] - 1)
            gain += base[cx, cy] * qpow[n] * pc
            if sign > 0:
                counts[cx, cy] += 1
    return gain


@njit
def _walk_gain(walk: np.ndarray, n: int, counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float,
               radius: int) -> float:
    """The exact expected finds walk[:n]'s readings add to `counts` (left as it was)."""
    gain = 0.0
    for i in range(n):
        gain += read_footprint(counts, base, qpow, pc, walk[i, 0], walk[i, 1], radius, 1)
    for i in range(n - 1, -1, -1):
        read_footprint(counts, base, qpow, pc, walk[i, 0], walk[i, 1], radius, -1)
    return gain


@njit
def _prizes(counts: np.ndarray, base: np.ndarray, qpow: np.ndarray, pc: float, radius: int, blocked: np.ndarray,
            factor: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
    """Each cell's prize over the box [x0, x1] x [y0, y1]: its footprint's next readings' gains,
    each base cell's times `factor` (1: a first reading)."""
    nx, ny = counts.shape
    prize = np.zeros((x1 - x0 + 1, y1 - y0 + 1), dtype=np.float64)
    for x in range(x0, x1 + 1):
        for y in range(y0, y1 + 1):
            if blocked[x, y]:
                continue
            p = 0.0
            for cx in range(x - radius, x + radius + 1):
                for cy in range(y - radius, y + radius + 1):
                    if 0 <= cx < nx and 0 <= cy < ny:
                        p += base[cx, cy] * qpow[min(counts[cx, cy], qpow.shape[0] - 1)] * pc * factor[cx, cy]
            prize[x - x0, y - y0] = p
    return prize


@njit
def backtrace(parent: np.ndarray, steps: int, x: int, y: int, h: int, ox: np.ndarray, oy: np.ndarray,
              dx: np.ndarray, dy: np.ndarray, out: np.ndarray) -> None:
    """The walk of `steps` poses a programme's parents (`parent[t, i, j, h]`: the heading before
    pose t, cells from (ox[t], oy[t])) lead back from pose (x, y, h) at step `steps`: rows x, y,
    heading into `out[:steps]` (`_best_end` and `planner.improve._dp_window`; a fixed box has
    the same origin at every step)."""
    for t in range(steps, 0, -1):
        out[t - 1, 0] = x
        out[t - 1, 1] = y
        out[t - 1, 2] = h
        p = parent[t, x - ox[t], y - oy[t], h]
        x -= dx[h]
        y -= dy[h]
        h = p


@njit
def _walk_dp(sx: int, sy: int, sh: int, steps: int, budget: int, time_budget: int, prize: np.ndarray, x0: int,
             y0: int, ox: np.ndarray, oy: np.ndarray, blocked: np.ndarray, others: np.ndarray, home: np.ndarray,
             successors: np.ndarray, dx: np.ndarray, dy: np.ndarray, move_costs: np.ndarray, turns: np.ndarray,
             mu: float, turn_weight: float, parent: np.ndarray, end_value: np.ndarray, end_cost: np.ndarray,
             end_turns: np.ndarray) -> None:
    """The programme (module docstring) at penalty `mu` per unit of cost (moves, and
    `turn_weight` times each turn's charge), over the box of `prize` from (x0, y0): the states of
    step t are the `parent.shape[1]` x `parent.shape[2]` cells from (ox[t], oy[t]) (grid cells in
    the box: the whole box at every step, or a tube). Writes the parents (`parent[t, i, j, h]`:
    the heading before pose t) and, per step t and heading h, the best walk's penalised value,
    cost and turn charges ending on the airport (sx, sy) there (`end_value` -inf where none).

    Each state pulls from its predecessors (the one cell a move g comes from, each heading h the
    OC lets turn into g, in increasing h; the first best kept): the plans of pushing every state
    to its successors, bit for bit, with each target's checks made once and written once. Only
    the cells within one move of those reached at the step before are visited."""
    bw, bh = prize.shape
    tw, th = parent.shape[1], parent.shape[2]
    width = successors.shape[1]
    preds = np.full((8, 8), -1, dtype=np.int64)
    npred = 0
    for g in range(8):
        k = 0
        for h in range(8):
            for m in range(width):
                if successors[h, m] < 0:
                    break
                if successors[h, m] == g:
                    preds[g, k] = h
                    k += 1
                    break
        npred = max(npred, k)
    stop = np.zeros((bw, bh), dtype=np.int64)
    for i in range(bw):
        for j in range(bh):
            if blocked[x0 + i, y0 + j]:
                stop[i, j] = 1
    # a move's penalty and turn charge by (g, h): none for the turn at the airport pose (step 0)
    pen = np.empty((2, 8, 8))
    turn = np.zeros((2, 8, 8), dtype=np.int64)
    for g in range(8):
        for h in range(8):
            pen[0, g, h] = mu * (move_costs[g] + turn_weight * 0)
            pen[1, g, h] = mu * (move_costs[g] + turn_weight * turns[(g - h) & 7])
            turn[1, g, h] = turns[(g - h) & 7]
    value = np.full((2, tw, th, 8), -np.inf)
    cost = np.zeros((2, tw, th, 8), dtype=np.int32)  # int32 as the costs: a cost near 2^31 never fits
    turned = np.zeros((2, tw, th, 8), dtype=np.int32)
    end_value[:] = -np.inf
    value[0, sx - ox[0], sy - oy[0], sh] = 0.0
    # the cells reached at step t lie in [i0, i1] x [j0, j1] (grid cells); the states of step t
    # outside it are stale
    i0, i1, j0, j1 = sx, sx, sy, sy
    for t in range(steps):
        cur = t & 1
        nxt = 1 - cur
        late = 1 if t >= 1 else 0
        ax = ox[t + 1]
        ay = oy[t + 1]
        r0 = max(ax, i0 - 1)
        r1 = min(ax + tw - 1, i1 + 1)
        c0 = max(ay, j0 - 1)
        c1 = min(ay + th - 1, j1 + 1)
        if t + 1 < others.shape[1]:
            for u in range(others.shape[0]):
                px = others[u, t + 1, 0] - x0
                py = others[u, t + 1, 1] - y0
                if others[u, t + 1, 0] >= 0 and 0 <= px < bw and 0 <= py < bh:
                    stop[px, py] += 1
        n0, n1, m0, m1 = ax + tw, -1, ay + th, -1
        for qx in range(r0, r1 + 1):
            for qy in range(c0, c1 + 1):
                qi = qx - ax
                qj = qy - ay
                if stop[qx - x0, qy - y0] > 0:
                    for g in range(8):
                        value[nxt, qi, qj, g] = -np.inf
                    continue
                p = prize[qx - x0, qy - y0]
                hit = False
                for g in range(8):
                    best = -np.inf
                    px = qx - dx[g]
                    py = qy - dy[g]
                    if i0 <= px <= i1 and j0 <= py <= j1:
                        i = px - ox[t]
                        j = py - oy[t]
                        back = move_costs[g] + home[g, qx, qy]
                        room_g = budget - back
                        troom_g = time_budget - back
                        bc = 0
                        bt = 0
                        bp = -1
                        for k in range(npred):
                            h = preds[g, k]
                            if h < 0:
                                break
                            c_here = cost[cur, i, j, h]
                            t_here = turned[cur, i, j, h] + turn[late, g, h]
                            w = value[cur, i, j, h] + p - pen[late, g, h]
                            if c_here <= room_g and c_here + t_here <= troom_g and w > best:
                                best = w
                                bc = c_here
                                bt = t_here
                                bp = h
                        if bp >= 0:
                            cost[nxt, qi, qj, g] = bc + move_costs[g]
                            turned[nxt, qi, qj, g] = bt
                            parent[t + 1, qi, qj, g] = bp
                            hit = True
                    value[nxt, qi, qj, g] = best
                if hit:
                    n0 = min(n0, qx)
                    n1 = max(n1, qx)
                    m0 = min(m0, qy)
                    m1 = max(m1, qy)
        if t + 1 < others.shape[1]:
            for u in range(others.shape[0]):
                px = others[u, t + 1, 0] - x0
                py = others[u, t + 1, 1] - y0
                if others[u, t + 1, 0] >= 0 and 0 <= px < bw and 0 <= py < bh:
                    stop[px, py] -= 1
        if r0 <= sx <= r1 and c0 <= sy <= c1:
            for h in range(8):
                end_value[t + 1, h] = value[nxt, sx - ax, sy - ay, h]
                end_cost[t + 1, h] = cost[nxt, sx - ax, sy - ay, h]
                end_turns[t + 1, h] = turned[nxt, sx - ax, sy - ay, h]
        if n1 < 0:
            break
        i0, i1, j0, j1 = n0, n1, m0, m1


@njit
def _best_end(sx: int, sy: int, ox: np.ndarray, oy: np.ndarray, budget: int, time_budget: int, parent: np.ndarray,
              end_value: np.ndarray, end_cost: np.ndarray, end_turns: np.ndarray, counts: np.ndarray,
              base: np.ndarray, qpow: np.ndarray, pc: float, radius: int, dx: np.ndarray, dy: np.ndarray,
              out: np.ndarray, scratch: np.ndarray) -> tuple[float, int]:
    """The walks `_walk_dp` ends on the airport (sx, sy) that fit both budgets, the best
    penalised one per step, each scored exactly: the best one's gain and number of poses (in
    `out`), (-1, 0) when none fits."""
    steps = end_value.shape[0] - 1
    best = -1.0
    best_n = 0
    for t in range(1, steps + 1):
        pick = -1
        for h in range(8):
            if end_value[t, h] == -np.inf or end_cost[t, h] > budget \
                    or end_cost[t, h] + end_turns[t, h] > time_budget:
                continue
            if pick < 0 or end_value[t, h] > end_value[t, pick]:
                pick = h
        if pick < 0:
            continue
        backtrace(parent, t, sx, sy, pick, ox, oy, dx, dy, scratch)
        gain = _walk_gain(scratch, t, counts, base, qpow, pc, radius)
        if gain > best:
            best = gain
            best_n = t
            out[:t] = scratch[:t]
    return best, best_n


@njit
def _multiplicity_factor(walk: np.ndarray, n: int, shape_x: int, shape_y: int, radius: int, q: float) -> np.ndarray:
    """Per cell, the mean gain of the walk's m readings of it over a first reading's,
    (1 - q^m) / (m (1 - q)) (1 where m <= 1)."""
    m = np.zeros((shape_x, shape_y), dtype=np.int64)
    for k in range(n):
        for cx in range(walk[k, 0] - radius, walk[k, 0] + radius + 1):
            for cy in range(walk[k, 1] - radius, walk[k, 1] + radius + 1):
                if 0 <= cx < shape_x and 0 <= cy < shape_y:
                    m[cx, cy] += 1
    factor = np.ones((shape_x, shape_y), dtype=np.float64)
    for cx in range(shape_x):
        for cy in range(shape_y):
            if m[cx, cy] > 1:
                factor[cx, cy] = (1.0 - q ** m[cx, cy]) / (m[cx, cy] * (1.0 - q))
    return factor


def _reach_box(start: tuple[int, int], home: np.ndarray, budget: int,
               cheapest: int) -> tuple[int, int, int, int] | None:
    """The box of cells a walk from `start` can reach and come home from within `budget`: the
    Chebyshev distance out, at the cheapest move, plus the lowest cost home."""
    nx, ny = home.shape[1:]
    xs = np.arange(nx)[:, None]
    ys = np.arange(ny)[None, :]
    out = np.maximum(np.abs(xs - start[0]), np.abs(ys - start[1])) * cheapest
    ok = out + home.min(axis=0).astype(np.int64) <= budget
    if not ok.any():
        return None
    cx = np.flatnonzero(ok.any(axis=1))
    cy = np.flatnonzero(ok.any(axis=0))
    return int(cx[0]), int(cy[0]), int(cx[-1]), int(cy[-1])


def _programme(path: np.ndarray, budget: int, home: np.ndarray, move_costs: np.ndarray, settings: ResponseSettings
               ) -> tuple[int, tuple[int, int, int, int] | None, int]:
    """(steps, box, side) of a UAV's programme: its steps, the box it can reach and come home
    from (None: none), and -1 when the programme over the box fits `settings.states`, else the
    side of its tube (0: none fits)."""
    cheapest = int(move_costs.min())
    steps = min(budget // cheapest, path.shape[0] - 1)
    box = _reach_box((int(path[0, 0]), int(path[0, 1])), home, budget, cheapest) if steps >= 1 else None
    if box is None:
        return steps, None, 0
    x0, y0, x1, y1 = box
    if (steps + 1) * (x1 - x0 + 1) * (y1 - y0 + 1) * 8 <= settings.states:
        return steps, box, -1
    side = math.isqrt(settings.tube_states // ((steps + 1) * 8))
    side -= 1 - side % 2
    return steps, box, side if side >= MIN_TUBE else 0


def in_tube(path: np.ndarray, budget: int, home: np.ndarray, move_costs: np.ndarray,
            settings: ResponseSettings) -> bool:
    """Whether `respond` answers the UAV of `path` in a tube (module docstring)."""
    return _programme(path, budget, home, move_costs, settings)[2] > 0


def _tube_origins(path: np.ndarray, n_poses: int, steps: int, tw: int, th: int,
                  box: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Per step t, the first cell of the tw x th tube around the UAV's current pose at step t
    (its last, the airport, past its end), kept inside `box`."""
    x0, y0, x1, y1 = box
    at = np.minimum(np.arange(steps + 1), n_poses - 1)
    ox = np.clip(path[at, 0].astype(np.int64) - tw // 2, x0, x1 - tw + 1)
    oy = np.clip(path[at, 1].astype(np.int64) - th // 2, y0, y1 - th + 1)
    return ox, oy


def _walk_is_safe(walk: np.ndarray, n: int, start: tuple[int, int, int], budget: int, time_budget: int,
                  blocked: np.ndarray, others: np.ndarray, allowed: np.ndarray, dx: np.ndarray, dy: np.ndarray,
                  move_costs: np.ndarray, turns: np.ndarray) -> bool:
    """walk[:n] after the airport pose `start`: OC moves in the grid, off no-fly cells and the
    others' cells at each step, home at the end, its cost within `budget` and its time-priced
    cost (moves and turns at its inner poses) within `time_budget`."""
    nx, ny = blocked.shape
    if n < 1 or (int(walk[n - 1, 0]), int(walk[n - 1, 1])) != start[:2]:
        return False
    x, y, h = start
    cost = 0
    timed = 0
    for s in range(n):
        wx, wy, g = (int(v) for v in walk[s])
        if not allowed[h, g] or (wx - x, wy - y) != (int(dx[g]), int(dy[g])):
            return False
        if not (0 <= wx < nx and 0 <= wy < ny) or blocked[wx, wy]:
            return False
        if s + 1 < others.shape[1] and np.any((others[:, s + 1, 0] == wx) & (others[:, s + 1, 1] == wy)):
            return False
        cost += int(move_costs[g])
        timed += int(move_costs[g]) + (int(turns[(g - h) & 7]) if s >= 1 else 0)
        x, y, h = wx, wy, g
    return cost <= budget and timed <= time_budget


def respond(path: np.ndarray, n_poses: int, budget: int, time_budget: int, counts: np.ndarray, base: np.ndarray,
            qpow: np.ndarray, pc: float, radius: int, others: np.ndarray, blocked: np.ndarray,
            successors: np.ndarray, allowed: np.ndarray, home: np.ndarray, dx: np.ndarray, dy: np.ndarray,
            move_costs: np.ndarray, turns: np.ndarray, settings: ResponseSettings,
            hint: int | None = None) -> tuple[float, int, int | None]:
    """UAV's best response: `path[:n_poses]` (rows x, y, heading; its readings counted in
    `counts`) replaced whole by the best walk the programme finds from its airport pose home,
    when that gains more than `MIN_GAIN`; `path`, `counts` change in place. `budget`: range less
    reserve (move-cost units); `time_budget`: the most its time-priced cost may be (moves, and
    `turns` at inner poses); `others[u, step]` the other UAVs' cells (-1 when not flying);
    `home` its return table. `hint`: the rung of mu's ladder whose walk scored best last time
    (None: the whole ladder; else only it and its neighbours). Returns the gain (0.0 when
    unchanged), the number of poses, and the rung for the next call."""
    steps, box, side = _programme(path, budget, home, move_costs, settings)
    if box is None or side == 0:
        return 0.0, n_poses, hint
    start = (int(path[0, 0]), int(path[0, 1]), int(path[0, 2]))
    x0, y0, x1, y1 = box
    tw, th = x1 - x0 + 1, y1 - y0 + 1
    ox, oy = np.full(steps + 1, x0, dtype=np.int64), np.full(steps + 1, y0, dtype=np.int64)
    if side > 0:
        tw, th = min(side, tw), min(side, th)
        ox, oy = _tube_origins(path, n_poses, steps, tw, th, box)
    old_gain = 0.0
    for i in range(n_poses - 1, 0, -1):
        old_gain += read_footprint(counts, base, qpow, pc, int(path[i, 0]), int(path[i, 1]), radius, -1)
    parent = np.zeros((steps + 1, tw, th, 8), dtype=np.int8)
    end_value = np.empty((steps + 1, 8))
    end_cost = np.zeros((steps + 1, 8), dtype=np.int64)
    end_turns = np.zeros((steps + 1, 8), dtype=np.int64)
    best = np.zeros((steps, 3), dtype=np.int64)
    walk = np.zeros((steps, 3), dtype=np.int64)
    scratch = np.zeros((steps, 3), dtype=np.int64)
    # turns priced in the programme only where the time budget can bind: a path within the
    # metres whose every inner pose takes the dearest turn still fits, or not
    turn_weight = 1.0 if time_budget < budget + max(steps - 1, 0) * int(turns.max()) else 0.0
    factor = np.ones(counts.shape)
    best_gain, best_n, best_rung = -1.0, 0, hint

    def run(rung: int, scale: float, prize: np.ndarray) -> None:
        """The programme at the rung's mu, its best walk kept when it scores best so far."""
        nonlocal best_gain, best_n, best_rung
        mu = 0.0 if rung < 0 else scale * 2.0 ** (rung - 2)
        _walk_dp(start[0], start[1], start[2], steps, budget, time_budget, prize, x0, y0, ox, oy, blocked, others,
                 home, successors, dx, dy, move_costs, turns, mu, turn_weight, parent, end_value, end_cost, end_turns)
        gain, n = _best_end(start[0], start[1], ox, oy, budget, time_budget, parent, end_value, end_cost, end_turns,
                            counts, base, qpow, pc, radius, dx, dy, walk, scratch)
        if n > 0 and gain > best_gain:
            best_gain, best_n, best_rung = gain, n, rung
            best[:n] = walk[:n]

    ladder = settings.ladder
    for done in range(settings.passes):
        if done > 0:
            if best_n == 0:
                break
            factor = _multiplicity_factor(best, best_n, counts.shape[0], counts.shape[1], radius, 1.0 - pc)
            if factor.min() >= 1.0:
                break
        prize = _prizes(counts, base, qpow, pc, radius, blocked, factor, x0, y0, x1, y1)
        positive = prize[prize > 0]
        if positive.size == 0:
            break
        scale = float(positive.mean()) / float(move_costs.max())
        rungs = range(-1, ladder) if best_rung is None else range(max(-1, best_rung - 1), min(ladder, best_rung + 2))
        for rung in rungs:
            run(rung, scale, prize)
    if best_n == 0 or best_gain <= old_gain + MIN_GAIN or not _walk_is_safe(
            best, best_n, start, budget, time_budget, blocked, others, allowed, dx, dy, move_costs, turns):
        for i in range(1, n_poses):
            read_footprint(counts, base, qpow, pc, int(path[i, 0]), int(path[i, 1]), radius, 1)
        return 0.0, n_poses, best_rung
    path[1:best_n + 1] = best[:best_n]
    path[best_n + 1:] = -1
    for i in range(1, best_n + 1):
        read_footprint(counts, base, qpow, pc, int(path[i, 0]), int(path[i, 1]), radius, 1)
    return best_gain - old_gain, best_n + 1, best_rung
