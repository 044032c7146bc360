"""Looking past the horizon: a value for the cell an Np-step path ends on.

J1 (eq. 7) pays for the Np cells a path flies and for nothing after them. A UAV whose likely
regions all lie farther than Np cells sees none of them: it searches the nearest unsearched
cells (often the area's edge) and never heads for a region it could reach, search and come back
from. The horizon value adds to the J1 of every path the worth of its last cell s as a place to
go on searching from:

    H_i(s) = weight * Np * max over cells c UAV i can reach of M_i(c) * exp(-d(s, c) / L_i)

- r(c) = w1 P(c) + w2 chi(c) / 2 on the current map: what J1's map terms pay for a first visit
  of c (eq. 7-9), 0 in no-fly cells;
- reachable: d(u, c) + home(c) <= the UAV's range left, u its cell now, d the fewest 8-connected
  steps around no-fly cells and home(c) its exact table's steps home from c (best heading): cells
  it can still fly to and come back from (both counts are lower bounds: the OC only adds steps);
- the discount length L_i = length * (range left - steps home from u), the UAV's surplus range:
  a dense region is worth heading for while the trip takes a small part of what is left;
- the UAV's share of c, a_i(c) = w_i(c) / sum_j w_j(c) over the searching UAVs, w_j(c) =
  exp(-d(u_j, c) / L_j) where UAV j can reach c (else 0): the team splits the likely ground
  instead of all heading for the densest region, and a region the nearest UAV cannot reach is
  left to the others;
- M_i(c), the belief mass around c: the mean of a_i r over the (2 radius + 1)^2 cells centred on
  c, unreachable cells and cells outside the grid counting 0, so edges, no-fly zones and
  searched ground weigh less (radius Np by default: what one more horizon could search there);
- weight * Np: the value counts as `weight` horizons' worth of steps at that density.

max_c M(c) exp(-d(s, c) / L) is a distance transform: -L ln H(s) = min_c (-L ln M(c) + d(s, c)),
computed exactly by one breadth-first pass from all cells at once (`discounted_max`). Its only
local maxima are its sources: from every other cell one neighbour is a step nearer the best
source, so a UAV climbing it reaches a dense region and is not held behind a no-fly zone (a
blur of the map would pull it into the wall).

The fields are recomputed every `every` steps from the shared map (every UAV's looks lower r
where it searched) and handed to the strategies as a window of values around each UAV
(`horizon_window`), which the shared kernels add to J1 (`planner.reward.add_terminal_value`),
so the option composes with every optimiser (CPIO, PIO, PSO, GA, exhaustive). The lawnmower
ignores all scores. Without the option J1 is the paper's, bit for bit.

Cost: a field takes a few linear passes over the grid and a sort (under 1 ms on 50 x 50 cells).
Grids of more than FIELD_CELLS cells are pooled into b x b blocks first (b = ceil(sqrt(cells /
FIELD_CELLS)): block means of r, a block blocked when all its cells are, its best steps home),
the field computed over blocks and read at a cell's block; by default their fields are also
recomputed less often (every ceil(cells / FIELD_CELLS) steps).

Defaults (weight 1, length 1, radius Np) were chosen on random areas 100-115 and paper seeds
200-205 (`benchmarks/bench_success.py` reports on other ones)."""

import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from planner.config import njit

__all__ = ["FIELD_CELLS", "Flyer", "HorizonValue", "block_size", "box_mean", "discount_length", "discounted_max",
           "horizon_window", "reachable_cells", "steps_from", "team_fields", "team_shares", "visit_reward"]

#: Largest grid whose fields are computed cell by cell (128 x 128); bigger ones are pooled.
FIELD_CELLS = 16_384


