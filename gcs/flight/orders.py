"""Orders an operator types during a flight: `return ID`, `return all`, `range ID METRES`."""

from __future__ import annotations

import asyncio
import math
import sys
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController


@dataclass(frozen=True, slots=True)
class OperatorOrder:
    """One typed order: `kind` "return" (uav None: every UAV) or "range" (`range_m`, metres along
    the UAV's plan from take-off)."""

    kind: str
    uav: int | None
    range_m: float | None = None


ORDER_HELP = "type 'return ID', 'return all' or 'range ID METRES' ('r ID' for short)"


def parse_order(line: str) -> OperatorOrder:
    """`return ID` / `r ID` / `rtl ID`, `return all`, `range ID METRES`; ValueError saying what
    was not understood."""
    parts = line.split()
    if not parts:
        raise ValueError(f"empty order: {ORDER_HELP}")
    verb = parts[0].lower()
    if verb in ("r", "rtl", "return") and len(parts) == 2:
        if parts[1].lower() == "all":
            return OperatorOrder("return", None)
        return OperatorOrder("return", _uav_id(parts[1]))
    if verb == "range" and len(parts) == 3:
        try:
            metres = float(parts[2])
        except ValueError:
            raise ValueError(f"range {parts[2]!r} is not a number of metres") from None
        if not (math.isfinite(metres) and metres > 0):
            raise ValueError(f"range must be a positive number of metres, not {parts[2]}")
        return OperatorOrder("range", _uav_id(parts[1]), metres)
    raise ValueError(f"unknown order {line.strip()!r}: {ORDER_HELP}")


def _uav_id(text: str) -> int:
    try:
        uav = int(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a UAV id") from None
    if uav < 1:
        raise ValueError(f"{text!r} is not a UAV id")
    return uav


def apply_order(controller: FlightController, order: OperatorOrder) -> None:
    """Carry out one operator order; ValueError for an unknown UAV."""
    if order.kind == "range":
        assert order.uav is not None and order.range_m is not None
        controller.set_range(order.uav, order.range_m)
        return
    for uav in sorted(controller.status) if order.uav is None else [order.uav]:
        controller.order_return(uav)


def start_stdin_reader(loop: asyncio.AbstractEventLoop, controller: FlightController) -> None:
    """Operator orders typed on stdin (`parse_order`)."""

    def order(line: str) -> None:
        try:
            apply_order(controller, parse_order(line))
        except ValueError as exc:
            controller.say(None, f"error: {exc}")

    def read() -> None:
        for line in sys.stdin:
            if line.strip():
                loop.call_soon_threadsafe(order, line)

    threading.Thread(target=read, name="stdin-orders", daemon=True).start()
