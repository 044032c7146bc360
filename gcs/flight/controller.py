"""The fleet controller: flies one plan with one `VehicleFlight` per UAV
(`gcs.flight.vehicle_flight`, where each vehicle's stages, energy, trigger, orders and timers
live) and orchestrates them: it routes each link's messages to the vehicle that sent them, the
operator's orders to the vehicle they name, ticks every vehicle (its stage from telemetry, its
return trigger), sends home the ones that must go, and ends the flight when every vehicle is down
(or failed, or stayed lost), leaving none armed on the ground.

`FlightController` publishes what happens as `FlightEvent`s (`subscribe`): stage changes, take-
offs, flight-mode changes and sensor readings, the moment the vehicles see them; the Rerun
recorder and the MQTT feed listen, and sample only the telemetry (`status`). What it has to tell
the operator goes, as stamped lines, to one output channel (`out`, `say`); it draws nothing
itself (the live table is `gcs.display.status_table.LiveTable`, given by whoever starts the
flight). `gcs.flight.fly.fly_async` wires links, listeners and the online planner around one
controller.

The flight modules that drive the vehicles beside its own loop (`run`: the online planner, a
resumed flight) use each vehicle's flight (`vehicles[uid]`: `set_stage`, `update_stage`,
`mark_lost`, `claim` / `release`, `prepare`, `rtl`) and the controller's `take_orders`,
`send_home`, `recover_readings`, `wait_until`, `spawn`, `emit` and `interrupted`."""

from __future__ import annotations

import asyncio
import itertools
import time
from collections.abc import Callable

from gcs.errors import UserError
from gcs.flight.events import FlightEvent, FlightListener, LinkChanged
from gcs.flight.options import LANDED_AWAY_M, FlyOptions
from gcs.flight.preflight import wait_until
from gcs.flight.vehicle_flight import VehicleFlight
from gcs.links import LinkStatus, MavLink
from gcs.plans.plan_folder import FleetPlan
from gcs.telemetry.status import FINAL_STAGES, Stage, VehicleStatus

__all__ = ["LANDED_AWAY_M", "STOP_WAIT_S", "FlightAborted", "FlightController", "FlyOptions"]

#: How long a stopped flight waits for its cancelled tasks (uploads, launches) to end before it
#: secures the vehicles
STOP_WAIT_S = 5.0


class FlightAborted(UserError):
    """The controller failed mid-flight; every vehicle in the air was sent home first."""

    exit_code = 1


