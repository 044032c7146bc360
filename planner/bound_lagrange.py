"""The `LAGRANGIAN` bound of `planner.bound`: the Lagrangian relaxation of its `HEADINGS` model,
minimised by column generation, with each UAV's part a dynamic programme over (steps, cell,
heading) instead of arcs in an LP, so it fits areas whose `HEADINGS` LP has millions of arcs.

The `HEADINGS` LP (`planner.bound`) maximises sum_c sum_k g_ck z_ck + tail_c y_c over one unit
flow per UAV i through its (step, cell, heading) nodes (start pose at step 0, the OC's turns,
never off the grid or into a no-fly cell, landing on the airport at a step >= 1), subject to

    (reads)   sum_k z_ck + y_c <= reads_c(x) + fixed_c     for every cell c,
    (budget)  metres_i(x) <= B_i                            for every UAV i,

with 0 <= z_ck <= 1, y_c >= 0, g_ck = P0 (1 - Pc)^before Pc (1 - Pc)^(k-1) (k = 1..K,
K = `_listed_looks`) and tail_c = P0 (1 - Pc)^before Pc (1 - Pc)^K (looks past K; `_add_gains`
writes the reads row as an equality, which changes nothing: every gain is >= 0). Relaxing the
reads rows with lambda_c >= tail_c and the budget rows with mu_i >= 0 gives, for ANY such
multipliers, an upper bound on the LP's optimum (weak duality), so on every plan:

    L(lambda, mu) = sum_i [ max over walks W of UAV i of ( sum_{poses p of W, step >= 1}
                               sum_{c in footprint(p)} lambda_c  -  mu_i metres(W) )  +  mu_i B_i ]
                    + sum_c [ lambda_c fixed_c + sum_{k=1..K} max(0, g_ck - lambda_c) ]

(the y_c term is 0 once lambda_c >= tail_c, and unbounded below it). A walk's flow polytope is
integral, so min L equals the `HEADINGS` LP's value (Lagrangian duality). fixed_c counts the
footprints read at step 0 on the airports; cells no UAV can read are left out, as the LP has no
row for them. A walk's inner max is a backward DP over (steps left, cell, heading) in
`_best_walk`, over exactly the poses `planner.bound._cell_states` keeps (fit, and
max(t straight, out) + home <= B_i; the forward reach there only drops poses no walk from the
start reaches, here `cheb` <= t does the same for speed): O(T cells 8 branching) per UAV.

`minimise_dual` evaluates L at two starts, every cell worth its first look with metres free
(each UAV as if alone: tight when the UAVs' reaches barely overlap) and the counting bound's
multipliers (a price tau on every read and tau a cell side on metres: L is then about what
`BLOCKS` gives on large areas), then runs column generation (Dantzig-Wolfe; in the dual,
Kelley's cutting planes): the walks the DP found are the columns of a master LP (per UAV a
convex combination of them, its metre row, the cells' concave gains: `_Master`, HiGHS), whose
row duals are the next multipliers, stabilised by Wentges' smoothing towards the best so far.
Every evaluation of L is a valid bound and the smallest is kept (anytime); the master's optimum
is a value the `HEADINGS` LP reaches (a floor: no multipliers give less), and the two meet at
the LP's optimum, which on tiny areas takes a fraction of a second (HiGHS on the LP itself:
tens of seconds on the paper scenario at range 28).

Pure computation, no printing."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from planner.config import njit
from planner.highs_solver import quiet_highs
from planner.motion import HEADING_DX, HEADING_DY, OrientationConstraint
from planner.return_exact import UNREACHABLE

if TYPE_CHECKING:
    from planner.bound import _Uav

#: Work units (one successor looked at in the DP) a second, measured on the 2-core machine
#: (2-5e8 on its own, less with the master LP and a loaded machine): sizes the model to the time.
WORK_PER_SECOND = 1e8

#: Seconds a master LP takes per cell of the grid, estimated from above (0.02-0.06 s on 420 cells,
#: 0.1-0.4 s on 2,500 after 40-170 walks, 2026-12-02).
MASTER_SECONDS_PER_CELL = 1e-4

#: The most bytes the DP's choice table (steps x 8 headings x cells, one byte each) may take.
MAX_CHOICE_BYTES = 600_000_000

#: Wentges' smoothing: L is evaluated at this share of the best multipliers so far plus the rest
#: of the master's duals, which jump about from one iteration to the next.
SMOOTHING = 0.8

#: Evaluations of L the dual wants at least; fewer fit the time and the model is not used.
MIN_ITERATIONS = 8


@njit
def _best_walk(reward: np.ndarray, tmin: np.ndarray, tmax: np.ndarray, successors: np.ndarray,
               dx: np.ndarray, dy: np.ndarray, move_cost: np.ndarray, ax: int, ay: int, heading: int,
               steps: int, choice: np.ndarray, path: np.ndarray) -> tuple[float, int]:
    """The best walk of one UAV under rewards: max over walks from pose (ax, ay, heading) at step
    0, at most `steps` moves along `successors` (the OC), pose (h, x, y) allowed at step t >= 1
    only when tmin[x, y] <= t <= tmax[h, x, y], ending on (ax, ay) at a step >= 1, of
    sum over its poses at steps >= 1 of (reward[x, y] - move_cost[h]) (h the heading it arrived
    with). Returns (that max, -inf when no walk exists; n) and writes the walk's poses after the
    start as path[:n] = (x, y, h). `choice` ((steps + 1, 8, nx, ny) int8) is scratch: per pose,
    0 to land, k + 1 to take successors[h, k], -1 none."""
    nx, ny = reward.shape
    width = successors.shape[1]
    neg = -np.inf
    nxt = np.full((8, nx, ny), neg)
    cur = np.full((8, nx, ny), neg)
    for t in range(steps, -1, -1):
        for h in range(8):
            for x in range(nx):
                for y in range(ny):
                    choice[t, h, x, y] = -1
                    if t == 0:
                        if h != heading or x != ax or y != ay:
                            cur[h, x, y] = neg
                            continue
                    elif t < tmin[x, y] or t > tmax[h, x, y]:
                        cur[h, x, y] = neg
                        continue
                    best = neg
                    arg = -1
                    if t >= 1 and x == ax and y == ay:
                        best = 0.0
                        arg = 0
                    if t < steps:
                        for k in range(width):
                            g = successors[h, k]
                            if g < 0:
                                break
                            qx = x + dx[g]
                            qy = y + dy[g]
                            if qx < 0 or qx >= nx or qy < 0 or qy >= ny:
                                continue
                            v = nxt[g, qx, qy]
                            if v == neg:
                                continue
                            v += reward[qx, qy] - move_cost[g]
                            if v > best:
                                best = v
                                arg = k + 1
                    cur[h, x, y] = best
                    choice[t, h, x, y] = arg
        cur, nxt = nxt, cur
    value = nxt[heading, ax, ay]
    n = 0
    if value == neg:
        return value, 0
    x, y, h = ax, ay, heading
    for t in range(steps + 1):
        a = choice[t, h, x, y]
        if a <= 0:
            break
        g = successors[h, a - 1]
        x += dx[g]
        y += dy[g]
        h = g
        path[n, 0] = x
        path[n, 1] = y
        path[n, 2] = g
        n += 1
    return value, n


@njit
def _box_sum(values: np.ndarray, radius: int, out: np.ndarray) -> None:
    """out[x, y] = the sum of `values` over the in-grid cells of the (2 radius + 1)^2 square
    centred on (x, y): what one reading from (x, y) is worth at prices `values`."""
    nx, ny = values.shape
    for x in range(nx):
        for y in range(ny):
            s = 0.0
            for cx in range(max(x - radius, 0), min(x + radius + 1, nx)):
                for cy in range(max(y - radius, 0), min(y + radius + 1, ny)):
                    s += values[cx, cy]
            out[x, y] = s


@dataclass(frozen=True)
class Walker:
    """One UAV's part of the dual, prepared once: its start pose, its step and metre budget and
    the step window of every pose (`tmin` (nx, ny), `tmax` (8, nx, ny); `tmax` -1 where no walk
    may be), and the scratch the DP writes."""

    airport: tuple[int, int]
    heading: int
    budget: int
    steps: int
    tmin: np.ndarray
    tmax: np.ndarray
    choice: np.ndarray
    path: np.ndarray


def walker(u: _Uav, no_fly: np.ndarray, straight: int, choice: np.ndarray | None = None) -> Walker:
    """`u`'s DP (`choice`: scratch of at least (u.steps + 1, 8, nx, ny) int8, shared among UAVs):
    pose (h, x, y) at step t >= 1 allowed when it is free, its ways home and out are finite,
    max(t straight, out) + home <= budget (`planner.bound._cell_states`' test) and the airport
    is at most t 8-connected steps away."""
    fit = (u.home < UNREACHABLE) & (u.out < UNREACHABLE) & ~no_fly[None] & (u.out + u.home <= u.budget)
    tmax = np.where(fit, (u.budget - np.where(fit, u.home, 0)) // straight, -1).astype(np.int64)
    tmin = np.where(u.cheb >= 0, u.cheb, np.iinfo(np.int64).max).astype(np.int64)
    nx, ny = no_fly.shape
    if choice is None:
        choice = np.empty((u.steps + 1, 8, nx, ny), dtype=np.int8)
    return Walker(u.airport, u.heading, u.budget, u.steps, tmin, tmax, choice[:u.steps + 1],
                  np.zeros((u.steps + 1, 3), dtype=np.int64))


def best_walk(w: Walker, reward: np.ndarray, oc: OrientationConstraint, move_cost: np.ndarray
              ) -> tuple[float, np.ndarray]:
    """`_best_walk` for `w`: (its value, the walk's poses after the start, (n, 3) x, y, heading)."""
    value, n = _best_walk(np.ascontiguousarray(reward, dtype=np.float64), w.tmin, w.tmax, oc.successors,
                          HEADING_DX, HEADING_DY, np.ascontiguousarray(move_cost, dtype=np.float64),
                          int(w.airport[0]), int(w.airport[1]), int(w.heading), int(w.steps), w.choice, w.path)
    return float(value), w.path[:n].copy()


def dual_work(uavs: list[_Uav], cells: int, oc: OrientationConstraint) -> tuple[int, int]:
    """(successors the DP looks at per evaluation of L over all UAVs, the largest choice table in bytes)."""
    return (sum((u.steps + 1) * 8 * cells * oc.branching for u in uavs),
            max((u.steps + 1) * 8 * cells for u in uavs))


def dual_seconds(uavs: list[_Uav], cells: int, oc: OrientationConstraint) -> float:
    """The seconds one evaluation of L and one master LP take, estimated from above: the DP's
    work at `WORK_PER_SECOND`, the master `MASTER_SECONDS_PER_CELL` a cell."""
    return dual_work(uavs, cells, oc)[0] / WORK_PER_SECOND + cells * MASTER_SECONDS_PER_CELL


def dual_fits(uavs: list[_Uav], cells: int, oc: OrientationConstraint, time_limit_s: float) -> bool:
    """Whether `MIN_ITERATIONS` evaluations of the dual fit `time_limit_s` and its choice table the memory."""
    return (dual_work(uavs, cells, oc)[1] <= MAX_CHOICE_BYTES
            and MIN_ITERATIONS * dual_seconds(uavs, cells, oc) <= time_limit_s)


@dataclass(frozen=True)
class Dual:
    """What `minimise_dual` found: `value` the smallest L of its iterates (inf without one),
    `first` the smaller of its two starts', `floor` the last master LP's optimum (-inf without
    one: the `HEADINGS` LP reaches it, so no multipliers give less), `iterations` (evaluations
    of L) done, `seconds` taken."""

    value: float
    first: float
    floor: float
    iterations: int
    seconds: float


class _Lagrangian:
    """L of the module docstring and the walks that attain it, over one scenario's arrays."""

    def __init__(self, uavs: list[_Uav], oc: OrientationConstraint, no_fly: np.ndarray, marginal: np.ndarray,
                 pc: float, looks: int, radius: int, by_heading: np.ndarray, straight: int) -> None:
        nx, ny = no_fly.shape
        choice = np.empty((max(u.steps for u in uavs) + 1, 8, nx, ny), dtype=np.int8)
        self.walkers = [walker(u, no_fly, straight, choice) for u in uavs]
        self.oc, self.radius = oc, radius
        fixed = np.zeros((nx, ny))
        readable = np.zeros((nx, ny), dtype=bool)
        box = np.empty((nx, ny))
        for w, u in zip(self.walkers, uavs):
            fixed[max(u.airport[0] - radius, 0):u.airport[0] + radius + 1,
                  max(u.airport[1] - radius, 0):u.airport[1] + radius + 1] += 1
            can = ((w.tmax >= np.maximum(w.tmin, 1)[None]) & (w.tmax >= 1)).any(axis=0)
            _box_sum(can.astype(np.float64), radius, box)
            readable |= box > 0
        self.fixed = fixed
        self.active = (readable | (fixed > 0)) & (marginal > 0)       # cells with a row in the LP
        factors = pc * (1.0 - pc) ** np.arange(looks)
        self.gains = marginal[self.active][:, None] * factors[None, :]  # (active cells, K), decreasing in k
        self.tail = marginal[self.active] * pc * (1.0 - pc) ** looks
        self.scale = by_heading.astype(np.float64) / straight           # a move's metres, in cell sides
        self.budgets = np.array([u.budget / straight for u in uavs])
        self.steps = np.array([u.steps for u in uavs])

    def starts(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Two starting multipliers (lambda over the active cells, mu per UAV in cell sides):
        every cell worth its first look and metres free (each UAV as if alone); and the counting
        bound's: tau the N-th largest gain, N the reads all steps can make, lambda_c =
        min(g_c1, tau) and mu_i = tau (2r + 1)^2 (then L is about N tau + the gains above tau)."""
        alone = (self.gains[:, 0].copy(), np.zeros(len(self.walkers)))
        per_step = (2 * self.radius + 1) ** 2
        reads_max = per_step * int(self.steps.sum())
        ordered = np.sort(self.gains.ravel())[::-1]
        tau = float(ordered[reads_max - 1]) if reads_max <= ordered.size else 0.0
        counting = (np.maximum(np.minimum(self.gains[:, 0], tau), self.tail),
                    np.full(len(self.walkers), per_step * tau))
        return [alone, counting]

    def cheapest(self) -> list[Walk]:
        """Each UAV's walk of the fewest metres (no rewards, every metre a cost)."""
        lam = np.zeros(self.gains.shape[0])
        return self(lam, np.ones(len(self.walkers)) * 1e3)[1]

    def __call__(self, lam_active: np.ndarray, mu: np.ndarray) -> tuple[float, list[Walk]]:
        """(L at lambda (over the active cells) and mu (per UAV, a cell side's worth), and each
        UAV's best walk); L inf when a UAV has no walk."""
        lam = np.zeros(self.fixed.shape)
        lam[self.active] = lam_active
        reward = np.empty(lam.shape)
        _box_sum(lam, self.radius, reward)
        value = float((lam * self.fixed).sum())
        walks = []
        for i, w in enumerate(self.walkers):
            v, path = best_walk(w, reward, self.oc, mu[i] * self.scale)
            if not math.isfinite(v):
                return math.inf, []
            value += v + mu[i] * self.budgets[i]
            reads = np.zeros(self.fixed.shape)
            _add_footprints(reads, path, self.radius)
            at = np.nonzero(reads[self.active])[0]
            walks.append(Walk(at, reads[self.active][at], float(self.scale[path[:, 2]].sum())))
        value += float(np.maximum(self.gains - lam_active[:, None], 0.0).sum())
        return value, walks


@dataclass(frozen=True)
class Walk:
    """A walk as the master LP sees it: the active cells it reads (`cells`), how often
    (`counts`), and its metres in cell sides."""

    cells: np.ndarray
    counts: np.ndarray
    metres: float


class _Master:
    """The restricted master LP of column generation (Dantzig-Wolfe) for the `HEADINGS` LP: per
    UAV a convex combination of the walks found so far (its cheapest walk among them, which
    keeps the master feasible), the metre row, and per cell the concave gains of its reads.
    Its optimum is a value the `HEADINGS` LP reaches; its row duals are the multipliers
    (lambda, mu) where the cutting-plane model of L made of those walks is least: the next
    point to evaluate L at (Kelley's method, dual to Dantzig-Wolfe). HiGHS's simplex,
    warm-started as walks are added."""

    def __init__(self, lagrangian: _Lagrangian) -> None:
        import highspy

        n, m = lagrangian.gains.shape[0], len(lagrangian.walkers)
        looks = lagrangian.gains.shape[1]
        self.n, self.m = n, m
        lp = highspy.HighsLp()
        cols = n * looks + n
        lp.num_col_ = cols
        lp.num_row_ = n + 2 * m
        lp.col_cost_ = -np.concatenate([lagrangian.gains.ravel(), lagrangian.tail])
        lp.col_lower_ = np.zeros(cols)
        lp.col_upper_ = np.concatenate([np.ones(n * looks), np.full(n, np.inf)])
        lp.row_lower_ = np.concatenate([np.full(n + m, -np.inf), np.ones(m)])
        lp.row_upper_ = np.concatenate([lagrangian.fixed[lagrangian.active], lagrangian.budgets, np.ones(m)])
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = np.arange(cols + 1, dtype=np.int32)
        lp.a_matrix_.index_ = np.concatenate([np.repeat(np.arange(n), looks), np.arange(n)]).astype(np.int32)
        lp.a_matrix_.value_ = np.ones(cols)
        self.h = quiet_highs()
        self.h.passModel(lp)

    def add(self, uav: int, walk: Walk) -> None:
        """A walk of UAV `uav` as a column."""
        rows = np.concatenate([walk.cells, [self.n + uav, self.n + self.m + uav]]).astype(np.int32)
        values = np.concatenate([-walk.counts, [walk.metres, 1.0]]).astype(np.float64)
        self.h.addCol(0.0, 0.0, np.inf, len(rows), rows, values)

    def solve(self, time_limit_s: float) -> tuple[float, np.ndarray, np.ndarray, np.ndarray] | None:
        """(the master's optimum, lambda over the active cells, mu per UAV, the convexity rows'
        duals pi per UAV), None when HiGHS did not solve it in time."""
        import highspy

        self.h.setOptionValue("time_limit", self.h.getRunTime() + max(float(time_limit_s), 0.01))  # its clock adds up
        self.h.run()
        if self.h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
            return None
        dual = -np.asarray(self.h.getSolution().row_dual)
        n, m = self.n, self.m
        return -self.h.getInfo().objective_function_value, dual[:n], dual[n:n + m], dual[n + m:]


def minimise_dual(uavs: list[_Uav], oc: OrientationConstraint, no_fly: np.ndarray, marginal: np.ndarray,
                  pc: float, looks: int, radius: int, by_heading: np.ndarray, straight: int,
                  time_limit_s: float, max_iterations: int = 100_000, trace: list[float] | None = None) -> Dual:
    """The module docstring's column generation on L: at most `max_iterations` evaluations of L
    (the two starts of `_Lagrangian.starts` at least) within `time_limit_s`, stopping early
    once L meets the master LP (then both are the `HEADINGS` LP's optimum). `marginal` is
    P0 (1 - Pc)^before per cell (0 on no-fly cells), `looks` K, `radius` the footprint's,
    `by_heading` each move's metres in budget units, `straight` an axis move's. L is evaluated
    at `SMOOTHING` x the best multipliers so far + the rest x the master's duals (projected:
    lambda_c >= tail_c, mu >= 0), the smoothing halved while the walks found there do not pay
    at the master's duals (mispricing). `trace` gets every evaluation's L."""
    start = time.perf_counter()
    lagrangian = _Lagrangian(uavs, oc, no_fly, marginal, pc, looks, radius, by_heading, straight)
    tried = [(*lagrangian(lam, mu), lam, mu) for lam, mu in lagrangian.starts()]
    if trace is not None:
        trace += [t[0] for t in tried]
    best, _, centre_lam, centre_mu = min(tried, key=lambda t: t[0])
    first, floor, it = best, -math.inf, len(tried)
    if not math.isfinite(best):
        return Dual(best, first, floor, it, time.perf_counter() - start)
    master = _Master(lagrangian)
    for i, walk in enumerate(lagrangian.cheapest()):
        master.add(i, walk)
    for _, walks, _, _ in tried:
        for i, walk in enumerate(walks):
            master.add(i, walk)
    smoothing = SMOOTHING
    while it < max_iterations and time.perf_counter() - start < time_limit_s:
        solved = master.solve(time_limit_s - (time.perf_counter() - start))
        if solved is None:
            break
        floor, lam, mu, pi = solved
        if best - floor <= 1e-7 * abs(best):
            break                                              # L meets the master: both are the LP's optimum
        lam, mu = np.maximum(lam, lagrangian.tail), np.maximum(mu, 0.0)
        at_lam = smoothing * centre_lam + (1 - smoothing) * lam
        at_mu = smoothing * centre_mu + (1 - smoothing) * mu
        value, walks = lagrangian(at_lam, at_mu)
        it += 1
        if trace is not None:
            trace.append(value)
        if not walks:
            break
        priced = [float(lam[w.cells] @ w.counts - mu[i] * w.metres - pi[i]) for i, w in enumerate(walks)]
        for i, walk in enumerate(walks):
            master.add(i, walk)
        if value < best:
            best, centre_lam, centre_mu = value, at_lam, at_mu
        # mispricing: no walk found pays at the master's own duals; the next point is nearer them
        smoothing = SMOOTHING if max(priced) > 1e-9 * abs(best) else smoothing / 2
    return Dual(best, first, floor, it, time.perf_counter() - start)


def _add_footprints(reads: np.ndarray, path: np.ndarray, radius: int) -> None:
    """reads[c] += 1 for every cell c of every pose's footprint in `path`."""
    nx, ny = reads.shape
    for ox in range(-radius, radius + 1):
        for oy in range(-radius, radius + 1):
            x, y = path[:, 0] + ox, path[:, 1] + oy
            inside = (x >= 0) & (x < nx) & (y >= 0) & (y < ny)
            np.add.at(reads, (x[inside], y[inside]), 1.0)
