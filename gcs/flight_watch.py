"""Watching a `FlightController` from beside it: its events as they happen, and its vehicle
states sampled while a block runs (the Rerun recorder and the sortie log both do)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gcs.flight import FlightController, FlightListener


@contextlib.asynccontextmanager
async def watching(controller: FlightController, on_event: FlightListener, sample: Callable[[bool], None],
                   period_s: float, name: str) -> AsyncIterator[None]:
    """Subscribe `on_event` and call `sample(False)` every `period_s` while the block runs; on
    the way out, however it ends, unsubscribe, stop sampling and call `sample(True)` once."""
    unsubscribe = controller.subscribe(on_event)

    async def poll() -> None:
        while True:
            sample(False)
            await asyncio.sleep(period_s)

    task = asyncio.create_task(poll(), name=name)
    try:
        yield
    finally:
        unsubscribe()
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        sample(True)
