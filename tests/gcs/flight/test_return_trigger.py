"""The fuel-based return trigger's pure parts: the fuel gauge, the range check in charge, its
confirmation, and the operator's orders; checked by hand, over small grids of inputs and by
properties."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, strategies as st

from gcs.flight.fuel import MIN_SHARE, PRIOR_WEIGHT_M, SETTLE_S, SHOWN_AFTER_M, FlightPhase, FuelGauge
from gcs.flight.orders import OperatorOrder, parse_order
from gcs.flight.return_trigger import HOME_MARGIN, SEVERE_SHARE, THIRSTY_SHARE, check_return, confirmed, fuel_decision
from planner.energy import MAX_WIND_FACTOR, Airframe, EnergyProfile, wind_factor

COPTER = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3000.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.0,
                       loiter_mah_per_s=8.0, launch_mah=20.0, climb_mah_per_m=5.0, landing_mah=10.0,
                       descent_mah_per_m=2.0)


def cruise(gauge: FuelGauge, seconds: int, *, mah_per_m: float, start_s: float = 0.0, used: float = 0.0,
           heading=(10.0, 0.0), phase=FlightPhase.CRUISE, consumed=True) -> tuple[float, float]:
    """Fly `seconds` at one step of `heading` metres a second, the battery reporting each
    second (consumed mAh, or only its percentage): (time, used) at the end."""
    t = start_s
    for _ in range(seconds):
        t += 1.0
        gauge.moved(t, *heading, phase)
        used += mah_per_m * math.hypot(*heading)
        if consumed:
            gauge.battery(t, phase, used, None)
        else:
            gauge.battery(t, phase, None, float(round(100.0 * (1 - used / gauge.capacity_mah))))
    return t, used


#: The prior's weight along one direction flown alone: the average's and its two harmonics' (each
#: weighted twice the average's) add up, 1 / (1/w + 1/2w + 1/2w) = w / 2.
ALONG_ONE_WAY = PRIOR_WEIGHT_M / 2


def along(prior: float, mah: float, metres: float) -> float:
    """What the gauge learns along the one direction a vehicle has flown."""
    return (ALONG_ONE_WAY * prior + mah) / (ALONG_ONE_WAY + metres)


def test_the_rate_starts_at_the_profile_and_moves_with_level_flight():
    gauge = FuelGauge(COPTER)
    assert gauge.rate_mah_per_m == COPTER.cruise_mah_per_m == gauge.rate_along(0.3, -0.7)
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    t, used = cruise(gauge, 25, mah_per_m=2.0)  # draining twice as fast as the profile says
    sampled = (25 - SETTLE_S) * 10.0  # the first SETTLE_S seconds of level flight are left out
    assert gauge.cruise_m == pytest.approx(sampled) and sampled < SHOWN_AFTER_M
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(along(1.0, 2.0 * sampled, sampled))  # the prior still pulls
    assert 1.0 < gauge.rate_mah_per_m < gauge.rate_along(1.0, 0.0)  # the average moves half as far
    cruise(gauge, 10, mah_per_m=2.0, start_s=t, used=used)
    assert gauge.cruise_m >= SHOWN_AFTER_M
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(2.0)  # never under what level flight has shown
    assert gauge.rate_along(-1.0, 0.0) > COPTER.cruise_mah_per_m  # the other ways lifted as much
    assert gauge.remaining_mah == pytest.approx(3000.0 - 2.0 * 350)


def test_a_cheaper_cruise_moves_the_rate_down_only_as_the_evidence_grows():
    """Cheaper than the profile: no lift, the prior's pull stays (the safe side)."""
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    cruise(gauge, 340, mah_per_m=0.5)
    assert gauge.cruise_m == pytest.approx(3300.0)
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(along(1.0, 0.5 * 3300, 3300))


def test_the_launch_and_the_climb_are_never_averaged_as_cruise():
    """A plane's full-throttle climb (ArduPlane SITL: 47 A against 11 A cruising) is not cruise:
    PX4's PR 22401."""
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    t, used = cruise(gauge, 40, mah_per_m=8.0, phase=FlightPhase.LAUNCH)
    assert gauge.cruise_m == 0 and gauge.rate_mah_per_m == COPTER.cruise_mah_per_m
    assert gauge.phase_mah[FlightPhase.LAUNCH] == pytest.approx(8.0 * 400.0)
    cruise(gauge, 60, mah_per_m=1.0, start_s=t, used=used)
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(1.0) and gauge.rate_mah_per_m == pytest.approx(1.0)


