"""`gcs fly` on real ArduCopter and ArduPlane SITL: each vehicle waits until it is ready, flies its
planned search in AUTO and lands at its own airport (the plane on its runway, after the landing
approach); a fast-draining battery brings its vehicle home early by fuel while the other keeps
searching; a vehicle that refuses to arm stays on the ground with ArduPilot's reason while the
other flies. Each test reads the flight back from its Rerun recording: where each vehicle
landed, that no recorded position entered a no-fly cell, and that the stages came in order."""

from __future__ import annotations

import asyncio
import json
import math
import re
import subprocess
import sys
import threading
import time
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pytest

from gcs.fleet import FleetPlan, load_plan_dir
from gcs.flight_recording import FLIGHT_TIME
from gcs.recording import read_recording
from tests.bus.helpers import Mosquitto
from tests.peers.ardupilot import ArduPilotSitl, free_udp_port
from tests.peers.relay import UdpRelay
from tests.peers.site import COPTERS, PLANE, Site

pytestmark = pytest.mark.autopilot

STAGES = ["preparing", "uploading", "arming", "search"]


COPTER_SPEED = ("--cruise-speed", "5")  # ArduCopter's average on 30 m cells: it slows down at every waypoint


def _fly(plan: Path, port: int, *extra: str, timeout: float = 600, on_line=None) -> subprocess.CompletedProcess:
    """`gcs fly` on the plan over one UDP port; `on_line(line)` sees its output as it comes."""
    args = [sys.executable, "-m", "gcs.cli", "fly", "--plan", str(plan), "--connect", f"udpin:127.0.0.1:{port}",
            "--rrd", str(plan / "flight.rrd"), *extra]
    with subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as process:
        err: list[str] = []
        reader = threading.Thread(target=lambda: err.append(process.stderr.read()), daemon=True)
        reader.start()
        out = []
        deadline = time.monotonic() + timeout
        for line in process.stdout:
            out.append(line)
            if on_line is not None:
                on_line(line)
            if time.monotonic() > deadline:
                process.kill()
        process.wait(timeout)
        reader.join(5)
    return subprocess.CompletedProcess(args, process.returncode, "".join(out), "".join(err))


def _metres(plan: FleetPlan, a, b) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)


def _depth_in_no_fly_cell(plan: FleetPlan, lat: float, lon: float) -> float:
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


def _recorded(plan_dir: Path) -> tuple[FleetPlan, dict[int, list], dict[int, list[str]]]:
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


def _assert_landed_home_and_clear_of_no_fly(plan_dir: Path, max_from_airport_m: float, tolerance_m: float) -> dict:
    plan, tracks, stages = _recorded(plan_dir)
    landed = {}
    for uid, task in plan.uavs.items():
        track = tracks[uid]
        assert len(track) > 20, f"UAV {uid}: too few recorded positions"
        assert max(_metres(plan, p, task.airport_lat_lon) for p in track) > 2 * plan.cell_size_m  # it went searching
        landed[uid] = _metres(plan, track[-1], task.airport_lat_lon)
        assert landed[uid] <= max_from_airport_m, f"UAV {uid} landed {landed[uid]:.1f} m from its airport"
        deepest = max(_depth_in_no_fly_cell(plan, *p) for p in track)
        assert deepest <= tolerance_m, f"UAV {uid} went {deepest:.1f} m into a no-fly cell"
        seen = stages[uid]
        assert seen[:len(STAGES)] == STAGES and seen[-1] == "landed", f"UAV {uid} stages {seen}"
    return landed


def test_a_copter_flies_its_search_and_lands_at_its_airport(tmp_path):
    site = Site(COPTERS.airports[:1])
    plan_dir = site.plan(tmp_path)
    with ArduPilotSitl("copter", home=site.home(0)) as sitl:
        done = _fly(plan_dir, sitl.gcs_port, *COPTER_SPEED)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert "ready: GPS fix" in done.stdout and "mission verified" in done.stdout
    landed = _assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=3.0, tolerance_m=3.0)
    assert landed[1] <= 3.0
    assert "1/1 landed" in done.stdout
    row = next(line.split() for line in done.stdout.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and row[5] == "plan"  # it flew its whole search and the plan's own way home


def test_a_plane_takes_off_along_its_runway_searches_and_lands_on_it(tmp_path):
    plan_dir = PLANE.plan(tmp_path, "--vehicle", "plane", "--approach-m", "400")
    plan = json.loads((plan_dir / "plan.json").read_text())
    assert plan["uavs"][0]["approach"] is not None
    with ArduPilotSitl("plane", home=PLANE.home(0), params={"NAVL1_PERIOD": 10}) as sitl:
        done = _fly(plan_dir, sitl.gcs_port, "--cruise-speed", "22")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert "RTL_AUTOLAND set to 2" in done.stdout
    fleet_plan, tracks, _ = _recorded(plan_dir)
    # on the runway: along its axis (north) within the measured stopping distance, close to the line
    east, north = np.subtract(fleet_plan.local_m(*tracks[1][-1]), fleet_plan.local_m(*fleet_plan.uavs[1].airport_lat_lon))
    assert abs(east) <= 5.0 and -30.0 <= north <= 5.0, (east, north)
    _assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=30.0, tolerance_m=15.0)


