"""Before arming: a vehicle's charge is checked against its plan even when the vehicle is ready
before it has said anything of its battery."""

from __future__ import annotations

import asyncio
import re
from collections.abc import Callable
from contextlib import ExitStack

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.flight.fly import fly_async
from gcs.telemetry.status import Stage
from sim.plan_fleet import fleet_for_plan
from tests.gcs.flight.conftest import SPEEDUP, fast_options
from tests.peers.relay import UdpRelay


def _battery_held_back(asked: list[bool]) -> Callable[[bytes, bool], bool]:
    """A relay's filter between a station and a vehicle it calls: the vehicle's BATTERY_STATUS
    is dropped until the station has asked for it (MAV_CMD_REQUEST_MESSAGE); `asked[0]` then
    turns True."""
    parsers = {True: mavlink.MAVLink(None), False: mavlink.MAVLink(None)}

    def forward(datagram: bytes, to_vehicle: bool) -> bool:
        messages = parsers[to_vehicle].parse_buffer(datagram) or []
        if to_vehicle:
            asked[0] |= any(m.get_type() in ("COMMAND_LONG", "COMMAND_INT")
                            and m.command == mavlink.MAV_CMD_REQUEST_MESSAGE
                            and int(m.param1) == mavlink.MAVLINK_MSG_ID_BATTERY_STATUS for m in messages)
            return True
        return asked[0] or not any(m.get_type() == "BATTERY_STATUS" for m in messages)

    return forward


def test_a_vehicle_ready_before_its_first_battery_report_is_asked_for_it_and_kept_down_when_it_cannot_pay(plan):
    """Every vehicle is ready at once and uploads in a fraction of a second, and its battery
    stream has not spoken yet (a relay holds it back until the station asks). The station asks
    for BATTERY_STATUS, reads the charge, and keeps each of these small packs (two minutes of
    flight) on the ground, naming what it pays for and what the plan needs. Before the station
    asked, the check was skipped and they flew."""
    fleet = fleet_for_plan(plan, speedup=SPEEDUP, endurance_s=120.0, boot_scale=0.05).start()
    asked = [[False] for _ in plan.uavs]
    try:
        with ExitStack() as relays:
            ports = [relays.enter_context(UdpRelay(int(c.rsplit(":", 1)[1]), _battery_held_back(a))).port
                     for c, a in zip(fleet.connection_strings(), asked)]
            controller = asyncio.run(asyncio.wait_for(
                fly_async(plan, [f"udpout:127.0.0.1:{p}" for p in ports], fast_options()), 60))
    finally:
        fleet.stop()
    assert not fleet.errors, fleet.errors
    for uid in plan.uavs:
        status = controller.status[uid]
        assert status.stage is Stage.FAILED, (uid, status.stage, status.note)
        assert re.match(r"not armed: charge \d+% = \d+ mAh pays for \d+ m of its plan's \d+ m",
                        status.note), status.note
        assert not status.armed
    assert all(a[0] for a in asked)