def test_a_percentage_only_battery_reads_through_the_capacity():
    """PX4 SIH reports no current: the used charge is the capacity times the percentage gone."""
    gauge = FuelGauge(COPTER)
    gauge.set_capacity(5000.0)
    gauge.battery(0.0, FlightPhase.GROUND, None, 100.0)
    cruise(gauge, 600, mah_per_m=0.5, consumed=False)
    assert gauge.capacity_mah == 5000.0 and not gauge.measures_current
    assert gauge.remaining_mah == pytest.approx(5000.0 - 0.5 * 6000, abs=50.0)  # whole percent: 50 mAh
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(along(1.0, 0.5 * gauge.cruise_m, gauge.cruise_m), rel=0.03)
    gauge.set_capacity(-1.0)  # PX4's BAT1_CAPACITY -1: not set, ignored
    assert gauge.capacity_mah == 5000.0


def test_a_percentage_that_sags_and_recovers_balances_out():
    """A percentage that dips under load and comes back: what goes back up is charge the sum
    gives back, so only the net drain counts."""
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.GROUND, None, 100.0)
    t = 0.0
    pct = 100.0
    for i in range(420):  # sagging by 3 % for 20 s of every 40, not at the end
        t += 1.0
        gauge.moved(t, 10.0, 0.0, FlightPhase.CRUISE)
        pct -= 0.1
        sag = 3.0 if (i // 20) % 2 else 0.0
        gauge.battery(t, FlightPhase.CRUISE, None, pct - sag)
    net = 0.1 / 100 * 3000 / 10.0  # 0.3 mAh per metre
    assert gauge.cruise_m == pytest.approx(4100.0)
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(along(1.0, net * 4100, 4100))


def test_a_reported_wind_prices_a_way_into_it_above_one_with_it():
    """ArduPlane reports its wind estimate: before any cruise is sampled, a plane holding 20 m/s
    through the air draws its cruise current for as long as each way takes over the ground."""
    plane = EnergyProfile(airframe=Airframe.PLANE, capacity_mah=3300.0, cruise_speed_m_s=20.0, cruise_mah_per_m=0.3,
                          loiter_mah_per_s=6.0, launch_mah=0.0, climb_mah_per_m=0.0, landing_mah=0.0,
                          descent_mah_per_m=0.0)
    gauge = FuelGauge(plane)
    gauge.set_wind(0.0, 0.0)  # ArduCopter's "no estimate": still air
    assert gauge.way_cost([(-1000.0, 0.0)]).mah == pytest.approx(300.0)
    gauge.set_wind(-5.0, 0.0)  # the air moves west
    west, east = gauge.way_cost([(-1000.0, 0.0)]), gauge.way_cost([(1000.0, 0.0)])
    assert west.metres == east.metres == 1000.0
    assert west.mah == pytest.approx(300.0 * 20 / 25) and east.mah == pytest.approx(300.0 * 20 / 15)
    assert gauge.way_cost([(0.0, 1000.0)]).mah == pytest.approx(300.0 * 20 / math.sqrt(20**2 - 5**2))


def test_a_copter_in_the_wind_is_priced_by_the_ground_speed_it_can_make():
    """A multicopter holds its cruise speed over the ground where its air speed allows: downwind a
    metre costs what it costs in still air, upwind in 8 m/s at 10 m/s it makes 2 m/s, five times
    dearer (ArduCopter SITL: 4.6, docs/energy.md); a wind it cannot fly against is capped."""
    gauge = FuelGauge(COPTER)  # 10 m/s, 1 mAh/m
    gauge.set_wind(0.0, -8.0)  # the air moves south
    assert gauge.rate_along(0.0, -1.0) == pytest.approx(1.0)
    assert gauge.rate_along(0.0, 1.0) == pytest.approx(5.0)
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(10.0 / 6.0)
    gauge.set_wind(0.0, -12.0)
    assert gauge.rate_along(0.0, 1.0) == pytest.approx(MAX_WIND_FACTOR)


LEG = st.tuples(st.floats(-500.0, 500.0), st.floats(-500.0, 500.0)) | st.just((0.0, 0.0))


@given(legs=st.lists(LEG, max_size=12), wind=st.tuples(st.floats(-14.0, 14.0), st.floats(-14.0, 14.0)))
def test_a_way_costs_what_its_legs_cost_one_by_one(legs, wind):
    """The priced way (all legs at once, as the trigger prices it every tick) is the sum of each
    leg priced alone at its direction's rate, after a search in the wind has been learned; a wind
    factor asked for many directions at once is the one asked for each."""
    gauge = FuelGauge(COPTER)
    gauge.set_wind(*wind)
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    t, used = 0.0, 0.0
    for heading, mah_per_m in {(10.0, 0.0): 1.3, (0.0, 10.0): 2.5, (-7.0, -7.0): 0.7}.items():
        t, used = cruise(gauge, 40, mah_per_m=mah_per_m, start_s=t, used=used, heading=heading)
    way = gauge.way_cost(legs)
    alone = [(math.hypot(e, n), math.hypot(e, n) * gauge.rate_along(e, n)) for e, n in legs if e or n]
    assert way.metres == pytest.approx(sum(m for m, _ in alone))
    assert way.mah == pytest.approx(sum(mah for _, mah in alone))
    east, north = [e for e, _ in legs], [n for _, n in legs]
    together = wind_factor(COPTER, east, north, wind)
    assert list(together) == pytest.approx([wind_factor(COPTER, e, n, wind) for e, n in legs])
    assert all(f == 1.0 for f, (e, n) in zip(together, legs) if not (e or n))


def test_a_wind_the_autopilot_does_not_report_is_learned_from_the_charge():
    """ArduCopter reports no wind, yet an 8 m/s wind makes its upwind metres 4.6 times dearer
    than its downwind ones (docs/energy.md): a search flown east and west, north and south learns
    it, and a way home straight upwind is priced near what it costs, not at the average."""
    gauge = FuelGauge(COPTER)  # the profile: 1 mAh/m in still air
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    cost = {(10.0, 0.0): 1.2, (-10.0, 0.0): 1.2, (0.0, 10.0): 3.9, (0.0, -10.0): 0.8}  # the air moving south
    t, used = 0.0, 0.0
    for _ in range(6):
        for heading, mah_per_m in cost.items():
            t, used = cruise(gauge, 40, mah_per_m=mah_per_m, start_s=t, used=used, heading=heading)
    assert gauge.rate_along(0.0, 1.0) == pytest.approx(3.9, rel=0.08)  # the profile's 1 still pulls a little
    assert 0.8 <= gauge.rate_along(0.0, -1.0) <= 1.0  # the prior's pull taken back: on the safe side
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(1.2, rel=0.05)
    assert gauge.rate_mah_per_m == pytest.approx((1.2 + 1.2 + 3.9 + 0.8) / 4, rel=0.05)
    assert gauge.way_cost([(0.0, 500.0)]).mah > 2.5 * gauge.way_cost([(0.0, -500.0)]).mah


def test_a_direction_never_flown_stays_near_the_profile_and_none_is_priced_below_a_floor():
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.GROUND, 0.0, None)
    t, used = 0.0, 0.0
    for _ in range(10):
        t, used = cruise(gauge, 30, mah_per_m=2.0, start_s=t, used=used, heading=(10.0, 0.0))
        t, used = cruise(gauge, 30, mah_per_m=0.1, start_s=t, used=used, heading=(-10.0, 0.0))
    a = gauge.rate_mah_per_m
    north, south = gauge.rate_along(0.0, 1.0), gauge.rate_along(0.0, -1.0)
    assert north == pytest.approx(south) and north == pytest.approx(COPTER.cruise_mah_per_m, rel=0.1)
    assert gauge.rate_along(-1.0, 0.0) == pytest.approx(MIN_SHARE * a)  # the learned 0.1 is floored
    assert gauge.rate_along(1.0, 0.0) == pytest.approx(2.0, rel=0.05)


