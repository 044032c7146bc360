"""`new_vehicle` makes the vehicle of a config's profile; a vehicle class refuses another profile's
config (one made by hand cannot fly the wrong autopilot's behaviour)."""

from __future__ import annotations

import pytest

from sim import HomePose, SimVehicle, VehicleConfig, new_vehicle
from sim.autopilot.px4_vehicle import Px4Vehicle

HOME = HomePose(47.2771883, 11.4039709, 584.0, 90.0)


@pytest.mark.parametrize(("profile", "cls"), [("ardupilot", SimVehicle), ("px4", Px4Vehicle)])
@pytest.mark.parametrize("vehicle_type", ["copter", "plane"])
def test_new_vehicle_makes_the_profiles_vehicle(profile, cls, vehicle_type):
    vehicle = new_vehicle(3, HOME, VehicleConfig(profile=profile, vehicle_type=vehicle_type))
    assert type(vehicle) is cls
    assert (vehicle.sysid, vehicle.config.profile, vehicle.config.vehicle_type) == (3, profile, vehicle_type)
    assert vehicle.ardupilot == (profile == "ardupilot")


def test_without_a_config_each_vehicle_takes_its_own_profile():
    assert type(new_vehicle(1, HOME)) is SimVehicle
    assert new_vehicle(1, HOME).config.profile == "ardupilot"
    assert Px4Vehicle(1, HOME).config.profile == "px4"


@pytest.mark.parametrize(("cls", "profile"), [(SimVehicle, "px4"), (Px4Vehicle, "ardupilot")])
def test_a_vehicle_class_refuses_another_profiles_config(cls, profile):
    with pytest.raises(ValueError, match="new_vehicle"):
        cls(1, HOME, VehicleConfig(profile=profile))
