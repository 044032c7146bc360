"""Helpers for flights on real autopilots: `gcs fly` as the user runs it (its output streamed), and
the flight read back from its Rerun recording (tracks, stages from the event log), with the
checks every flight test makes: landed at its own airport, never inside a no-fly cell, stages in
order."""

from __future__ import annotations

import asyncio
import json
import math
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from shapely.geometry import Polygon

from gcs.autopilots.mission_transfer import MissionType, WireItem, download
from gcs.links import MavLink, mavlink
from gcs.plans.area_file import read_area_file
from gcs.plans.plan_folder import FleetPlan, load_plan_dir
from gcs.recording.flight import FLIGHT_TIME
from gcs.recording.plan import read_recording
from tests.peers.recorder import SpareRecorder

STAGES = ["preparing", "uploading", "arming", "search"]


def fly(plan: Path, connections: list[str] | int, *extra: str, timeout: float = 600,
        on_line=None, orders: tuple[tuple[str, str, float], ...] = (),
        ctrl_c_on: tuple[str, float] | None = None) -> subprocess.CompletedProcess:
    """`gcs fly` on the plan over the links given (a port number: `udpin:127.0.0.1:PORT`);
    `on_line(line)` sees its output as it comes; `orders`: (text, order, after_s), the operator
    typing `order` `after_s` seconds after a line with `text` was printed; `ctrl_c_on`: (text,
    after_s), the operator's Ctrl-C (SIGINT) `after_s` seconds after a line with `text`."""
    if isinstance(connections, int):
        connections = [f"udpin:127.0.0.1:{connections}"]
    args = [sys.executable, "-m", "gcs.cli", "fly", "--plan", str(plan), "--rrd", str(plan / "flight.rrd"),
            *(arg for c in connections for arg in ("--connect", c)), *extra]
    if orders:
        args.append("--stdin-orders")
        pending = list(orders)

        def type_order(order: str) -> None:
            if process.poll() is None:
                process.stdin.write(order + "\n")
                process.stdin.flush()

        def type_orders(line: str, user=on_line) -> None:
            for entry in list(pending):
                if entry[0] in line:
                    pending.remove(entry)
                    threading.Timer(entry[2], type_order, (entry[1],)).start()
            if user is not None:
                user(line)

        on_line = type_orders
    if ctrl_c_on is not None:
        def ctrl_c() -> None:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)

        def press_ctrl_c(line: str, user=on_line, pressed=[]) -> None:  # noqa: B006 (the one press)
            if ctrl_c_on[0] in line and not pressed:
                pressed.append(threading.Timer(ctrl_c_on[1], ctrl_c))
                pressed[0].start()
            if user is not None:
                user(line)

        on_line = press_ctrl_c
    process = subprocess.Popen(args, stdin=subprocess.PIPE if orders else None, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    # killed at the deadline even when it falls silent, and whatever ends the test (pytest-timeout
    # raising in the middle of a read): a station left running would hold its worker forever
    deadline = threading.Timer(timeout, process.kill)
    deadline.start()
    try:
        err: list[str] = []
        reader = threading.Thread(target=lambda: err.append(process.stderr.read()), daemon=True)
        reader.start()
        out = []
        for line in process.stdout:
            out.append(line)
            if on_line is not None:
                on_line(line)
        process.wait(30)
        reader.join(5)
    finally:
        deadline.cancel()
        if process.poll() is None:
            process.kill()
            process.wait(30)
        for stream in (process.stdin, process.stdout, process.stderr):
            if stream is not None:
                stream.close()
    return subprocess.CompletedProcess(args, process.returncode, "".join(out), "".join(err))


def fly_with_a_dropout(plan: Path, connections: list[str] | int, relay, uav_id: int, *extra: str,
                       after_s: float, silent_s: float) -> subprocess.CompletedProcess:
    """`fly`, with `relay` (a `tests.peers.relay.UdpRelay`) silent for `silent_s` of wall time from
    `after_s` after UAV `uav_id` started its search."""
    searching = threading.Event()

    def drop_out() -> None:
        if searching.wait(120):
            time.sleep(after_s)
            relay.silence()
            time.sleep(silent_s)
            relay.restore()

    thread = threading.Thread(target=drop_out, daemon=True)
    thread.start()
    def on_line(line: str) -> None:
        if line.split("] ", 1)[-1].startswith(f"UAV {uav_id}: search"):
            searching.set()

    done = fly(plan, connections, *extra, on_line=on_line)
    thread.join(5)
    return done


def ctrl_c_while_its_way_home_is_lost(plan: Path, connection: str, recorder: SpareRecorder,
                                      uploads_lost: threading.Event, order_after_s: float,
                                      home: tuple[float, float], within_m: float = 5.0) -> None:
    """`gcs fly` on a one-vehicle plan whose uploads the radio loses (`uploads_lost`, set here as
    the search starts: a relay's `tests.peers.relay.losing_uploads`): the operator orders UAV 1
    home `order_after_s` seconds into its search and presses Ctrl-C a second after it turned
    home, its return leg not uploaded. The station must end (exit 130) with it commanded to the
    autopilot's RTL, not holding; `recorder` (its spare port) must see it land within `within_m`
    of `home`."""
    def on_line(line: str) -> None:
        if "UAV 1: search - mission started" in line:
            uploads_lost.set()

    done = fly(plan, [connection], orders=(("UAV 1: search", "r 1", order_after_s),), on_line=on_line,
               ctrl_c_on=("UAV 1: return - going home", 1.0))
    for _ in range(900):  # 90 s of wall time
        if recorder.flown.landed:
            break
        time.sleep(0.1)
    out = done.stdout
    assert done.returncode == 130, out[-3000:] + done.stderr
    stop = out.index("stopping: every vehicle in the air is sent home")
    assert "UAV 1: return - going home (order)" in out[:stop] and "UAV 1: return leg of" not in out, out[-3000:]
    assert "UAV 1: rtl - autopilot RTL" in out[stop:], out[-3000:]
    flown = recorder.flown
    assert flown.landed, f"still in the air 90 s after the station ended: {flown.positions[-1:]}"
    lat, lon, _alt = flown.positions[-1]
    away = math.hypot((lat - home[0]) * 111_319.49, (lon - home[1]) * 111_319.49 * math.cos(math.radians(lat)))
    assert away <= within_m, f"landed {away:.1f} m from its airport"


def bus_events(port: int, fleet: str, events: list, stop: threading.Event) -> threading.Thread:
    """Every UAV event of `fleet` on the MQTT bus at `port`, appended to `events` until `stop`."""
    import aiomqtt

    async def listen() -> None:
        try:
            async with aiomqtt.Client("127.0.0.1", port, identifier=f"{fleet}-test") as client:
                await client.subscribe(f"gcs/{fleet}/uav/+/event", qos=1)
                async for message in client.messages:
                    events.append(json.loads(message.payload))
                    if stop.is_set():
                        return
        except aiomqtt.MqttError:
            return  # the broker was stopped at the end of the test

    thread = threading.Thread(target=lambda: asyncio.run(asyncio.wait_for(listen(), 600)), daemon=True)
    thread.start()
    return thread


def metres(plan: FleetPlan, a, b) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)


