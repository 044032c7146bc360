"""The simulated downward sensor for a real vehicle: a MAVLink camera component that flies along
with ArduPilot (SITL, or a real flight over a simulated world) and reports the readings the
simulated vehicles would report, so online mode and the belief map work on real autopilots.

Wiring (docs/detector.md): the detector connects to the vehicle's companion port (ArduPilot
SERIAL2; any connection string) as component 100 (MAV_COMP_ID_CAMERA) of the vehicle's own
system id. It sends a camera HEARTBEAT (MAV_TYPE_CAMERA, MAV_AUTOPILOT_INVALID) every second and
asks the autopilot for GLOBAL_POSITION_INT at `POSITION_HZ` (MAV_CMD_SET_MESSAGE_INTERVAL, or
REQUEST_DATA_STREAM when that is refused: ArduCopter sends a companion port no position until
asked), again whenever positions stop. ArduPilot forwards the detector's messages to the ground
station with its ids, and the station's COMMAND_LONG to (system, 100) to the detector.

The world is the one `gcs fly --sim` simulates (`World`): the fleet frame at the first UAV's
airport, the plan's grid as the sensor grid, the plan's targets; the sensor is `sim.physics.sensor`'s
`DownwardSensor` with the noise of `planner.sensor_noise` per (seed, UAV, cell, visit). So on
one seed the detector reports what the simulated vehicle flying the same track reports, with
the same CAMERA_IMAGE_CAPTURED (`sim.autopilot.telemetry.reading_message`; image indices from 0) and
STATUSTEXT for a positive reading, and answers MAV_CMD_REQUEST_MESSAGE(263, index) for a lost
one with COMMAND_ACK and the reading again.

The simulated vehicle moves its sensor in steps of 0.1 s (1 m at 10 m/s); positions arrive every
0.2 s, so `Detector` walks the straight track between two reports in steps of at most `STEP_M`
(reports further apart than `MAX_GAP_S` of vehicle time are a jump, not a track)."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Sequence
from contextlib import AsyncExitStack, suppress
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gcs.links import AUTOPILOT_COMPONENT_ID, CommandError, LinkError, MavLink, MAVMessage, SigningKey, mavlink
from planner.georef import LocalFrame
from sim.autopilot.telemetry import reading_message, reading_text
from sim.physics.sensor import DownwardSensor, Observation, SensorConfig

if TYPE_CHECKING:
    from gcs.plans.plan_folder import FleetPlan
    from gcs.plans.planning import AreaSetup

__all__ = ["CAMERA_COMPONENT_ID", "Detector", "Fix", "World", "run_detectors", "serve"]

CAMERA_COMPONENT_ID = mavlink.MAV_COMP_ID_CAMERA
POSITION_HZ = 5.0
STEP_M = 1.0
MAX_GAP_S = 1.0
STALE_S = 3.0
HEARTBEAT_PERIOD_S = 1.0


@dataclass(frozen=True)
class World:
    """What the simulated fleet of a plan senses: its local frame (at the airport of the lowest
    UAV id, where `gcs fly --sim` puts vehicle 1), the sensor grid's south-west corner
    (`grid_origin`, lat/lon), the cell size and the true targets (cell centres, lat/lon)."""

    frame: LocalFrame
    grid_origin: tuple[float, float]
    cell_size_m: float
    targets: tuple[tuple[float, float], ...]

    @classmethod
    def of_plan(cls, plan: FleetPlan) -> World:
        """The world of a plan folder (`gcs.plans.plan_folder.load_plan_dir`)."""
        first = plan.uavs[min(plan.uavs)].airport_lat_lon
        corner = plan.frame.local2geodetic(plan.grid.east0_m, plan.grid.north0_m)
        return cls(LocalFrame(*first), (float(corner[0]), float(corner[1])), plan.cell_size_m,
                   tuple(plan.cell_lat_lon(x, y) for x, y in plan.targets))

    @classmethod
    def of_area(cls, setup: AreaSetup) -> World:
        """The world of an area file as `gcs plan --area` lays it out (the same grid and target
        cells as the plan folder it writes), without planning."""
        area, first = setup.area, setup.source.airports[0]
        corner = area.frame.local2geodetic(area.grid.east0_m, area.grid.north0_m)
        targets = area.cells_lonlat(setup.search.scenario.targets)
        return cls(LocalFrame(first.lat_deg, first.lon_deg), (float(corner[0]), float(corner[1])),
                   area.grid.cell_size_m, tuple((float(lat), float(lon)) for lat, lon in targets))

    def sensor_config(self, pc: float, pf: float) -> SensorConfig:
        return SensorConfig(cell_size_m=self.cell_size_m, pc=pc, pf=pf)

    def sensor(self, uav_id: int, *, seed: int, pc: float, pf: float) -> DownwardSensor:
        """UAV `uav_id`'s sensor: the one the simulated fleet gives vehicle `uav_id`."""
        return DownwardSensor(self.sensor_config(pc, pf), self.frame, self.targets, seed=seed, vehicle_id=uav_id,
                              origin_en=self.frame.geodetic2en(*self.grid_origin))


