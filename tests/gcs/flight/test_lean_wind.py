"""The wind a multicopter shows by leaning into it (`gcs.flight.lean_wind`)."""

from __future__ import annotations

import math

import pytest

from gcs.flight.lean_wind import (
    FIRM_SAMPLES,
    GRAVITY_M_S2,
    LAW_SIGMA_M_S,
    LEAN_EXPONENT,
    MAX_ACCELERATION_M_S2,
    MIN_SAMPLES,
    LeanWind,
    thrust_lean,
)
from gcs.telemetry.wind import CALM_M_S
from sim.autopilot.telemetry import COPTER_LEAN_AT_10_M_S, COPTER_LEAN_EXPONENT

L10 = 0.507  # ArduCopter SITL's quad (benchmarks/lean_wind.py, at SITL's wind at 40 m)


def lean_for(air_east: float, air_north: float) -> tuple[float, float]:
    speed = math.hypot(air_east, air_north)
    tan = L10 * (speed / 10.0) ** LEAN_EXPONENT
    return (tan * air_east / speed, tan * air_north / speed) if speed else (0.0, 0.0)


def test_a_nose_down_pitch_leans_the_thrust_the_way_the_nose_points():
    east, north = thrust_lean(0.0, math.radians(-10.0), 0.0)  # nose north, pitched down
    assert north == pytest.approx(math.tan(math.radians(10.0))) and east == pytest.approx(0.0, abs=1e-12)
    east, north = thrust_lean(0.0, math.radians(-10.0), math.radians(90.0))  # nose east
    assert east == pytest.approx(math.tan(math.radians(10.0))) and north == pytest.approx(0.0, abs=1e-12)
    east, north = thrust_lean(math.radians(10.0), 0.0, 0.0)  # nose north, rolled right: thrust east
    assert east == pytest.approx(math.tan(math.radians(10.0))) and north == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("speed, source_deg", [(8.0, 250.0), (4.0, 90.0), (12.0, 0.0)])
def test_a_hover_reads_as_the_wind_it_holds_against(speed, source_deg):
    """Hovering, its air velocity is the wind's reversed: ArduCopter SITL leans 0.288 into 6.53 m/s
    (SIM_WIND_SPD 8 at 40 m)."""
    towards = math.radians(source_deg + 180.0)
    wind_e, wind_n = speed * math.sin(towards), speed * math.cos(towards)
    wind = LeanWind(L10)
    for _ in range(MIN_SAMPLES - 1):
        wind.sample(lean_for(-wind_e, -wind_n), (0.0, 0.0), (0.0, 0.0))
    assert wind.wind_m_s is None  # not on a few samples
    wind.sample(lean_for(-wind_e, -wind_n), (0.0, 0.0), (0.0, 0.0))
    east, north = wind.wind_m_s
    assert math.hypot(east, north) == pytest.approx(speed)
    off = (math.degrees(math.atan2(-east, -north)) - source_deg + 180.0) % 360.0 - 180.0
    assert off == pytest.approx(0.0, abs=1e-6)
    assert math.hypot(*lean_for(8.0 * (40.0 / 60.0) ** 0.5, 0.0)) == pytest.approx(0.288, abs=0.002)
    estimate = wind.estimate  # six identical samples: the law's own error, not yet averaged over many
    assert estimate.sigma_m_s == pytest.approx(LAW_SIGMA_M_S * math.sqrt(FIRM_SAMPLES / MIN_SAMPLES))
    assert estimate.young
    for _ in range(FIRM_SAMPLES - MIN_SAMPLES):
        wind.sample(lean_for(-wind_e, -wind_n), (0.0, 0.0), (0.0, 0.0))
    assert wind.estimate.sigma_m_s == pytest.approx(LAW_SIGMA_M_S) and not wind.estimate.young


def test_in_level_flight_the_wind_is_the_ground_velocity_less_the_air_velocity():
    """Flying north at 2 m/s over the ground into an 8 m/s north wind it flies 10 m/s through the
    air; flying east at 10 m/s over the ground across it, sqrt(10^2 + 8^2) crabbing into it."""
    wind = LeanWind(L10)
    for _ in range(MIN_SAMPLES):
        wind.sample(lean_for(0.0, 10.0), (0.0, 2.0), (0.0, 0.0))
        wind.sample(lean_for(10.0, 8.0), (10.0, 0.0), (0.0, 0.0))
    east, north = wind.wind_m_s
    assert east == pytest.approx(0.0, abs=1e-9) and north == pytest.approx(-8.0)


def test_an_acceleration_is_not_taken_for_a_wind_and_a_hard_one_is_left_out():
    wind = LeanWind(L10)
    for _ in range(MIN_SAMPLES):  # speeding up north at 0.5 m/s^2 from 5 m/s in still air
        air = lean_for(0.0, 5.0)
        wind.sample((air[0], air[1] + 0.5 / GRAVITY_M_S2), (0.0, 5.0), (0.0, 0.5))
    east, north = wind.estimate.vector
    assert math.hypot(east, north) == pytest.approx(0.0, abs=1e-9)
    wind.sample((0.0, 1.0), (0.0, 5.0), (0.0, MAX_ACCELERATION_M_S2 + 0.1))  # a turn, a stop
    assert wind.samples == MIN_SAMPLES


def test_the_simulated_copter_leans_as_the_profile_reads_and_shows_no_wind():
    """The simulator's copter flies in still air: its lean at any speed reads as no wind."""
    assert (COPTER_LEAN_AT_10_M_S, COPTER_LEAN_EXPONENT) == (L10, LEAN_EXPONENT)
    wind = LeanWind(L10)
    for speed in (2.0, 5.0, 10.0, 15.0) * 10:
        pitch = -math.atan(COPTER_LEAN_AT_10_M_S * (speed / 10.0) ** COPTER_LEAN_EXPONENT)
        wind.sample(thrust_lean(0.0, pitch, math.radians(30.0)), (speed * 0.5, speed * math.sqrt(0.75)), (0.0, 0.0))
    assert math.hypot(*wind.wind_m_s) == pytest.approx(0.0, abs=1e-6)


def test_a_light_wind_reads_as_still_air():
    """Below CALM_M_S, or two of its standard deviations, the lean law's own error could be all
    there is: still air."""
    wind = LeanWind(L10)
    for _ in range(MIN_SAMPLES):
        wind.sample(lean_for(-(CALM_M_S - 0.5), 0.0), (0.0, 0.0), (0.0, 0.0))
    assert wind.wind_m_s == (0.0, 0.0)


def test_gusts_make_a_young_estimate_and_a_steady_wind_firms_it_up():
    """Samples scattered by gusts of 3 m/s: an estimate as unsure as they are, sure once many agree."""
    wind = LeanWind(L10)
    gusts = [(-6.0 + 3.0 * math.cos(k), 3.0 * math.sin(k)) for k in range(MIN_SAMPLES)]
    for east, north in gusts:
        wind.sample(lean_for(-east, -north), (0.0, 0.0), (0.0, 0.0))
    young = wind.estimate
    assert young.young and young.sigma_m_s > 1.0
    for _ in range(50):
        wind.sample(lean_for(6.0, 0.0), (0.0, 0.0), (0.0, 0.0))
    firm = wind.estimate
    assert not firm.young and firm.sigma_m_s < young.sigma_m_s
    assert firm.speed_m_s == pytest.approx(6.0, abs=0.5) and firm.from_deg == pytest.approx(90.0, abs=5.0)