def depth_in_no_fly_cell(plan: FleetPlan, lat: float, lon: float) -> float:
    """How far (m) a position lies inside a no-fly cell (0 when its cell is free)."""
    east, north = plan.local_m(lat, lon)
    g = plan.grid
    x, y = (east - g.east0_m) / g.cell_size_m, (north - g.north0_m) / g.cell_size_m
    ix, iy = int(math.floor(x)), int(math.floor(y))
    if not (0 <= ix < g.nx and 0 <= iy < g.ny) or not plan.no_fly[ix, iy]:
        return 0.0
    fx, fy = x - ix, y - iy
    return min(fx, 1 - fx, fy, 1 - fy) * g.cell_size_m


_STAGE_NAMES = ("connecting", "preparing", "uploading", "arming", "search", "return", "rtl", "landed", "lost", "failed")


def _stage_of(text: str) -> str | None:
    """The stage an event-log line announces ("arming", "return triggered (reason: battery): return ...")."""
    if text.startswith("return triggered"):
        return text.split("): ", 1)[-1].split(" ", 1)[0] if "): " in text else text.split(": ", 1)[1].split(" ")[0]
    word = text.split(" ", 1)[0]
    return word if word in _STAGE_NAMES else None


def recorded(plan_dir: Path) -> tuple[FleetPlan, dict[int, list], dict[int, list[str]]]:
    """Each UAV's recorded positions, and its stages in the order the event log announced them."""
    plan = load_plan_dir(plan_dir)
    rec = read_recording(plan_dir / "flight.rrd", FLIGHT_TIME)
    _, lines = rec.column("events", "TextLog:text")
    tracks, stages = {}, {}
    for uid in plan.uavs:
        _, positions = rec.column(f"geo/uav/{uid}", "GeoPoints:positions")
        tracks[uid] = [tuple(p[0]) for p in positions]
        prefix = f"UAV {uid}: "
        said = [_stage_of(line[0][len(prefix):]) for line in lines if line[0].startswith(prefix)]
        stages[uid] = [stage for stage in said if stage is not None]
    return plan, tracks, stages


