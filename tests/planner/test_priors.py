"""Mass priors: a raster resampled onto the grid keeps its mass and splits it by area."""

import numpy as np
import pytest

from planner.georef import Grid
from planner.priors import PEAK_TEP, mixture, searchable_mass, tep_of_mass
from planner.priors.raster import mass_on_grid


def _corners(rows, cols, pixel_m, east0=0.0, north0=0.0, angle_deg=0.0):
    """Pixel corners of a rows x cols raster, row 0 along the north edge, rotated about (east0, north0)."""
    col, row = np.meshgrid(np.arange(cols + 1) * pixel_m, np.arange(rows + 1) * pixel_m)
    e, n = col, rows * pixel_m - row
    a = np.radians(angle_deg)
    return east0 + e * np.cos(a) - n * np.sin(a), north0 + e * np.sin(a) + n * np.cos(a)


def test_a_pixel_twice_a_cell_splits_its_mass_into_four_equal_quarters():
    grid = Grid(0.0, 0.0, 10.0, 4, 4)
    values = np.array([[0.0, 1.0], [3.0, 0.0]])  # row 0 north: 1.0 at the north-east pixel
    out = mass_on_grid(values, *_corners(2, 2, 20.0), grid)
    assert out[2:, 2:] == pytest.approx(np.full((2, 2), 0.25))
    assert out[:2, :2] == pytest.approx(np.full((2, 2), 0.75))
    assert out.sum() == pytest.approx(4.0)


def test_a_rotated_fine_raster_keeps_its_mass_and_spreads_it_by_area():
    grid = Grid(-200.0, -200.0, 25.0, 16, 16)
    rng = np.random.default_rng(1)
    values = rng.random((37, 41))
    out = mass_on_grid(values, *_corners(37, 41, 7.0, -60.0, -185.0, angle_deg=30.0), grid)
    assert out.sum() == pytest.approx(values.sum(), rel=1e-12)
    uniform = mass_on_grid(np.ones((40, 40)), *_corners(40, 40, 5.0, -100.0, -100.0), grid)
    assert uniform[4:12, 4:12] == pytest.approx(np.full((8, 8), 25.0))  # 25 pixels of 5 m in a 25 m cell
    assert uniform.sum() == pytest.approx(1600.0)


def test_mass_off_the_grid_is_dropped_and_the_rest_normalised_on_searchable_cells():
    grid = Grid(0.0, 0.0, 10.0, 2, 2)
    out = mass_on_grid(np.ones((1, 4)), *_corners(1, 4, 10.0, 0.0, 10.0), grid)  # half the raster east of the grid
    assert out.sum() == pytest.approx(2.0)
    searchable = np.array([[True, True], [True, False]])
    prior = searchable_mass(out, 4.0, searchable)
    assert prior.inside == pytest.approx(0.25) and prior.mass.sum() == pytest.approx(1.0)
    assert prior.mass[1, 1] == 0 and prior.tep.max() == pytest.approx(PEAK_TEP)
    with pytest.raises(ValueError, match="no mass on a searchable cell"):
        searchable_mass(out, 4.0, np.zeros((2, 2), dtype=bool))


def test_tep_keeps_the_shape_of_the_mass_and_mixtures_weigh_normalised_maps():
    ramp = np.arange(1.0, 1001.0).reshape(10, 100)
    tep = tep_of_mass(ramp)
    reference = np.quantile(ramp, 0.99)
    assert tep[4, 99] == pytest.approx(PEAK_TEP * 500 / reference)  # the shape below the top 1 %
    assert np.all(tep[ramp >= reference] == PEAK_TEP) and (tep == PEAK_TEP).sum() == 10
    assert tep_of_mass(np.zeros((2, 2))).max() == 0
    mixed = mixture([np.array([[2.0, 0.0]]), np.array([[0.0, 10.0]])], [3.0, 1.0])
    assert mixed == pytest.approx(np.array([[0.75, 0.25]]))
