"""What a flight teaches about each vehicle's energy (`learned_profile`), kept as vehicle records
(`learned_records`) that `gcs fly` writes beside its sortie record as `vehicles.json` and merges
into the file given with `--vehicles` (`save_learned`).

Each part of the profile moves to what the flight showed where it showed enough of it: the cost
of a cruise metre is what the whole cruise cost where the autopilot counts the charge it consumed
(`whole_cruise_mah_per_m`; a profile that prices a path by its time, `EnergyProfile.cornering`,
moves its cost of a second as far), else the fuel gauge's still-air estimate at touch-down (the profile's figure
weighed against the level flight sampled, `gcs.flight.fuel`: a percentage read off the voltage
is still recovering from the climb in the first seconds of cruise), the launch and the landing are scaled to the charge
they took (their split between a fixed cost and a cost per metre of climb or descent kept), and
the capacity is the one the autopilot counts with. The hover and the wind response stay the
profile's until a flight measures them."""

from __future__ import annotations

import math
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

from gcs.atomic import write_json_atomic
from gcs.flight.fuel import FlightPhase
from gcs.flight.vehicle_energy import VehicleEnergy
from gcs.plans.vehicle_file import VEHICLES_FILE, VehicleRecord, merge_vehicles, vehicle_key, vehicles_to_dict
from planner.energy import EnergyProfile

__all__ = ["MIN_CRUISE_M", "VEHICLES_FILE", "last_flight", "learned_profile", "learned_records", "save_learned",
           "whole_cruise_mah_per_m"]

#: Metres of sampled cruise below which a flight does not move the cruise figure.
MIN_CRUISE_M = 100.0


def _scaled(observed_mah: float, predicted_mah: float) -> float | None:
    if predicted_mah > 0 and observed_mah > 0 and math.isfinite(observed_mah):
        return observed_mah / predicted_mah
    return None


def whole_cruise_mah_per_m(vehicle: VehicleEnergy) -> float | None:
    """What a still-air metre of its whole cruise cost, turns, stops and speed-ups included: the
    charge counted in cruise, less the hovers while the station sent a way home (at the profile's
    price), over the cruise metres weighed by the wind known as they were flown. None under
    MIN_CRUISE_M of cruise. This, not the level flight the fuel gauge samples, is what a plan's
    metre costs: a copter's learned gauge alone priced its next flight 0.6-5.5 % under what it drew."""
    fuel, prior = vehicle.fuel, vehicle.launch_profile
    if prior is None or fuel.phase_m[FlightPhase.CRUISE] < MIN_CRUISE_M or fuel.cruise_priced_m <= 0:
        return None
    spent = fuel.phase_mah[FlightPhase.CRUISE] - prior.loiter_mah_per_s * vehicle.hover_s
    return spent / fuel.cruise_priced_m if spent > 0 else None


def learned_profile(vehicle: VehicleEnergy) -> EnergyProfile | None:
    """The vehicle's profile as this flight leaves it; None when it never flew on a known charge."""
    prior = vehicle.launch_profile
    fuel = vehicle.fuel
    if prior is None or fuel.used_mah is None:
        return None
    altitude = vehicle.task.altitude_m
    changes: dict[str, float] = {"capacity_mah": fuel.capacity_mah}
    cruise = whole_cruise_mah_per_m(vehicle) if fuel.measures_current else None
    if cruise is not None:
        changes["cruise_mah_per_m"] = cruise
    elif fuel.cruise_m >= MIN_CRUISE_M:
        changes["cruise_mah_per_m"] = fuel.still_air_mah_per_m
    if "cruise_mah_per_m" in changes and prior.moving_mah_per_s is not None and vehicle.path_en is not None:
        # the metre of this plan's path the prior predicted moves to the one learned, its second with it
        changes["moving_mah_per_s"] = (prior.moving_mah_per_s * changes["cruise_mah_per_m"]
                                       / prior.path_mah_per_m(vehicle.path_en))
    launch = _scaled(fuel.phase_mah[FlightPhase.LAUNCH], prior.launch_cost_mah(altitude))
    if launch is not None:
        changes.update(launch_mah=prior.launch_mah * launch, climb_mah_per_m=prior.climb_mah_per_m * launch)
    landing = _scaled(fuel.phase_mah[FlightPhase.LANDING], prior.landing_cost_mah(vehicle.landing_altitude_m))
    if landing is not None:
        changes.update(landing_mah=prior.landing_mah * landing, descent_mah_per_m=prior.descent_mah_per_m * landing)
    return replace(prior, **changes)


def last_flight(vehicle: VehicleEnergy) -> dict:
    """The wind the flight was flown in (its last estimate; None in still air) and what it made
    good over the ground each way (`gcs.flight.heading_speeds`), for vehicles.json."""
    wind = vehicle.fuel.wind
    return {"wind": None if wind is None else {"speed_m_s": round(wind.speed_m_s, 2),
                                               "from_deg": round(wind.from_deg, 1),
                                               "sigma_m_s": round(wind.sigma_m_s, 2), "source": wind.source},
            "heading_speeds": vehicle.fuel.headings.as_dict()}


def learned_records(vehicles: dict[int, VehicleEnergy], before: dict[str, VehicleRecord] | None = None
                    ) -> dict[str, VehicleRecord]:
    """A record per vehicle that flew: keyed by its board's unique id, or its system id where it
    sends none or shares it with another vehicle of the flight (simulators often do); `before`
    (the file's records) counts the flights."""
    uids = [v.status.board_uid for v in vehicles.values()]
    now = datetime.now(UTC).isoformat(timespec="seconds")
    out = {}
    for uid, vehicle in sorted(vehicles.items()):
        profile = learned_profile(vehicle)
        if profile is None:
            continue
        board = vehicle.status.board_uid
        key = vehicle_key(board if board and uids.count(board) == 1 else None, uid)
        flights = (before or {}).get(key)
        out[key] = VehicleRecord(key, uid, uid, vehicle.autopilot, (flights.flights if flights else 0) + 1, now,
                                 profile, last_flight(vehicle))
    return out


def save_learned(folder: Path, vehicles: dict[int, VehicleEnergy], merge_into: str | None) -> tuple[Path | None, str]:
    """Write the flight's records to `folder`/vehicles.json and merge them into `merge_into`;
    the file written (None when no vehicle flew) and a line for the operator (a file that could
    not be merged is said, not raised: the flight is over and its own record stands)."""
    from gcs.errors import UserError
    from gcs.plans.vehicle_file import load_vehicles

    before: dict[str, VehicleRecord] = {}
    if merge_into and Path(merge_into).exists():
        try:
            before = load_vehicles(merge_into)
        except UserError:
            before = {}
    records = learned_records(vehicles, before)
    if not records:
        return None, "no vehicle flew on a known charge: no energy profile learned"
    path = Path(folder) / VEHICLES_FILE
    write_json_atomic(path, vehicles_to_dict(records))
    line = f"energy profiles learned: {path}"
    if merge_into:
        try:
            merge_vehicles(merge_into, records)
            line += f", merged into {merge_into}"
        except (UserError, OSError) as exc:
            line += f"; NOT merged into {merge_into} ({exc})"
    return path, line
