"""`fly_async`: one flight wired together: the links, one `FlightController`, its listeners and
watchers (recorder, MQTT bus, journal, sortie log, live table), operator orders, and the online
planner or a resumed flight when asked for.

The flight imports none of what watches it: the caller builds the recorder
(`gcs.recording.flight.FlightRecorder`), the bus feed (`gcs.bus.flight_feed.BusFeed`) and the
terminal's live table (`gcs.display.status_table.LiveTable`) and hands them in."""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Callable, Sequence
from contextlib import AsyncExitStack

from gcs.flight.controller import FlightAborted, FlightController, FlyOptions
from gcs.flight.events import FlightListener
from gcs.flight.orders import start_stdin_reader
from gcs.links import SigningKey, open_links
from gcs.links.connection import Connection
from gcs.plans.plan_folder import FleetPlan


async def fly_async(plan: FleetPlan, connections: Sequence[str | Connection], options: FlyOptions,
                    stdin_orders: bool = False, online=None, recorder=None, bus=None,
                    listeners: Sequence[FlightListener] = (), signing: SigningKey | None = None,
                    watchers: Sequence = (), resume=None,
                    out: Callable[[str], None] | None = None) -> FlightController:
    """Fly the plan (or, with `online` an observed search, search with the planner in the loop);
    `recorder` (a `gcs.recording.flight.FlightRecorder`) records it; `bus` (a
    `gcs.bus.flight_feed.BusFeed`) shares it over MQTT; `listeners` get every `FlightEvent`;
    `watchers` (e.g. `gcs.flight.sortie.SortieLog`, `gcs.display.status_table.LiveTable`) are
    held, as the bus and the recorder are (in that order, before them), by their
    `attach(controller)` for the whole flight and see how it ends; `out` takes the controller's
    lines (default: printed; `LiveTable.line` shows them under the table);
    with `signing` every link signs what it sends and refuses unsigned traffic;
    `resume` (a `gcs.flight.resume.Resumption`) takes over a flight whose station died: its
    `restore(controller)` runs before anything listens, its `run(controller)` instead of
    `controller.run()`."""
    async with AsyncExitStack() as stack:
        links = await stack.enter_async_context(open_links(connections, signing=signing))
        controller = FlightController(plan, links, options, out)
        if resume is not None:
            resume.restore(controller)
        for listener in listeners:
            controller.subscribe(listener)
        if bus is not None:
            await stack.enter_async_context(bus.attach(controller))
        if recorder is not None:
            await stack.enter_async_context(recorder.attach(controller))
        for watcher in watchers:
            await stack.enter_async_context(watcher.attach(controller))
        loop = asyncio.get_running_loop()
        try:
            loop.add_signal_handler(signal.SIGINT, controller.interrupt)
        except (NotImplementedError, RuntimeError):
            pass
        if stdin_orders:
            start_stdin_reader(loop, controller)
        try:
            if online is not None:
                from gcs.flight.online import OnlineFlight

                await OnlineFlight(controller, online).run()
            elif resume is not None:
                await resume.run(controller)
            else:
                await controller.run()
        except Exception as exc:  # a bug in the loop must not leave vehicles flying unwatched
            controller.say(None, f"error: the flight controller failed ({type(exc).__name__}: {exc})")
            await controller.bring_everyone_home()
            raise FlightAborted(f"the flight controller failed ({type(exc).__name__}: {exc}); "
                                "every vehicle in the air was commanded RTL") from exc
        finally:
            try:
                loop.remove_signal_handler(signal.SIGINT)
            except (NotImplementedError, RuntimeError):
                pass
    return controller

