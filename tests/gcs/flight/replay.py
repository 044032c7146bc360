"""Recorded telemetry (`tests/peers/wind_log.py`'s gzipped tlogs) fed to a vehicle's energy as the
station feeds it in flight: status first, then the fuel gauge."""

from __future__ import annotations

import gzip
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega

from gcs.flight.vehicle_energy import VehicleEnergy
from gcs.links import mavlink
from gcs.plans.plan_folder import UavTask
from gcs.plans.vehicle_file import STOCK_PROFILES
from gcs.telemetry.status import VehicleStatus
from planner.energy import Airframe

DATA = Path(__file__).resolve().parents[2] / "data"
WIND_LOG = DATA / "arducopter-wind-8-from-250.tlog.gz"  # SIM_WIND_SPD 8 from 250, TURB 2: 6.5 m/s at 40 m
STILL_AIR_LOG = DATA / "arducopter-still-air.tlog.gz"
#: SITL's wind at the log's 40 m (SIM_WIND_T 0: the set speed times sqrt(40 / 60))
LOGGED_WIND_M_S = 8.0 * (40.0 / 60.0) ** 0.5
LOGGED_FROM_DEG = 250.0
COPTER = STOCK_PROFILES[("ardupilot", Airframe.COPTER)]


def messages(path: Path) -> Iterator[mavlink.MAVLink_message]:
    """The messages of a gzipped tlog (an 8-byte big-endian stamp before each MAVLink 2 frame)."""
    data = gzip.decompress(path.read_bytes())
    parser = ardupilotmega.MAVLink(None)
    i = 0
    while i < len(data):
        i += 8
        length = 12 + data[i + 1] + (13 if data[i + 2] & 1 else 0)
        yield parser.decode(bytearray(data[i:i + length]))
        i += length


def replayed(path: Path, task: UavTask, on_each=None) -> VehicleEnergy:
    """A vehicle's energy fed the log, at the log's 40 m; `on_each(energy)` after every message."""
    status = VehicleStatus(task.uav_id)
    energy = VehicleEnergy(replace(task, altitude_m=40.0), status, COPTER, reserve_pct=30.0)
    energy.autopilot = "ardupilot"
    now = 0.0
    for msg in messages(path):
        if msg.get_type() == "GLOBAL_POSITION_INT":
            now = msg.time_boot_ms / 1000.0
        status.update(msg, now)
        energy.on_message(msg)
        if on_each is not None:
            on_each(energy)
    return energy
