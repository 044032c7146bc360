import numpy as np
import pytest

from planner.environment import (
    SearchMap,
    Sensor,
    eu_after_visit,
    footprint_cells,
    sense,
    tep_after_no_report,
    tep_after_report,
)


def test_bayes_after_report_matches_hand_computation():
    # eq. (2): 0.5 * 0.9 / ((0.9 - 0.1) * 0.5 + 0.1) = 0.45 / 0.5
    assert tep_after_report(0.5, 0.9, 0.1) == pytest.approx(0.9)
    assert tep_after_report(0.2, 0.8, 0.05) == pytest.approx(0.16 / (0.75 * 0.2 + 0.05))


def test_bayes_after_no_report_matches_hand_computation():
    # eq. (3): 0.5 * 0.1 / ((0.1 - 0.9) * 0.5 + 0.9) = 0.05 / 0.5
    assert tep_after_no_report(0.5, 0.9, 0.1) == pytest.approx(0.1)
    assert tep_after_no_report(0.9, 0.9, 0.1) == pytest.approx(0.09 / (-0.72 + 0.9))


def test_certain_cells_stay_certain():
    assert tep_after_report(0.0, 0.9, 0.1) == 0.0
    assert tep_after_no_report(0.0, 0.9, 0.1) == 0.0
    # exactly, where the equations as written round past 1 (1.0000000000000002 and 1.0000000000000004)
    assert tep_after_report(1.0, 0.9, 0.2) == 1.0
    assert tep_after_no_report(1.0, 0.875, 0.4885) == 1.0


def test_eu_halves_per_visit():
    chi = 0.8
    for visits in range(1, 5):
        chi = eu_after_visit(chi)
        assert chi == pytest.approx(0.8 / 2**visits)


def _reference_sense(tep, eu, target_grid, cells, draws, radius, pc, pf):
    tep, eu = tep.copy(), eu.copy()
    rows, n = [], 0
    nx, ny = tep.shape
    for cx, cy in cells:
        for x in range(cx - radius, cx + radius + 1):
            for y in range(cy - radius, cy + radius + 1):
                if not (0 <= x < nx and 0 <= y < ny):
                    continue
                present = target_grid[x, y] > 0
                reported = draws[n] < (pc if present else pf)
                p = tep[x, y]
                tep[x, y] = p * pc / ((pc - pf) * p + pf) if reported else p * (1 - pc) / ((pf - pc) * p + 1 - pf)
                eu[x, y] /= 2
                rows.append((x, y, int(reported), int(present)))
                n += 1
    return tep, eu, np.array(rows).reshape(-1, 4)


@pytest.mark.parametrize("radius", [0, 1, 2])
def test_sense_kernel_matches_reference(radius):
    rng = np.random.default_rng(3)
    tep, eu = rng.random((7, 6)), rng.random((7, 6))
    targets = (rng.random((7, 6)) < 0.3).astype(np.int64)
    cells = np.array([[0, 0], [3, 2], [6, 5], [3, 2]])
    m = SearchMap(tep.copy(), eu.copy(), np.zeros((7, 6), bool))
    observed = sum(len(footprint_cells(x, y, radius, (7, 6))) for x, y in cells)
    draws = np.random.default_rng(11).random(observed)
    reports = sense(m, targets, cells, Sensor(0.8, 0.2, radius), draws)
    ref_tep, ref_eu, ref_rows = _reference_sense(tep, eu, targets, cells, draws, radius, 0.8, 0.2)
    np.testing.assert_allclose(m.tep, ref_tep)
    np.testing.assert_allclose(m.eu, ref_eu)
    np.testing.assert_array_equal(reports, ref_rows)
    assert m.visits.sum() == len(ref_rows)


def test_sensor_and_map_reject_bad_values():
    with pytest.raises(ValueError):
        Sensor(0.1, 0.9)
    with pytest.raises(ValueError):
        Sensor(0.9, 0.1, -1)
    with pytest.raises(ValueError):
        SearchMap(np.full((3, 3), 1.5), np.zeros((3, 3)), np.zeros((3, 3), bool))
    with pytest.raises(ValueError):
        SearchMap(np.zeros((3, 3)), np.zeros((3, 4)), np.zeros((3, 3), bool))
