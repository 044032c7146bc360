"""Vehicle energy profiles on file (`vehicles.json`), and the stock profiles vehicles start from.

`gcs fly` writes what each vehicle's flight taught (`gcs.flight.energy_learning`) beside its
sortie record as `vehicles.json`, and, given `--vehicles FILE`, merges it into FILE (atomically,
under a lock: two stations may share one file). `gcs plan --vehicles FILE` plans each UAV's range
from the usable energy of the vehicle that flew as it, and `gcs fly --vehicles FILE` prices its
return trigger and its check before arming with it. A vehicle is keyed by itself, not by the UAV
it flew as: its board's unique id (AUTOPILOT_VERSION.uid) where the autopilot sends one, else
its MAVLink system id.

The file (schema `gcs/schemas/vehicles.schema.json`):

    {"schema_version": 1,
     "vehicles": {"uid:0123456789abcdef": {"uav_id": 2, "system_id": 2, "autopilot": "ardupilot",
                                            "flights": 3, "updated": "2026-11-27T10:00:00Z",
                                            "profile": {"airframe": "copter", "capacity_mah": 3300, ...}}}}

Stock profiles (`STOCK_PROFILES`) are the SITL vehicles in `../shared/peers/` as measured there
(docs/energy.md, `benchmarks/measure_energy.py`)."""

from __future__ import annotations

import fcntl
import json
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from importlib import resources
from pathlib import Path

from gcs.atomic import write_json_atomic
from gcs.errors import UserError
from planner.energy import Airframe, EnergyProfile
from planner.path_time import ARDUCOPTER_CORNERING, Cornering

__all__ = ["STOCK_PROFILES", "VEHICLES_FILE", "VehicleRecord", "load_vehicles", "merge_vehicles", "profile_for_uav",
           "stock_profile", "vehicles_to_dict"]

SCHEMA_VERSION = 1
#: the name of the file a flight writes beside its sortie record
VEHICLES_FILE = "vehicles.json"

#: Stock energy profiles by (autopilot family, airframe): the SITL vehicles of ../shared/peers
#: as `benchmarks/measure_energy.py` measured them (docs/energy.md has the figures and the command).
STOCK_PROFILES: dict[tuple[str, Airframe], EnergyProfile] = {
    # ArduCopter quad, copter.parm: 3300 mAh; 30.3 A at its 10 m/s WPNAV_SPEED (0.84 mAh/m straight, 1.43 on
    # 50 m legs with turns: a search path between; 1.01-1.11 on three fleet flights' search paths with
    # their slow seconds priced apart, 1.03 chosen within, docs/energy.md); 28.1 A hovering; 115 mAh to
    # 30 m, 223 to 60 m; landing 262 mAh from 30 m, 411 from
    # 60 m; and in every sortie about 13 s in level flight below 2 m/s (the climb's end, the station's
    # hold, the arrival before the descent), 100 mAh: half on the launch, half on the landing; hovering
    # it leans 0.288 into 6.5 m/s of wind (SIM_WIND_SPD 8 at 40 m, gcs.flight.lean_wind). Its current hardly
    # changes with its speed
    # (8.1 mAh/s in zig-zags of 50 m legs, 8.3 on a straight): a known path costs 8.15 mAh a second of
    # its time with ArduCopter's corners (planner.path_time; 0.99-1.05 mAh/m on the field fleets' plans
    # of 50 m cells, 1.11-1.18 on the paper area's 20 m cells)
    ("ardupilot", Airframe.COPTER): EnergyProfile(
        airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.03,
        loiter_mah_per_s=7.8, launch_mah=57.0, climb_mah_per_m=3.6, landing_mah=163.0, descent_mah_per_m=4.97,
        lean_tan_at_10_m_s=0.507, cornering=ARDUCOPTER_CORNERING, moving_mah_per_s=8.15),
    # ArduPlane, plane.parm: 3300 mAh; 11.3 A at 22 m/s air (0.134 mAh/m); 3.2 mAh/s loitering; its
    # full-throttle take-off 77 mAh to 30 m, 114 to 60 m; gliding in 27 mAh from 30 m, 82 from 60 m
    ("ardupilot", Airframe.PLANE): EnergyProfile(
        airframe=Airframe.PLANE, capacity_mah=3300.0, cruise_speed_m_s=22.0, cruise_mah_per_m=0.137,
        loiter_mah_per_s=3.2, launch_mah=40.0, climb_mah_per_m=1.23, landing_mah=0.0, descent_mah_per_m=1.4),
    # PX4 SIH quad: no current measured; its percentage drains in armed time only (SIM_BAT_DRAIN s
    # from full to empty; PX4's 60 s halves it in 30 s: our tests and --sim give it 1200 s, a
    # 20-minute pack, docs/energy.md): a nominal 5000 mAh, 4.17 mAh/s whatever it does; missions
    # at MPC_XY_CRUISE 5 m/s, climbing 1.9 m/s, descending 1.35 m/s, the last 10 m at 0.7 m/s
    ("px4", Airframe.COPTER): EnergyProfile(
        airframe=Airframe.COPTER, capacity_mah=5000.0, cruise_speed_m_s=5.0, cruise_mah_per_m=0.833,
        loiter_mah_per_s=4.17, launch_mah=0.0, climb_mah_per_m=2.2, landing_mah=29.0, descent_mah_per_m=3.1),
    # PX4 SIH plane: does not take off at v1.15.3 (../shared/peers/px4/README.md): the same pack in
    # time, at a plane's speed
    ("px4", Airframe.PLANE): EnergyProfile(
        airframe=Airframe.PLANE, capacity_mah=5000.0, cruise_speed_m_s=15.0, cruise_mah_per_m=0.278,
        loiter_mah_per_s=4.17, launch_mah=0.0, climb_mah_per_m=1.0, landing_mah=0.0, descent_mah_per_m=2.0),
}


