"""The sensor noise of a simulated world, fixed by (seed, UAV, cell, visit).

A reading's uniform draw depends only on who looks at which cell for the how-many-th time, not
on the order or timing of all other readings. So the planner's simulated sensing and the
simulated vehicles (`sim/`) that fly the plan see the same world on the same seed, and a live
flight whose timing shifts by a tick still gets the same readings. Pure Python, no dependencies:
the simulator imports it without the planner's numerical stack."""

from __future__ import annotations

__all__ = ["reading_draw"]

_MASK = (1 << 64) - 1


def _splitmix64(z: int) -> int:
    z = (z + 0x9E3779B97F4A7C15) & _MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
    return z ^ (z >> 31)


def reading_draw(seed: int, uav_id: int, x: int, y: int, visit: int) -> float:
    """The uniform number in [0, 1) behind UAV `uav_id`'s `visit`-th reading (from 0) of cell
    (x, y): the reading reports a target when it is below Pc (target present) or Pf (empty)."""
    h = 0
    for value in (seed, uav_id, x, y, visit):
        h = _splitmix64(h ^ (value & _MASK))
    return (h >> 11) * 2.0**-53
