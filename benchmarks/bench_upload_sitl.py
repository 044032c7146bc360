"""Upload-and-verify time of a 200-item mission to real ArduCopter SITL, over TCP and over UDP,
and to real PX4 SITL (SIH copter) over its GCS UDP port, next to a plain stop-and-wait pymavlink
client in the same run.

    .venv/bin/python benchmarks/bench_upload_sitl.py [--items 200] [--repeats 3] [--speedup 1]

For each link: gcs's `upload_verified` (upload, read back, compare) and its upload alone, and a
plain client that sends MISSION_COUNT, answers each request with MISSION_ITEM_INT and waits for
the ACK (then reads the list back the same way). Medians of the repeats, milliseconds per item.
Needs the ArduPilot and PX4 SITL of the peers folder (../shared/peers or $GCS_PEERS_DIR); PX4
answers only the first address that speaks to its GCS port, so the plain client gets a PX4 of
its own."""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from gcs.autopilots import Autopilot  # noqa: E402
from gcs.autopilots.mission_transfer import Upload, WireItem, transfer, upload_verified  # noqa: E402
from gcs.links import MavLink, mavlink  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl, require_ardupilot  # noqa: E402
from tests.peers.px4 import Px4Sitl, require_px4  # noqa: E402
from tests.peers.site import CENTRE  # noqa: E402


def mission(n: int) -> list[WireItem]:
    lat, lon = CENTRE
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
    return [WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon, 0.0)] + \
        [WireItem.at(i, rel, mavlink.MAV_CMD_NAV_WAYPOINT, lat + 1e-5 * (i % 50), lon + 1e-5 * (i // 50), 40.0)
         for i in range(1, n)]


async def gcs_times(connection: str, items: list[WireItem], repeats: int,
                    autopilot: Autopilot = Autopilot.ARDUPILOT) -> tuple[list[float], list[float]]:
    verified, upload_only = [], []
    async with MavLink(connection) as link:
        await link.wait_for(1, "HEARTBEAT", timeout_s=30.0)
        await link.command(1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION, 1e6)
        assert await link.wait_for(1, "HOME_POSITION", timeout_s=60.0) is not None, "no home from the SITL"
        for _ in range(repeats):
            start = time.perf_counter()
            await upload_verified(link, 1, items, autopilot)
            verified.append(time.perf_counter() - start)
            start = time.perf_counter()
            await transfer(link, Upload((1, 1), items))
            upload_only.append(time.perf_counter() - start)
    return verified, upload_only


def plain_times(connection: str, items: list[WireItem], repeats: int) -> tuple[list[float], list[float]]:
    """A plain stop-and-wait pymavlink client: no re-sends, no pipelining."""
    conn = mavutil.mavlink_connection(connection, source_system=254)
    conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)  # PX4 waits to be called
    conn.wait_heartbeat(timeout=30)
    uploads, downloads = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        conn.mav.mission_count_send(1, 1, len(items), 0)
        while True:
            msg = conn.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True,
                                  timeout=5)
            assert msg is not None, "plain client: the vehicle stopped answering"
            if msg.get_type() == "MISSION_ACK":
                assert msg.type == 0, msg
                break
            it = items[msg.seq]
            conn.mav.mission_item_int_send(1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2,
                                           it.param3, it.param4, it.x, it.y, it.z, 0)
        uploads.append(time.perf_counter() - start)
        start = time.perf_counter()
        conn.mav.mission_request_list_send(1, 1, 0)
        count = conn.recv_match(type="MISSION_COUNT", blocking=True, timeout=5).count
        for seq in range(count):
            conn.mav.mission_request_int_send(1, 1, seq, 0)
            assert conn.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=5) is not None
        conn.mav.mission_ack_send(1, 1, 0, 0)
        downloads.append(time.perf_counter() - start)
    conn.close()
    return uploads, downloads


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--items", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--speedup", type=float, default=1.0)
    args = parser.parse_args()
    require_ardupilot()
    require_px4()
    items = mission(args.items)
    rows = []
    with ArduPilotSitl("copter", home=(*CENTRE, 584.0, 0.0), speedup=args.speedup) as sitl:
        for name, conn in (("tcp", sitl.tcp_connection), ("udp", sitl.udp_connection)):
            verified, upload = asyncio.run(gcs_times(conn, items, args.repeats))
            plain_conn = conn if name == "tcp" else f"udpin:127.0.0.1:{sitl.gcs_port}"
            plain_up, plain_down = plain_times(plain_conn, items, args.repeats)
            rows.append((f"ArduCopter {name}", statistics.median(upload), statistics.median(verified),
                         statistics.median(plain_up), statistics.median(plain_up) + statistics.median(plain_down)))
    with Px4Sitl(home=(*CENTRE, 584.0), speedup=args.speedup) as px4:
        verified, upload = asyncio.run(gcs_times(px4.gcs_connection, items, args.repeats, Autopilot.PX4))
    with Px4Sitl(home=(*CENTRE, 584.0), speedup=args.speedup) as px4:
        plain_up, plain_down = plain_times(px4.gcs_connection, items, args.repeats)
    rows.append(("PX4 udp", statistics.median(upload), statistics.median(verified), statistics.median(plain_up),
                 statistics.median(plain_up) + statistics.median(plain_down)))
    n = args.items
    print(f"SITL at speedup {args.speedup:g}, {n}-item mission, median of {args.repeats}")
    print(f"{'link':<14} {'gcs upload s':>12} {'ms/item':>8} {'gcs upload+verify s':>20} {'ms/item':>8} "
          f"{'plain upload s':>15} {'ms/item':>8} {'plain up+down s':>16} {'ms/item':>8}")
    for name, up, ver, pup, pboth in rows:
        print(f"{name:<14} {up:>12.2f} {1000 * up / n:>8.2f} {ver:>20.2f} {1000 * ver / n:>8.2f} "
              f"{pup:>15.2f} {1000 * pup / n:>8.2f} {pboth:>16.2f} {1000 * pboth / n:>8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
