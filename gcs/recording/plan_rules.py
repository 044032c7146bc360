"""What a plan's recording does the same wherever it is made, here (`gcs.recording.plan`) or in a
helper process (`gcs.recording.background`): how often the maps are logged, how an interruption
reads. Its own module, so neither of the two imports the other for it."""

from __future__ import annotations

import math

__all__ = ["MAP_CELLS_EVERY_STEP", "interruption", "map_interval"]

#: Grids up to this many cells log their maps every step; bigger ones every ceil(cells / this)
#: steps, so a 1000 x 1000 area logs 2 x 3 MB of images every 100 steps, not every step.
MAP_CELLS_EVERY_STEP = 10_000


def map_interval(cells: int) -> int:
    """Steps between the TEP and EU maps logged on a grid of `cells` cells, by default."""
    return max(1, math.ceil(cells / MAP_CELLS_EVERY_STEP))


def interruption(exc_type: type[BaseException], exc: BaseException | None) -> str:
    """What stopped a run, as its recording's last event says it."""
    return "Ctrl-C" if issubclass(exc_type, KeyboardInterrupt) else f"{exc_type.__name__}: {exc}"