@dataclass(frozen=True)
class HorizonValue:
    """Settings of the horizon value (see the module docstring): `weight` horizons' worth of
    steps, discount length as a share `length` of the surplus range, mass radius `radius`
    cells (None: Np), recomputed every `every` steps (None: 1 step, or ceil(cells / FIELD_CELLS)
    steps on grids of more than FIELD_CELLS cells)."""

    weight: float = 1.0
    length: float = 1.0
    radius: int | None = None
    every: int | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.weight) and self.weight >= 0):
            raise ValueError(f"horizon weight must be >= 0, got {self.weight}")
        if not (np.isfinite(self.length) and self.length > 0):
            raise ValueError(f"horizon length must be > 0, got {self.length}")
        if self.radius is not None and self.radius < 0:
            raise ValueError(f"horizon radius must be >= 0, got {self.radius}")
        if self.every is not None and self.every < 1:
            raise ValueError(f"horizon update period must be at least 1 step, got {self.every}")

    def period(self, shape: tuple[int, int]) -> int:
        """Steps between two computations of a UAV's field on a grid of `shape`."""
        if self.every is not None:
            return self.every
        return max(1, math.ceil(shape[0] * shape[1] / FIELD_CELLS))

    def as_dict(self, np_steps: int, shape: tuple[int, int]) -> dict[str, float | int]:
        return {"weight": self.weight, "length": self.length,
                "radius": np_steps if self.radius is None else self.radius, "every": self.period(shape)}


