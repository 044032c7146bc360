import pytest

from planner.motion import OC3, OC4, OC5, OC8, constraint_by_name, heading_between


def test_3oc_is_left_straight_right():
    assert sorted(OC3.successors[0]) == [0, 1, 7]
    assert sorted(OC3.successors[4]) == [3, 4, 5]
    assert OC3.allows(7, 0) and not OC3.allows(0, 2)


def test_4oc_is_axis_moves_whatever_the_heading():
    for h in range(8):
        assert sorted(OC4.successors[h]) == [0, 2, 4, 6]


def test_5oc_and_8oc():
    assert sorted(OC5.successors[2]) == [0, 1, 2, 3, 4]
    assert all(sorted(OC8.successors[h]) == list(range(8)) for h in range(8))


def test_constraint_names():
    assert constraint_by_name("3") is OC3
    assert constraint_by_name("8OC") is OC8
    assert constraint_by_name(4) is OC4
    with pytest.raises(ValueError, match="unknown orientation constraint"):
        constraint_by_name("7")


def test_headings_run_clockwise_from_north():
    assert heading_between(0, 1) == 0
    assert heading_between(1, 0) == 2
    assert heading_between(0, -1) == 4
    assert heading_between(-1, 1) == 7
    with pytest.raises(ValueError):
        heading_between(0, 0)
