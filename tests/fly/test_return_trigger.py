"""The return trigger's pure functions, checked exhaustively over small grids of inputs and
against hand-computed cases."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gcs.return_trigger import (RangeModel, battery_drain_pct_s, check_return, drain_rate_pct_s, landing_steps,
                                range_left_steps)

MODEL = RangeModel(step_m=20.0, speed_m_s=10.0, reserve_pct=30.0, descent_m_s=2.0)


def test_range_left_by_hand():
    # 50 % left, 30 % reserve: 20 % usable at 0.1 %/s = 200 s = 2000 m = 100 steps of 20 m
    assert range_left_steps(50.0, 0.1, MODEL) == pytest.approx(100.0)
    assert range_left_steps(30.0, 0.1, MODEL) == 0.0
    assert range_left_steps(10.0, 0.1, MODEL) == 0.0
    assert range_left_steps(50.0, None, MODEL) == math.inf
    assert range_left_steps(50.0, 0.0, MODEL) == math.inf
    assert range_left_steps(None, 0.1, MODEL) == 0.0


def test_landing_steps_by_hand():
    assert landing_steps(60.0, MODEL) == pytest.approx(60 / 2.0 * 10.0 / 20.0)
    assert landing_steps(-3.0, MODEL) == 0.0


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


@given(st.floats(0, 100), st.floats(0.001, 5), st.floats(0, 200), st.floats(0, 200))
def test_trigger_is_monotone(pct, drain, home, alt):
    """Less charge, a faster drain, a longer way home or a higher altitude never turn a return into
    a continue."""
    base = check_return(range_left_steps(pct, drain, MODEL), home, landing_steps(alt, MODEL))
    worse = check_return(range_left_steps(pct * 0.9, drain * 1.1, MODEL), home + 1, landing_steps(alt + 1, MODEL))
    assert worse.margin <= base.margin
    if base.must_return:
        assert worse.must_return


def test_model_validation():
    with pytest.raises(ValueError):
        RangeModel(step_m=0.0, speed_m_s=10.0)
    with pytest.raises(ValueError):
        RangeModel(step_m=10.0, speed_m_s=10.0, reserve_pct=100.0)