@dataclass(frozen=True, slots=True)
class Fix:
    """One position report: vehicle time, position, altitude AMSL and above home."""

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    relative_alt_m: float

    @classmethod
    def of(cls, msg: MAVMessage) -> Fix:
        """From GLOBAL_POSITION_INT."""
        return cls(msg.time_boot_ms / 1000.0, msg.lat / 1e7, msg.lon / 1e7, msg.alt / 1000.0, msg.relative_alt / 1000.0)


class Detector:
    """One vehicle's detector, free of transport: messages in (`handle`), messages to send out."""

    def __init__(self, sensor: DownwardSensor, sysid: int, component: int = CAMERA_COMPONENT_ID) -> None:
        self.sensor = sensor
        self.sysid = sysid
        self.component = component
        self.captures: list[MAVMessage] = []  # by image index, to send again when asked
        self.positions = 0
        self._last: tuple[Fix, tuple[float, float]] | None = None

    @property
    def observations(self) -> list[Observation]:
        return self.sensor.observations

    def heartbeat(self) -> MAVMessage:
        return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                 mavlink.MAV_STATE_ACTIVE, 3)

    def handle(self, msg: MAVMessage) -> list[MAVMessage]:
        """Positions from the vehicle's autopilot and commands addressed to this component."""
        kind = msg.get_type()
        if kind == "GLOBAL_POSITION_INT":
            if (msg.get_srcSystem(), msg.get_srcComponent()) == (self.sysid, AUTOPILOT_COMPONENT_ID):
                return self.position(Fix.of(msg))
        elif kind in ("COMMAND_LONG", "COMMAND_INT"):
            if (msg.target_system, msg.target_component) == (self.sysid, self.component):
                return self.command(msg)
        return []

    def position(self, fix: Fix) -> list[MAVMessage]:
        """The readings (CAMERA_IMAGE_CAPTURED, then STATUSTEXT when positive) of the track from
        the last report to this one."""
        self.positions += 1
        if fix.lat_deg == 0.0 and fix.lon_deg == 0.0:  # no GPS origin yet
            self._last = None
            return []
        here = self.sensor.frame.geodetic2en(fix.lat_deg, fix.lon_deg)
        last, self._last = self._last, (fix, here)
        if last is None or not 0.0 < fix.time_s - last[0].time_s <= MAX_GAP_S:
            last = (fix, here)  # the first report, or a jump: only this point
        (fix0, (e0, n0)), (e1, n1) = last, here
        steps = max(1, math.ceil(math.hypot(e1 - e0, n1 - n0) / STEP_M))
        out = []
        for k in range(1, steps + 1):
            f = k / steps
            alt_m = fix0.alt_m + f * (fix.alt_m - fix0.alt_m)
            rel_m = fix0.relative_alt_m + f * (fix.relative_alt_m - fix0.relative_alt_m)
            obs = self.sensor.update(e0 + f * (e1 - e0), n0 + f * (n1 - n0), rel_m,
                                     fix0.time_s + f * (fix.time_s - fix0.time_s))
            if obs is None:
                continue
            self.captures.append(reading_message(obs, self.sensor.config, alt_m, rel_m))
            out.append(self.captures[-1])
            if obs.reported:
                out.append(mavlink.MAVLink_statustext_message(mavlink.MAV_SEVERITY_NOTICE, reading_text(obs).encode()))
        return out

    def command(self, msg: MAVMessage) -> list[MAVMessage]:
        """COMMAND_ACK to every command addressed here; MAV_CMD_REQUEST_MESSAGE(263, index) is
        answered with the reading too (DENIED for an index not taken yet), others UNSUPPORTED."""
        result, extra = mavlink.MAV_RESULT_UNSUPPORTED, []
        captured = mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED
        if msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE and int(msg.param1) == captured:
            index = int(msg.param2)
            if 0 <= index < len(self.captures):
                result, extra = mavlink.MAV_RESULT_ACCEPTED, [self.captures[index]]
            else:
                result = mavlink.MAV_RESULT_DENIED
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        ack = mavlink.MAVLink_command_ack_message(msg.command, result, 0, 0, *sender)
        return [ack, *extra]


