"""Mission transfer against real ArduCopter and ArduPlane SITL: a planned mission uploads and
reads back over UDP and TCP, signed and unsigned; refusals (no room, a bad frame) come back as
one clear line with the vehicle's own words, and a refused list is not left half-replaced."""

from __future__ import annotations

import asyncio
import json
import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import MissionTransferError, MissionType, WireItem, download, upload_verified
from gcs.links import MavLink, SigningKey, mavlink
from gcs.missions.fence import uav_fence
from gcs.plans.area_file import read_area_file
from gcs.plans.plan_folder import fence_wire
from tests.gcs.autopilots.flights import assert_fence_holds_the_area, read_back_fence
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.process import SITL_WORKER
from tests.peers.site import COPTERS, PLANE, WILDLAND, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

SITE = Site(COPTERS.airports[:1])
SITES = {"copter": SITE, "plane": PLANE}
SPEEDUP = 20.0  # the highest the flight tests pass at; an upload waits only for the vehicle's home
KEY = SigningKey.from_passphrase("gcs autopilot tests")


def _gcs(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def plans(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("site")
    return {"copter": SITE.plan(root / "copter"), "plane": PLANE.plan(root / "plane", "--vehicle", "plane")}


async def _ready(link: MavLink) -> None:
    """Until ArduPilot has a home (its mission storage is ready then; before, it holds 0 items)."""
    await link.wait_for(1, "HEARTBEAT", timeout_s=30.0)
    await link.command(1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION, 1e6)
    assert await link.wait_for(1, "HOME_POSITION", timeout_s=30.0) is not None, "the SITL never set its home"


def _waypoints(n: int, frame: int = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT) -> list[WireItem]:
    lat, lon = SITE.centre
    home = WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0)
    return [home] + [WireItem.at(i, frame, mavlink.MAV_CMD_NAV_WAYPOINT, lat + i * 1e-5, lon, 30.0 + i % 7)
                     for i in range(1, n)]


@pytest.mark.parametrize("vehicle", ["copter", "plane"])
def test_signed_upload_after_provisioning_and_unsigned_station_told_why(plans, vehicle):
    with ArduPilotSitl(vehicle, home=SITES[vehicle].home(0), speedup=SPEEDUP) as sitl:
        provisioned = _gcs("signing", "--connect", sitl.tcp_connection, "--uav", "1", "--signing-passphrase",
                           "gcs autopilot tests", "--wait", "15")
        assert provisioned.returncode == 0, provisioned.stdout + provisioned.stderr
        # SERIAL0 is ArduPilot's USB port, which it trusts unsigned; the UDP link below must refuse
        assert f"signs with key {KEY.fingerprint}; this link still accepts unsigned" in provisioned.stdout
        signed = _gcs("upload", "--plan", str(plans[vehicle]), "--connect", sitl.udp_connection,
                      "--signing-passphrase", "gcs autopilot tests", "--connect-timeout", "30")
        assert signed.returncode == 0, signed.stdout + signed.stderr
        unsigned = _gcs("upload", "--plan", str(plans[vehicle]), "--connect", sitl.udp_connection,
                        "--connect-timeout", "30")
        assert unsigned.returncode == 1
        assert "signs its MAVLink messages" in unsigned.stdout and "--signing-key" in unsigned.stdout
    assert "UAV 1: verified: mission" in signed.stdout


def test_refusals_are_named_with_the_vehicles_words_and_leave_no_mixed_mission():
    async def main():
        with ArduPilotSitl("copter", home=SITE.home(0), speedup=SPEEDUP) as sitl:
            async with MavLink(sitl.tcp_connection) as link:
                await _ready(link)
                good = _waypoints(6)
                await upload_verified(link, 1, good, Autopilot.ARDUPILOT)
                with pytest.raises(MissionTransferError) as full:
                    await upload_verified(link, 1, _waypoints(700), Autopilot.ARDUPILOT)
                assert full.value.result == mavlink.MAV_MISSION_NO_SPACE and full.value.capacity == 650
                assert "700 items sent, the vehicle holds at most 650 items" in str(full.value)
                assert len(await download(link, 1)) == 6  # refused at the COUNT: the old mission is intact

                bad = _waypoints(6)
                bad[3] = WireItem.at(3, mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_CMD_NAV_WAYPOINT, 1.0, 2.0, 3.0)
                with pytest.raises(MissionTransferError) as frame:
                    await upload_verified(link, 1, bad, Autopilot.ARDUPILOT)
                assert frame.value.result == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
                assert "MAV_MISSION_UNSUPPORTED_FRAME" in str(frame.value) and "cleared" in str(frame.value)
                assert len(await download(link, 1)) <= 1  # at most home: items 1-2 new and 3-5 old were not left

    asyncio.run(main())


@pytest.fixture(scope="module")
def shared_sitl() -> Iterator[Callable[[str], ArduPilotSitl]]:
    """One SITL per vehicle type, started when first asked for and shared by the upload tests (an
    upload replaces the whole mission, fence and rally points, and changes nothing else); the
    tests that share one are in one xdist group, so in one process. They are the module's last
    tests, the plane's last of all: a shared SITL runs (at speed-up 20, some two thirds of a core)
    until the module ends, and while the signing and refusal tests flew SITLs of their own after
    them, the two shared ones idled beside those for about 50 s (ci71: some 60 CPU-s)."""
    started: dict[str, ArduPilotSitl] = {}

    def get(vehicle: str) -> ArduPilotSitl:
        if vehicle not in started:  # kept once started: where it cannot be (no peers: a skip), each test says so
            started[vehicle] = ArduPilotSitl(vehicle, home=SITES[vehicle].home(0), speedup=SPEEDUP).start()
        return started[vehicle]

    yield get
    for sitl in started.values():
        sitl.stop()


def test_a_wildland_fence_too_big_for_the_copter_is_fitted_and_read_back_around_the_area(tmp_path, shared_sitl):
    """The issue's wildland: a traced outline of 96 vertices and a round no-fly zone of 28, 124
    fence vertices where ArduCopter holds 69 in one polygon. As drawn, ArduCopter refuses it
    (the station used to fly without a fence then); planned, it is fitted and uploaded whole, and
    the fence the copter reads back holds the area and the zone. A plan folder made before the
    fitting (its .plan carrying all 124) is fitted by the station at upload."""
    plan = WILDLAND.plan(tmp_path / "wild")
    area_file = tmp_path / "wild" / "site.geojson"
    source = read_area_file(area_file)
    drawn = uav_fence(source.area, source.no_fly)
    assert drawn.vertices == 124
    drawn_rings = [(True, r[:-1]) for r in drawn.inclusion] + [(False, r[:-1]) for r in drawn.exclusion]
    sitl = shared_sitl("copter")

    async def refused() -> MissionTransferError:
        async with MavLink(sitl.tcp_connection) as link:
            await _ready(link)
            with pytest.raises(MissionTransferError) as full:
                await upload_verified(link, 1, fence_wire(drawn_rings), Autopilot.ARDUPILOT, MissionType.FENCE)
            return full.value

    refusal = asyncio.run(refused())
    assert refusal.result == mavlink.MAV_MISSION_NO_SPACE and refusal.capacity == 70

    done = _gcs("upload", "--plan", str(plan), "--connect", sitl.tcp_connection, "--connect-timeout", "30")
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r"UAV 1: verified: mission \d+ items \(0 re-sends\), fence 64 items", done.stdout), done.stdout
    assert_fence_holds_the_area(area_file, read_back_fence(sitl.tcp_connection), 64)

    doc = json.loads((plan / "uav1.plan").read_text())
    doc["geoFence"]["polygons"] = [{"inclusion": inclusion, "polygon": [list(p) for p in ring], "version": 1}
                                   for inclusion, ring in drawn_rings]
    (plan / "uav1.plan").write_text(json.dumps(doc))
    done = _gcs("upload", "--plan", str(plan), "--connect", sitl.tcp_connection, "--connect-timeout", "30")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "UAV 1: fence: 124 vertices simplified to 68, at most" in done.stdout, done.stdout  # 28 + 40 in 560 bytes
    assert "fence 68 items" in done.stdout
    assert_fence_holds_the_area(area_file, read_back_fence(sitl.tcp_connection), 68)


@pytest.mark.parametrize("vehicle", ["copter", "plane"])  # one worker runs every SITL test: the shared SITLs hold
@pytest.mark.parametrize("transport", ["udp", "tcp"])
def test_planned_mission_uploads_and_reads_back(plans, shared_sitl, vehicle, transport):
    sitl = shared_sitl(vehicle)
    conn = sitl.udp_connection if transport == "udp" else sitl.tcp_connection
    done = _gcs("upload", "--plan", str(plans[vehicle]), "--connect", conn, "--connect-timeout", "30")
    assert done.returncode == 0, done.stdout + done.stderr
    plan = json.loads((plans[vehicle] / "plan.json").read_text())
    landing = 3 if vehicle == "plane" else 1  # DO_LAND_START, approach, NAV_LAND; or NAV_LAND
    items = 1 + 1 + len(plan["uavs"][0]["waypoints"]) + landing  # home, take-off, waypoints, landing
    assert plan["uavs"][0]["mission_items"] == items  # what the plan tells the crew before any upload
    assert f"UAV 1: verified: mission {items} items" in done.stdout
    assert "fence" in done.stdout and "rally 1 items" in done.stdout
    assert "1/1 vehicles verified" in done.stdout
