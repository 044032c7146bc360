"""One flight of a plan, wired together.

`fly_plan` flies a plan anew and `fly_resumed` takes over a flight whose station died: each keeps
the flight's journal (`gcs.flight.journal`, what a restarted station resumes from) and its
sortie record (`gcs.flight.sortie`), and returns a `FlightOutcome`; a new flight also writes the
energy profiles it taught (`gcs.flight.profiles`, vehicles.json). Both are what `gcs fly` calls;
`fly_async` beneath them joins the links, one `FlightController`, its listeners and watchers,
operator orders, and the online planner or a resumed flight when asked for.

The flight imports none of what watches it: the caller builds the recorder
(`gcs.recording.flight.FlightRecorder`), the bus feed (`gcs.bus.flight_feed.BusFeed`) and the
terminal's live table (`gcs.display.status_table.LiveTable`) and hands them in."""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Callable, Sequence
from contextlib import AbstractAsyncContextManager, AsyncExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from gcs.flight.controller import FlightAborted, FlightController, FlyOptions
from gcs.flight.events import FlightListener
from gcs.flight.journal import JOURNALED_OPTIONS, FlightJournal, JournalState, journal_options, new_start
from gcs.flight.orders import start_stdin_reader
from gcs.flight.profiles import save_learned
from gcs.flight.sortie import SortieLog
from gcs.links import SigningKey, open_links
from gcs.links.connection import Connection
from gcs.plans.belief_file import file_sha256
from gcs.plans.plan_folder import FleetPlan
from gcs.telemetry.status import Stage

if TYPE_CHECKING:
    from planner.dtscs import ClosedSearch


class Watcher(Protocol):
    """Anything that follows a whole flight: held by `attach(controller)` while it runs."""

    def attach(self, controller: FlightController) -> AbstractAsyncContextManager[Any]: ...


class Display(Watcher, Protocol):
    """A terminal view of the flight (`gcs.display.status_table.LiveTable`): a watcher that also
    shows the controller's lines."""

    def line(self, text: str) -> None: ...


@dataclass
class FlightOutcome:
    """How a flight ended: its controller (every vehicle's last status), its sortie record, its
    recording, and what became of the energy profiles it taught (`learned`, a line)."""

    controller: FlightController
    sortie: SortieLog
    recording: Path | None = None
    learned: str = ""

    @property
    def exit_code(self) -> int:
        """0 when every vehicle landed at its airport, 130 when the operator interrupted the flight,
        else 1 (a vehicle landed away, failed or was lost)."""
        if self.controller.interrupted:
            return 130
        return 0 if all(st.stage is Stage.LANDED for st in self.controller.status.values()) else 1


async def upload_plan(plan: FleetPlan, connections: Sequence[str], options: FlyOptions,
                      out: Callable[[str], None] | None = None,
                      signing: SigningKey | None = None) -> FlightController:
    """Send every UAV's mission (and geofence and rally point unless `options.fence` is off) to
    its vehicle and verify it by reading it back, without flying (`gcs upload`); the
    vehicles' `upload_reports` say what each one holds."""
    async with open_links(connections, signing=signing) as links:
        controller = FlightController(plan, links, options, out)
        await controller.upload_all()
    return controller


def fly_plan(plan: FleetPlan, connections: Sequence[str], options: FlyOptions, *, signing: SigningKey | None = None,
             simulated: bool = False, online: ClosedSearch | None = None, recorder=None, bus=None,
             display: Display | None = None, stdin_orders: bool = False,
             watchers: Sequence[Watcher] = ()) -> FlightOutcome:
    """Fly `plan` over `connections` until every vehicle is down (`fly_async`), keeping the
    flight's journal in the plan folder (a `simulated` fleet stops with the station, so its
    journal never holds a later flight back) and writing its sortie record; `online` flies the
    search with the planner in the loop (`gcs.flight.online.observed_search`); `watchers` (e.g.
    `gcs.tak.flight_feed.TakFeed`) follow the flight after the journal and the sortie record."""
    folder = Path(plan.folder)
    rrd = recorder.rrd_path if recorder is not None else None
    start = new_start(file_sha256(folder / "plan.json"), list(connections), sim=simulated, signed=signing is not None,
                      online=online is not None, options=journal_options(options),
                      rrd=_relative(rrd, folder), recording_id=None)
    sortie = SortieLog(plan)
    if recorder is not None:
        recorder.sortie = sortie  # the plan's segments, and the figures the record gives them
    journal = FlightJournal.begin(plan, start, recorder)
    controller = asyncio.run(fly_async(plan, connections, options, stdin_orders=stdin_orders, online=online,
                                       recorder=recorder, bus=bus, signing=signing,
                                       watchers=[journal, sortie, *watchers], display=display))
    _, learned = save_learned(folder, {uid: v.energy for uid, v in controller.vehicles.items()},
                              options.vehicles_file)
    return FlightOutcome(controller, sortie, rrd, learned)


