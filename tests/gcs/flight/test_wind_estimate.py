"""The wind estimators on recorded ArduCopter SITL telemetry (`tests/peers/wind_log.py`: a star of
200 m legs at 10 m/s and 40 m, in SIM_WIND_SPD 8 from 250 with gusts, and in still air), fed as
the station feeds them in flight; and a return a young estimate alone asks for, put off."""

from __future__ import annotations

import math

import pytest

from gcs.flight.fuel import FlightPhase
from gcs.flight.heading_speeds import CONFIDENT_S
from gcs.flight.vehicle_energy import VehicleEnergy
from gcs.telemetry.status import VehicleStatus
from tests.gcs.flight.replay import COPTER, LOGGED_FROM_DEG, LOGGED_WIND_M_S, STILL_AIR_LOG, WIND_LOG, replayed


def _towards(deg: float) -> tuple[float, float]:
    return math.sin(math.radians(deg)), math.cos(math.radians(deg))


def test_a_copter_s_lean_in_steady_flight_reads_sitl_s_wind_and_firms_up(plan):
    estimates = []
    energy = replayed(WIND_LOG, plan.uavs[1], lambda e: estimates.append(e.status.wind))
    seen = [w for w in estimates if w is not None]
    assert seen, "no wind estimated"
    for w in seen[len(seen) // 10:-len(seen) // 5]:  # past the first seconds, before the landing's lower air
        assert w.speed_m_s == pytest.approx(LOGGED_WIND_M_S, abs=1.0), w.text()
        assert abs((w.from_deg - LOGGED_FROM_DEG + 180.0) % 360.0 - 180.0) < 12.0, w.text()
    assert not seen[len(seen) // 2].young
    assert energy.fuel.wind is not None and energy.fuel.wind.source == "its lean"
    assert any(note.startswith("wind ") and "(its lean)" in note for note in energy.notes)


def test_in_still_air_no_wind_is_read_turns_and_speed_ups_included(plan):
    most = [0.0]

    def each(e: VehicleEnergy) -> None:
        if e.status.wind is not None:
            most[0] = max(most[0], e.status.wind.speed_m_s)

    energy = replayed(STILL_AIR_LOG, plan.uavs[1], each)
    assert energy.status.wind is not None and most[0] <= 1.5
    assert energy.fuel.wind_m_s is None and not any(n.startswith("wind") for n in energy.notes)


def test_each_direction_is_priced_by_the_ground_speed_it_made_good(plan):
    """Into the wind (towards 270 and 225) the copter made 4 m/s of its 10, across and down it
    all 10: a metre that way costs 2.4 times a still-air one; in still air every way costs one."""
    windy = replayed(WIND_LOG, plan.uavs[1]).fuel
    speeds = windy.headings.speeds()
    assert windy.headings.seconds[[0, 2, 4, 6, 8, 10, 12, 14]].min() >= CONFIDENT_S  # the star's eight ways
    assert speeds[12] == pytest.approx(4.0, abs=0.5) and speeds[10] == pytest.approx(4.0, abs=0.5)
    assert speeds[4] == pytest.approx(9.9, abs=0.3) and speeds[8] == pytest.approx(7.1, abs=0.5)
    assert windy.factor(*_towards(270.0)) == pytest.approx(10.0 / speeds[12], rel=0.12)
    assert windy.factor(*_towards(90.0)) == pytest.approx(1.0, abs=0.05)
    still = replayed(STILL_AIR_LOG, plan.uavs[1]).fuel
    assert all(still.factor(*_towards(d)) == pytest.approx(1.0, abs=0.05) for d in range(0, 360, 45))


@pytest.mark.parametrize("sigma, young", [(1.6, True), (0.5, False)])
def test_a_return_only_a_young_estimate_asks_for_is_put_off(plan, sigma, young):
    """Home 500 m to the east into a 6.5 m/s east wind: at some charges the return is needed in
    that wind but not in one two sigmas weaker. A young estimate searches on there; a firm one
    returns; where both winds ask for it, both return."""
    def decide(used: int, wind: tuple[float, float], sigma_m_s: float):
        energy = VehicleEnergy(plan.uavs[1], VehicleStatus(1), COPTER, reserve_pct=30.0)
        energy.fuel.battery(0.0, FlightPhase.CRUISE, float(used), None)
        energy.fuel.set_wind(*wind, sigma_m_s=sigma_m_s, source="its lean")
        return energy, energy.evaluate([[(0.0, 50.0)]], [[(500.0, 0.0)]], [])

    deferred = 0
    for used in range(900, 2400, 50):
        energy, decision = decide(used, (-6.5, 0.0), sigma)
        weaker = energy.fuel.wind.weakened()
        assert weaker[0] == pytest.approx(-6.5 + 2.0 * sigma) and weaker[1] == 0.0
        _, kinder = decide(used, weaker, 0.0)
        if young:
            assert decision.deferred == (decision.fuel.must_return and not kinder.must_return)
        else:
            assert not decision.deferred
        assert decision.must_return == (decision.fuel.must_return and not decision.deferred)
        deferred += decision.deferred
    assert (deferred > 0) == young


@pytest.mark.parametrize("wind", [(0.0, 0.0), (-8.0, 0.0)])
def test_a_plane_s_metre_is_priced_against_its_true_air_speed(wind):
    """ArduPlane SITL flies 23.4 m/s through the air at its 22 indicated (docs/energy.md): in still
    air every way costs what its profile says, in a wind a way costs that air speed over what it
    makes good, whether flown or not."""
    from gcs.flight.fuel import FuelGauge
    from gcs.plans.vehicle_file import STOCK_PROFILES
    from planner.energy import Airframe

    gauge = FuelGauge(STOCK_PROFILES[("ardupilot", Airframe.PLANE)])
    if any(wind):
        gauge.set_wind(*wind)
    t = 0.0
    gauge.moved(t, 0.0, 0.0, FlightPhase.CRUISE)
    def made_good(towards: float) -> float:
        east, north = _towards(towards)
        along = east * wind[0] + north * wind[1]
        return along + math.sqrt(23.4 ** 2 - (wind[0] ** 2 + wind[1] ** 2 - along ** 2))

    for towards in (0.0, 90.0, 180.0):  # never west (with the wind)
        east, north = _towards(towards)
        ground = (made_good(towards) * east, made_good(towards) * north)
        for _ in range(40):
            t += 0.5
            gauge.moved(t, ground[0] * 0.5, ground[1] * 0.5, FlightPhase.CRUISE)
            gauge.steady(t, ground, 0.5, FlightPhase.CRUISE)
    assert gauge.headings.cruise_speed_m_s == pytest.approx(23.4, abs=0.01)
    for towards in (0.0, 90.0, 180.0, 270.0):
        assert gauge.factor(*_towards(towards)) == pytest.approx(23.4 / made_good(towards), rel=0.02), towards