def _decision(gauge, home_m=1000.0, step_m=30.0, ordered=None, circuit=()):
    return fuel_decision(gauge, reserve_pct=30.0, landing_mah=COPTER.landing_cost_mah(50.0),
                         steps_ahead=[[(step_m, 0.0)]], home_legs=[[(-home_m, 0.0)]], circuit_legs=list(circuit),
                         ordered_left_m=ordered)


def test_the_decision_by_hand():
    gauge = FuelGauge(COPTER)
    assert _decision(gauge) is None  # no charge read yet
    gauge.battery(0.0, FlightPhase.CRUISE, 1800.0, None)  # 1200 mAh left of 3000, reserve 900, landing 110
    d = _decision(gauge)
    assert d.fuel.cost == pytest.approx(30 + 1000 + 110 + 900)
    assert d.fuel.margin == pytest.approx(1200 - 2040) and d.must_return and not d.by_order
    assert d.range_left_m == pytest.approx(1200 - 900 - 110)
    assert d.home_m == 1000.0 and d.home_mah == pytest.approx(1110.0)
    assert d.margin_m == pytest.approx(-840.0)
    ok = _decision(gauge, home_m=100.0)
    assert not ok.must_return and ok.margin_m == pytest.approx(1200 - 30 - 100 - 110 - 900)