def assert_landed_home_and_clear_of_no_fly(plan_dir: Path, max_from_airport_m: float, tolerance_m: float) -> dict:
    plan, tracks, stages = recorded(plan_dir)
    landed = {}
    for uid, task in plan.uavs.items():
        track = tracks[uid]
        assert len(track) > 20, f"UAV {uid}: too few recorded positions"
        assert max(metres(plan, p, task.airport_lat_lon) for p in track) > 2 * plan.cell_size_m  # it went searching
        landed[uid] = metres(plan, track[-1], task.airport_lat_lon)
        assert landed[uid] <= max_from_airport_m, f"UAV {uid} landed {landed[uid]:.1f} m from its airport"
        deepest = max(depth_in_no_fly_cell(plan, *p) for p in track)
        assert deepest <= tolerance_m, f"UAV {uid} went {deepest:.1f} m into a no-fly cell"
        seen = stages[uid]
        assert seen[:len(STAGES)] == STAGES and seen[-1] == "landed", f"UAV {uid} stages {seen}"
    return landed


#: How far a read-back fence vertex may sit from what was sent: the autopilots keep 1e-7 degree.
FENCE_STORED_DEG = 1.5e-7


def read_back_fence(connection: str, sysid: int = 1) -> list[tuple[bool, Polygon]]:
    """The polygons of the fence a vehicle holds (inclusion flag, lon/lat polygon), downloaded."""
    async def main() -> list[WireItem]:
        async with MavLink(connection) as link:
            await link.wait_for(sysid, "HEARTBEAT", timeout_s=30.0)
            return await download(link, sysid, MissionType.FENCE, timeout_s=1.0)

    items = asyncio.run(main())
    polygons, k = [], 0
    while k < len(items):
        n = int(items[k].param1)
        inclusion = items[k].command == mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
        polygons.append((inclusion, Polygon([(it.y / 1e7, it.x / 1e7) for it in items[k:k + n]])))
        k += n
    return polygons


def planned_fence(plan_dir: Path, uav_id: int = 1) -> list[tuple[bool, Polygon]]:
    """The polygons of a UAV's fence as its .plan carries them (and `gcs upload` sends them)."""
    doc = json.loads((plan_dir / f"uav{uav_id}.plan").read_text())
    return [(bool(p["inclusion"]), Polygon([(lon, lat) for lat, lon in p["polygon"]]))
            for p in doc["geoFence"]["polygons"]]


def assert_fence_holds_the_area(area_file: Path, fence: list[tuple[bool, Polygon]], capacity: int) -> None:
    """One valid inclusion polygon around the whole area, every no-fly zone inside a valid
    exclusion polygon, within the vehicle's `capacity` of vertices."""
    source = read_area_file(area_file)
    inclusions = [p for inclusion, p in fence if inclusion]
    exclusions = [p for inclusion, p in fence if not inclusion]
    assert sum(len(p.exterior.coords) - 1 for _, p in fence) <= capacity
    assert len(inclusions) == 1 and inclusions[0].is_valid
    assert inclusions[0].buffer(FENCE_STORED_DEG).covers(source.area)
    for zone in source.no_fly:
        assert any(p.is_valid and p.buffer(FENCE_STORED_DEG).covers(zone) for p in exclusions), zone.wkt
