"""What a flight teaches a vehicle's profile (`gcs.flight.profiles`): the profile it leaves prices
the flight it learned from at what that flight cost, turns, stops and the wind included; fed
battery reports and steps as the station reads them, no vehicle."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gcs.flight.fuel import FlightPhase, FuelGauge
from gcs.flight.profiles import learned_profile, whole_cruise_mah_per_m
from gcs.flight.vehicle_energy import VehicleEnergy
from gcs.flight.vehicle_track import PlanTrack
from gcs.telemetry.status import VehicleStatus
from planner.energy import Airframe, EnergyProfile, wind_factor
from planner.path_time import ARDUCOPTER_CORNERING

PROFILE = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=5000.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.0,
                        loiter_mah_per_s=6.0, launch_mah=40.0, climb_mah_per_m=3.0, landing_mah=20.0,
                        descent_mah_per_m=1.5)

#: The vehicle as flown: dearer than its profile in level flight, dearer still as it speeds up
#: out of each turn, and a hover that costs what the profile says.
LEVEL_MAH_PER_M = 1.2
SPEED_UP_MAH_PER_M = 2.5
SPEED_UP_S = 3


class Flight:
    """One vehicle's energy, fed a flight second by second."""

    def __init__(self, plan, *, consumed: bool = True) -> None:
        self.energy = VehicleEnergy(plan.uavs[1], VehicleStatus(1), PROFILE, reserve_pct=30.0)
        self.energy.launch_profile = PROFILE
        self.consumed = consumed
        self.t = 0.0
        self.used = 0.0
        self.fuel: FuelGauge = self.energy.fuel
        self.fuel.battery(0.0, FlightPhase.GROUND, 0.0 if consumed else None, 100.0)

    def second(self, phase: FlightPhase, mah: float, east: float = 0.0, north: float = 0.0) -> None:
        self.t += 1.0
        self.used += mah
        self.fuel.moved(self.t, east, north, phase)
        if self.consumed:
            self.fuel.battery(self.t, phase, self.used, None)
        else:
            self.fuel.battery(self.t, phase, None, 100.0 * (1.0 - self.used / self.fuel.capacity_mah))

    def legs(self, headings: list[tuple[float, float]], seconds: int, wind=None) -> None:
        """Cruise legs at 10 m/s, each `seconds` long, the first SPEED_UP_S of each dearer; a
        metre costs `wind_factor` times more in the wind the gauge is told of."""
        for east, north in headings:
            factor = 1.0 if wind is None else wind_factor(PROFILE, east, north, wind)
            for s in range(seconds):
                rate = SPEED_UP_MAH_PER_M if s < SPEED_UP_S else LEVEL_MAH_PER_M
                self.second(FlightPhase.CRUISE, rate * factor * math.hypot(east, north), east, north)

    def fly(self, wind=None) -> None:
        for _ in range(10):
            self.second(FlightPhase.LAUNCH, 15.0)
        if wind is not None:
            self.fuel.set_wind(*wind)
        self.legs([(10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), (0.0, -10.0)] * 3, 12, wind)
        self.energy.hover_s = 8.0  # held while its way home was sent
        for _ in range(8):
            self.second(FlightPhase.CRUISE, PROFILE.loiter_mah_per_s)
        self.legs([(7.07, 7.07), (-7.07, -7.07)], 15, wind)
        for _ in range(12):
            self.second(FlightPhase.LANDING, 4.0)


@pytest.mark.parametrize("wind", [None, (0.0, 5.0)], ids=["still air", "5 m/s wind"])
def test_the_learned_profile_prices_the_flight_it_learned_from_at_what_it_cost(plan, wind):
    flight = Flight(plan)
    flight.fly(wind)
    learned = learned_profile(flight.energy)
    assert learned is not None
    flight.energy.launch_profile = learned
    account = flight.energy.energy_account()
    assert account is not None
    assert account.used_mah == pytest.approx(flight.used)
    assert account.predicted_mah == pytest.approx(account.used_mah, rel=1e-9)
    assert LEVEL_MAH_PER_M < learned.cruise_mah_per_m < SPEED_UP_MAH_PER_M  # still air's: the wind taken out
    if wind is None:  # the level flight the gauge samples misses the speed-ups after take-off and the hover
        assert learned.cruise_mah_per_m > flight.fuel.still_air_mah_per_m


def test_the_whole_cruise_leaves_out_the_hover_while_the_way_home_was_sent(plan):
    flight = Flight(plan)
    flight.fly()
    whole = whole_cruise_mah_per_m(flight.energy)
    assert whole is not None
    cruise_m = flight.fuel.phase_m[FlightPhase.CRUISE]
    speed_ups = 14 * SPEED_UP_S * 10.0
    expected = (SPEED_UP_MAH_PER_M * speed_ups + LEVEL_MAH_PER_M * (cruise_m - speed_ups)) / cruise_m
    assert whole == pytest.approx(expected, rel=1e-3)


def test_a_battery_read_only_as_a_percentage_keeps_the_gauges_level_figure(plan):
    flight = Flight(plan, consumed=False)
    flight.fly()
    learned = learned_profile(flight.energy)
    assert learned is not None and learned.cruise_mah_per_m == pytest.approx(flight.fuel.still_air_mah_per_m)


def test_a_flight_too_short_to_show_its_cruise_leaves_the_profiles_figure(plan):
    flight = Flight(plan)
    for _ in range(10):
        flight.second(FlightPhase.LAUNCH, 15.0)
    flight.legs([(10.0, 0.0)], 5)
    assert whole_cruise_mah_per_m(flight.energy) is None
    learned = learned_profile(flight.energy)
    assert learned is not None and learned.cruise_mah_per_m == PROFILE.cruise_mah_per_m


def test_a_profile_that_prices_a_path_by_its_time_learns_its_second_and_predicts_its_plan(plan):
    """A profile with ArduCopter's cornering: the energy account predicts a cruise metre at the
    plan's own path (its corners spread over it), the return trigger's gauge still at the metre
    the plan was sized with; the learned profile's second moves as its metre did, so that priced
    along the same plan it costs what the flight learned."""
    timed = replace(PROFILE, cornering=ARDUCOPTER_CORNERING, moving_mah_per_s=9.0)
    track = PlanTrack(plan, 1).track_m
    per_m = timed.path_mah_per_m(track)
    assert per_m != pytest.approx(timed.cruise_mah_per_m, rel=0.02)
    flight = Flight(plan)
    energy = flight.energy = VehicleEnergy(plan.uavs[1], VehicleStatus(1), timed, reserve_pct=30.0, path_en=track)
    assert energy.fuel.profile.cruise_mah_per_m == timed.cruise_mah_per_m
    flight.fuel = energy.fuel
    energy.launch_profile = timed
    flight.fuel.battery(0.0, FlightPhase.GROUND, 0.0, 100.0)
    flight.fly()
    account = energy.energy_account()
    assert account is not None
    assert account.predicted_mah == pytest.approx(
        timed.launch_cost_mah(energy.task.altitude_m) + per_m * energy.fuel.cruise_priced_m
        + timed.loiter_mah_per_s * energy.hover_s + timed.landing_cost_mah(energy.landing_altitude_m))
    learned = learned_profile(energy)
    assert learned is not None and learned.cornering == ARDUCOPTER_CORNERING
    assert learned.cruise_mah_per_m == pytest.approx(whole_cruise_mah_per_m(energy))
    assert learned.moving_mah_per_s == pytest.approx(9.0 * learned.cruise_mah_per_m / per_m)
    assert learned.path_mah_per_m(track) == pytest.approx(learned.cruise_mah_per_m)