async def serve(link: MavLink, detector: Detector, say: Callable[[str], None] = lambda line: None) -> None:
    """Run `detector` on an open link (opened with the detector's system and component ids and
    without the station heartbeat) until cancelled: answer what arrives, send the camera
    heartbeat, and once the autopilot is heard keep its position stream coming."""
    heard = asyncio.Event()

    def receive(msg: MAVMessage) -> None:
        if msg.get_srcSystem() == detector.sysid and msg.get_srcComponent() == AUTOPILOT_COMPONENT_ID:
            heard.set()
        for out in detector.handle(msg):
            link.send(out)
            if out.get_type() == "STATUSTEXT":
                say(out.text if isinstance(out.text, str) else out.text.decode())

    link.subscribe(receive)
    beat = asyncio.create_task(_heartbeats(link, detector), name=f"detector heartbeat {link.name}")
    try:
        await heard.wait()
        told = False
        while True:
            await _ask_for_positions(link, detector, say)
            positions = detector.positions
            await asyncio.sleep(STALE_S)
            while detector.positions > positions:  # still coming
                positions, told = detector.positions, False
                await asyncio.sleep(STALE_S)
            if not told:
                say(f"no position from the autopilot for {STALE_S:g} s: asking again")
                told = True
    finally:
        beat.cancel()


async def _heartbeats(link: MavLink, detector: Detector) -> None:
    while True:
        link.send(detector.heartbeat())
        await asyncio.sleep(HEARTBEAT_PERIOD_S)


async def _ask_for_positions(link: MavLink, detector: Detector, say: Callable[[str], None]) -> None:
    """MAV_CMD_SET_MESSAGE_INTERVAL for GLOBAL_POSITION_INT on this link; REQUEST_DATA_STREAM
    (POSITION) when the autopilot refuses it or does not answer."""
    try:
        await link.command(detector.sysid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                           mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 1e6 / POSITION_HZ, timeout_s=1.0, retries=1)
        return
    except CommandError as exc:
        say(f"position stream not set ({exc}); asking with REQUEST_DATA_STREAM")
    link.send(mavlink.MAVLink_request_data_stream_message(detector.sysid, AUTOPILOT_COMPONENT_ID,
                                                          mavlink.MAV_DATA_STREAM_POSITION, round(POSITION_HZ), 1))


async def run_detectors(pairs: Sequence[tuple[str, Detector]], stop: asyncio.Event, *,
                        signing: SigningKey | None = None, say: Callable[[int, str], None] = lambda uid, line: None
                        ) -> None:
    """Serve every (connection string, detector) pair, each on its own link, until `stop` is
    set; `LinkUnavailable` (one line for the user) when a link cannot be opened."""
    async with AsyncExitStack() as stack:
        tasks = []
        for connection, detector in pairs:
            link = await stack.enter_async_context(
                MavLink(connection, signing=signing, source_system=detector.sysid, source_component=detector.component,
                        heartbeat=False))
            link.on_status(lambda status, uid=detector.sysid: say(uid, str(status)))
            say(detector.sysid, f"detector on {connection} as system {detector.sysid} component {detector.component}")
            tasks.append(asyncio.create_task(serve(link, detector, lambda line, uid=detector.sysid: say(uid, line)),
                                             name=f"detector {detector.sysid}"))
        stopping = asyncio.create_task(stop.wait())
        try:
            await asyncio.wait([stopping, *tasks], return_when=asyncio.FIRST_COMPLETED)
            for task in tasks:
                if task.done():
                    task.result()  # a detector that failed ends them all, with its error
        finally:
            for task in (stopping, *tasks):
                task.cancel()
            for task in tasks:
                with suppress(asyncio.CancelledError, LinkError):
                    await task