def test_an_operator_range_binds_when_it_is_shorter():
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.CRUISE, 0.0, None)
    d = _decision(gauge, home_m=200.0, ordered=220.0)
    assert d.must_return and d.by_order and not d.fuel.must_return
    assert d.margin_m == pytest.approx(220.0 - 30.0 - 200.0)
    assert not _decision(gauge, home_m=200.0, ordered=500.0).must_return


def test_a_plane_pays_its_landing_circuit():
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.CRUISE, 1500.0, None)
    without = _decision(gauge, home_m=300.0)
    circuit = _decision(gauge, home_m=300.0, circuit=[(250.0, 0.0), (-250.0, 0.0)])
    assert circuit.home_m == without.home_m + 500.0
    assert circuit.fuel.margin == pytest.approx(without.fuel.margin - 500.0)


def test_a_return_is_confirmed_after_the_wait_or_at_once_when_severe():
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.CRUISE, 2000.0, None)  # 1000 left
    slight = _decision(gauge, home_m=15.0)  # short by 55 mAh: under 2 % of 3000
    assert slight.must_return and slight.fuel.margin > -SEVERE_SHARE * 3000
    go, since = confirmed(slight, None, 10.0, confirm_s=3.0, capacity_mah=3000.0)
    assert not go and since == 10.0
    go, since = confirmed(slight, since, 12.9, confirm_s=3.0, capacity_mah=3000.0)
    assert not go and since == 10.0
    go, _ = confirmed(slight, since, 13.0, confirm_s=3.0, capacity_mah=3000.0)
    assert go
    fuller = FuelGauge(COPTER)
    fuller.battery(0.0, FlightPhase.CRUISE, 500.0, None)
    assert confirmed(_decision(fuller, home_m=10.0), since, 13.0, confirm_s=3.0, capacity_mah=3000.0) == (False, None)
    severe = _decision(gauge, home_m=500.0)
    assert confirmed(severe, None, 20.0, confirm_s=3.0, capacity_mah=3000.0) == (True, 20.0)
    assert confirmed(None, 5.0, 20.0, confirm_s=3.0, capacity_mah=3000.0) == (False, None)


def test_an_operator_range_is_acted_on_at_once():
    gauge = FuelGauge(COPTER)
    gauge.battery(0.0, FlightPhase.CRUISE, 0.0, None)
    ordered = _decision(gauge, home_m=200.0, ordered=100.0)
    assert confirmed(ordered, None, 1.0, confirm_s=10.0, capacity_mah=3000.0)[0]


@given(used=st.floats(0, 3000), home=st.floats(0, 3000), step=st.floats(0, 100), extra=st.floats(0, 500),
       rate=st.floats(0.2, 5))
def test_the_trigger_is_monotone(used, home, step, extra, rate):
    """Less charge, a dearer metre or a longer way home never turn a return into a continue."""
    def decide(used, home, rate):
        gauge = FuelGauge(EnergyProfile(**{**COPTER.__dict__, "cruise_mah_per_m": rate}))
        gauge.battery(0.0, FlightPhase.CRUISE, used, None)
        return _decision(gauge, home_m=home, step_m=step)

    base = decide(used, home, rate)
    worse = decide(used + extra, home + extra, rate * 1.1)
    assert worse.fuel.margin <= base.fuel.margin + 1e-9
    if base.must_return:
        assert worse.must_return