def fly_resumed(plan: FleetPlan, state: JournalState, connections: Sequence[str], options: FlyOptions, *,
                signing: SigningKey | None = None, recorder=None, bus=None,
                display: Display | None = None, stdin_orders: bool = False,
                watchers: Sequence[Watcher] = ()) -> FlightOutcome:
    """Take over the flight `state` (`gcs.flight.resume.resumable_flight`) left in `plan`'s
    folder and fly it on to the end: the journal and sortie record carry on from what they kept,
    each `udpout` link sends from the port the dead station used, and `recorder` writes the
    recording's next segment (`gcs.recording.flight.resumed_flight_recorder`)."""
    from gcs.flight.resume import Resumption, links_from_the_same_ports

    sortie = SortieLog(plan)
    sortie.restore(state)
    if recorder is not None:
        recorder.sortie = sortie
    rrd = recorder.rrd_path if recorder is not None else None
    journal = FlightJournal.reopen(plan, state, list(connections), _relative(rrd, Path(plan.folder)))
    links = links_from_the_same_ports(list(connections), state.udp_source_ports)
    controller = asyncio.run(fly_async(plan, links, options, stdin_orders=stdin_orders, recorder=recorder, bus=bus,
                                       signing=signing, watchers=[journal, sortie, *watchers], display=display,
                                       resume=Resumption(plan, state)))
    return FlightOutcome(controller, sortie, rrd)


def resumed_options(options: FlyOptions, state: JournalState, given: set[str]) -> FlyOptions:
    """`options` with the journal's value of every knob it kept (`JOURNALED_OPTIONS`) that is
    not among the `given` field names."""
    kept = {name: value for name, value in state.start.options.items()
            if name in JOURNALED_OPTIONS and name not in given}
    return replace(options, **kept)


def _relative(path: Path | None, folder: Path) -> str | None:
    if path is None:
        return None
    try:
        return str(path.resolve().relative_to(folder.resolve()))
    except ValueError:
        return str(path.resolve())


async def fly_async(plan: FleetPlan, connections: Sequence[str | Connection], options: FlyOptions,
                    stdin_orders: bool = False, online=None, recorder=None, bus=None,
                    listeners: Sequence[FlightListener] = (), signing: SigningKey | None = None,
                    watchers: Sequence = (), resume=None,
                    out: Callable[[str], None] | None = None, display: Display | None = None) -> FlightController:
    """Fly the plan (or, with `online` an observed search, search with the planner in the loop);
    `recorder` (a `gcs.recording.flight.FlightRecorder`) records it; `bus` (a
    `gcs.bus.flight_feed.BusFeed`) shares it over MQTT; `listeners` get every `FlightEvent`;
    `watchers` (e.g. `gcs.flight.sortie.SortieLog`, `gcs.display.status_table.LiveTable`) are
    held, as the bus and the recorder are (in that order, before them), by their
    `attach(controller)` for the whole flight and see how it ends; `out` takes the controller's
    lines (default: printed); `display` (a `Display`, e.g. `LiveTable`) is the last watcher and
    takes the lines under its table;
    with `signing` every link signs what it sends and refuses unsigned traffic;
    `resume` (a `gcs.flight.resume.Resumption`) takes over a flight whose station died: its
    `restore(controller)` runs before anything listens, its `run(controller)` instead of
    `controller.run()`."""
    if display is not None:
        out, watchers = display.line, [*watchers, display]
    plan.prepare_returns()  # before any link is read: the first return check must not stall them
    async with AsyncExitStack() as stack:
        links = await stack.enter_async_context(open_links(connections, signing=signing))
        controller = FlightController(plan, links, options, out)
        if resume is not None:
            resume.restore(controller)
        else:
            for uav in plan.raw.get("grounded", []):
                controller.say(int(uav["id"]), f"stays on the ground - planned without it: {uav['reason']}")
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

