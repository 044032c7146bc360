"""How many simulated vehicles one process serves in real time, what a flying vehicle costs, and
200-item upload time.

    python benchmarks/bench_sim.py [--counts 1,10,25,50,75,100] [--seconds 5] [--hz 10]
                                   [--flight 50] [--flight-seconds 60]

For each fleet size the simulator runs in this process at speedup 1; a separate receiver process
(so decoding does not steal the simulator's CPU) says hello to every vehicle from one UDP socket,
asks each for position, attitude and HUD at --hz and the status messages at 1 Hz
(MAV_CMD_SET_MESSAGE_INTERVAL: a simulated ArduCopter, like a real one, streams nothing unasked)
and counts GLOBAL_POSITION_INT datagrams by reading the MAVLink 2 header. Reported: achieved
position rate per vehicle, total datagrams per second, simulated/real time ratio, and the process
CPU share.

--flight N (repeatable as a list; "" for none) steps N copters flying a mission in AUTO in this
process, without sockets, exactly as the fleet's tick does (`step`, then `emit` with the same
streams asked for): what the simulator itself costs per vehicle and tick while vehicles fly
(kinematics, mission logic, local-frame conversions, sensor, message building). Reported: CPU
microseconds per vehicle-tick (the median of 5 runs) and how many flying vehicles that leaves
room for in real time at the fleet's 20 ms tick.
"""

from __future__ import annotations

import argparse
import math
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

from sim import FleetOptions, HomePose, Mode, SimFleet, VehicleConfig, WireItem, homes_for
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


def _square_mission(home: HomePose, side_m: float = 200.0) -> list[WireItem]:
    """Home, take-off to 30 m, a square of `side_m` north-east of home, then round again for ever."""
    m_per_deg = 111_319.49
    corners = [(0.0, side_m), (side_m, side_m), (side_m, 0.0), (0.0, 0.0)]
    items = [WireItem(seq=0, frame=mavlink.MAV_FRAME_GLOBAL, command=mavlink.MAV_CMD_NAV_WAYPOINT),
             WireItem(seq=1, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, command=mavlink.MAV_CMD_NAV_TAKEOFF,
                      z=30.0)]
    for east, north in corners:
        lat = home.lat_deg + north / m_per_deg
        lon = home.lon_deg + east / (m_per_deg * math.cos(math.radians(home.lat_deg)))
        items.append(WireItem(seq=len(items), frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                              command=mavlink.MAV_CMD_NAV_WAYPOINT, x=round(lat * 1e7), y=round(lon * 1e7), z=30.0))
    items.append(WireItem(seq=len(items), frame=mavlink.MAV_FRAME_MISSION, command=mavlink.MAV_CMD_DO_JUMP,
                          param1=2, param2=-1))
    return items


def bench_flight(n: int, seconds: float, hz: float, runs: int = 5) -> dict:
    """`n` copters flying `_square_mission` in AUTO, stepped `seconds` of vehicle time per run at
    the fleet's tick, telemetry asked for as in `bench_fleet`."""
    options = FleetOptions(base_port=0)
    fleet = SimFleet(homes_for(n, [HOME], spacing_m=50.0), VehicleConfig(boot_scale=0.0, telemetry_hz=hz), options)
    vehicles = fleet.vehicles
    for v in vehicles:
        v.load_mission(_square_mission(v.home))
        for msg_id in FAST + SLOW:
            interval_us = 1e6 / (hz if msg_id in FAST else 1.0)
            v.handle(mavlink.MAVLink_command_long_message(v.sysid, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                                          msg_id, interval_us, 0, 0, 0, 0, 0), 0.0)
        v.step(options.tick_s)  # home and EKF origin (no start-up delays)
        assert v.set_mode(Mode.GUIDED) == mavlink.MAV_RESULT_ACCEPTED and v.arm() == mavlink.MAV_RESULT_ACCEPTED
        start = v.handle(mavlink.MAVLink_command_long_message(v.sysid, 1, mavlink.MAV_CMD_MISSION_START, 0,
                                                              0, 0, 0, 0, 0, 0, 0), 0.0)
        assert start[0].result == mavlink.MAV_RESULT_ACCEPTED
    ticks = round(seconds / options.tick_s)

    def run() -> tuple[float, int]:
        sent = 0
        cpu0 = time.process_time()
        for _ in range(ticks):
            for v in vehicles:
                v.step(options.tick_s)
                sent += len(v.emit())
        return time.process_time() - cpu0, sent

    run()  # take off and settle into the square
    results = [run() for _ in range(runs)]
    assert all(v.state.alt_rel_m > 25.0 and v.state.mode == Mode.AUTO for v in vehicles), "not flying the mission"
    us = statistics.median(cpu for cpu, _ in results) / (ticks * n) * 1e6
    return {"vehicles": n, "us_per_vehicle_tick": us, "messages_s": results[-1][1] / seconds / n,
            "real_time_capacity": options.tick_s * 1e6 / us}


def bench_upload(repeats: int = 5, items_n: int = 200) -> list[float]:
    from pymavlink import mavutil

    fleet = SimFleet([HOME], VehicleConfig(), FleetOptions(base_port=0, speedup=1.0))
    items = [WireItem(seq=0, frame=0, command=16)] + [
        WireItem(seq=i, frame=6, command=16, x=-353632610 + 100 * i, y=1491652300, z=20.0)
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
    parser.add_argument("--flight", default="50", help="flying fleet sizes stepped without sockets (\"\": none)")
    parser.add_argument("--flight-seconds", type=float, default=60.0, help="vehicle seconds per run")
    args = parser.parse_args()
    counts = [int(c) for c in args.counts.split(",") if c]
    flights = [int(c) for c in args.flight.split(",") if c]
    if counts:
        _bench_fleets(counts, args.seconds, args.hz)
    if flights:
        print(f"flying copters in AUTO, stepped without sockets ({args.flight_seconds:g} s of vehicle time per run, "
              f"median of 5 runs)")
        print(f"{'vehicles':>8} {'µs CPU per vehicle-tick':>23} {'messages/s per vehicle':>22} "
              f"{'flying vehicles in real time':>28}")
        for n in flights:
            r = bench_flight(n, args.flight_seconds, args.hz)
            print(f"{r['vehicles']:>8} {r['us_per_vehicle_tick']:>23.1f} {r['messages_s']:>22.1f} "
                  f"{r['real_time_capacity']:>28.0f}", flush=True)
    times = bench_upload()
    print("200-item mission upload over loopback (pymavlink MissionClient): "
          f"median {statistics.median(times) * 1000:.1f} ms, min {min(times) * 1000:.1f} ms, "
          f"max {max(times) * 1000:.1f} ms over {len(times)} runs")


def _bench_fleets(counts: list[int], seconds: float, hz: float) -> None:
    print(f"telemetry target: GLOBAL_POSITION_INT/ATTITUDE/VFR_HUD at {hz:g} Hz per vehicle, speedup 1")
    print(f"{'vehicles':>8} {'pos Hz mean':>11} {'pos Hz min':>10} {'datagrams/s':>11} {'sim/real':>8} {'CPU':>5}")
    for n in counts:
        r = bench_fleet(n, seconds, hz)
        print(f"{r['vehicles']:>8} {r['pos_hz_mean']:>11.2f} {r['pos_hz_min']:>10.2f} {r['datagrams_s']:>11.0f} "
              f"{r['sim_over_real']:>8.3f} {r['cpu_share']:>5.0%}", flush=True)


if __name__ == "__main__":
    main()
