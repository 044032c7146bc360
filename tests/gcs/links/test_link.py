"""The async link against the simulated vehicles over every transport: UDP both ways, TCP
(with the far end closing and the link coming back), a serial cable (a socat pseudo-terminal
pair, unplugged and plugged back), several vehicles behind one port; commands carry their
result code, a silent peer times out without blocking."""

from __future__ import annotations

import asyncio
import socket

import pytest
import serial

from gcs.links import CommandError, Connection, LinkKind, LinkState, LinkUnavailable, MavLink, mavlink, parse_connection
from tests.peers.ports import free_udp_port


@pytest.mark.parametrize("text, expected", [
    ("udpout:127.0.0.1:14540", Connection(LinkKind.UDP_OUT, "127.0.0.1", 14540)),
    ("udpin:0.0.0.0:14550", Connection(LinkKind.UDP_IN, "0.0.0.0", 14550)),
    ("udp:127.0.0.1:14550", Connection(LinkKind.UDP_IN, "127.0.0.1", 14550)),
    ("tcp:127.0.0.1:5760", Connection(LinkKind.TCP_CLIENT, "127.0.0.1", 5760)),
    ("tcp:localhost:5762", Connection(LinkKind.TCP_CLIENT, "localhost", 5762)),
    ("tcpin:127.0.0.1:5770", Connection(LinkKind.TCP_SERVER, "127.0.0.1", 5770)),
    ("/dev/ttyUSB0", Connection(LinkKind.SERIAL, device="/dev/ttyUSB0", baud=57600)),
    ("/dev/ttyUSB0,115200", Connection(LinkKind.SERIAL, device="/dev/ttyUSB0", baud=115200)),
    ("/dev/serial/by-id/usb-3DR_Radio-if00-port0,57600",
     Connection(LinkKind.SERIAL, device="/dev/serial/by-id/usb-3DR_Radio-if00-port0", baud=57600)),
    ("COM3", Connection(LinkKind.SERIAL, device="COM3", baud=57600)),
    ("COM12,921600", Connection(LinkKind.SERIAL, device="COM12", baud=921600)),
    ("serial:/dev/ttyACM0:115200", Connection(LinkKind.SERIAL, device="/dev/ttyACM0", baud=115200)),
])
def test_connection_strings_users_type_are_understood(text, expected):
    assert parse_connection(text) == expected
    assert parse_connection(str(expected)) == expected  # the canonical form reads back


@pytest.mark.parametrize("text, reason", [
    ("serial:", "no serial device"), ("udpout:127.0.0.1", "expected udpout:HOST:PORT"),
    ("udpout:127.0.0.1:0", "out of range"), ("udpout:127.0.0.1:x", "not a number"),
    ("tcp:no-such-host.invalid:5760", "unknown host"),
    ("/dev/ttyUSB0,1234", "baud rate 1234"), ("/dev/ttyUSB0,fast", "not a number"), ("ttyUSB0", "expected"),
    ("COM0", "expected"), ("", "empty"), ("http://127.0.0.1:80", "expected"),
])
def test_malformed_connection_strings_say_what_is_wrong(text, reason):
    with pytest.raises(ValueError, match=reason):
        parse_connection(text)


def test_commands_carry_their_result_and_a_silent_peer_times_out(make_fleet):
    fleet = make_fleet()

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

    asyncio.run(main())


async def _arm_and_disarm(link: MavLink, sysid: int) -> None:
    assert await link.command(sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.5) == 0
    assert await link.command(sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, timeout_s=0.5) == 0


def test_tcp_link_comes_back_when_the_far_end_closes_and_keeps_its_state(make_fleet):
    fleet = make_fleet(tcp=True)
    [conn] = fleet.tcp_connection_strings()
    seen = []

    async def main():
        async with MavLink(conn) as link:
            link.on_status(seen.append)
            assert await link.wait_for(1, "HEARTBEAT", timeout_s=3.0) is not None
            await _arm_and_disarm(link, 1)
            heard_before = dict(link.systems)
            assert fleet.drop_stream_clients(1) == 1
            for _ in range(100):
                if [s.state for s in seen] == [LinkState.LOST, LinkState.RECONNECTED]:
                    break
                await asyncio.sleep(0.05)
            assert [s.state for s in seen] == [LinkState.LOST, LinkState.RECONNECTED], seen
            assert all(s.link == conn for s in seen)
            assert link.systems.keys() == heard_before.keys()  # what the link knew survives
            await _arm_and_disarm(link, 1)
            assert link.transport.reconnects == 1

    asyncio.run(main())


def test_serial_cable_unplugged_and_plugged_back(make_fleet, serial_cable):
    make_fleet(serial_devices=(serial_cable.vehicle_end,))  # the vehicle at the cable's other end
    seen = []

    async def main():
        async with MavLink(f"{serial_cable.station_end},57600") as link:
            link.on_status(seen.append)
            assert await link.wait_for(1, "HEARTBEAT", timeout_s=3.0) is not None
            await _arm_and_disarm(link, 1)
            serial_cable.unplug()
            for _ in range(100):
                if seen:
                    break
                await asyncio.sleep(0.05)
            assert [s.state for s in seen] == [LinkState.LOST]
            with pytest.raises(CommandError):
                await link.command(1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=0.1, retries=0)
            serial_cable.plug()
            for _ in range(200):
                if len(seen) == 2:
                    break
                await asyncio.sleep(0.05)
            assert await link.wait_for(1, "HEARTBEAT", timeout_s=3.0) is not None
            assert [s.state for s in seen] == [LinkState.LOST, LinkState.RECONNECTED], seen
            await _arm_and_disarm(link, 1)

    asyncio.run(main())


def test_links_that_cannot_open_say_why(serial_cable, tmp_path):
    async def open_(text: str) -> None:
        async with MavLink(text):
            pass

    with pytest.raises(LinkUnavailable, match="no such device"):
        asyncio.run(open_(str(tmp_path / "ttyUSB9")))
    with serial.Serial(serial_cable.station_end, exclusive=True):
        with pytest.raises(LinkUnavailable, match="busy"):
            asyncio.run(open_(serial_cable.station_end))
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # bound but not listening: the connection is refused
        with pytest.raises(LinkUnavailable, match="connection refused"):
            asyncio.run(open_(f"tcp:127.0.0.1:{port}"))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        with pytest.raises(LinkUnavailable, match="already in use"):
            asyncio.run(open_(f"udpin:127.0.0.1:{s.getsockname()[1]}"))


def test_several_vehicles_pushing_to_one_udp_port_are_each_answered(make_fleet):
    """As several SITLs with `--serial1 udpclient:HOST:PORT` or MAVProxy outputs: each vehicle
    sends from its own port to ours, and each must get its own replies."""
    port = free_udp_port()
    fleet = make_fleet(3, out=(("127.0.0.1", port),))

    async def main():
        async with MavLink(f"udpin:127.0.0.1:{port}") as link:
            for _ in range(100):
                if len(link.systems) == 3:
                    break
                await asyncio.sleep(0.05)
            assert sorted(link.systems) == [1, 2, 3]
            assert len(link.transport.peers) == 3
            await asyncio.gather(*(_arm_and_disarm(link, sysid) for sysid in (1, 2, 3)))

    asyncio.run(main())
    assert [fleet.link(i).received > 0 for i in (1, 2, 3)] == [True] * 3
