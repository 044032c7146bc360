"""POA / POD / cumulative POD / POS per segment against values computed by hand on a 2 x 2 area."""

from __future__ import annotations

import numpy as np
import pytest

from planner.search_theory import Segment, block_segments, looks_per_cell, search_theory
from planner.success import expected_finds

P0 = np.array([[0.4, 0.1], [0.3, 0.2]])  # [x, y]: column A is x = 0, column B x = 1
ALL = np.ones((2, 2), dtype=bool)
SEGMENTS = [Segment("A", np.array([[True, True], [False, False]])),
            Segment("B", np.array([[False, False], [True, True]]))]
FIRST = np.array([[1, 0], [2, 0]])  # (0, 0) read once, (1, 0) twice


def test_a_first_sortie_by_hand() -> None:
    theory = search_theory(P0 * 7, ALL, 0.5, FIRST, SEGMENTS)  # the prior's scale does not matter
    a, b = theory.segments
    # A: POA 0.5, missed 0.4 * 0.5 + 0.1 = 0.3; B: POA 0.5, missed 0.3 * 0.25 + 0.2 = 0.275
    assert (a.poa, a.pod, a.pos) == pytest.approx((0.5, 0.4, 0.2))
    assert (b.poa, b.pod, b.pos) == pytest.approx((0.5, 0.45, 0.225))
    assert (a.cumulative_pod, b.cumulative_pod) == pytest.approx((0.4, 0.45))
    assert theory.pos == pytest.approx(0.425) == expected_finds(P0, ALL, 0.5, FIRST)
    assert (a.poa_after, b.poa_after) == pytest.approx((0.3 / 0.575, 0.275 / 0.575))
    assert "A            2  50.0%  40.0%  20.0%   40.0%     52.2%" in theory.table()


def test_a_second_sortie_starts_from_the_shifted_poas() -> None:
    second = np.array([[0, 1], [0, 0]])  # (0, 1) read once
    theory = search_theory(P0, ALL, 0.5, second, SEGMENTS, looks_before=FIRST)
    a, b = theory.segments
    assert a.poa == pytest.approx(0.3 / 0.575)
    assert a.pod == pytest.approx(1 - (0.2 + 0.05) / 0.3)
    assert a.cumulative_pod == pytest.approx(1 - (0.4 * 0.5 + 0.1 * 0.5) / 0.5)
    assert (b.pod, b.cumulative_pod) == pytest.approx((0.0, 0.45))
    assert theory.cumulative_pos == pytest.approx(1 - (0.2 + 0.05 + 0.075 + 0.2))


def test_the_rest_of_the_world_keeps_its_share() -> None:
    theory = search_theory(P0, ALL, 0.5, FIRST, SEGMENTS, inside=0.8)
    assert sum(s.poa for s in theory.segments) + theory.rest_poa == pytest.approx(1.0)
    assert theory.rest_poa == pytest.approx(0.2)
    assert theory.pos == pytest.approx(0.8 * 0.425)
    assert sum(s.poa_after for s in theory.segments) + theory.rest_poa_after == pytest.approx(1.0)


def test_blocks_are_named_from_the_north_west() -> None:
    searchable = np.ones((5, 4), dtype=bool)
    searchable[4, :2] = False  # the south-east block holds no searchable cell
    blocks = {b.name: b.block for b in block_segments(searchable, side=2)}
    assert blocks == {"A1": (0, 2, 2, 4), "A2": (0, 0, 2, 2), "B1": (2, 2, 4, 4), "B2": (2, 0, 4, 2),
                      "C1": (4, 2, 5, 4)}


def test_looks_per_cell_and_bad_input() -> None:
    assert looks_per_cell([(0, 1, 0, 0), (1, 2, 0, 0), (1, 1, 1, 1)], (2, 2)).tolist() == [[2, 0], [0, 1]]
    with pytest.raises(ValueError, match="Pc must be"):
        search_theory(P0, ALL, 0.0, FIRST, SEGMENTS)
    with pytest.raises(ValueError, match="prior must be"):
        search_theory(np.zeros((2, 2)), ALL, 0.5, FIRST, SEGMENTS)
