"""The simulated vehicle of each autopilot profile: `new_vehicle` makes the one its config names,
`SimVehicle` for `ardupilot`, `sim.autopilot.px4_vehicle.Px4Vehicle` for `px4`. A new profile's
vehicle is added here."""

from __future__ import annotations

from typing import Any

from sim.autopilot.px4_vehicle import Px4Vehicle
from sim.autopilot.vehicle import SimVehicle, VehicleConfig
from sim.physics.airframe import HomePose

VEHICLES: dict[str, type[SimVehicle]] = {"ardupilot": SimVehicle, "px4": Px4Vehicle}


def new_vehicle(sysid: int, home: HomePose, config: VehicleConfig | None = None, **options: Any) -> SimVehicle:
    """The vehicle of `config.profile` (default config: ardupilot); `options` as `SimVehicle` takes them."""
    config = config or VehicleConfig()
    return VEHICLES[config.profile](sysid, home, config, **options)