def _bus_events(port: int, fleet: str, events: list, stop: threading.Event) -> threading.Thread:
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


def test_a_fast_draining_battery_brings_its_copter_home_first_and_the_other_searches_on(tmp_path):
    plan_dir = COPTERS.plan(tmp_path)
    port = free_udp_port()
    (tmp_path / "mosquitto").mkdir()
    broker = Mosquitto(tmp_path / "mosquitto")
    broker.start()
    events: list = []
    stop = threading.Event()
    try:
        listener = _bus_events(broker.port, "drain", events, stop)
        with ExitStack() as stack:  # both vehicles push to one UDP port: one link for the fleet
            stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port))
            stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=port,
                                              params={"BATT_CAPACITY": 2000}))  # drains 1.65x as fast
            done = _fly(plan_dir, port, *COPTER_SPEED, "--mqtt", f"mqtt://127.0.0.1:{broker.port}", "--fleet", "drain")
        stop.set()
        listener.join(5)
    finally:
        broker.stop()
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert "UAV 2: battery" in done.stdout and "the way home needs" in done.stdout
    at_landing = {int(m.group(1)): int(m.group(2)) for m in re.finditer(r"UAV (\d): landed - battery (\d+)%", done.stdout)}
    assert at_landing[2] >= 25  # the 30 % reserve, give or take the whole percent ArduPilot reports and the descent
    landed = _assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=3.0, tolerance_m=3.0)
    assert set(landed) == {1, 2}
    by_uav: dict[int, list] = {1: [], 2: []}
    for e in events:
        by_uav[e["uav"]].append(e)
    for uid, seq in by_uav.items():
        assert [e["seq"] for e in seq] == sorted(e["seq"] for e in seq) and seq, f"UAV {uid} events out of order"
        kinds = [e["kind"] for e in seq]
        assert "takeoff" in kinds and kinds[-1] == "landed" and kinds.index("takeoff") < kinds.index("landed")
    returns = [e for e in by_uav[2] if e["kind"] == "return"]
    assert returns and returns[0]["reason"] == "battery"
    assert not [e for e in by_uav[1] if e["kind"] == "return"]  # UAV 1 flew its plan's own return
    land_time = {uid: next(e["t_s"] for e in seq if e["kind"] == "landed") for uid, seq in by_uav.items()}
    assert land_time[2] < land_time[1]


def test_a_vehicle_that_refuses_to_arm_stays_on_the_ground_with_its_reason_while_the_other_flies(tmp_path):
    plan_dir = COPTERS.plan(tmp_path)
    port = free_udp_port()
    with ExitStack() as stack:
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port))
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=port,
                                          params={"BATT_ARM_VOLT": 13.0}))  # the sim battery gives 12.6 V
        done = _fly(plan_dir, port, *COPTER_SPEED, "--no-rrd", "--arm-timeout", "10")
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr
    assert "UAV 2: arming refused: Arm: Battery 1 below minimum arming voltage" in done.stdout
    assert "UAV 2: failed - cannot arm" in done.stdout and "left on the ground" in done.stdout
    assert "UAV 1: landed" in done.stdout and "1/2 landed" in done.stdout


def test_a_vehicle_whose_link_goes_silent_flies_on_by_itself_and_never_stalls_the_other(tmp_path):
    """UAV 2's radio drops out for 10 s of wall time (100 s at the SITL speed-up) mid-search: the
    station marks it lost and keeps flying UAV 1; ArduPilot (GCS failsafe off, its default) flies
    its mission on; when the link comes back the station picks it up again; both land at home."""
    plan_dir = COPTERS.plan(tmp_path)
    port = free_udp_port()
    with UdpRelay(port) as relay, ExitStack() as stack:
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port))
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=relay.port))

        def drop_out() -> None:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not (plan_dir / "search-started").exists():
                time.sleep(0.1)
            time.sleep(3.0)
            relay.silence()
            time.sleep(10.0)
            relay.restore()

        flight = threading.Thread(target=drop_out, daemon=True)
        flight.start()
        done = _fly(plan_dir, port, *COPTER_SPEED, "--lost-giveup", "60", on_line=lambda line: (
            (plan_dir / "search-started").touch() if "UAV 2: search" in line else None))
        flight.join(5)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert relay.dropped > 50
    assert "UAV 2: lost - no telemetry" in done.stdout and "UAV 2: search - link back" in done.stdout
    assert "UAV 1: lost" not in done.stdout
    _, _, stages = _recorded(plan_dir)
    assert "lost" in stages[2] and stages[2][-1] == "landed" and "lost" not in stages[1]
    _assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=3.0, tolerance_m=3.0)
