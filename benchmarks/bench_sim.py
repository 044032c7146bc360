"""How many simulated vehicles one process serves in real time, and 200-item upload time.

    python benchmarks/bench_sim.py [--counts 1,10,25,50,75,100] [--seconds 5] [--hz 10]

For each fleet size the simulator runs in this process at speedup 1; a separate receiver process
(so decoding does not steal the simulator's CPU) says hello to every vehicle from one UDP socket,
asks each for position, attitude and HUD at --hz and the status messages at 1 Hz
(MAV_CMD_SET_MESSAGE_INTERVAL: a simulated ArduCopter, like a real one, streams nothing unasked)
and counts GLOBAL_POSITION_INT datagrams by reading the MAVLink 2 header. Reported: achieved
position rate per vehicle, total datagrams per second, simulated/real time ratio, and the process
CPU share.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import socket
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim import FleetOptions, HomePose, MissionItem, SimFleet, VehicleConfig, homes_for
from tests.sim.mission_client import MissionClient

HOME = HomePose(-35.363261, 149.165230, 584.0, 0.0)


FAST = (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mavlink.MAVLINK_MSG_ID_ATTITUDE, mavlink.MAVLINK_MSG_ID_VFR_HUD)
SLOW = (mavlink.MAVLINK_MSG_ID_SYS_STATUS, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
        mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)


def _receiver(ports: list[int], seconds: float, hz: float, out: mp.Queue) -> None:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.1)
    mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    hello = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3).pack(mav)
    for sysid, port in enumerate(ports, start=1):
        sock.sendto(hello, ("127.0.0.1", port))
        for msg_id in FAST + SLOW:
            interval_us = 1e6 / (hz if msg_id in FAST else 1.0)
            ask = mavlink.MAVLink_command_long_message(sysid, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id,
                                                       interval_us, 0, 0, 0, 0, 0)
            sock.sendto(ask.pack(mav), ("127.0.0.1", port))
    settle = time.monotonic() + 1.0  # streams start once the vehicles know us
    while time.monotonic() < settle:
        try:
            sock.recv(2048)
        except TimeoutError:
            pass
    positions: dict[int, int] = {}
    total = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            data = sock.recv(2048)
        except TimeoutError:
            continue
        total += 1
        if data[0] == 0xFD and int.from_bytes(data[7:10], "little") == mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
            positions[data[5]] = positions.get(data[5], 0) + 1
    out.put((positions, total))


def bench_fleet(n: int, seconds: float, hz: float) -> dict:
    fleet = SimFleet(homes_for(n, [HOME]), VehicleConfig(telemetry_hz=hz), FleetOptions(base_port=0, speedup=1.0))
    with fleet.running():
        ports = [port for _, port in fleet.addresses]
        ctx = mp.get_context("spawn")
        queue = ctx.Queue()
        proc = ctx.Process(target=_receiver, args=(ports, seconds, hz, queue))
        proc.start()
        time.sleep(1.0)
        wall0, sim0, cpu0 = time.monotonic(), fleet.vehicles[0].time_s, time.process_time()
        positions, total = queue.get(timeout=seconds + 30)
        wall, sim, cpu = time.monotonic() - wall0, fleet.vehicles[0].time_s - sim0, time.process_time() - cpu0
        proc.join()
    rates = [positions.get(sysid, 0) / seconds for sysid in range(1, n + 1)]
    return {
        "vehicles": n,
        "pos_hz_mean": statistics.fmean(rates),
        "pos_hz_min": min(rates),
        "datagrams_s": total / seconds,
        "sim_over_real": sim / wall,
        "cpu_share": cpu / wall,  # includes the receiver's hello only; CPU of this process
    }


def bench_upload(repeats: int = 5, items_n: int = 200) -> list[float]:
    from pymavlink import mavutil

    fleet = SimFleet([HOME], VehicleConfig(), FleetOptions(base_port=0, speedup=1.0))
    items = [MissionItem(seq=0, frame=0, command=16)] + [
        MissionItem(seq=i, frame=6, command=16, x=-353632610 + 100 * i, y=1491652300, z=20.0)
        for i in range(1, items_n + 1)
    ]
    times = []
    with fleet.running():
        host, port = fleet.addresses[0]
        conn = mavutil.mavlink_connection(f"udpout:{host}:{port}", source_system=255, dialect="ardupilotmega")
        conn.mav.heartbeat_send(6, 8, 0, 0, 0)
        conn.wait_heartbeat(timeout=5)
        client = MissionClient(conn, 1)
        for _ in range(repeats):
            times.append(client.upload(items).elapsed_s)
        conn.close()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", default="1,10,25,50,75,100")
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--hz", type=float, default=10.0)
    args = parser.parse_args()
    print(f"telemetry target: GLOBAL_POSITION_INT/ATTITUDE/VFR_HUD at {args.hz:g} Hz per vehicle, speedup 1")
    print(f"{'vehicles':>8} {'pos Hz mean':>11} {'pos Hz min':>10} {'datagrams/s':>11} {'sim/real':>8} {'CPU':>5}")
    for n in (int(c) for c in args.counts.split(",")):
        r = bench_fleet(n, args.seconds, args.hz)
        print(f"{r['vehicles']:>8} {r['pos_hz_mean']:>11.2f} {r['pos_hz_min']:>10.2f} {r['datagrams_s']:>11.0f} "
              f"{r['sim_over_real']:>8.3f} {r['cpu_share']:>5.0%}", flush=True)
    times = bench_upload()
    print("200-item mission upload over loopback (pymavlink MissionClient): "
          f"median {statistics.median(times) * 1000:.1f} ms, min {min(times) * 1000:.1f} ms, "
          f"max {max(times) * 1000:.1f} ms over {len(times)} runs")


if __name__ == "__main__":
    main()
