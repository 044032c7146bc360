"""Helpers for the resume tests: a station killed mid-flight and what it left behind.

`station(...)` runs `gcs fly` as the user does, in its own process, and `kill_when(...)`
SIGKILLs it the moment the journal it writes shows a given state; `flight_events` reads the
event log back from every segment of the flight's Rerun recording with Rerun's reader."""

from __future__ import annotations

import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from gcs.flight.journal import JOURNAL_FILE, JournalError, JournalState, read_journal
from gcs.recording.flight import FLIGHT_TIME, segment_path
from gcs.recording.plan import read_recording
from tests.peers.ports import free_ports
from tests.peers.process import stop_process


def station(plan_dir: Path, connections: list[str], *extra: str) -> subprocess.Popen:
    """`gcs fly --plan DIR --connect ...` in its own process (output kept in DIR/../station.log)."""
    log = open(plan_dir.parent / "station.log", "wb")
    args = [sys.executable, "-m", "gcs.cli", "fly", "--plan", str(plan_dir),
            *(arg for c in connections for arg in ("--connect", c)), *extra]
    process = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT)
    log.close()
    return process


def kill_when(process: subprocess.Popen, plan_dir: Path, ready: Callable[[JournalState], bool],
              timeout_s: float = 120.0) -> JournalState:
    """SIGKILL `process` once its journal satisfies `ready`; the journal as it was left."""
    deadline = time.monotonic() + timeout_s
    while True:
        assert process.poll() is None, (plan_dir.parent / "station.log").read_text()[-3000:]
        assert time.monotonic() < deadline, "the journal never reached the state to kill in"
        if (plan_dir / JOURNAL_FILE).exists():
            try:
                state = read_journal(plan_dir)
            except JournalError:
                state = None  # the start line is being written
            if state is not None and ready(state):
                process.kill()
                process.wait(10)
                return read_journal(plan_dir)
        time.sleep(0.02)


def readings(state: JournalState) -> dict[int, int]:
    return {uid: len(v.readings) for uid, v in state.vehicles.items()}


def flight_events(plan_dir: Path, segments: int) -> tuple[list[str], list[list[tuple[float, str]]]]:
    """The recording ids and the event log of each segment (flight second, line)."""
    from rerun.chunk import RrdReader

    ids, logs = [], []
    for k in range(segments):
        path = segment_path(plan_dir / "flight.rrd", k)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a killed station's file has no footer
            ids += [r.recording_id for r in RrdReader(str(path)).recordings()]
        rec = read_recording(path, FLIGHT_TIME)
        times, lines = rec.column("events", "TextLog:text") if "events" in rec.temporal else ([], [])
        logs.append([(t, line[0]) for t, line in zip(times, lines)])  # a station killed early flushed none
    return ids, logs


class SimProcess:
    """`gcs sim` in its own process with a vehicle at each of a plan's airports (system id =
    UAV id), the plan's targets and a sensor on its cells, so the vehicles outlive a station."""

    def __init__(self, plan, *, speedup: float, drain: float = 1.0, pf: float = 0.1) -> None:
        self.plan = plan
        self.speedup = speedup
        self.drain = drain
        self.pf = pf
        self.process: subprocess.Popen | None = None
        self.ports: list[int] = []

    @property
    def connections(self) -> list[str]:
        return [f"udpout:127.0.0.1:{port}" for port in self.ports]

    def __enter__(self) -> SimProcess:
        plan = self.plan
        ids = sorted(plan.uavs)
        args = [sys.executable, "-m", "gcs.cli", "sim", "--vehicles", str(len(ids)), "--speedup", f"{self.speedup:g}",
                "--cell-size-m", f"{plan.cell_size_m:g}", "--pf", f"{self.pf:g}",
                "--drain-multiplier", f"{self.drain:g}"]
        for uid in ids:
            lat, lon = plan.uavs[uid].airport_lat_lon
            args.append(f"--home={lat},{lon},{plan.uavs[uid].start_heading * 45}")
        args += [f"--target={lat},{lon}" for lat, lon in (plan.cell_lat_lon(x, y) for x, y in plan.targets)]
        base = free_ports(len(ids))
        self.ports = list(range(base, base + len(ids)))
        self.process = subprocess.Popen([*args, "--base-port", str(base)], stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True)
        for _ in ids:  # "vehicle N: ..." once each is listening
            line = self.process.stdout.readline()
            while line and not line.startswith("vehicle"):
                line = self.process.stdout.readline()
            assert line, "gcs sim did not start"
        return self

    def __exit__(self, *exc: object) -> None:
        if self.process is not None:
            stop_process(self.process)


def vehicle_state(connection: str, timeout_s: float = 10.0) -> tuple[float, float, bool]:
    """(lat, lon, armed) as the vehicle itself reports them now, asked over its own link."""
    from pymavlink import mavutil

    link = mavutil.mavlink_connection(connection, source_system=250, dialect="common")
    try:
        deadline = time.monotonic() + timeout_s
        position = armed = None
        while time.monotonic() < deadline and (position is None or armed is None):
            link.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            msg = link.recv_match(type=["GLOBAL_POSITION_INT", "HEARTBEAT"], blocking=True, timeout=0.5)
            if msg is None:
                continue
            if msg.get_type() == "GLOBAL_POSITION_INT":
                position = (msg.lat / 1e7, msg.lon / 1e7)
            elif msg.get_srcComponent() == 1 and msg.type != mavutil.mavlink.MAV_TYPE_GCS:
                armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        assert position is not None and armed is not None, f"{connection}: the vehicle did not answer"
        return (*position, armed)
    finally:
        link.close()
