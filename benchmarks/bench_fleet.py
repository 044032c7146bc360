"""A fleet of 64 on one station, in real time: every vehicle flown to the ground by one `gcs fly`
process at speed-up 1 with its default telemetry rates, and what that station costs (issue 39).

    .venv/bin/python benchmarks/bench_fleet.py [--vehicles 64] [--range-m 1000] [--spacing-m 250]
                                               [--cell-size 25] [--no-tap] [--keep DIR]
                                               [--station-arg ARG] [--timeout-s 900]

1. A square area with the airports on a lattice (`--spacing-m` apart, `--vehicles` of them,
   range `--range-m` each, 16 targets), written as GeoJSON and planned by `gcs plan --area` in
   its own process (altitude layers from 20 m, 1 m apart, so that every UAV has its own and the
   climbs and descents stay short).
2. `gcs sim --area AREA --speedup 1` in its own process: a vehicle at each airport (ArduCopter
   profile, its measured 42 s from boot to ready), the plan's grid and targets.
3. `gcs fly --plan DIR --connect udpout:...` (one link per vehicle) in its own process, with
   every default (telemetry rates, tick, recording, journal); it runs until every vehicle is
   down.

Measured from outside, none of it changing the station: its CPU (user + system, all threads, from
/proc every second and `wait4`'s totals at its exit) as a share of one core, the mean over its
whole run and over the airborne part (first take-off to last landing, as its own lines say) and the
peak second; how long its event loop (the main thread) was runnable but waiting for a CPU
(/proc/PID/schedstat: on a shared machine, what the other processes took from it); the depth of its
sockets' receive queues and the datagrams the kernel dropped on them (/proc/net/udp, every 0.25 s:
a station that does not keep up shows here first); the vehicles landed (its summary's "N/M landed
at their airports" and its exit code); lost links, return orders and error lines from its output.
The station does not count what it receives where another process can read it, so the MAVLink
messages per second are counted by a tap: `gcs sim --out udp:127.0.0.1:TAP` sends a copy of every
datagram each vehicle sends the station to a listener process (one MAVLink message per datagram),
which counts them by type and vehicle; what the station received is that, less its sockets' drops.
The tap costs the simulator a second send per message (`--no-tap`: none, and no message count).
Prints one table; with `--keep DIR` the area, plan, flight, logs and the timelines (backlog.csv,
cpu.csv) stay in DIR. `--station-arg=--no-rrd` (repeatable) passes an argument to `gcs fly`.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from planner.georef import LocalFrame  # noqa: E402
from tests.peers.ports import free_ports  # noqa: E402

CENTRE = (46.95, 7.45)  # lat, lon of the area's centre
HEADINGS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
TARGETS = 16
GCS = [sys.executable, "-m", "gcs.cli"]


# ---- the area -------------------------------------------------------------------------------

def fleet_area(vehicles: int, spacing_m: float, range_m: float, cell_m: float) -> dict:
    """A square area around `CENTRE` with `vehicles` airports on a square lattice `spacing_m`
    apart (headings in turn), each with `range_m`, a border of 1.5 spacings, and `TARGETS` targets
    on a coarser lattice between the airports: the same file for the same arguments."""
    side_n = math.ceil(math.sqrt(vehicles))
    half = (side_n - 1) * spacing_m / 2 + 1.5 * spacing_m
    frame = LocalFrame(*CENTRE)

    def lon_lat(east: float, north: float) -> list[float]:
        lat, lon = frame.en2geodetic(east, north)
        return [round(lon, 9), round(lat, 9)]

    ring = [lon_lat(e, n) for e, n in ((-half, -half), (half, -half), (half, half), (-half, half), (-half, -half))]
    features = [{"type": "Feature", "properties": {"role": "area", "name": "fleet"},
                 "geometry": {"type": "Polygon", "coordinates": [ring]}}]
    offset = (side_n - 1) * spacing_m / 2
    for i in range(vehicles):
        row, col = divmod(i, side_n)
        # a quarter of a cell off the lattice, so no airport sits on a cell edge
        east, north = col * spacing_m - offset + cell_m / 4, row * spacing_m - offset + cell_m / 4
        features.append({"type": "Feature", "properties": {"role": "airport", "name": f"a{i + 1}",
                                                           "heading": HEADINGS[i % len(HEADINGS)],
                                                           "range_m": range_m},
                         "geometry": {"type": "Point", "coordinates": lon_lat(east, north)}})
    per_side = math.isqrt(TARGETS)
    for k in range(per_side * per_side):
        row, col = divmod(k, per_side)
        east = -half + (col + 0.5) * 2 * half / per_side + 0.3 * spacing_m
        north = -half + (row + 0.5) * 2 * half / per_side + 0.3 * spacing_m
        features.append({"type": "Feature", "properties": {"role": "target", "name": f"t{k + 1}"},
                         "geometry": {"type": "Point", "coordinates": lon_lat(east, north)}})
    return {"type": "FeatureCollection", "name": "fleet", "properties": {"cell_size_m": cell_m},
            "features": features}


# ---- the tap: every datagram the vehicles send the station, counted in another process ------

def _tap(port: int, ready: mp.Event, stop: mp.Event, out: mp.Queue) -> None:
    """Count the datagrams arriving on `port` (one MAVLink message each) per wall second, per
    message id and per vehicle, and each vehicle's longest gap between GLOBAL_POSITION_INTs."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    sock.bind(("127.0.0.1", port))
    sock.settimeout(0.2)
    inode = os.fstat(sock.fileno()).st_ino
    per_second: Counter[int] = Counter()
    per_second_id: Counter[tuple[int, int]] = Counter()
    by_id: Counter[int] = Counter()
    by_vehicle: Counter[int] = Counter()
    last_position: dict[int, float] = {}
    gap: dict[int, float] = {}
    ready.set()
    while not stop.is_set():
        try:
            data = sock.recv(4096)
        except TimeoutError:
            continue
        now = time.monotonic()
        per_second[int(now)] += 1
        if data[0] == 0xFD:
            msg_id, sysid = int.from_bytes(data[7:10], "little"), data[5]
        elif data[0] == 0xFE:
            msg_id, sysid = data[5], data[3]
        else:
            continue
        by_id[msg_id] += 1
        per_second_id[int(now), msg_id] += 1
        by_vehicle[sysid] += 1
        if msg_id == 33:  # GLOBAL_POSITION_INT
            if sysid in last_position:
                gap[sysid] = max(gap.get(sysid, 0.0), now - last_position[sysid])
            last_position[sysid] = now
    out.put({"per_second": dict(per_second), "by_id": dict(by_id), "per_second_id": dict(per_second_id),
             "by_vehicle": dict(by_vehicle), "gap": gap, "drops": _udp_sockets().get(inode, (0, 0))[1]})
    sock.close()


