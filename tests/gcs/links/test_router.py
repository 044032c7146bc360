"""Several vehicles behind one link: three simulated vehicles behind MAVProxy, a real router that
forwards every system id over one UDP port. Each is answered on its own system id and takes a
verified mission, concurrently."""

from __future__ import annotations

import asyncio
import shutil
import subprocess
import sys
from pathlib import Path

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import WireItem, upload_verified
from gcs.links import MavLink, mavlink
from tests.peers.ports import free_udp_port

MAVPROXY = Path(sys.executable).with_name("mavproxy.py")


def _mission(sysid: int) -> list[WireItem]:
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
    home = WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, -35.3632, 149.1652, 0.0)
    return [home] + [WireItem.at(i, rel, mavlink.MAV_CMD_NAV_WAYPOINT, -35.3632 + 1e-4 * i, 149.1652 + 1e-4 * sysid,
                                 20.0 + i) for i in range(1, 6 + sysid)]


def test_three_vehicles_behind_one_router_port_are_each_answered_and_take_their_missions(make_fleet, tmp_path):
    assert MAVPROXY.exists() or shutil.which("mavproxy.py"), "MAVProxy is installed by tools/setup --test"
    fleet = make_fleet(3)
    port = free_udp_port()
    args = [str(MAVPROXY if MAVPROXY.exists() else shutil.which("mavproxy.py")), "--daemon", "--non-interactive",
            "--out", f"udpout:127.0.0.1:{port}", "--state-basedir", str(tmp_path)]
    for conn in fleet.connection_strings():
        args += ["--master", conn]
    router = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)

    async def main():
        async with MavLink(f"udpin:127.0.0.1:{port}") as link:
            for _ in range(200):
                if len(link.systems) == 3:
                    break
                await asyncio.sleep(0.05)
            assert sorted(link.systems) == [1, 2, 3]
            assert len(link.transport.peers) == 1  # everything comes from the router's one address
            reports = await asyncio.gather(*(upload_verified(link, s, _mission(s), Autopilot.ARDUPILOT)
                                             for s in (1, 2, 3)))
            assert [r.items for r in reports] == [7, 8, 9]

    try:
        asyncio.run(asyncio.wait_for(main(), 60))
    finally:
        router.terminate()
        router.wait(10)
    for sysid in (1, 2, 3):
        stored = fleet.vehicle(sysid).mission.items()
        assert len(stored) == 6 + sysid and stored[-1].y == round((149.1652 + 1e-4 * sysid) * 1e7)
