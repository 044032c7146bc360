"""`fly_async`: one flight wired together: the links, one `FlightController`, its listeners
(recorder, MQTT bus, journal, sortie log), operator orders, and the online planner or a resumed
flight when asked for."""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Sequence
from contextlib import AsyncExitStack

from gcs.flight.controller import FlightAborted, FlightController, FlyOptions
from gcs.flight.events import FlightListener
from gcs.flight.orders import start_stdin_reader
from gcs.links import SigningKey, open_links
from gcs.links.connection import Connection
from gcs.plans.plan_folder import FleetPlan


async def fly_async(plan: FleetPlan, connections: Sequence[str | Connection], options: FlyOptions,
                    stdin_orders: bool = False, online=None, recorder=None, bus: dict | None = None,
                    listeners: Sequence[FlightListener] = (), signing: SigningKey | None = None,
                    watchers: Sequence = (), resume=None) -> FlightController:
    """Fly the plan (or, with `online` an observed search, search with the planner in the loop);
    `recorder` (a `gcs.recording.flight.FlightRecorder`) records it; `bus` (keywords of
    `gcs.bus.flight_feed.attach_bus`) shares it over MQTT; `listeners` get every `FlightEvent`;
    `watchers` (e.g. `gcs.flight.sortie.SortieLog`) are held, as the recorder is, by their
    `attach(controller)` for the whole flight and see how it ends;
    with `signing` every link signs what it sends and refuses unsigned traffic;
    `resume` (a `gcs.flight.resume.Resumption`) takes over a flight whose station died: its
    `restore(controller)` runs before anything listens, its `run(controller)` instead of
    `controller.run()`."""
    async with AsyncExitStack() as stack:
        links = await stack.enter_async_context(open_links(connections, signing=signing))
        controller = FlightController(plan, links, options)
        if resume is not None:
            resume.restore(controller)
        for listener in listeners:
            controller.subscribe(listener)
        if bus is not None:
            from gcs.bus.flight_feed import attach_bus

            await stack.enter_async_context(attach_bus(controller, **bus))
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


