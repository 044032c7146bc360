"""The async link against the simulator: commands carry their result code, a silent peer times
out without blocking, connection strings are checked."""

from __future__ import annotations

import asyncio

import pytest

from gcs.link import CommandError, Endpoint, MavLink, mavlink, parse_connection
from sim import FleetOptions, HomePose, SimFleet


def test_parse_connection():
    assert parse_connection("udpout:127.0.0.1:14540") == Endpoint("out", "127.0.0.1", 14540)
    assert parse_connection("udpin:0.0.0.0:14550") == Endpoint("in", "0.0.0.0", 14550)
    assert parse_connection("udp:127.0.0.1:14550").mode == "in"
    for bad in ("serial:/dev/ttyUSB0", "udpout:127.0.0.1", "udpout:127.0.0.1:0", "udpout:127.0.0.1:x"):
        with pytest.raises(ValueError):
            parse_connection(bad)


def test_commands_carry_their_result_and_a_silent_peer_times_out():
    fleet = SimFleet([HomePose(-35.36, 149.16)], options=FleetOptions(base_port=0, speedup=10)).start()

    async def main():
        async with MavLink(fleet.connection_strings()[0]) as link, MavLink("udpout:127.0.0.1:9") as silent:
            hb = await link.wait_for(1, "HEARTBEAT", timeout_s=3.0)
            assert hb is not None and hb.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
            assert await link.command(1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                                      mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, 5e5) == mavlink.MAV_RESULT_ACCEPTED
            with pytest.raises(CommandError) as refused:
                await link.command(1, mavlink.MAV_CMD_DO_GRIPPER, 1, 0)
            assert refused.value.result == mavlink.MAV_RESULT_UNSUPPORTED and "DO_GRIPPER" in str(refused.value)
            async with link.listen(1, ["BATTERY_STATUS"]) as queue:
                msg = await asyncio.wait_for(queue.get(), 3.0)
                assert msg.get_srcSystem() == 1
            with pytest.raises(CommandError) as timeout:
                await silent.command(1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.05, retries=1)
            assert timeout.value.result is None

    try:
        asyncio.run(main())
    finally:
        fleet.stop()
