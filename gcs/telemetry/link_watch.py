"""Watching vehicles straight over their MAVLink links, without a plan or a bus: every autopilot
heard gets a `VehicleStatus`, is asked once for the telemetry a station needs (ArduCopter sends
none until asked), and appears in a table (`render_vehicles`). `gcs watch --connect` uses it."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Sequence

from gcs.links import AUTOPILOT_COMPONENT_ID, CommandError, MavLink, SigningKey, mavlink, open_links
from gcs.telemetry.status import VehicleStatus

__all__ = ["LinkWatcher", "render_vehicles"]


class LinkWatcher:
    """An async context manager over `connections`: `vehicles` maps system id -> status."""

    def __init__(self, connections: Sequence[str], *, signing: SigningKey | None = None) -> None:
        self.connections = list(connections)
        self.signing = signing
        self.vehicles: dict[int, VehicleStatus] = {}
        self.links: list[MavLink] = []
        self.notes: list[str] = []
        self._asked: set[int] = set()
        self._tasks: set[asyncio.Task] = set()
        self._context = None

    async def __aenter__(self) -> LinkWatcher:
        self._context = open_links(self.connections, signing=self.signing)
        self.links = await self._context.__aenter__()
        for link in self.links:
            link.subscribe(lambda msg, link=link: self._on_message(link, msg))
            link.on_status(lambda status: self.notes.append(str(status)))
        return self

    async def __aexit__(self, *exc: object) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        await self._context.__aexit__(*exc)

    def _on_message(self, link: MavLink, msg: mavlink.MAVLink_message) -> None:
        if msg.get_srcComponent() != AUTOPILOT_COMPONENT_ID:
            return
        if msg.get_type() == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_GCS:
            return
        uid = msg.get_srcSystem()
        status = self.vehicles.setdefault(uid, VehicleStatus(uid))
        status.update(msg, time.monotonic())
        if status.autopilot is not None and uid not in self._asked:
            self._asked.add(uid)
            task = asyncio.get_running_loop().create_task(self._ask_streams(link, status))
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)

    async def _ask_streams(self, link: MavLink, status: VehicleStatus) -> None:
        for msg_id, hz in status.autopilot.streams_hz().items():
            try:
                await link.command(status.uav_id, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, retries=2)
            except CommandError:
                status.unsupported_streams.add(msg_id)


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def render_vehicles(watcher: LinkWatcher, now: float | None = None) -> str:
    """One row per vehicle heard: autopilot and type, mode and armed state, position, altitude,
    battery, GPS, what it still waits for before it can fly, and its last message."""
    now = time.monotonic() if now is None else now
    rows = [f"{'sys':>3} {'autopilot':<9} {'type':<6} {'mode':<10} {'armed':<5} {'lat':>11} {'lon':>12} {'alt m':>6} "
            f"{'batt %':>6} {'gps':>4} {'heard s':>7}  waiting for / last message"]
    for uid, st in sorted(watcher.vehicles.items()):
        kind = "plane" if st.fixed_wing else "copter" if st.mav_type is not None else "-"
        position = st.has_position
        heard = now - st.last_heard_s if st.last_heard_s is not None else None
        missing = st.waiting_for()
        rows.append(f"{uid:>3} {(st.autopilot.value if st.autopilot else '-'):<9} {kind:<6} {st.mode_name[:10]:<10} "
                    f"{'yes' if st.armed else 'no':<5} {_num(st.lat_deg if position else None, '.6f'):>11} "
                    f"{_num(st.lon_deg if position else None, '.6f'):>12} {st.rel_alt_m:>6.1f} "
                    f"{_num(st.battery_pct, '.0f'):>6} {_num(st.gps_fix_type, 'd'):>4} {_num(heard, '.1f'):>7}  "
                    + ("waiting for " + ", ".join(missing) if missing else "ready")
                    + (f"; {st.last_text}" if st.last_text else ""))
    if len(rows) == 1:
        rows.append("(no vehicle heard yet)")
    return "\n".join(rows + watcher.notes[-5:])