def test_check_return_exhaustive_small_grid():
    for rng, home, land, reserve, step in itertools.product(range(0, 15), range(0, 10), (0.0, 0.5, 3.0), (0.0, 2.0),
                                                            (1.0, 1.415)):
        c = check_return(float(rng), float(home), land, reserve, step)
        assert c.cost == step + home + land + reserve
        assert c.margin == rng - c.cost
        # return exactly when one more step and the way home after it would not fit (eq. 23)
        assert c.must_return == (rng < step + home + land + reserve)


def test_check_return_unknowns_are_safe():
    assert check_return(math.inf, 10.0).must_return is False
    assert check_return(5.0, math.inf).must_return is True  # no way home from the next pose
    assert check_return(math.nan, 3.0).must_return is True


@pytest.mark.parametrize("line, order", [
    ("r 2", OperatorOrder("return", 2)), ("return 3", OperatorOrder("return", 3)),
    ("RTL 1", OperatorOrder("return", 1)), ("return all", OperatorOrder("return", None)),
    ("range 2 1500", OperatorOrder("range", 2, 1500.0)), ("  range 4 750.5 ", OperatorOrder("range", 4, 750.5)),
])
def test_operator_orders_are_read(line, order):
    assert parse_order(line) == order


@pytest.mark.parametrize("line, reason", [
    ("", "empty order"), ("fly 2", "unknown order"), ("return", "unknown order"), ("r two", "not a UAV id"),
    ("range 2", "unknown order"), ("range 2 lots", "not a number of metres"), ("range 2 0", "positive number"),
    ("range 2 nan", "positive number"), ("return 0", "not a UAV id"),
])
def test_bad_operator_orders_say_why(line, reason):
    with pytest.raises(ValueError, match=reason):
        parse_order(line)


def test_a_vehicle_draining_faster_than_its_profile_has_its_way_home_priced_with_a_margin():
    """As profiled, the way home is priced as planned; once cruise has cost more than
    THIRSTY_SHARE of the profile's, HOME_MARGIN dearer (the profile is known wrong)."""
    gauge = FuelGauge(COPTER)  # 1 mAh/m
    gauge.battery(0.0, FlightPhase.CRUISE, 1800.0, None)
    assert _decision(gauge).home_mah == pytest.approx(1000.0 + 110.0)
    thirsty = FuelGauge(COPTER)
    thirsty.battery(0.0, FlightPhase.GROUND, 0.0, None)
    cruise(thirsty, 60, mah_per_m=1.6)
    assert thirsty.rate_mah_per_m > THIRSTY_SHARE * COPTER.cruise_mah_per_m
    d = _decision(thirsty)
    way = thirsty.way_cost([(-1000.0, 0.0)]).mah
    assert way > 1000.0 and d.home_mah == pytest.approx((way + 110.0) * (1 + HOME_MARGIN), rel=1e-6)


def test_the_trigger_is_evaluated_again_when_what_it_reads_changes_and_not_at_every_position(plan):
    """The last decision stands while the vehicle is within REEVALUATE_M of where it was made and
    nothing it was made from changed; a battery report, another pose or ten metres more make a
    new one."""
    from gcs.flight.vehicle_energy import REEVALUATE_M, VehicleEnergy
    from gcs.flight.vehicle_track import PlanTrack
    from gcs.telemetry.status import Stage, VehicleStatus

    track, status = PlanTrack(plan, 1), VehicleStatus(1)
    energy = VehicleEnergy(plan.uavs[1], status, COPTER, reserve_pct=30.0)
    energy.fuel.battery(0.0, FlightPhase.CRUISE, 500.0, None)
    status.stage, status.airborne_seen = Stage.SEARCH, True
    first = plan.uavs[1].trajectory[1]
    metre_north = 1.0 / 111_195.0

    def at(north_m: float):
        status.lat_deg, status.lon_deg = first.lat_deg + north_m * metre_north, first.lon_deg
        energy.check_along(track, 3, None)
        return energy.decision

    made = at(0.0)
    assert made is not None and math.isfinite(made.margin_m)
    assert at(0.3 * REEVALUATE_M) is made and at(0.9 * REEVALUATE_M) is made
    assert at(1.1 * REEVALUATE_M) is not made
    made = energy.decision
    energy.fuel.battery(1.0, FlightPhase.CRUISE, 510.0, None)
    after_report = at(1.1 * REEVALUATE_M)
    assert after_report is not made and after_report.margin_m < made.margin_m
    status.track_index = 1
    assert at(1.1 * REEVALUATE_M) is not after_report
