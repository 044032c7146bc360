import numpy as np
import pytest

from planner.motion import OC3, OC4, OC8
from planner.search.flock import (
    DEPTH_WEIGHT,
    choices_along,
    clamp_position,
    decode_positions,
    turn_ordered,
)


def test_turn_ordered_sorts_each_row_left_to_right():
    table = turn_ordered(OC3.successors)
    assert table[0].tolist() == [7, 0, 1]          # N: NW, N, NE
    assert table[2].tolist() == [1, 2, 3]
    assert table[7].tolist() == [6, 7, 0]          # NW: W, NW, N (wraps)
    assert turn_ordered(OC8.successors)[0].tolist() == [5, 6, 7, 0, 1, 2, 3, 4]  # U-turn last
    assert turn_ordered(OC4.successors)[1].tolist() == [6, 0, 2, 4]              # NE: -135, -45, +45, +135


@pytest.mark.parametrize("x, choice", [(-3.0, 0), (-0.5, 0), (0.49, 0), (0.5, 1), (1.49, 1), (1.5, 2), (2.5, 2),
                                       (9.0, 2)])
def test_positions_round_and_clamp_to_a_valid_choice(x, choice):
    out = np.empty((1, 1), dtype=np.int64)
    decode_positions(np.array([[x]]), 3, out)
    assert out[0, 0] == choice


def test_positions_are_clamped_to_the_span_that_rounds_to_a_choice():
    assert clamp_position(-4.0, 3) == -0.5
    assert clamp_position(7.0, 3) == 2.5
    assert clamp_position(1.2, 3) == 1.2


def test_choices_along_follows_known_cells_then_goes_straight():
    table = turn_ordered(OC3.successors)
    cells = np.array([[5, 6], [6, 7], [-1, -1], [-1, -1]])     # from (5,5) heading N: N, NE, then unknown
    row = choices_along(table, (5, 5, 0), cells, 4)
    assert row.tolist() == [1, 2, 1, 1]
    assert choices_along(table, (5, 5, 0), np.array([[5, 4], [-1, -1]]), 2) is None   # a U-turn is not allowed
    assert choices_along(table, (5, 5, 0), None, 2) is None


def test_depth_weight_dominates_any_j1_difference():
    worst_step, best_step = 0.3 * -100.0, 0.3 + 0.3 * 0.5 + 0.3 + 0.1
    assert DEPTH_WEIGHT + 12 * worst_step > 12 * best_step