def visit_reward(tep: np.ndarray, eu: np.ndarray, weights: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """r = w1 P + w2 chi / 2: J1's map terms for a first visit, 0 in blocked cells."""
    return np.where(blocked, 0.0, weights[0] * tep + weights[1] * 0.5 * eu)


@njit
def _spread(blocked: np.ndarray, sources: np.ndarray, source_costs: np.ndarray, best: np.ndarray) -> int:
    """best[s] = min over sources i of source_costs[i] + steps(s, sources[i]) (8-connected steps
    around blocked cells; inf where none reaches), sources (flat cell indices) sorted by cost.
    The sources are merged with a FIFO queue whose costs rise by one step per ring, so every
    cell is settled once, at its final cost."""
    nx, ny = blocked.shape
    n = nx * ny
    k = sources.shape[0]
    best[:, :] = np.inf
    queued = np.full((nx, ny), np.inf)
    queue = np.empty(n, dtype=np.int64)
    queue_costs = np.empty(n)
    head = 0
    tail = 0
    i = 0
    while True:
        if head < tail and (i >= k or queue_costs[head] <= source_costs[i]):
            c = queue[head]
            cost = queue_costs[head]
            head += 1
        elif i < k:
            c = sources[i]
            cost = source_costs[i]
            i += 1
        else:
            break
        x = c // ny
        y = c % ny
        if best[x, y] < np.inf:
            continue
        best[x, y] = cost
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                qx = x + dx
                qy = y + dy
                if (dx == 0 and dy == 0) or qx < 0 or qy < 0 or qx >= nx or qy >= ny:
                    continue
                if blocked[qx, qy] or best[qx, qy] < np.inf or cost + 1.0 >= queued[qx, qy]:
                    continue
                queued[qx, qy] = cost + 1.0
                queue[tail] = qx * ny + qy
                queue_costs[tail] = cost + 1.0
                tail += 1
    return 0


def steps_from(blocked: np.ndarray, cell: tuple[int, int]) -> np.ndarray:
    """Fewest 8-connected steps from `cell` to every cell around no-fly cells (-1: unreachable)."""
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    best = np.empty(blocked.shape)
    _spread(blocked, np.array([int(cell[0]) * blocked.shape[1] + int(cell[1])]), np.zeros(1), best)
    return np.where(np.isfinite(best), best, -1).astype(np.int64)


@njit
def _box_sums(values: np.ndarray, radius: int, out: np.ndarray) -> int:
    """out[x, y] = sum of values over the (2 radius + 1)^2 cells centred on (x, y), in the grid."""
    nx, ny = values.shape
    sums = np.zeros((nx + 1, ny + 1))
    for x in range(nx):
        for y in range(ny):
            sums[x + 1, y + 1] = values[x, y] + sums[x, y + 1] + sums[x + 1, y] - sums[x, y]
    for x in range(nx):
        x0 = max(0, x - radius)
        x1 = min(nx, x + radius + 1)
        for y in range(ny):
            y0 = max(0, y - radius)
            y1 = min(ny, y + radius + 1)
            out[x, y] = sums[x1, y1] - sums[x0, y1] - sums[x1, y0] + sums[x0, y0]
    return 0


def box_mean(values: np.ndarray, radius: int) -> np.ndarray:
    """Mean of `values` over the (2 radius + 1)^2 cells centred on each cell (outside the grid: 0)."""
    out = np.empty(values.shape)
    _box_sums(np.ascontiguousarray(values, dtype=np.float64), int(radius), out)
    return out / (2 * radius + 1) ** 2


@njit
def _discounted_max(mass: np.ndarray, blocked: np.ndarray, length: float, best: np.ndarray) -> int:
    """best[s] = min over sources c (free, mass > 0) of -length ln mass(c) + steps(s, c)."""
    nx, ny = mass.shape
    costs = np.empty(nx * ny)
    cells = np.empty(nx * ny, dtype=np.int64)
    k = 0
    for x in range(nx):
        for y in range(ny):
            if not blocked[x, y] and mass[x, y] > 0.0:
                costs[k] = -length * np.log(mass[x, y])
                cells[k] = x * ny + y
                k += 1
    order = np.argsort(costs[:k])
    _spread(blocked, cells[:k][order], costs[:k][order], best)
    return 0


def discounted_max(mass: np.ndarray, blocked: np.ndarray, length: float) -> np.ndarray:
    """max over free cells c with mass > 0 of mass(c) * exp(-d(s, c) / length) for every cell s,
    d the fewest 8-connected steps around blocked cells (0 where no such c is reachable)."""
    if not length > 0:
        raise ValueError(f"discount length must be > 0, got {length}")
    best = np.empty(mass.shape)
    _discounted_max(np.ascontiguousarray(mass, dtype=np.float64), np.ascontiguousarray(blocked, dtype=np.bool_),
                    float(length), best)
    return np.exp(-best / length)


def block_size(shape: tuple[int, int]) -> int:
    """Side b of the blocks a grid's fields are computed over (1: cell by cell)."""
    return max(1, math.ceil(math.sqrt(shape[0] * shape[1] / FIELD_CELLS)))


def _pooled(values: np.ndarray, b: int, fill: float, reduce: Callable[..., np.ndarray]) -> np.ndarray:
    """`reduce` over b x b blocks (axis (1, 3)), the grid padded with `fill` to whole blocks."""
    nx, ny = values.shape
    bx, by = -(-nx // b), -(-ny // b)
    padded = np.full((bx * b, by * b), fill, dtype=values.dtype)
    padded[:nx, :ny] = values
    return np.asarray(reduce(padded.reshape(bx, b, by, b), axis=(1, 3)))


def discount_length(length: float, range_left: int, home_steps_now: int) -> float:
    """L = `length` times the surplus range (range left minus steps home now), at least 1 step."""
    return max(1.0, length * max(1, int(range_left) - int(home_steps_now)))


def reachable_cells(steps: np.ndarray, home_steps: np.ndarray, range_left: int, step: int = 1) -> np.ndarray:
    """Cells a UAV `steps` away (from `steps_from`, in units of `step` steps) can fly to and still
    get home from within `range_left` steps."""
    return np.asarray((steps >= 0) & (steps * step + home_steps <= range_left))


def team_shares(steps: list[np.ndarray], reachable: list[np.ndarray], lengths: list[float]) -> list[np.ndarray]:
    """Each searching UAV's share of every cell: w_i / sum_j w_j, w_j = exp(-steps_j / L_j) where
    UAV j can reach the cell and come back (`reachable[j]`), else 0; `steps[j]` from `steps_from`
    and L_j its discount length."""
    weights = [np.where(r, np.exp(-np.maximum(s, 0) / length), 0.0) for s, r, length in zip(steps, reachable, lengths)]
    if not weights:
        return []
    total = np.sum(weights, axis=0)
    return [np.divide(w, total, out=np.zeros_like(w), where=total > 0) for w in weights]


@dataclass(frozen=True)
class Flyer:
    """A searching UAV as the horizon value sees it: its cell, range left (reserve deducted) and
    steps home from every cell (best heading)."""

    cell: tuple[int, int]
    range_left: int
    home_steps: np.ndarray


def team_fields(reward: np.ndarray, blocked: np.ndarray, flyers: list[Flyer], radius: int, length: float,
                block: int = 1) -> list[np.ndarray]:
    """Each flyer's field max over reachable c of M_i(c) exp(-d(s, c) / L_i) for every cell s (the
    module docstring), `reward` = r. With `block` b > 1 they are computed over b x b blocks (block
    means of r, a block blocked when all its cells are, its fewest steps home; a block of distance
    counting b steps) and read at each cell's block."""
    if block <= 1:
        return _team_fields(reward, blocked, flyers, radius, length, 1)
    nx, ny = reward.shape
    coarse = [Flyer((f.cell[0] // block, f.cell[1] // block), f.range_left, _pooled_home(f.home_steps, blocked, block))
              for f in flyers]
    fields = _team_fields(_pooled(reward, block, 0.0, np.mean), _pooled(blocked, block, True, np.all), coarse,
                          max(1, round(radius / block)), length, block)
    return [np.repeat(np.repeat(f, block, axis=0), block, axis=1)[:nx, :ny] for f in fields]


#: id(home table) -> (a weak reference to it, the mask, the block, the pooled table). An entry
#: lives as long as its table (a mission's), however many UAVs there are: a fixed number of
#: entries would be recomputed at every update once the fleet outnumbers it.
_POOLED_HOMES: dict[int, tuple[weakref.ref[np.ndarray], np.ndarray, int, np.ndarray]] = {}


def _pooled_home(home_steps: np.ndarray, blocked: np.ndarray, block: int) -> np.ndarray:
    """The fewest steps home from each block (pooled once per table and kept: a mission's tables
    never change, and pooling a 400 x 400 one costs a few milliseconds every update)."""
    key = id(home_steps)
    hit = _POOLED_HOMES.get(key)
    if hit is not None and hit[0]() is home_steps and hit[1] is blocked and hit[2] == block:
        return hit[3]
    far = np.iinfo(np.int64).max // 4
    pooled = _pooled(np.where(blocked, far, home_steps).astype(np.int64), block, far, np.min)
    if hit is None:
        weakref.finalize(home_steps, _POOLED_HOMES.pop, key, None)
    _POOLED_HOMES[key] = (weakref.ref(home_steps), blocked, block, pooled)
    return pooled


def _team_fields(reward: np.ndarray, blocked: np.ndarray, flyers: list[Flyer], radius: int, length: float,
                 step: int) -> list[np.ndarray]:
    """`team_fields` over a grid whose unit of distance is `step` steps."""
    steps = [steps_from(blocked, f.cell) for f in flyers]
    reach = [reachable_cells(s, f.home_steps, f.range_left, step) for s, f in zip(steps, flyers)]
    lengths = [discount_length(length, f.range_left, f.home_steps[f.cell]) / step for f in flyers]
    shares = team_shares(steps, reach, lengths)
    return [_field(reward * a, blocked, s, r, radius, L) for a, s, r, L in zip(shares, steps, reach, lengths)]


def _field(reward: np.ndarray, blocked: np.ndarray, steps: np.ndarray, reachable: np.ndarray, radius: int,
           discount: float) -> np.ndarray:
    """max over reachable c of mean(reward around c) * exp(-steps(s, c) / discount)."""
    mass = box_mean(np.where(reachable, reward, 0.0), radius)
    return discounted_max(np.where(reachable, mass, 0.0), blocked, discount)


def horizon_window(field: np.ndarray, cell: tuple[int, int], half: int, scale: float) -> np.ndarray:
    """`scale` * field over the (2 half + 1)^2 cells centred on `cell` (0 outside the grid): the
    window `planner.reward.add_terminal_value` reads a path's last cell from."""
    x, y = int(cell[0]), int(cell[1])
    nx, ny = field.shape
    window = np.zeros((2 * half + 1, 2 * half + 1))
    x0, x1 = max(0, x - half), min(nx, x + half + 1)
    y0, y1 = max(0, y - half), min(ny, y + half + 1)
    window[x0 - x + half: x1 - x + half, y0 - y + half: y1 - y + half] = scale * field[x0:x1, y0:y1]
    return window
