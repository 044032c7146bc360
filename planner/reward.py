"""Reward J1 of eq. (7)-(11) over Np-step-ahead predicted paths (Definition 4), with the
constraints of eq. (8) pruning them.

A candidate path is encoded as Np turn choices: choice c at step q takes heading
`successors[h, c]` from the current heading h. Every optimiser (exhaustive, PIO, CPIO, PSO, GA,
ST tracking) scores its paths with `score_paths`, so they share one fitness; with the horizon
value on (`planner.horizon`), `add_terminal_value` then adds the value of each path's last cell,
for every optimiser alike."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.config import njit

SQRT2 = np.sqrt(2.0)
COLLISION_PENALTY = -100.0


@dataclass(frozen=True)
class RewardWeights:
    """w1..w4 of eq. (7) (Table 1: 0.3, 0.3, 0.3, 0.1)."""

    tep: float = 0.3
    eu: float = 0.3
    separation: float = 0.3
    airport: float = 0.1

    def as_array(self) -> np.ndarray:
        return np.array([self.tep, self.eu, self.separation, self.airport], dtype=np.float64)


def airport_reward_map(shape: tuple[int, int], airports: np.ndarray) -> np.ndarray:
    """F_a of eq. (11) for every cell: exp(-1 / d_sum), d_sum = sum of distances to all airports."""
    xs, ys = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    d_sum = np.zeros(shape)
    for ax, ay in np.asarray(airports).reshape(-1, 2):
        d_sum += np.hypot(xs - ax, ys - ay)
    with np.errstate(divide="ignore"):
        return np.where(d_sum > 0, np.exp(-1.0 / np.where(d_sum > 0, d_sum, 1.0)), 0.0)


@njit
def separation_reward(d_min: float) -> float:
    """F_r of eq. (10)."""
    if d_min <= 1.4142135623730951:
        return -100.0
    return float(np.exp(-1.0 / d_min))


@njit
def others_near(others: np.ndarray, x0: int, y0: int, np_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The rows of `others` that `score_paths` needs at each step q: `near[q, :n_near[q]]`, every
    vehicle that could be the nearest one to (or share) some cell a path from (x0, y0) can reach
    at step q (within q + 1 cells of it on each axis). A vehicle whose least squared distance to
    that box exceeds the smallest greatest one of any vehicle is never the nearest, so F_r and the
    hard-clash check read the same minimum from these rows as from all of them (squared distances
    are integers: exact), while the work per path step no longer grows with the fleet."""
    n_others = others.shape[0]
    near = np.empty((np_steps, n_others), dtype=np.int64)
    n_near = np.zeros(np_steps, dtype=np.int64)
    for q in range(min(np_steps, others.shape[1])):
        r = q + 1
        bound = -1
        for j in range(n_others):
            if others[j, q, 0] < 0:
                continue
            ax = abs(others[j, q, 0] - x0) + r
            ay = abs(others[j, q, 1] - y0) + r
            if bound < 0 or ax * ax + ay * ay < bound:
                bound = ax * ax + ay * ay
        for j in range(n_others):
            if others[j, q, 0] < 0:
                continue
            ax = max(abs(others[j, q, 0] - x0) - r, 0)
            ay = max(abs(others[j, q, 1] - y0) - r, 0)
            if ax * ax + ay * ay <= bound:
                near[q, n_near[q]] = j
                n_near[q] += 1
    return near, n_near


