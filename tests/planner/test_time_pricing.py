"""A multicopter's path priced by its time (`planner.time_pricing`): a corner's loss against
`planner.path_time`'s seconds where it is exact, never less than them where corners are close,
and the budget a range buys."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.energy import Airframe, EnergyProfile
from planner.motion import HEADING_DX, HEADING_DY, OC3, OC8, STEPS, cell_lengths
from planner.path_time import ARDUCOPTER_CORNERING, Cornering, path_length_m, path_time_s, turn_angles_deg
from planner.time_pricing import (
    TimePricing,
    change_turn_deg,
    stop_loss_m,
    time_pricing,
    turn_loss_m,
    turn_units,
)

V = 10.0
COPTER = EnergyProfile(airframe=Airframe.COPTER, capacity_mah=3300.0, cruise_speed_m_s=V, cruise_mah_per_m=1.03,
                       loiter_mah_per_s=7.8, launch_mah=57.0, climb_mah_per_m=3.6, landing_mah=163.0,
                       descent_mah_per_m=4.97, cornering=ARDUCOPTER_CORNERING, moving_mah_per_s=8.15)


def test_the_eight_heading_changes_are_their_turns():
    assert [change_turn_deg(d) for d in range(8)] == [0, 45, 90, 135, 180, 135, 90, 45]
    assert change_turn_deg(-1) == 45.0


def test_ardupilots_corners_lose_what_braking_and_speeding_up_again_take():
    """(v - f v)^2 / a at 10 m/s and 1.5 m/s^2: 46 % of cruise through 45 degrees, 31 % through 90."""
    assert turn_loss_m(ARDUCOPTER_CORNERING, V, [0.0, 45.0, 90.0, 180.0]) == pytest.approx(
        [0.0, 5.4**2 / 1.5, 6.9**2 / 1.5, 100.0 / 1.5])
    assert stop_loss_m(ARDUCOPTER_CORNERING, V) == pytest.approx(100.0 / 3.0)


@pytest.mark.parametrize("turn_deg", [0.0, 30.0, 45.0, 90.0, 135.0, 170.0])
def test_a_lone_corner_and_the_stops_cost_path_times_seconds_exactly(turn_deg):
    """Legs long enough to reach the cruise speed between the ends and the corner: the path's
    seconds at cruise are its metres, the corner's loss and both stops'."""
    angle = math.radians(turn_deg)
    points = [(0.0, 0.0), (0.0, 400.0), (400.0 * math.sin(angle), 400.0 + 400.0 * math.cos(angle))]
    assert turn_angles_deg(points) == pytest.approx([turn_deg])
    seconds = path_time_s(points, V, ARDUCOPTER_CORNERING)
    want_m = 800.0 + turn_loss_m(ARDUCOPTER_CORNERING, V, turn_deg) + 2 * stop_loss_m(ARDUCOPTER_CORNERING, V)
    assert seconds * V == pytest.approx(want_m, rel=1e-12)


def _cell_path(start_heading, changes, oc):
    """A path from cell (0, 0) whose moves turn by `changes` eighths, each allowed by `oc`, as
    (headings of its moves, cell centres)."""
    headings = [start_heading % 8]
    for d in changes:
        g = (headings[-1] + d) % 8
        if oc.allows(headings[-1], g):
            headings.append(g)
    x, y = 0, 0
    cells = [(0, 0)]
    for h in headings:
        x, y = x + int(HEADING_DX[h]), y + int(HEADING_DY[h])
        cells.append((x, y))
    return headings, cells


@settings(max_examples=200, deadline=None)
@given(start=st.integers(0, 7), changes=st.lists(st.integers(-4, 4), min_size=0, max_size=40),
       cell_m=st.floats(5.0, 200.0), accel=st.floats(0.5, 5.0), f45=st.floats(0.0, 1.0), f90=st.floats(0.0, 1.0),
       speed=st.floats(2.0, 20.0), eight=st.booleans())
def test_a_cell_paths_priced_cost_is_never_less_than_its_seconds(start, changes, cell_m, accel, f45, f90, speed,
                                                                 eight):
    """Over any path of cells, its metres, its corners' losses and its stops' (the module's sum of
    single dips, in metres and rounded up in range units) are at least its seconds times the
    cruise speed, however close its corners (the true speed is the least of the dips)."""
    cornering = Cornering(accel_m_s2=accel, corner_fractions=((0.0, 1.0), (45.0, max(f45, f90)), (90.0, min(f45, f90)),
                                                              (180.0, 0.0)))
    headings, cells = _cell_path(start, changes, OC8 if eight else OC3)
    points = np.array(cells, dtype=float) * cell_m
    seconds = path_time_s(points, speed, cornering)
    summed_m = path_length_m(points) + turn_loss_m(cornering, speed, turn_angles_deg(points)).sum() \
        + 2 * stop_loss_m(cornering, speed)
    assert seconds * speed <= summed_m * (1 + 1e-12) + 1e-9
    costs = cell_lengths()
    profile = replace(COPTER, cornering=cornering, cruise_speed_m_s=speed)
    pricing = time_pricing(profile, cell_m, costs)
    assert pricing is not None
    units = pricing.path_units(headings, costs)
    assert units >= summed_m * costs.straight / cell_m * (1 - 1e-12)
    assert units <= summed_m * costs.straight / cell_m + 2 * len(headings) + 1  # each move, turn and the stops round up
    assert seconds * speed * costs.straight / cell_m <= units * (1 + 1e-12)


def test_close_corners_are_priced_above_their_seconds_far_ones_at_them():
    """A zig-zag of 45-degree corners on 20 m cells: ArduCopter never reaches its cruise speed
    between them, so the dips overlap and the sum prices the path above its seconds; on 400 m
    legs the corners are apart and the sum is the seconds."""
    for leg_m, exact in ((20.0, False), (400.0, True)):
        headings, cells = _cell_path(0, [1, -1] * 10, OC3)
        points = np.array(cells, dtype=float) * leg_m
        seconds_m = path_time_s(points, V, ARDUCOPTER_CORNERING) * V
        summed_m = path_length_m(points) + turn_loss_m(ARDUCOPTER_CORNERING, V, turn_angles_deg(points)).sum() \
            + 2 * stop_loss_m(ARDUCOPTER_CORNERING, V)
        assert summed_m == pytest.approx(seconds_m, rel=1e-9) if exact else summed_m > seconds_m * 1.05


def test_the_stock_copter_prices_each_turn_in_thousandths_of_its_cells():
    pricing = time_pricing(COPTER, 50.0, cell_lengths())
    assert pricing is not None
    # 20 units a metre on 50 m cells, each loss rounded up
    assert pricing.turn_units == tuple(math.ceil(20 * m - 1e-9) for m in
                                       turn_loss_m(ARDUCOPTER_CORNERING, V, [0, 45, 90, 135, 180, 135, 90, 45]))
    assert pricing.turn_units[:3] == (0, 389, 635) and pricing.stop_units == 1334
    assert turn_units(ARDUCOPTER_CORNERING, V, 25.0, cell_lengths())[1] == 778  # half the cell: twice the units


def test_a_range_buys_its_charge_in_seconds_at_cruise():
    """1000 m of range at 1.03 mAh/m is 1030 mAh, 126.4 s of flying at 8.15 mAh/s: 1264 m at
    10 m/s, in range units on 50 m cells (20 a metre) 25276."""
    pricing = time_pricing(COPTER, 50.0, cell_lengths())
    assert pricing is not None
    assert pricing.units_per_range_unit == pytest.approx(1.03 * 10.0 / 8.15)
    assert pricing.budget_units(20_000) == math.floor(20_000 * 1.03 * 10.0 / 8.15)
    assert pricing.budget_units(20_000) == 25_276
    assert pricing.budget_units(-5) == 0
    # a straight path of the range's metres fits what it buys with room for its stops and 19 corners of 90 degrees
    straight = pricing.path_units([2] * 20, cell_lengths())
    assert straight == 20_000 + pricing.stop_units < pricing.budget_units(20_000)
    assert pricing.path_units([2, 4] * 10, cell_lengths()) == 20_000 + 19 * pricing.turn_units[2] + pricing.stop_units


def test_a_profile_that_prices_metres_has_no_time_pricing():
    plane = EnergyProfile(airframe=Airframe.PLANE, capacity_mah=3300.0, cruise_speed_m_s=22.0, cruise_mah_per_m=0.137,
                          loiter_mah_per_s=3.2, launch_mah=40.0, climb_mah_per_m=1.23, landing_mah=0.0,
                          descent_mah_per_m=1.4)
    assert time_pricing(plane, 50.0, cell_lengths()) is None
    assert time_pricing(replace(COPTER, cornering=None, moving_mah_per_s=None), 50.0, cell_lengths()) is None
    assert time_pricing(None, 50.0, cell_lengths()) is None


@pytest.mark.parametrize("kwargs, says", [
    ({"turn_units": (0,) * 7}, "turn_units"),
    ({"turn_units": (0, -1, 0, 0, 0, 0, 0, 0)}, "turn_units"),
    ({"stop_units": -1}, "stop_units"),
    ({"units_per_range_unit": 0.0}, "units_per_range_unit"),
    ({"units_per_range_unit": math.inf}, "units_per_range_unit"),
])
def test_a_time_pricing_refuses_nonsense(kwargs, says):
    good = {"turn_units": (0,) * 8, "stop_units": 0, "units_per_range_unit": 1.0}
    with pytest.raises(ValueError, match=says):
        TimePricing(**{**good, **kwargs})
    with pytest.raises(ValueError, match="cell size"):
        turn_units(ARDUCOPTER_CORNERING, V, 0.0, cell_lengths())
    with pytest.raises(ValueError, match="cruise speed"):
        turn_loss_m(ARDUCOPTER_CORNERING, -1.0, 45.0)


def test_in_the_papers_unit_steps_a_turn_is_priced_in_steps():
    """Move costs of one unit a step: a range unit is a cell side, and so is a turn's unit."""
    pricing = time_pricing(COPTER, 50.0, STEPS)
    assert pricing is not None and pricing.turn_units[2] == math.ceil(6.9**2 / 1.5 / 50.0)
    assert OC3.allows(0, 1) and pricing.path_units([0, 1], STEPS) == 2 + pricing.turn_units[1] + pricing.stop_units
