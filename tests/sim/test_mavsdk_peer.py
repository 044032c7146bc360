"""The simulator as seen by an independent client: MAVSDK (native binding, v4), used as against
a real ArduPilot: position streams asked for (ArduCopter sends none unasked), arming retried
until the autopilot is ready, MissionRaw with its own home item."""

from __future__ import annotations

import asyncio
import math

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync, ActionError
from mavsdk.asyncio.plugins.mission import MissionAsync, MissionItem, MissionPlan
from mavsdk.asyncio.plugins.mission_raw import MissionItem as RawItem, MissionRawAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

from gcs.autopilots.ardupilot_storage import stored_item
from sim import WireItem as SimItem
from tests.sim.helpers import HOME, distance_m, fast, offset


async def _with_system(port: int, body):
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as mavsdk:
        await mavsdk.add_any_connection(f"udpout://127.0.0.1:{port}")
        system = await mavsdk.first_autopilot(timeout_s=10.0)
        assert system is not None, "MAVSDK found no autopilot"
        return await body(system)


async def _position(system):
    """The first position after the GPS fix (ArduPilot reports 0, 0 before)."""
    telemetry = TelemetryAsync(system)
    await telemetry.set_rate_position(4.0)
    async for position in telemetry.subscribe_position():
        if not math.isnan(position.latitude_deg) and (position.latitude_deg, position.longitude_deg) != (0.0, 0.0):
            return position


async def _arm(system, timeout_s: float = 20.0):
    """Arm, retrying while the autopilot refuses (it does until its EKF has a position)."""
    end = asyncio.get_running_loop().time() + timeout_s
    while True:
        try:
            return await ActionAsync(system).arm()
        except ActionError:
            if asyncio.get_running_loop().time() > end:
                raise
            await asyncio.sleep(0.1)


def _run(fleet, body):
    return asyncio.run(asyncio.wait_for(_with_system(fleet.addresses[0][1], body), 60))


def test_mavsdk_sees_an_ardupilot_autopilot_and_its_position(make_fleet):
    fleet = make_fleet()

    async def body(system):
        position = await _position(system)
        return str(await system.autopilot_type()), position

    autopilot, position = _run(fleet, body)
    assert "ARDUPILOT" in autopilot.upper() or autopilot.endswith("2")
    assert position.latitude_deg == pytest_approx(HOME.lat_deg)
    assert position.longitude_deg == pytest_approx(HOME.lon_deg)


def test_mavsdk_raw_mission_of_200_items_round_trips(make_fleet):
    fleet = make_fleet()
    items = [RawItem(seq=0, frame=0, command=16, current=1, autocontinue=1, mission_type=0)]
    for i in range(1, 201):
        lat, lon = offset(HOME, (i % 20) * 15.0, (i // 20) * 15.0)
        items.append(RawItem(seq=i, frame=6, command=16, current=0, autocontinue=1, param2=float(i % 4),
                             x=round(lat * 1e7), y=round(lon * 1e7), z=25.0, mission_type=0))

    async def body(system):
        raw = MissionRawAsync(system)
        await raw.upload_mission(items)
        return await raw.download_mission()

    back = _run(fleet, body)
    assert len(back) == 201
    key = lambda it: (it.seq, it.frame, it.command, it.current, it.param1, it.param2, it.x, it.y, it.z)  # noqa: E731
    kept = [stored_item(SimItem(seq=i.seq, frame=i.frame, command=i.command, current=i.current, param2=i.param2,
                                x=i.x, y=i.y, z=i.z), fixed_wing=False) for i in items]
    assert [key(b) for b in back[1:]] == [key(k) for k in kept[1:]]  # frame 6 reads back as 3, param2 dropped
    assert (back[0].x, back[0].y) == (round(HOME.lat_deg * 1e7), round(HOME.lon_deg * 1e7))
    stored = fleet.vehicle(1).mission.items()
    assert [(s.x, s.y) for s in stored[1:]] == [(i.x, i.y) for i in items[1:]]


def _plan(points):
    return MissionPlan([
        MissionItem(latitude_deg=lat, longitude_deg=lon, relative_altitude_m=15.0, is_fly_through=True,
                    acceptance_radius_m=2.0, loiter_time_s=float("nan"))
        for lat, lon in points
    ])


def test_mavsdk_mission_plugin_round_trips_on_the_px4_profile(make_fleet):
    fleet = make_fleet(config=fast(profile="px4"))
    points = [offset(HOME, e, n) for e, n in ((0, 40), (40, 40), (40, 0))]

    async def body(system):
        mission = MissionAsync(system)
        await mission.upload_mission(_plan(points))
        return await mission.download_mission()

    downloaded = _run(fleet, body)
    got = [(it.latitude_deg, it.longitude_deg, it.relative_altitude_m) for it in downloaded.mission_items]
    assert len(got) == 3
    for (lat, lon, alt), (elat, elon) in zip(got, points, strict=True):
        assert distance_m(lat, lon, elat, elon) < 0.05 and alt == pytest_approx(15.0)


def test_mavsdk_raw_mission_flight_on_the_ardupilot_profile(make_fleet):
    """With ArduPilot, item 0 is home: MAVSDK's MissionRaw sends a placeholder there, as a GCS must."""
    fleet = make_fleet(speedup=20.0)
    points = [offset(HOME, e, n) for e, n in ((0, 40), (40, 40), (40, 0))]
    items = [RawItem(seq=0, frame=0, command=16, current=1, autocontinue=1, mission_type=0),
             RawItem(seq=1, frame=3, command=22, autocontinue=1, z=15.0, mission_type=0)]
    for i, (lat, lon) in enumerate(points):
        items.append(RawItem(seq=i + 2, frame=6, command=16, autocontinue=1, param2=2.0,
                             x=round(lat * 1e7), y=round(lon * 1e7), z=15.0, mission_type=0))

    async def body(system):
        raw = MissionRawAsync(system)
        await raw.upload_mission(items)
        await _position(system)
        await _arm(system)
        await raw.start_mission()
        async for progress in raw.subscribe_mission_progress():
            if progress.current >= 4:
                break
        while fleet.vehicle(1).reached[-1:] != [4]:
            await asyncio.sleep(0.05)
        return progress, await _position(system)

    progress, position = _run(fleet, body)
    assert progress.total == 5
    assert distance_m(position.latitude_deg, position.longitude_deg, *points[-1]) < 5.0
    assert fleet.vehicle(1).reached == [1, 2, 3, 4]


def pytest_approx(value: float):
    import pytest

    return pytest.approx(value, abs=1e-6 if abs(value) > 1 else 1e-3)