# ---- the kernel's view of a process's UDP sockets -------------------------------------------

def _udp_sockets() -> dict[int, tuple[int, int]]:
    """inode -> (bytes waiting in the receive queue, datagrams dropped) of every IPv4 UDP socket."""
    out = {}
    try:
        lines = Path("/proc/net/udp").read_text().splitlines()[1:]
    except OSError:
        return out
    for line in lines:
        f = line.split()
        out[int(f[9])] = (int(f[4].split(":")[1], 16), int(f[12]))
    return out


def _socket_inodes(pid: int) -> set[int]:
    inodes = set()
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            try:
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(int(target[8:-1]))
    except OSError:
        pass
    return inodes


def _schedstat_s(pid: int) -> tuple[float, float] | None:
    """(seconds on a CPU, seconds runnable but waiting for one) of the main thread of `pid` (the
    station's event loop) so far (/proc/PID/schedstat), or None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/schedstat").read_text().split()
    except OSError:
        return None
    return int(fields[0]) / 1e9, int(fields[1]) / 1e9


def _datagram_cost() -> int:
    """Bytes a small datagram takes in a UDP socket's receive queue as /proc/net/udp counts it (the
    kernel's buffer, not the payload: 832 on this machine's kernel)."""
    rx, tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM), socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        rx.bind(("127.0.0.1", 0))
        for _ in range(50):
            tx.sendto(b"\xfd" + bytes(40), rx.getsockname())
        time.sleep(0.1)
        return _udp_sockets()[os.fstat(rx.fileno()).st_ino][0] // 50 or 1
    finally:
        rx.close()
        tx.close()


def _cpu_s(proc: psutil.Process) -> float | None:
    """User + system seconds of `proc` (every thread) and of its live children, or None once gone."""
    try:
        t = proc.cpu_times()
        total = t.user + t.system
        for child in proc.children(recursive=True):
            try:
                c = child.cpu_times()
                total += c.user + c.system
            except psutil.Error:
                pass
        return total
    except psutil.Error:
        return None


# ---- the run --------------------------------------------------------------------------------

@dataclass
class Station:
    """What the benchmark saw of the station process."""

    started: float
    lines: list[tuple[float, str]] = field(default_factory=list)
    cpu_samples: list[tuple[float, float]] = field(default_factory=list)  # (monotonic, cpu s so far)
    sched: list[tuple[float, float, float]] = field(default_factory=list)  # (monotonic, on a CPU s, waiting s)
    cpu_total_s: float = 0.0
    ended: float = 0.0
    exit_code: int | None = None
    backlog: list[tuple[float, int, int]] = field(default_factory=list)  # (monotonic, all sockets, fullest), bytes
    drops: dict[int, int] = field(default_factory=dict)
    sockets: int = 0


def _read_lines(stream, sink: list[tuple[float, str]], log) -> None:
    for line in stream:
        sink.append((time.monotonic(), line.rstrip("\n")))
        log.write(line)
        log.flush()


def _wait4(pid: int, block: bool) -> tuple[int, float] | None:
    """(exit code, user + system seconds of the whole process) once `pid` has exited."""
    got, status, usage = os.wait4(pid, 0 if block else os.WNOHANG)
    if got == 0:
        return None
    return os.waitstatus_to_exitcode(status), usage.ru_utime + usage.ru_stime


def fly(plan_dir: Path, ports: list[int], log_path: Path, timeout_s: float, extra: list[str]) -> Station:
    """Run `gcs fly --plan plan_dir` over one udpout link per vehicle (and `extra`) until it exits;
    sample it."""
    args = [*GCS, "fly", "--plan", str(plan_dir), *(a for p in ports for a in ("--connect", f"udpout:127.0.0.1:{p}")),
            *extra]
    print("station: " + " ".join(["gcs", *args[3:6], "--connect udpout:127.0.0.1:PORT ...", *extra]), flush=True)
    log = open(log_path, "w")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            text=True, bufsize=1)
    station = Station(time.monotonic())
    reader = threading.Thread(target=_read_lines, args=(proc.stdout, station.lines, log), daemon=True)
    reader.start()
    ps = psutil.Process(proc.pid)
    inodes: set[int] = set()
    next_cpu = next_inodes = station.started
    deadline = station.started + timeout_s
    while True:
        now = time.monotonic()
        done = _wait4(proc.pid, block=False)
        if done is not None:
            station.exit_code, station.cpu_total_s = done
            station.ended = now
            proc.returncode = station.exit_code
            break
        if now > deadline:
            print(f"station still running after {timeout_s:g} s: interrupted (SIGINT brings everyone home)", flush=True)
            proc.send_signal(signal.SIGINT)
            deadline = now + 120
        if now >= next_inodes:
            inodes |= _socket_inodes(proc.pid)
            next_inodes = now + 2.0
        sockets = _udp_sockets()
        mine = {i: sockets[i] for i in inodes if i in sockets}
        if mine:
            station.backlog.append((now, sum(q for q, _ in mine.values()), max(q for q, _ in mine.values())))
        for i, (_, dropped) in mine.items():
            station.drops[i] = dropped
        if now >= next_cpu:
            cpu = _cpu_s(ps)
            if cpu is not None:
                station.cpu_samples.append((now, cpu))
            sched = _schedstat_s(proc.pid)
            if sched is not None:
                station.sched.append((now, *sched))
            next_cpu = now + 1.0
        time.sleep(0.25)
    reader.join(5.0)
    log.close()
    station.sockets = len(station.drops)
    return station


def _stamp_of(station: Station, pattern: str, pick) -> float | None:
    times = [t for t, line in station.lines if re.search(pattern, line)]
    return pick(times) if times else None


def _cpu_share(samples: list[tuple[float, float]], t0: float, t1: float) -> float | None:
    inside = [(t, c) for t, c in samples if t0 <= t <= t1]
    if len(inside) < 2:
        return None
    return (inside[-1][1] - inside[0][1]) / (inside[-1][0] - inside[0][0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vehicles", type=int, default=64)
    ap.add_argument("--range-m", type=float, default=1000.0, help="every UAV's range (default 1000)")
    ap.add_argument("--spacing-m", type=float, default=250.0, help="between neighbouring airports (default 250)")
    ap.add_argument("--cell-size", type=float, default=25.0, help="grid cell side, m (default 25)")
    ap.add_argument("--no-tap", action="store_true", help="no copy of the traffic to a counting listener")
    ap.add_argument("--keep", type=Path, default=None, help="keep the area, plan, flight and logs in this folder")
    ap.add_argument("--timeout-s", type=float, default=900.0, help="interrupt the station after this long")
    ap.add_argument("--station-arg", action="append", default=[], metavar="ARG",
                    help="one more argument for gcs fly (repeatable; e.g. --station-arg=--no-rrd); "
                         "none by default")
    args = ap.parse_args()
    if not 1 <= args.vehicles <= 250:
        ap.error("--vehicles: 1..250 (gcs sim's limit)")

    work = args.keep or Path(tempfile.mkdtemp(prefix="bench-fleet-"))
    if args.keep and work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    area = work / "fleet.geojson"
    area.write_text(json.dumps(fleet_area(args.vehicles, args.spacing_m, args.range_m, args.cell_size), indent=1))
    plan_dir = work / "plan"
    print(f"load average before: {Path('/proc/loadavg').read_text().strip()}  ({os.cpu_count()} cores)", flush=True)
    t = time.monotonic()
    if subprocess.run([*GCS, "plan", "--area", str(area), "--out", str(plan_dir), "--altitude", "20",
                       "--altitude-step", "1", "--quiet"], stdout=subprocess.DEVNULL).returncode:
        raise SystemExit("gcs plan refused the area (above)")
    plan = json.loads((plan_dir / "plan.json").read_text())
    flown = [u for u in plan["uavs"] if u["id"] not in {g["id"] for g in plan.get("grounded", [])}]
    lengths = [u["length_m"] for u in flown if u.get("length_m") is not None]
    print(f"plan: {len(flown)} UAVs on {args.spacing_m:g} m lattice, planned in {time.monotonic() - t:.1f} s; "
          f"paths {min(lengths):.0f}-{max(lengths):.0f} m (mean {sum(lengths) / len(lengths):.0f} m)", flush=True)

    ctx = mp.get_context("spawn")
    tap = None
    tap_port = None
    if not args.no_tap:
        tap_port = free_ports(1)
        ready, stop, queue = ctx.Event(), ctx.Event(), ctx.Queue()
        tap = ctx.Process(target=_tap, args=(tap_port, ready, stop, queue), daemon=True)
        tap.start()
        if not ready.wait(30):
            raise SystemExit("the tap did not start")
    base = free_ports(args.vehicles)
    ports = list(range(base, base + args.vehicles))
    sim_args = [*GCS, "sim", "--area", str(area), "--speedup", "1", "--base-port", str(base)]
    if tap_port is not None:
        sim_args += ["--out", f"udp:127.0.0.1:{tap_port}"]
    sim = subprocess.Popen(sim_args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    heard = 0
    sim_log = []
    while heard < args.vehicles:
        line = sim.stdout.readline()
        if not line:
            raise SystemExit("gcs sim did not start:\n" + "".join(sim_log))
        sim_log.append(line)
        heard += line.startswith("vehicle ")
    sim_started = time.monotonic()
    threading.Thread(target=lambda: sim_log.extend(sim.stdout), daemon=True).start()

    load_during: list[str] = []

    def sample_load() -> None:
        while sim.poll() is None:
            load_during.append(Path("/proc/loadavg").read_text().split()[0])
            time.sleep(30)

    threading.Thread(target=sample_load, daemon=True).start()
    try:
        station = fly(plan_dir, ports, work / "station.log", args.timeout_s, args.station_arg)
    finally:
        sim.send_signal(signal.SIGINT)
        got = _wait4(sim.pid, block=True)
        sim.returncode = got[0] if got else None
        sim_cpu = got[1] if got else float("nan")
        sim_wall = time.monotonic() - sim_started
        if tap is not None:
            stop.set()
            tapped = queue.get(timeout=30)
            tap.join(10)
    load_after = Path("/proc/loadavg").read_text().strip()
    (work / "sim.log").write_text("".join(sim_log))
    cost = _datagram_cost()
    (work / "backlog.csv").write_text("s_after_start,datagrams_waiting,fullest_socket\n" + "".join(
        f"{t - station.started:.2f},{total // cost},{fullest // cost}\n" for t, total, fullest in station.backlog))
    (work / "cpu.csv").write_text("s_after_start,cpu_s,on_cpu_s,runqueue_wait_s\n" + "".join(
        f"{t - station.started:.2f},{c:.3f},{on:.3f},{waiting:.3f}\n"
        for (t, c), (_, on, waiting) in zip(station.cpu_samples, station.sched)))

    # ---- the figures -----------------------------------------------------------------------
    wall = station.ended - station.started
    take_off = _stamp_of(station, r"UAV \d+: search - mission started", min)
    last_landing = _stamp_of(station, r"UAV \d+: landed", max)
    summary = next((line for _, line in station.lines if "landed at their airports" in line), "")
    m = re.search(r"(\d+)/(\d+) landed at their airports", summary)
    landed, total = (int(m.group(1)), int(m.group(2))) if m else (0, args.vehicles)
    samples = station.cpu_samples
    peaks = [((c1 - c0) / (t1 - t0), t1) for (t0, c0), (t1, c1) in zip(samples, samples[1:]) if t1 > t0]
    airborne_peaks = [p for p, t in peaks if take_off and last_landing and take_off <= t <= last_landing]
    airborne_cpu = _cpu_share(samples, take_off, last_landing) if take_off and last_landing else None
    lines = [line for _, line in station.lines]
    lost = [line for line in lines if re.search(r"UAV \d+: .*\blost\b", line)]
    link_lines = [line for line in lines if re.search(r"\blink \S+: (lost|reconnected|peer)", line)]
    errors = [line for line in lines if "error" in line.lower() or "Traceback" in line]
    returns = [line for line in lines if "return triggered" in line or "return ordered" in line]
    drops = sum(station.drops.values())
    max_wait = max((w1 - w0 for (_, _, w0), (_, _, w1) in zip(station.sched, station.sched[1:])), default=0.0)
    rcvbuf = int(Path("/proc/sys/net/core/rmem_default").read_text())
    worst = max(station.backlog, key=lambda b: b[1], default=(station.started, 0, 0))
    fullest = max((b[2] for b in station.backlog), default=0)
    airborne_backlog = sorted(b[1] for b in station.backlog
                              if take_off and last_landing and take_off <= b[0] <= last_landing)

    def pct(values: list[int], q: float) -> int:
        return values[min(len(values) - 1, int(q * len(values)))] if values else 0

    rows: list[tuple[str, str]] = [
        ("vehicles landed at their airports", f"{landed}/{total} (station exit code {station.exit_code})"),
        ("station wall time, start to exit", f"{wall:.1f} s"),
        ("first take-off to last landing", f"{last_landing - take_off:.1f} s" if take_off and last_landing else "-"),
        ("station CPU, whole run (wait4)", f"{100 * station.cpu_total_s / wall:.1f}% of one core "
                                           f"({station.cpu_total_s:.1f} s)"),
        ("station CPU, airborne part", f"{100 * airborne_cpu:.1f}% of one core" if airborne_cpu is not None else "-"),
        ("station CPU, peak 1-s interval, airborne", f"{100 * max(airborne_peaks):.1f}% of one core"
                                                     if airborne_peaks else "-"),
        ("station CPU, peak 1-s interval, any", f"{100 * max(peaks)[0]:.1f}% of one core, "
                                               f"{max(peaks)[1] - station.started:.0f} s after its start"
                                               if peaks else "-"),
        ("its event loop waiting for a CPU", f"{station.sched[-1][2]:.1f} s of its {wall:.0f} s, "
                                                  f"worst second {max_wait:.2f} s" if station.sched else "-"),
        ("simulator CPU (its own process)", f"{100 * sim_cpu / sim_wall:.1f}% of one core over {sim_wall:.0f} s"
                                            + (" (with the tap's copies)" if tap else "")),
        ("station UDP sockets watched", f"{station.sockets}"),
        ("datagrams dropped on them (kernel)", f"{drops}"),
        ("receive backlog, all sockets, deepest", f"{worst[1] // cost} datagrams ({worst[1]} bytes at {cost} a "
                                                  f"datagram), {worst[0] - station.started:.0f} s after its start"),
        ("  airborne: median / p99 / max", " / ".join(f"{pct(airborne_backlog, q) // cost}" for q in (.5, .99, 1.0))
                                          + " datagrams"),
        ("  fullest single socket", f"{fullest // cost} datagrams of the {rcvbuf // cost} its buffer holds "
                                    f"({rcvbuf} bytes)"),
        ("vehicles reported lost / link changes", f"{len(lost)} / {len(link_lines)}"),
        ("return orders and triggers", f"{len(returns)}"),
        ("error lines", f"{len(errors)}"),
    ]
    if tap is not None:
        per_second = {s: n for s, n in tapped["per_second"].items() if station.started <= s < station.ended - 1}
        total_msgs = sum(n for s, n in tapped["per_second"].items() if station.started <= s <= station.ended)
        flying = {s: n for s, n in per_second.items() if take_off and last_landing and take_off <= s <= last_landing}
        top = Counter(tapped["by_id"]).most_common(6)
        from pymavlink.dialects.v20 import ardupilotmega as mavlink

        def named(i: int) -> str:
            return mavlink.mavlink_map[i].msgname if i in mavlink.mavlink_map else str(i)

        names = ", ".join(f"{named(i)} {n / wall:.0f}" for i, n in top)
        gaps = tapped["gap"]
        busiest = max(per_second, key=per_second.get) if per_second else None
        rate = (f"{total_msgs / wall:.0f} mean over the run, "
                f"{sum(flying.values()) / max(1, len(flying)):.0f} airborne")
        if busiest is not None:
            rate += f", {per_second[busiest]} peak second ({busiest - station.started:.0f} s after its start)"
            in_busiest = Counter({i: n for (sec, i), n in tapped["per_second_id"].items() if sec == busiest})
        rows[9:9] = [
            ("MAVLink messages/s to the station (tap)", rate),
            ("  per vehicle", f"{total_msgs / wall / args.vehicles:.1f}/s mean"),
            ("  busiest types, /s", names),
            ("  in the peak second", ", ".join(f"{named(i)} {n}" for i, n in in_busiest.most_common(5))
                                     if busiest is not None else "-"),
            ("  longest GLOBAL_POSITION_INT gap sent", f"{max(gaps.values()):.2f} s (vehicle "
                                                       f"{max(gaps, key=gaps.get)})" if gaps else "-"),
            ("  messages the station received", f"{total_msgs - drops} ({total_msgs} sent to it less {drops} dropped)"),
            ("  tap's own drops", f"{tapped['drops']}"),
        ]
    print()
    print(f"bench_fleet: {args.vehicles} vehicles, speed-up 1, range {args.range_m:g} m, "
          f"cell {args.cell_size:g} m, lattice {args.spacing_m:g} m; one link per vehicle"
          + (f"; gcs fly {' '.join(args.station_arg)}" if args.station_arg else ""))
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"  {k:<{width}}  {v}")
    print(f"load average before the flight / every 30 s during it / after: see above / "
          f"{' '.join(load_during)} / {load_after}")
    if lost or link_lines or errors:
        print("station lines about losses and errors (first 10):")
        for line in (lost + link_lines + errors)[:10]:
            print("  " + line)
    print(f"station summary: {summary}")
    print(f"logs: {work}/station.log, sim.log, backlog.csv (every 0.25 s), cpu.csv (every 1 s)"
          + ("" if args.keep else " (a temporary folder)"))


if __name__ == "__main__":
    main()
