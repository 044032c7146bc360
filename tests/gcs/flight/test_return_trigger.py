"""The return trigger's pure functions, checked exhaustively over small grids of inputs and
against hand-computed cases."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, strategies as st

from gcs.flight.orders import OperatorOrder, parse_order
from gcs.flight.return_trigger import (
    RangeModel,
    battery_drain_pct_s,
    check_return,
    consumption_pct_per_step,
    drain_rate_pct_s,
    estimate_range_steps,
    landing_seconds,
    range_left_steps,
)

MODEL = RangeModel(step_m=20.0, speed_m_s=10.0, reserve_pct=30.0, descent_m_s=2.0)


def test_range_left_by_hand():
    # 50 % left, 30 % reserve: 20 % usable at 0.1 %/s = 200 s = 2000 m = 100 steps of 20 m
    assert range_left_steps(50.0, 0.1, MODEL) == pytest.approx(100.0)
    assert range_left_steps(30.0, 0.1, MODEL) == 0.0
    assert range_left_steps(10.0, 0.1, MODEL) == 0.0
    assert range_left_steps(50.0, None, MODEL) == math.inf
    assert range_left_steps(50.0, 0.0, MODEL) == math.inf
    assert range_left_steps(None, 0.1, MODEL) == 0.0


def test_landing_seconds_by_hand():
    assert landing_seconds(60.0, MODEL) == pytest.approx(50 / 2.0 + 10 / 0.5)  # the last 10 m at 0.5 m/s
    assert landing_seconds(6.0, MODEL) == pytest.approx(6 / 0.5)
    assert landing_seconds(-3.0, MODEL) == 0.0


def test_consumption_per_step_is_the_least_squares_slope_once_far_enough():
    samples = [(float(t), 90.0 - 0.5 * 0.25 * t, 0.25 * t) for t in range(0, 60)]  # a step every 4 s, 0.5 %/step
    assert consumption_pct_per_step(samples) == pytest.approx(0.5)
    assert consumption_pct_per_step(samples[:20]) is None  # 4.75 steps flown: not yet 5
    climbing = [(float(t), 90.0 - 0.2 * t, 0.0) for t in range(0, 60)]  # draining, no step flown
    assert consumption_pct_per_step(climbing) is None
    stepped = [(float(t), float(int(90.0 - 0.125 * t)), 0.25 * t) for t in range(0, 120)]  # whole percent
    assert consumption_pct_per_step(stepped) == pytest.approx(0.5, rel=0.05)


def test_range_estimate_uses_the_cost_per_step_then_falls_back_to_time():
    flown = [(float(t), 90.0 - 0.5 * 0.25 * t, 0.25 * t) for t in range(0, 60)]
    remaining = flown[-1][1]
    # (remaining - 30 % reserve - the descent at 0.125 %/s) / 0.5 % per step
    descent_s = landing_seconds(60.0, MODEL)
    assert estimate_range_steps(remaining, None, flown, MODEL, descent_s) == \
        pytest.approx((remaining - 30.0 - 0.125 * descent_s) / 0.5)
    climbing = [(float(t), 100.0 - 0.1 * t, 0.0) for t in range(0, 30)]  # before any step: by time
    assert estimate_range_steps(97.1, None, climbing, MODEL) == pytest.approx(range_left_steps(97.1, 0.1, MODEL))
    assert estimate_range_steps(90.0, None, [], MODEL) == math.inf
    assert estimate_range_steps(31.0, None, flown, MODEL, descent_s) == 0.0  # the descent eats the rest


@pytest.mark.parametrize("line, order", [
    ("r 2", OperatorOrder("return", 2)), ("return 3", OperatorOrder("return", 3)),
    ("RTL 1", OperatorOrder("return", 1)), ("return all", OperatorOrder("return", None)),
    ("range 2 150", OperatorOrder("range", 2, 150)), ("  range 4 7 ", OperatorOrder("range", 4, 7)),
])
def test_operator_orders_are_read(line, order):
    assert parse_order(line) == order


@pytest.mark.parametrize("line, reason", [
    ("", "empty order"), ("fly 2", "unknown order"), ("return", "unknown order"), ("r two", "not a UAV id"),
    ("range 2", "unknown order"), ("range 2 lots", "not a whole number"), ("range 2 0", "at least 1 step"),
    ("return 0", "not a UAV id"),
])
def test_bad_operator_orders_say_why(line, reason):
    with pytest.raises(ValueError, match=reason):
        parse_order(line)


def test_drain_rate_is_the_least_squares_slope():
    samples = [(t, 100.0 - 0.25 * t) for t in range(0, 21)]
    assert drain_rate_pct_s(samples) == pytest.approx(0.25)
    assert drain_rate_pct_s(samples[:3]) is None  # spans 2 s < 5 s
    assert drain_rate_pct_s([(0.0, 50.0), (10.0, 60.0)]) == 0.0  # charging never counts as negative drain
    assert drain_rate_pct_s([]) is None


def test_drain_takes_the_worse_of_the_autopilot_and_the_observation():
    assert battery_drain_pct_s(60.0, 600.0, None) == pytest.approx(0.1)
    assert battery_drain_pct_s(60.0, 600.0, 0.3) == pytest.approx(0.3)
    assert battery_drain_pct_s(60.0, 100.0, 0.3) == pytest.approx(0.6)
    assert battery_drain_pct_s(60.0, 0.0, None) is None  # 0: the autopilot does not estimate
    assert battery_drain_pct_s(None, 600.0, None) is None


def test_check_return_exhaustive_small_grid():
    for rng, home, land, reserve in itertools.product(range(0, 15), range(0, 10), (0.0, 0.5, 3.0), (0.0, 2.0)):
        c = check_return(float(rng), float(home), land, reserve)
        assert c.cost == 1 + home + land + reserve
        assert c.margin == rng - c.cost
        # return exactly when one more step and the way home after it would not fit (eq. 23)
        assert c.must_return == (rng < 1 + home + land + reserve)


def test_check_return_unknowns_are_safe():
    assert check_return(math.inf, 10.0).must_return is False  # drain not known yet: the plan's range rules
    assert check_return(5.0, math.inf).must_return is True  # no way home from the next pose
    assert check_return(math.nan, 3.0).must_return is True


@given(st.floats(0, 100), st.floats(0.001, 5), st.floats(0, 200), st.floats(0, 200), st.floats(0.01, 2))
def test_trigger_is_monotone(pct, drain, home, alt, per_step):
    """Less charge, a faster drain, a costlier step, a longer way home or a higher altitude never
    turn a return into a continue."""
    def check(pct, drain, per_step, home, alt):
        samples = [(float(t), pct + drain * (20 - t), (t * drain / per_step)) for t in range(21)]
        left = estimate_range_steps(pct, None, samples, MODEL, landing_seconds(alt, MODEL))
        return check_return(left, home)

    base = check(pct, drain, per_step, home, alt)
    worse = check(pct * 0.9, drain * 1.1, per_step * 1.1, home + 1, alt + 1)
    assert worse.margin <= base.margin + 1e-9
    if base.must_return:
        assert worse.must_return


def test_model_validation():
    with pytest.raises(ValueError):
        RangeModel(step_m=0.0, speed_m_s=10.0)
    with pytest.raises(ValueError):
        RangeModel(step_m=10.0, speed_m_s=10.0, reserve_pct=100.0)
