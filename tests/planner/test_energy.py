"""Energy profiles: the range a charge buys and the cost of a flight's parts, by hand."""

from __future__ import annotations

import math

import pytest

from planner.energy import Airframe, EnergyProfile

COPTER = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=0.75,
                       loiter_mah_per_s=7.5, launch_mah=10.0, climb_mah_per_m=4.0, landing_mah=5.0,
                       descent_mah_per_m=2.0)
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
                                          ("loiter_mah_per_s", math.inf)])
def test_a_profile_refuses_nonsense(field, value):
    with pytest.raises(ValueError, match=field):
        EnergyProfile(**{**COPTER.__dict__, field: value})
