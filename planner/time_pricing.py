"""A multicopter's path priced by its time, in range units: what the whole-mission improvement
(`planner.improve`) charges a path of a UAV whose energy profile prices a path by its seconds.

A multicopter's current hardly changes with its speed, so what a path costs it is its time
(`planner.path_time`, `planner.energy.EnergyProfile.cornering`), and a corner costs the seconds
it loses braking to the corner's speed and speeding up again. At cruise speed v and acceleration
a, a corner kept at the share f of v (`Cornering.fraction`) brakes from v to fv over
(v^2 - f^2 v^2) / 2a metres in (v - fv) / a seconds, which at cruise take (v + fv) / 2a seconds:
braking loses v (1 - f)^2 / 2a seconds, speeding up again the same, so the corner loses

    dt = v (1 - f)^2 / a  seconds,  v dt = (v - fv)^2 / a  metres at cruise  (`turn_loss_m`),

and a stop (f = 0) at each end of the path v^2 / 2a metres (`stop_loss_m`). The speed a path is
flown at is the least of every corner's own dip (`planner.path_time.path_time_s`: from a stop to
a stop, no faster than v and than each corner allows, speed changing at most at a), and where
dips overlap 1 / min(dips) - 1 / v = max over dips of (1 / dip - 1 / v) <= their sum: so a path's

    metres + sum of its corners' losses + both stops' losses

is never less than its seconds times v; exact for corners far apart, an upper bound (by what
the dips share) where they are close, as on small cells.

In range units (`planner.motion.MoveCosts`: thousandths of a cell side over an area), a turn
at a pose is indexed by the heading change between the move into it and the move out of it,
d = (h' - h) mod 8 eighths of a turn (45 d degrees, 360 - 45 d past four): `TimePricing.turn_units`;
a path of headings h_1 .. h_n (after its airport pose) costs its moves, a turn at each inner
pose and the two stops (`TimePricing.path_units`).

The budget is the charge the UAV's range was sized with: a range of R metres is R times the
profile's `cruise_mah_per_m` (a metre of a typical search path), which pays for that over
`moving_mah_per_s` seconds of flying, v metres at cruise each: a range unit buys
`cruise_mah_per_m * v / moving_mah_per_s` units of the time-priced cost
(`TimePricing.units_per_range_unit`), and a path's cost so is at most (range - reserve) times
that (`TimePricing.budget_units`). The legs from the airport to its cell's centre and back,
outside the grid's range, are priced as a metre of range each. A plane keeps its speed through a
turn: its profile has no cornering, and no `TimePricing`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from planner.energy import EnergyProfile
from planner.motion import MoveCosts
from planner.path_time import Cornering

__all__ = ["HEADING_CHANGES", "TimePricing", "change_turn_deg", "stop_loss_m", "time_pricing", "turn_loss_m",
           "turn_units"]

#: Heading changes between two moves, in eighths of a turn ((h' - h) mod 8).
HEADING_CHANGES = 8


def change_turn_deg(change: int) -> float:
    """The turn of a heading change of `change` eighths ((h' - h) mod 8): 0 straight on, 180 back."""
    d = change % HEADING_CHANGES
    return 45.0 * min(d, HEADING_CHANGES - d)


def turn_loss_m(cornering: Cornering, cruise_speed_m_s: float, turn_deg: ArrayLike) -> np.ndarray:
    """Metres at cruise speed a multicopter loses to each turn of `turn_deg` (degrees, any sign):
    braking from the cruise speed v to the turn's speed f v and speeding up again,
    (v - f v)^2 / a (the module docstring)."""
    v = _speed(cruise_speed_m_s)
    kept = cornering.fraction(turn_deg)
    loss: np.ndarray = (v - kept * v) ** 2 / cornering.accel_m_s2
    return loss


def stop_loss_m(cornering: Cornering, cruise_speed_m_s: float) -> float:
    """Metres at cruise speed lost to one stop at an end of a path: speeding up from rest to the
    cruise speed v (or braking from it), v^2 / 2a."""
    v = _speed(cruise_speed_m_s)
    return v * v / (2.0 * cornering.accel_m_s2)


def turn_units(cornering: Cornering, cruise_speed_m_s: float, cell_size_m: float, costs: MoveCosts
               ) -> tuple[int, ...]:
    """Range units (`costs`, on cells of `cell_size_m`) a turn adds to a path, by heading change
    d = 0..7 eighths (45 d degrees; 360 - 45 d past four): `turn_loss_m` rounded up, so a path is
    never charged less than its time. Every orientation constraint's turns are among them."""
    per_m = _units_per_m(cell_size_m, costs)
    losses = turn_loss_m(cornering, cruise_speed_m_s, [change_turn_deg(d) for d in range(HEADING_CHANGES)])
    return tuple(_ceil_units(float(m) * per_m) for m in losses)


@dataclass(frozen=True, slots=True, kw_only=True)
class TimePricing:
    """One UAV's path priced by its time, in range units (the module docstring): `turn_units[d]`
    what a turn of heading change d eighths adds at a pose ((h' - h) mod 8; d = 0 straight on),
    `stop_units` the stops at the path's two ends together, `units_per_range_unit` the units of
    this pricing a unit of range buys."""

    turn_units: tuple[int, ...]
    stop_units: int
    units_per_range_unit: float

    def __post_init__(self) -> None:
        if len(self.turn_units) != HEADING_CHANGES or any(t < 0 for t in self.turn_units):
            raise ValueError(f"turn_units must be 8 units >= 0, got {self.turn_units}")
        if self.stop_units < 0:
            raise ValueError(f"stop_units must be >= 0, got {self.stop_units}")
        ratio = self.units_per_range_unit
        if not (math.isfinite(ratio) and ratio > 0):
            raise ValueError(f"units_per_range_unit must be a positive number, got {ratio}")

    @property
    def turn_array(self) -> np.ndarray:
        """`turn_units` as the kernels take them (int64[8])."""
        return np.array(self.turn_units, dtype=np.int64)

    def budget_units(self, range_units: int) -> int:
        """The most a path (`path_units`) may cost on `range_units` of range (the reserve already
        taken off): what that range buys, rounded down."""
        return int(math.floor(max(range_units, 0) * self.units_per_range_unit + 1e-9))

    def path_units(self, headings: Sequence[int], costs: MoveCosts) -> int:
        """What a path of moves along `headings` (its poses' after the first, in order) costs:
        its moves, a turn at each pose between two moves, and the two stops."""
        moves = sum(costs.of(int(h)) for h in headings)
        turns = sum(self.turn_units[(int(b) - int(a)) % HEADING_CHANGES] for a, b in zip(headings, headings[1:]))
        return moves + turns + self.stop_units


def time_pricing(profile: EnergyProfile | None, cell_size_m: float, costs: MoveCosts) -> TimePricing | None:
    """The time pricing of a UAV flying `profile` over cells of `cell_size_m` whose moves cost
    `costs`; None without a profile or when it prices a path by its metres (no `cornering`: a
    plane, a multicopter whose current was not measured against its speed)."""
    if profile is None or profile.cornering is None or profile.moving_mah_per_s is None:
        return None
    cornering, v = profile.cornering, profile.cruise_speed_m_s
    return TimePricing(turn_units=turn_units(cornering, v, cell_size_m, costs),
                       stop_units=_ceil_units(2.0 * stop_loss_m(cornering, v) * _units_per_m(cell_size_m, costs)),
                       units_per_range_unit=profile.cruise_mah_per_m * v / profile.moving_mah_per_s)


def _speed(cruise_speed_m_s: float) -> float:
    if not (math.isfinite(cruise_speed_m_s) and cruise_speed_m_s > 0):
        raise ValueError(f"cruise speed must be a positive number, got {cruise_speed_m_s}")
    return cruise_speed_m_s


def _units_per_m(cell_size_m: float, costs: MoveCosts) -> float:
    if not (math.isfinite(cell_size_m) and cell_size_m > 0):
        raise ValueError(f"cell size must be a positive number, got {cell_size_m}")
    return costs.straight / cell_size_m


def _ceil_units(units: float) -> int:
    """Rounded up, but not past a float's round-off of a whole number."""
    return int(math.ceil(units - 1e-9))
