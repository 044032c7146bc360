"""A fleet of simulated vehicles on one asyncio loop: one tick task steps every vehicle and
sends its telemetry; one UDP socket per vehicle receives.

Use it as an async context manager inside a running loop, or `start()` / `stop()` (or
`with fleet.running():`) to run it on a background thread, e.g. from synchronous tests.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from gcs.links.connection import Connection, LinkKind, parse_connection
from gcs.links.transport import LinkStatus, open_transport
from planner.georef import LocalFrame
from sim.autopilot.profiles import new_vehicle
from sim.autopilot.vehicle import SimVehicle, VehicleConfig
from sim.physics.airframe import HomePose
from sim.vehicle_link import Address, LinkFaults, VehicleLink

MAX_STEP_S = 0.1
# Real seconds one tick may simulate at most: a process that falls behind slows simulated time
# down, as SITL does, instead of jumping it forward past messages still waiting in the socket
# (a jump would expire the vehicles' mission-protocol timeouts, which run in vehicle time).
MAX_TICK_LAG_S = 0.05
log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True, kw_only=True)
class FleetOptions:
    """Network, clock and world settings. base_port 0 lets the OS pick a free port per vehicle.
    `grid_origin` is the (lat, lon) of the sensor grid's south-west corner; by default vehicle
    1's home is a cell centre. With `tcp` every vehicle also listens on a TCP port
    (`tcp_base_port` + i, or one the OS picks), like SITL's SERIAL0; `serial_devices` serves
    vehicle i on the i-th serial device ("/dev/pts/3" or "/dev/ttyUSB0,57600"; "" for none)."""

    base_port: int = 14540
    bind: str = "127.0.0.1"
    out: tuple[Address, ...] = ()
    speedup: float = 1.0
    tick_s: float = 0.02
    faults: LinkFaults = field(default_factory=LinkFaults)
    signing_key: bytes | None = None
    targets: tuple[tuple[float, float], ...] = ()
    seed: int = 0
    grid_origin: tuple[float, float] | None = None
    tcp: bool = False
    tcp_base_port: int = 0
    serial_devices: tuple[str, ...] = ()


def homes_for(count: int, poses: Sequence[HomePose], spacing_m: float = 5.0) -> list[HomePose]:
    """One pose per vehicle: the poses as given, or one pose reused with vehicles spaced
    `spacing_m` apart to the east. This is the hook for homes computed from an area."""
    if len(poses) == count:
        return list(poses)
    if len(poses) != 1:
        raise ValueError(f"need 1 or {count} home poses, got {len(poses)}")
    base = poses[0]
    frame = LocalFrame(base.lat_deg, base.lon_deg)
    out = []
    for i in range(count):
        lat, lon = frame.en2geodetic(i * spacing_m, 0.0)
        out.append(HomePose(lat, lon, base.alt_m, base.heading_deg))
    return out


class SimFleet:
    def __init__(
        self,
        homes: Sequence[HomePose],
        config: VehicleConfig | None = None,
        options: FleetOptions | None = None,
    ) -> None:
        if not homes:
            raise ValueError("a fleet needs at least one home pose")
        self.options = options = options or FleetOptions()
        self.config = config or VehicleConfig()
        frame = LocalFrame(homes[0].lat_deg, homes[0].lon_deg)
        half = 0.5 * self.config.sensor.cell_size_m
        origin = frame.geodetic2en(*options.grid_origin) if options.grid_origin else (-half, -half)
        self.vehicles = [
            new_vehicle(i + 1, home, self.config, frame=frame, targets=list(options.targets), seed=options.seed,
                        grid_origin_en=origin)
            for i, home in enumerate(homes)
        ]
        for v in self.vehicles:
            v.started_at_speedup(options.speedup)
        self.links = [
            VehicleLink(v, faults=options.faults, out=options.out, signing_key=options.signing_key)
            for v in self.vehicles
        ]
        self.ticks = 0
        self.errors: list[BaseException] = []
        self._tick_task: asyncio.Task[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._stop: asyncio.Event | None = None
        self._silent_at: dict[int, float] = {}

    # ---- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> SimFleet:
        self._loop = asyncio.get_running_loop()
        opts = self.options
        if len(opts.serial_devices) > len(self.links):
            raise ValueError(f"{len(opts.serial_devices)} serial devices for {len(self.links)} vehicles")
        try:
            for i, link in enumerate(self.links):
                port = opts.base_port + i if opts.base_port else 0
                await self._loop.create_datagram_endpoint(lambda link=link: link, local_addr=(opts.bind, port))
                if opts.tcp:
                    tcp_port = opts.tcp_base_port + i if opts.tcp_base_port else 0
                    await self._serve_stream(link, Connection(LinkKind.TCP_SERVER, host=opts.bind, port=tcp_port))
                if i < len(opts.serial_devices) and opts.serial_devices[i]:
                    await self._serve_stream(link, parse_connection(opts.serial_devices[i]))
        except BaseException:
            self._close()
            raise
        self._tick_task = asyncio.create_task(self._run(), name="sim-fleet-tick")
        return self

    async def __aexit__(self, *exc: object) -> None:
        if self._tick_task is not None:
            self._tick_task.cancel()
            try:
                await self._tick_task
            except asyncio.CancelledError:
                pass
        self._close()

    async def _serve_stream(self, link: VehicleLink, connection: Connection) -> None:
        def status(change: LinkStatus) -> None:
            log.info("vehicle %d: %s", link.vehicle.sysid, change)

        link.streams.append(await open_transport(connection, link.stream_received, status))

    def _close(self) -> None:
        for link in self.links:
            if link.transport is not None:
                link.transport.close()
            for stream in link.streams:
                stream.close()
            link.streams.clear()

    async def serve(self, stop: asyncio.Event, duration_s: float | None = None) -> None:
        """Run until `stop` is set or `duration_s` (real seconds) has passed."""
        async with self:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(duration_s):
                    await stop.wait()

    def start(self, timeout_s: float = 5.0) -> SimFleet:
        """Run on a background thread with its own event loop; returns once bound."""
        ready = threading.Event()
        errors: list[BaseException] = []

        async def main() -> None:
            self._stop = asyncio.Event()
            try:
                async with self:
                    ready.set()
                    await self._stop.wait()
            except BaseException as exc:
                errors.append(exc)
                ready.set()

        self._thread = threading.Thread(target=asyncio.run, args=(main(),), name="sim-fleet", daemon=True)
        self._thread.start()
        if not ready.wait(timeout_s):
            raise TimeoutError("simulator did not start")
        if errors:
            raise errors[0]
        return self

    def stop(self) -> None:
        if self._thread is None:
            return
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(5.0)
        self._thread = None

    @contextmanager
    def running(self) -> Iterator[SimFleet]:
        self.start()
        try:
            yield self
        finally:
            self.stop()

    def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """Run `fn(*args)` on the fleet's loop (thread-safe API access) and return its result."""
        assert self._loop is not None

        async def run() -> Any:
            return fn(*args)

        if self._thread is None or threading.current_thread() is self._thread:
            return fn(*args)
        return asyncio.run_coroutine_threadsafe(run(), self._loop).result(5.0)

    # ---- access ------------------------------------------------------------------------

    def vehicle(self, sysid: int) -> SimVehicle:
        return self.vehicles[sysid - 1]

    def link(self, sysid: int) -> VehicleLink:
        return self.links[sysid - 1]

    @property
    def addresses(self) -> list[Address]:
        return [link.local_address for link in self.links]

    def connection_strings(self) -> list[str]:
        """pymavlink / MAVProxy connection strings, one per vehicle (UDP)."""
        return [f"udpout:{host}:{port}" for host, port in self.addresses]

    def tcp_connection_strings(self) -> list[str]:
        """`tcp:HOST:PORT` of every vehicle's TCP port (with `FleetOptions.tcp`)."""
        out = []
        for link in self.links:
            server = next(t for t in link.streams if t.connection.kind is LinkKind.TCP_SERVER)
            host, port = server.local_address[:2]  # type: ignore[attr-defined]
            out.append(f"tcp:{host}:{port}")
        return out

    def drop_stream_clients(self, sysid: int) -> int:
        """Close every TCP client of vehicle `sysid` (the far end closing); the number closed."""
        def drop() -> int:
            closed = 0
            for stream in self.link(sysid).streams:
                if stream.connection.kind is LinkKind.TCP_SERVER:
                    closed += stream.drop_clients()  # type: ignore[attr-defined]
            return closed

        return self.call(drop)

    def stop_answering(self, sysid: int, after_s: float = 0.0) -> None:
        """Vehicle `sysid` goes silent (sends and receives nothing) after `after_s` sim seconds."""
        self._silent_at[sysid] = self.vehicle(sysid).time_s + after_s

    def resume_answering(self, sysid: int) -> None:
        self._silent_at.pop(sysid, None)
        self.link(sysid).silent = False

    # ---- the tick ----------------------------------------------------------------------

    async def _run(self) -> None:
        opts = self.options
        last = time.monotonic()
        while True:
            start = time.monotonic()
            sim_dt = min(start - last, MAX_TICK_LAG_S) * opts.speedup
            last = start
            self._tick(sim_dt, start)
            self.ticks += 1
            await asyncio.sleep(max(0.0, opts.tick_s - (time.monotonic() - start)))

    def _tick(self, sim_dt: float, wall_s: float) -> None:
        steps = max(1, math.ceil(sim_dt / MAX_STEP_S))
        dt = sim_dt / steps
        for vehicle, link in zip(self.vehicles, self.links, strict=True):
            try:
                for _ in range(steps):
                    vehicle.step(dt)
                silent_at = self._silent_at.get(vehicle.sysid)
                if silent_at is not None and vehicle.time_s >= silent_at:
                    link.silent = True
                link.send(vehicle.poll(wall_s))
                link.send(vehicle.emit())
            except Exception as exc:  # one faulty vehicle must not stop the fleet
                if len(self.errors) < 100:
                    self.errors.append(exc)
                    log.exception("vehicle %d: tick failed", vehicle.sysid)