def stock_profile(autopilot: str, airframe: Airframe | str) -> EnergyProfile:
    """The stock profile of an autopilot family and airframe (ArduPilot's for any other family)."""
    frame = Airframe(airframe)
    return STOCK_PROFILES.get((autopilot, frame), STOCK_PROFILES[("ardupilot", frame)])


@dataclass(frozen=True)
class VehicleRecord:
    """One vehicle in the file: the UAV it last flew as, its system id and autopilot, how many
    flights its profile was learned from, when, and the profile."""

    key: str
    uav_id: int
    system_id: int
    autopilot: str
    flights: int
    updated: str
    profile: EnergyProfile
    last_flight: dict | None = None  # the wind it was flown in and the ground speed each way made good


def vehicle_key(board_uid: int | None, system_id: int) -> str:
    """The key of a vehicle: its board's unique id where it sends one (not 0), else its system id."""
    return f"uid:{board_uid:016x}" if board_uid else f"sysid:{system_id}"


def profile_to_dict(profile: EnergyProfile) -> dict:
    out = asdict(profile)
    out["airframe"] = profile.airframe.value
    return {k: round(v, 6) if isinstance(v, float) else v for k, v in out.items()}


def profile_from_dict(data: dict) -> EnergyProfile:
    known = {f.name for f in fields(EnergyProfile)}
    values = {k: v for k, v in data.items() if k in known}
    values["airframe"] = Airframe(values["airframe"])
    if values.get("cornering") is not None:
        c = values["cornering"]
        values["cornering"] = Cornering(accel_m_s2=float(c["accel_m_s2"]),
                                        corner_fractions=tuple((float(t), float(f)) for t, f in c["corner_fractions"]))
    return EnergyProfile(**values)


def vehicles_to_dict(records: dict[str, VehicleRecord]) -> dict:
    return {"schema_version": SCHEMA_VERSION,
            "vehicles": {key: {"uav_id": r.uav_id, "system_id": r.system_id, "autopilot": r.autopilot,
                               "flights": r.flights, "updated": r.updated, "profile": profile_to_dict(r.profile)}
                         | ({"last_flight": r.last_flight} if r.last_flight else {})
                         for key, r in sorted(records.items())}}


@lru_cache(maxsize=1)
def vehicles_schema() -> dict:
    return json.loads(resources.files("gcs").joinpath("schemas/vehicles.schema.json").read_text())


def load_vehicles(path: str | Path) -> dict[str, VehicleRecord]:
    """Read a vehicles file; UserError with one line naming what is wrong."""
    import jsonschema

    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"{path}: no such vehicles file (gcs fly writes one beside its sortie record)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UserError(f"{path}: not a readable vehicles file ({exc})") from None
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(vehicles_schema()).iter_errors(data))
    if error is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
        raise UserError(f"{path}: does not follow the vehicles schema: {where or 'the top level'}: {error.message}")
    out = {}
    for key, v in data["vehicles"].items():
        try:
            profile = profile_from_dict(v["profile"])
        except (KeyError, TypeError, ValueError) as exc:
            raise UserError(f"{path}: vehicle {key}: bad profile ({exc})") from None
        out[key] = VehicleRecord(key, int(v["uav_id"]), int(v["system_id"]), str(v["autopilot"]), int(v["flights"]),
                                 str(v["updated"]), profile, v.get("last_flight"))
    return out


def profile_for_uav(records: dict[str, VehicleRecord], uav_id: int) -> VehicleRecord | None:
    """The vehicle that last flew as `uav_id` (the most recently updated one when several did)."""
    flew = [r for r in records.values() if r.uav_id == uav_id]
    return max(flew, key=lambda r: r.updated) if flew else None


@contextmanager
def _locked(path: Path) -> Iterator[None]:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(f".{path.name}.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def merge_vehicles(path: str | Path, records: dict[str, VehicleRecord]) -> dict[str, VehicleRecord]:
    """Merge `records` into the vehicles file at `path` (created when missing) atomically under a
    lock: a vehicle already there is replaced by its newer record. Returns the merged records; a
    file that cannot be read raises UserError and is left as it was."""
    path = Path(path)
    with _locked(path):
        merged = load_vehicles(path) if path.exists() else {}
        merged.update(records)
        write_json_atomic(path, vehicles_to_dict(merged))
    return merged


def finite_positive(value: float | None) -> bool:
    return value is not None and math.isfinite(value) and value > 0
