"""Energy profiles: the range a charge buys, the cost of a flight's parts, and what wind does to
a ground metre; by hand and by properties."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, strategies as st

from planner.energy import Airframe, EnergyProfile, wind_factor

COPTER = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=0.75,
                       loiter_mah_per_s=7.5, launch_mah=10.0, climb_mah_per_m=4.0, landing_mah=5.0,
                       descent_mah_per_m=2.0, drag_share=0.3)
PLANE = EnergyProfile(airframe=Airframe.PLANE, capacity_mah=3300.0, cruise_speed_m_s=20.0, cruise_mah_per_m=0.3,
                      loiter_mah_per_s=6.0, launch_mah=30.0, climb_mah_per_m=3.0, landing_mah=10.0,
                      descent_mah_per_m=0.5)


def test_range_by_hand():
    # 3300 mAh, 30 % reserve: 2310 usable; launch 10 + 4 x 50, landing 5 + 2 x 50: 2310 - 210 - 105 = 1995 mAh
    assert COPTER.launch_cost_mah(50.0) == 210.0 and COPTER.landing_cost_mah(50.0) == 105.0
    assert COPTER.range_m(50.0, 30.0) == pytest.approx(1995 / 0.75)
    assert COPTER.range_m(50.0, 30.0, charge_pct=50.0) == pytest.approx((1650 - 990 - 315) / 0.75)
    assert COPTER.range_m(50.0, 30.0, charge_pct=35.0) == 0.0
    assert COPTER.flight_cost_mah(1000.0, 50.0, loiter_s=10.0) == pytest.approx(210 + 750 + 75 + 105)
    assert COPTER.with_capacity(1800.0).range_m(50.0, 30.0) == pytest.approx((1260 - 315) / 0.75)


@pytest.mark.parametrize("field, value", [("capacity_mah", 0.0), ("cruise_mah_per_m", -1.0),
                                          ("cruise_speed_m_s", math.nan), ("launch_mah", -0.1),
                                          ("drag_share", 1.5), ("loiter_mah_per_s", math.inf)])
def test_a_profile_refuses_nonsense(field, value):
    with pytest.raises(ValueError, match=field):
        EnergyProfile(**{**COPTER.__dict__, field: value})


def test_plane_wind_by_hand():
    """A plane holds 20 m/s through the air: 5 m/s on the nose leaves 15 over the ground."""
    assert wind_factor(PLANE, 5.0, 0.0, -100.0, 0.0) == pytest.approx(20 / 15)  # air moving east, flying west
    assert wind_factor(PLANE, 5.0, 0.0, 100.0, 0.0) == pytest.approx(20 / 25)
    assert wind_factor(PLANE, 0.0, 12.0, 100.0, 0.0) == pytest.approx(20 / 16)  # crabbing: sqrt(400 - 144)
    assert wind_factor(PLANE, 25.0, 0.0, -1.0, 0.0) == math.inf  # cannot make way
    assert wind_factor(PLANE, 0.0, 0.0, 1.0, 0.0) == 1.0
    assert wind_factor(PLANE, 3.0, 4.0, 0.0, 0.0) == 1.0  # no leg


def test_copter_wind_by_hand():
    """A copter holds 10 m/s over the ground: into 5 m/s it flies 15 through the air, drag 30 %
    of its cruise power growing with the square of the airspeed."""
    assert wind_factor(COPTER, -5.0, 0.0, 100.0, 0.0) == pytest.approx(1 + 0.3 * (2.25 - 1))
    assert wind_factor(COPTER, 5.0, 0.0, 100.0, 0.0) == pytest.approx(1 + 0.3 * (0.25 - 1))
    assert wind_factor(COPTER, 0.0, 5.0, 100.0, 0.0) == pytest.approx(1 + 0.3 * (1.25 - 1))


@given(speed=st.floats(0, 15), direction=st.floats(0, 2 * math.pi))
def test_a_round_trip_in_the_wind_never_costs_less_than_in_still_air(speed, direction):
    """Out and back along any line: what the tailwind saves never pays for the headwind."""
    we, wn = speed * math.cos(direction), speed * math.sin(direction)
    for profile in (COPTER, PLANE):
        out, back = wind_factor(profile, we, wn, 100.0, 30.0), wind_factor(profile, we, wn, -100.0, -30.0)
        assert out + back >= 2.0 - 1e-9
