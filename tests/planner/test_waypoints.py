"""Straight runs collapse to their ends, turns stay, and unsafe merged legs are split again."""

import numpy as np
import pytest
from shapely.geometry import box

from planner.waypoints import legs_clear, legs_inside, merge_waypoints, path_length_m, turn_points


def test_a_straight_run_collapses_to_its_ends():
    cells = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0)]
    assert turn_points(cells).tolist() == [0, 4]


def test_turns_are_kept():
    cells = [(0, 0), (1, 0), (2, 0), (3, 1), (4, 2), (4, 3), (4, 4), (3, 4)]
    assert turn_points(cells).tolist() == [0, 2, 4, 6, 7]


def test_a_zigzag_keeps_every_cell():
    cells = [(0, 0), (1, 1), (2, 0), (3, 1), (4, 0)]
    assert turn_points(cells).tolist() == [0, 1, 2, 3, 4]


def test_a_closed_loop_keeps_its_corners_and_both_ends():
    cells = [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)]
    assert turn_points(cells).tolist() == [0, 1, 2, 3, 4]


def test_a_merged_leg_cutting_a_no_fly_corner_gets_its_intermediate_points_back():
    safe = box(-1, -1, 11, 11).difference(box(6, -2, 12, 4))   # zone in the south-east corner
    path = np.array([(0, 0), (5, 0), (5, 5), (10, 5), (10, 10)], dtype=float)
    assert legs_inside(path, safe).all()
    assert merge_waypoints(path, safe, np.array([0, 4])).tolist() == [0, 4]   # the diagonal passes north of it
    kept = merge_waypoints(path, safe, np.array([0, 3, 4]))    # (0,0)->(10,5) and (5,0)->(10,5) cross it
    assert kept.tolist() == [0, 1, 2, 3, 4]
    assert legs_inside(path[kept], safe).all()


def test_a_single_unsafe_step_is_an_error():
    safe = box(0, 0, 10, 10).difference(box(4, -1, 6, 11))
    with pytest.raises(ValueError, match="leaves the safe region"):
        merge_waypoints(np.array([(1.0, 5.0), (9.0, 5.0)]), safe)


def test_path_length_sums_the_legs():
    assert path_length_m(np.array([(0, 0), (3, 4), (3, 0)])) == pytest.approx(9.0)


def test_legs_are_clear_of_a_zone_they_pass_or_touch_but_not_of_one_they_cross():
    zone = box(10, -5, 20, 5)
    points = np.array([(0, 10), (30, 10), (30, 5), (0, 5), (0, 0), (30, 0)])  # beside, along its edge, through it
    assert legs_clear(points, zone).tolist() == [True, True, False, True, False]
    assert legs_clear(points[:1], zone).tolist() == []