@njit
def score_paths(choices: np.ndarray, x0: int, y0: int, h0: int, successors: np.ndarray, tep: np.ndarray,
                eu: np.ndarray, blocked: np.ndarray, fa_map: np.ndarray, others: np.ndarray, others_hard: np.ndarray,
                weights: np.ndarray, flown: int, budget: int, move_costs: np.ndarray, home_table: np.ndarray,
                tep_once: bool, scores: np.ndarray, depths: np.ndarray, cells: np.ndarray) -> int:
    """Score every row of `choices` (n x Np turn choices) from pose (x0, y0, h0).

    Writes `scores[i]` = J1 of the path's valid prefix, `depths[i]` = that prefix's length and
    `cells[i, q]` = (x, y, heading) of step q+1. A path stops (eq. 8) where it leaves the grid,
    enters a blocked cell or a pose with no way home at all (a dead end of the OC), or meets a
    vehicle whose path is hard (`others_hard`) on the same cell at the same step; its first step
    must also leave the range feasible: flown + move_costs[h1] + home_table[h1, x1, y1] <= budget
    (budget < 0 disables the check; costs in the units of `planner.motion.MoveCosts`).
    `others[j, q]` = (x, y) of vehicle j at step q+1, x < 0 where unknown.
    EU term: the reduction chi/2 of a visit, halved again for each earlier visit on the same path.
    With `tep_once`, a cell's TEP counts only at its first visit on the path (ST tracking)."""
    n, np_steps = choices.shape
    nx, ny = tep.shape
    w1 = weights[0]
    w2 = weights[1]
    w3 = weights[2]
    w4 = weights[3]
    near, n_near = others_near(others, x0, y0, np_steps)
    for i in range(n):
        x = x0
        y = y0
        h = h0
        total = 0.0
        depth = 0
        for q in range(np_steps):
            c = choices[i, q]
            if c < 0 or c >= successors.shape[1]:
                break
            g = successors[h, c]
            if g < 0:
                break
            if g == 0:
                qx, qy = x, y + 1
            elif g == 1:
                qx, qy = x + 1, y + 1
            elif g == 2:
                qx, qy = x + 1, y
            elif g == 3:
                qx, qy = x + 1, y - 1
            elif g == 4:
                qx, qy = x, y - 1
            elif g == 5:
                qx, qy = x - 1, y - 1
            elif g == 6:
                qx, qy = x - 1, y
            else:
                qx, qy = x - 1, y + 1
            if qx < 0 or qy < 0 or qx >= nx or qy >= ny or blocked[qx, qy]:
                break
            if home_table[g, qx, qy] >= 1073741824:
                break
            if q == 0 and budget >= 0:
                if flown + move_costs[g] + home_table[g, qx, qy] > budget:
                    break
            d2_min = -1
            clash = False
            for k in range(n_near[q]):
                j = near[q, k]
                ox = others[j, q, 0]
                if ox < 0:
                    continue
                oy = others[j, q, 1]
                if ox == qx and oy == qy and others_hard[j]:
                    clash = True
                    break
                d2 = (ox - qx) * (ox - qx) + (oy - qy) * (oy - qy)
                if d2_min < 0 or d2 < d2_min:
                    d2_min = d2
            if clash:
                break
            chi = 0.5 * eu[qx, qy]
            p = tep[qx, qy]
            for r in range(q):
                if cells[i, r, 0] == qx and cells[i, r, 1] == qy:
                    chi *= 0.5
                    if tep_once:
                        p = 0.0
            total += w1 * p + w2 * chi + w4 * fa_map[qx, qy]
            if d2_min >= 0:
                total += w3 * separation_reward(np.sqrt(d2_min))
            else:
                total += w3
            cells[i, q, 0] = qx
            cells[i, q, 1] = qy
            cells[i, q, 2] = g
            x = qx
            y = qy
            h = g
            depth += 1
        scores[i] = total
        depths[i] = depth
    return 0


@njit
def add_terminal_value(scores: np.ndarray, depths: np.ndarray, cells: np.ndarray, x0: int, y0: int,
                       horizon: np.ndarray) -> int:
    """Add to `scores[i]` the value of path i's last valid cell: `horizon` is a (2c+1) x (2c+1)
    window of values centred on the start cell (x0, y0), c >= Np, so every cell a path can end
    on is inside it. An empty window (0 x 0) adds nothing: J1 stays the paper's."""
    if horizon.shape[0] == 0:
        return 0
    c = (horizon.shape[0] - 1) // 2
    for i in range(scores.shape[0]):
        d = depths[i]
        if d > 0:
            scores[i] += horizon[cells[i, d - 1, 0] - x0 + c, cells[i, d - 1, 1] - y0 + c]
    return 0


@njit
def best_two(scores: np.ndarray, depths: np.ndarray) -> tuple[int, int]:
    """Indices of the best and runner-up paths: the deepest valid prefix first, then the highest
    score (ties to the lower index, so results do not depend on anything but the inputs).
    -1 where there is none (depth 0 paths are not candidates)."""
    best = -1
    second = -1
    for i in range(scores.shape[0]):
        if depths[i] == 0:
            continue
        if best < 0 or depths[i] > depths[best] or (depths[i] == depths[best] and scores[i] > scores[best]):
            second = best
            best = i
        elif second < 0 or depths[i] > depths[second] or (depths[i] == depths[second] and scores[i] > scores[second]):
            second = i
    return best, second
