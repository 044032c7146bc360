"""A multicopter's time along a path: by hand on straights, against a step-by-step reference on
random paths, the properties a speed profile must have, and ArduCopter SITL's seconds."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.energy import Airframe, EnergyProfile
from planner.path_time import ARDUCOPTER_CORNERING, Cornering, path_length_m, path_time_s, turn_angles_deg
from tests.planner.corner_stretches import SITL_S, SPEED_M_S, stretches

SIMPLE = Cornering(accel_m_s2=2.0, corner_fractions=((0.0, 1.0), (90.0, 0.5), (180.0, 0.0)))


def reference_time_s(points: np.ndarray, speed: float, c: Cornering, dt: float = 2e-3) -> float:
    """A point stepped along the path every `dt` s: it speeds up at the acceleration while the
    braking distance to every corner ahead (and the end) still allows it, else brakes."""
    legs = np.diff(points, axis=0)
    lengths = [float(x) for x in np.hypot(legs[:, 0], legs[:, 1]) if x > 1e-9]
    ends = list(itertools.accumulate(lengths))
    caps = [float(x) for x in speed * c.fraction(turn_angles_deg(points))] + [0.0]
    a, s, v, t, leg = c.accel_m_s2, 0.0, 0.0, 0.0, 0
    while s < ends[-1] - 1e-6:
        while ends[leg] <= s:
            leg += 1
        allowed = min(math.sqrt(caps[i] ** 2 + 2.0 * a * (ends[i] - s)) for i in range(leg, len(ends)))
        v_next = min(speed, v + a * dt, allowed)
        s += 0.5 * (v + v_next) * dt
        v = v_next
        t += dt
    return t


def test_a_path_is_as_long_as_its_legs_its_repeated_points_adding_nothing():
    assert path_length_m([(0, 0), (3, 4), (3, 4), (3, 10)]) == pytest.approx(11.0)
    assert path_length_m([(5, 5)]) == 0.0


def test_a_straight_by_hand():
    v, a = 10.0, SIMPLE.accel_m_s2
    assert path_time_s([(0, 0), (0, 400)], v) == pytest.approx(40.0)  # no cornering: at cruise all the way
    assert path_time_s([(0, 0), (0, 400)], v, SIMPLE) == pytest.approx(v / a + 400 / v)  # 25 m up, 25 m down
    assert path_time_s([(0, 0), (30, 40)], v, SIMPLE) == pytest.approx(2 * math.sqrt(50 / a))  # never at cruise
    assert path_time_s([(0, 0), (0, 200), (0, 400)], v, SIMPLE) == pytest.approx(v / a + 400 / v)  # straight on
    assert path_time_s([(0, 0), (0, 0), (5, 5)], v) == path_time_s([(0, 0), (5, 5)], v)  # a repeated point


def test_a_corner_by_hand():
    """Two 100 m legs at 90 degrees: up to 10 m/s, down to 5 through the corner, up, down to 0."""
    v, a = 10.0, SIMPLE.accel_m_s2
    leg = (v / a) + (v - 5) / a + (100 - (v * v / (2 * a)) - (v * v - 25) / (2 * a)) / v
    assert path_time_s([(0, 0), (0, 100), (100, 100)], v, SIMPLE) == pytest.approx(2 * leg)


def test_braking_for_a_corner_starts_a_leg_early_when_its_own_leg_is_short():
    """200 m straight on, then 5 m to a 90-degree corner: too short to brake in, so the braking
    begins on the long leg (the backward pass); flown backwards it takes as long."""
    points = np.array([(0.0, 0.0), (0.0, 200.0), (0.0, 205.0), (5.0, 205.0), (5.0, 300.0)])
    t = path_time_s(points, 10.0, ARDUCOPTER_CORNERING)
    assert t == pytest.approx(reference_time_s(points, 10.0, ARDUCOPTER_CORNERING), rel=3e-3)
    assert path_time_s(points[::-1], 10.0, ARDUCOPTER_CORNERING) == pytest.approx(t)


paths = st.lists(st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=2, max_size=8)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.tuples(st.integers(-4, 4), st.integers(-4, 4)), min_size=2, max_size=6),
       st.sampled_from([10.0, 20.0, 30.0]))
def test_random_paths_match_the_step_by_step_reference(cells, cell_m):
    points = np.array(cells, dtype=float) * cell_m
    if np.hypot(*np.diff(points, axis=0).T).sum() == 0:
        return
    want = reference_time_s(points, 10.0, ARDUCOPTER_CORNERING)
    assert path_time_s(points, 10.0, ARDUCOPTER_CORNERING) == pytest.approx(want, rel=3e-3, abs=0.02)


@settings(max_examples=50, deadline=None)
@given(paths, st.sampled_from([20.0, 50.0]))
def test_what_a_time_must_be(cells, cell_m):
    """Never quicker than at cruise all the way, the same flown backwards, and never quicker with
    sharper corners."""
    points = np.array(cells, dtype=float) * cell_m
    length = np.hypot(*np.diff(points, axis=0).T).sum()
    t = path_time_s(points, 10.0, ARDUCOPTER_CORNERING)
    assert t >= length / 10.0 - 1e-9
    assert path_time_s(points[::-1], 10.0, ARDUCOPTER_CORNERING) == pytest.approx(t)
    slower = Cornering(accel_m_s2=1.5, corner_fractions=((0.0, 1.0), (45.0, 0.3), (90.0, 0.2), (180.0, 0.0)))
    assert path_time_s(points, 10.0, slower) >= t - 1e-9


def test_ardupilots_cornering_gives_sitls_seconds():
    """ArduCopter SITL at 10 m/s (`tests/planner/corner_stretches.py`, `benchmarks/path_time_fit.py`):
    zig-zags of eight 50 m legs turning 90 and 45 degrees, and a 400 m straight, from a stop to a stop."""
    for name, points in stretches().items():
        assert path_time_s(points, SPEED_M_S, ARDUCOPTER_CORNERING) == pytest.approx(SITL_S[name], rel=0.01), name


def test_a_profile_prices_a_known_path_by_its_time():
    plain = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.0,
                          loiter_mah_per_s=7.5, launch_mah=10.0, climb_mah_per_m=4.0, landing_mah=5.0,
                          descent_mah_per_m=2.0)
    zigzag = [(0.0, 0.0), (0.0, 20.0), (20.0, 40.0), (20.0, 60.0), (40.0, 80.0)]
    assert plain.path_mah_per_m(zigzag) == 1.0 and plain.along(zigzag) == plain
    timed = EnergyProfile(**{**plain.__dict__, "cornering": SIMPLE, "moving_mah_per_s": 8.0})
    length = 40.0 + 2 * 20 * math.sqrt(2)
    assert timed.path_mah_per_m(zigzag) == pytest.approx(8.0 * path_time_s(zigzag, 10.0, SIMPLE) / length)
    assert timed.along(zigzag).cruise_mah_per_m == timed.path_mah_per_m(zigzag)
    straight = [(0.0, 0.0), (0.0, 2000.0)]
    assert timed.path_mah_per_m(straight) < timed.path_mah_per_m(zigzag)  # corners cost time, so charge
    assert timed.path_mah_per_m([(1.0, 1.0)]) == 1.0  # no path: the per-metre figure


@pytest.mark.parametrize("kwargs, says", [
    ({"accel_m_s2": 0.0, "corner_fractions": ((0.0, 1.0),)}, "accel_m_s2"),
    ({"accel_m_s2": 1.0, "corner_fractions": ((10.0, 1.0),)}, "start at 0"),
    ({"accel_m_s2": 1.0, "corner_fractions": ((0.0, 1.0), (90.0, 0.5), (45.0, 0.6))}, "increase"),
    ({"accel_m_s2": 1.0, "corner_fractions": ((0.0, 1.0), (90.0, 1.5))}, r"\[0, 1\]"),
])
def test_a_cornering_refuses_nonsense(kwargs, says):
    with pytest.raises(ValueError, match=says):
        Cornering(**kwargs)


def test_a_profile_has_both_cornering_figures_or_neither():
    base = dict(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=10.0, cruise_mah_per_m=1.0,
                loiter_mah_per_s=7.5, launch_mah=10.0, climb_mah_per_m=4.0, landing_mah=5.0, descent_mah_per_m=2.0)
    with pytest.raises(ValueError, match="together"):
        EnergyProfile(**base, cornering=SIMPLE)
    with pytest.raises(ValueError, match="moving_mah_per_s"):
        EnergyProfile(**base, cornering=SIMPLE, moving_mah_per_s=-1.0)
