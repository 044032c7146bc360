"""Headings, orientation constraints (Definition 1, eq. 6) and one-cell moves on the grid.

Headings 0..7 run clockwise from north: 0 = N (0,+1), 1 = NE, 2 = E (+1,0), ... 7 = NW.
Cells are (x, y) with x east and y north, 0-based inside the code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

HEADING_DX = np.array([0, 1, 1, 1, 0, -1, -1, -1], dtype=np.int64)
HEADING_DY = np.array([1, 1, 0, -1, -1, -1, 0, 1], dtype=np.int64)
COMPASS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")


@dataclass(frozen=True)
class OrientationConstraint:
    """The headings a vehicle may take on its next step, given its current heading.

    `successors[h]` lists the allowed next headings from heading h, padded with -1; the
    order fixes the meaning of a turn choice index (0 = the first listed heading)."""

    name: str
    allowed: tuple[tuple[bool, ...], ...] = field(repr=False)

    @property
    def successors(self) -> np.ndarray:
        width = max(sum(row) for row in self.allowed)
        table = np.full((8, width), -1, dtype=np.int64)
        for h, row in enumerate(self.allowed):
            nxt = [g for g in range(8) if row[g]]
            table[h, : len(nxt)] = nxt
        return table

    @property
    def branching(self) -> int:
        return int(max(sum(row) for row in self.allowed))

    def allows(self, heading: int, next_heading: int) -> bool:
        return self.allowed[heading % 8][next_heading % 8]


def turn_limited(name: str, max_turn_eighths: int) -> OrientationConstraint:
    """Turns of at most `max_turn_eighths` * 45 degrees either way (3OC: 1, 5OC: 2, 8OC: 4)."""
    rows = []
    for h in range(8):
        rows.append(tuple(min((g - h) % 8, (h - g) % 8) <= max_turn_eighths for g in range(8)))
    return OrientationConstraint(name, tuple(rows))


def axis_moves(name: str = "4OC") -> OrientationConstraint:
    """The four axis moves whatever the current heading (a slow ground robot)."""
    row = tuple(g % 2 == 0 for g in range(8))
    return OrientationConstraint(name, tuple(row for _ in range(8)))


OC3 = turn_limited("3OC", 1)
OC4 = axis_moves("4OC")
OC5 = turn_limited("5OC", 2)
OC8 = turn_limited("8OC", 4)

CONSTRAINTS = {"3": OC3, "4": OC4, "5": OC5, "8": OC8}


def constraint_by_name(name: str | int) -> OrientationConstraint:
    """'3', '3OC', 3 → OC3; raises ValueError for an unknown constraint."""
    key = str(name).upper().removesuffix("OC")
    if key not in CONSTRAINTS:
        raise ValueError(f"unknown orientation constraint {name!r} (choose from 3, 4, 5, 8)")
    return CONSTRAINTS[key]


def heading_between(dx: int, dy: int) -> int:
    """The heading of a one-cell move (dx, dy), each in {-1, 0, 1}, not both 0."""
    for h in range(8):
        if HEADING_DX[h] == dx and HEADING_DY[h] == dy:
            return h
    raise ValueError(f"({dx}, {dy}) is not a one-cell move")


@dataclass(frozen=True)
class MoveCosts:
    """What one step charges against a UAV's range, in integer units: an axis move (N, E, S, W)
    and a diagonal one.

    The paper counts every step alike (`STEPS`: the range T_i is a number of steps). Over a real
    area a step costs its length (`cell_lengths()`): a diagonal is sqrt(2) cells long, so a range
    in metres is spent as the planned path really spends it. Integer units keep the exact return
    table and every range check exact; `cell_lengths(1000)` counts thousandths of a cell side,
    the diagonal rounded up (1415), so a plan never charges less than its true length."""

    straight: int = 1
    diagonal: int = 1

    def __post_init__(self) -> None:
        if self.straight < 1 or self.diagonal < 1:
            raise ValueError(f"move costs must be positive integers, got {self.straight}, {self.diagonal}")

    @property
    def by_heading(self) -> np.ndarray:
        """Cost of a move along each heading 0..7 (int64[8])."""
        return np.array([self.straight if h % 2 == 0 else self.diagonal for h in range(8)], dtype=np.int64)

    def of(self, heading: int) -> int:
        return self.straight if heading % 2 == 0 else self.diagonal

    @property
    def cheapest(self) -> int:
        return min(self.straight, self.diagonal)

    @property
    def unit_steps(self) -> bool:
        """Every move costs one unit: ranges are counted in steps, as in the paper."""
        return self.straight == self.diagonal == 1


STEPS = MoveCosts(1, 1)

#: Units per cell side of `cell_lengths()`: a thousandth of a cell (5 cm on 50 m cells).
LENGTH_UNITS_PER_CELL = 1000


def cell_lengths(units_per_cell: int = LENGTH_UNITS_PER_CELL) -> MoveCosts:
    """Moves charged by their length: `units_per_cell` per axis move, that times sqrt(2),
    rounded up, per diagonal."""
    return MoveCosts(units_per_cell, math.ceil(units_per_cell * math.sqrt(2.0)))