class FlightController:
    """Flies one fleet: a `VehicleFlight` per UAV, orchestrated (see the module docstring)."""

    def __init__(self, plan: FleetPlan, links: list[MavLink], options: FlyOptions | None = None,
                 out: Callable[[str], None] | None = None) -> None:
        self.plan = plan
        self.links = links
        self.options = options = options or FlyOptions()
        self.out = out or (lambda line: print(line, flush=True))
        self._listeners: list[FlightListener] = []
        self._interrupted = False
        self._stopping = False
        self.t0 = time.monotonic()
        self.vehicles = {uid: VehicleFlight(plan, uid, options, self) for uid in plan.uavs}
        self.status: dict[int, VehicleStatus] = {uid: v.status for uid, v in self.vehicles.items()}
        self.loop_latency_s: list[float] = []
        self._order_numbers = itertools.count()
        self._last_recovery = 0.0
        self._tasks: set[asyncio.Task] = set()
        for link in links:
            link.subscribe(lambda msg, link=link: self._on_message(link, msg))
            link.on_status(lambda status, link=link: self._on_link_status(link, status))

    # ---- links ---------------------------------------------------------------------------

    def _on_message(self, link: MavLink, msg) -> None:
        vehicle = self.vehicles.get(msg.get_srcSystem())
        if vehicle is not None:
            vehicle.on_message(link, msg)

    def _on_link_status(self, link: MavLink, status: LinkStatus) -> None:
        uids = tuple(uid for uid, v in sorted(self.vehicles.items()) if v.link is link)
        self.say(None, f"{status}{' - UAV ' + ', '.join(map(str, uids)) if uids else ''}")
        self.emit(LinkChanged(status, uids))

    def recover_readings(self, now: float) -> None:
        """Ask again (MAV_CMD_REQUEST_MESSAGE, param2 = image index) for readings lost on the link;
        at most once a second, whoever calls it."""
        if now - self._last_recovery < 1.0:
            return
        self._last_recovery = now
        for vehicle in self.vehicles.values():
            vehicle.ask_for_lost_readings()

    # ---- events and lines ----------------------------------------------------------------

    def subscribe(self, listener: FlightListener) -> Callable[[], None]:
        """Call `listener(event, monotonic_time)` for every `FlightEvent` from now on; returns
        the call that unsubscribes it. A listener that raises is reported and dropped: it never
        stops the flight."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    def emit(self, event: FlightEvent) -> None:
        """Hand `event` to every listener now: the vehicles' events, and those of the modules
        that drive vehicles beside the controller (`Reattached` from a resumed flight)."""
        now = time.monotonic()
        for listener in list(self._listeners):
            try:
                listener(event, now)
            except Exception as exc:  # a recorder or bus bug must not stop the flight
                self._listeners.remove(listener)
                self.say(None, f"error: event listener {getattr(listener, '__qualname__', listener)} dropped "
                               f"({type(exc).__name__}: {exc})")

    def say(self, uid: int | None, text: str) -> None:
        """Tell the operator: one line, stamped with the flight time (and the UAV), to `out`, the
        controller's only output channel."""
        stamp = f"[{time.monotonic() - self.t0:6.1f}s]"
        self.out(f"{stamp} UAV {uid}: {text}" if uid is not None else f"{stamp} {text}")

    # ---- the operator --------------------------------------------------------------------

    def _vehicle(self, uid: int) -> VehicleFlight:
        """The flight of UAV `uid`; ValueError naming the plan's UAVs for an unknown one."""
        if uid not in self.vehicles:
            raise ValueError(f"unknown UAV {uid} (the plan has {', '.join(map(str, sorted(self.vehicles)))})")
        return self.vehicles[uid]

    def order_return(self, uid: int, reason: str = "order") -> None:
        """A return order (from the operator or a command); ValueError for an unknown UAV."""
        self._vehicle(uid).orders.append((next(self._order_numbers), reason))

    def set_range(self, uid: int, range_m: float) -> None:
        """The operator's new range T_i for a UAV (`VehicleFlight.set_range`); ValueError for an
        unknown UAV or a range that is not a positive number of metres."""
        self._vehicle(uid).set_range(range_m)

    def take_orders(self) -> list[tuple[int, str]]:
        """The return orders (UAV, reason) given since the last call, in the order given, now the
        caller's to carry out (the controller's `tick`, or the online planner, which makes its
        own returns)."""
        orders = sorted((number, uid, reason) for uid, v in self.vehicles.items() for number, reason in v.orders)
        for vehicle in self.vehicles.values():
            vehicle.orders = []
        return [(uid, reason) for _, uid, reason in orders]

    def interrupt(self) -> None:
        """Ctrl-C: bring everyone home, then stop."""
        self._interrupted = True

    @property
    def interrupted(self) -> bool:
        """The operator stopped the flight (`interrupt`, Ctrl-C): every vehicle is brought home,
        and loops driving vehicles beside the controller stop."""
        return self._interrupted

    @property
    def stopping(self) -> bool:
        """The flight is being stopped (`bring_everyone_home`: Ctrl-C, or the controller failed): no
        vehicle is armed or launched from now on."""
        return self._stopping or self._interrupted

    # ---- tasks ---------------------------------------------------------------------------

    wait_until = staticmethod(wait_until)

    def spawn(self, coro) -> None:
        """Run `coro` as a task the controller owns: cancelled when the flight is stopped
        (`bring_everyone_home`) or stops waiting for lost vehicles."""
        task = asyncio.create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def upload_all(self) -> dict[int, bool]:
        """Prepare every vehicle concurrently; True where the upload verified."""
        results = await asyncio.gather(*(v.prepare() for v in self.vehicles.values()), return_exceptions=True)
        out = {}
        for (uid, vehicle), res in zip(self.vehicles.items(), results):
            if isinstance(res, BaseException):
                vehicle.set_stage(Stage.FAILED, str(res))
                res = False
            out[uid] = bool(res)
        return out

    async def send_home(self, uid: int, reason: str) -> None:
        """Send UAV `uid` home on its planned return leg (`VehicleFlight.send_home`); the hold it
        took is what every vehicle's trigger expects a return's hold to take from then on."""
        held_s = await self.vehicles[uid].send_home(reason)
        if held_s is not None:
            for vehicle in self.vehicles.values():
                vehicle.energy.hold_s = max(vehicle.energy.hold_s, held_s)

    # ---- the loop ------------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """One pass of the GCS loop: return times and orders, then every vehicle's stage and
        return trigger."""
        elapsed = now - self.t0
        for uid, vehicle in self.vehicles.items():
            if vehicle.return_due(elapsed):
                self.order_return(uid)
        for uid, reason in self.take_orders():
            self.say(uid, f"return ordered ({reason})")
            self.spawn(self.send_home(uid, reason))
        self.recover_readings(now)
        for uid, vehicle in self.vehicles.items():
            vehicle.update_stage(now)
            reason = vehicle.watch()
            if reason is not None:
                self.spawn(self.send_home(uid, reason))

    def finished(self, now: float) -> bool:
        """Every vehicle landed, failed, or lost past `lost_giveup_s`."""
        return all(vehicle.done(now) for vehicle in self.vehicles.values())

    async def monitor(self) -> None:
        """Run the GCS loop until all vehicles have landed (or failed, or stayed lost)."""
        while True:
            start = time.monotonic()
            if self._interrupted:
                await self.bring_everyone_home()
                return
            self.tick(start)
            self.loop_latency_s.append(time.monotonic() - start)
            if self.finished(start):
                await self._give_up_on_lost(start)
                return
            await asyncio.sleep(self.options.tick_s)

    async def _give_up_on_lost(self, now: float) -> None:
        """Every vehicle has landed, failed or stayed lost past `lost_giveup_s`: stop waiting for
        the lost ones (their preparation or return may still be waiting on the link) and say so."""
        for uid, vehicle in self.vehicles.items():
            if vehicle.status.stage is Stage.LOST:
                self.say(uid, f"lost for {now - (vehicle.lost_since or now):.0f} s: no longer waited for; its "
                              "autopilot's own failsafe is the backstop")
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def bring_everyone_home(self) -> None:
        """Ctrl-C, or the controller failed: RTL for every vehicle in the air, disarm every one
        armed on the ground; then say where each vehicle was left."""
        self.say(None, "stopping: every vehicle in the air is sent home (RTL), every armed one on the ground disarmed")
        self._stopping = True
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        if tasks:  # what they were doing (an upload, an arming) is over before the vehicles are secured
            _, pending = await asyncio.wait(tasks, timeout=STOP_WAIT_S)
            if pending:
                self.say(None, f"{len(pending)} of the flight's tasks still running {STOP_WAIT_S:g} s after the stop")
        for st in self.status.values():
            if st.stage not in FINAL_STAGES and (st.airborne or st.armed):
                st.return_reason = st.return_reason or "stop"
        await self.make_safe(rtl_airborne=True)

    async def make_safe(self, *, rtl_airborne: bool = False) -> None:
        """Leave no vehicle armed on the ground (disarm it), and, with `rtl_airborne`, send every
        vehicle in the air that is not already going home to RTL. Reports each one it acted on."""
        await asyncio.gather(*(v.secure(rtl_airborne) for v in self.vehicles.values()), return_exceptions=True)

    async def run(self) -> None:
        """Prepare and launch every vehicle concurrently, monitor until the end, and leave no
        vehicle armed on the ground."""
        for vehicle in self.vehicles.values():
            self.spawn(vehicle.prepare_and_launch())
        await self.monitor()
        await self.make_safe()
