"""How a flight is shown on TAK: the name on its items and the rates and stale times (seconds).
Light on purpose: the command line reads its defaults without loading pytak."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TakSettings"]


@dataclass(frozen=True)
class TakSettings:
    """`name` prefixes every uid and callsign (`gcs.tak.cot.Naming`); a vehicle's track is sent
    at most every `every_s` and goes stale `stale_s` after it was sent; shapes, paths and
    markers stay `keep_s` and are sent again every `refresh_s` for clients that join later."""

    name: str
    every_s: float = 2.0
    stale_s: float = 20.0
    keep_s: float = 12 * 3600.0
    refresh_s: float = 60.0
