"""Lost-person priors: the log-normal fitted to Koester's quartile radii, its ring-area density on
the grid, the find-location weights and the segments' POAs."""

import math

import numpy as np
import pytest

from planner.georef import Grid
from planner.priors.lost_person import (
    DISTANCE_KM,
    FIND_LOCATION,
    QUANTILE_Z,
    QUANTILES,
    distance_mass,
    feature_weighted,
    fit_quartiles,
    segment_scaled,
)


@pytest.mark.parametrize("key", sorted(DISTANCE_KM))
def test_the_fit_is_the_least_squares_log_normal_through_the_four_quantiles(key):
    radii = DISTANCE_KM[key]
    fit = fit_quartiles(radii)
    residuals = np.log(radii) - (fit.mu + fit.sigma * np.array(QUANTILE_Z))
    assert residuals.sum() == pytest.approx(0, abs=1e-12)  # normal equations: orthogonal to 1 and z
    assert residuals @ np.array(QUANTILE_Z) == pytest.approx(0, abs=1e-12)
    for r, p in zip(radii, QUANTILES):
        assert abs(fit.cdf(r) - p) < 0.08, (key, r, fit.cdf(r), p)  # the table is nearly log-normal
    assert fit.cdf(fit.quantile_km(0.0)) == pytest.approx(0.5)


def test_hiker_in_the_mountains_median_and_quartiles():
    fit = fit_quartiles(DISTANCE_KM[("hiker", "mountainous", "temperate")])
    assert fit.quantile_km(0.0) == pytest.approx(2.68, abs=0.01)  # the table's 3.1 km, fitted with the others
    assert [round(fit.cdf(r), 3) for r in (1.1, 3.1, 5.8, 18.3)] == [0.226, 0.549, 0.743, 0.948]


def test_the_ring_density_on_the_grid_holds_the_fitted_cdf_within_each_radius():
    fit = fit_quartiles(DISTANCE_KM[("hiker", "flat", "temperate")])
    grid = Grid(-15_000.0, -15_000.0, 150.0, 200, 200)
    mass = distance_mass(grid, (75.0, -40.0), fit)
    east, north = grid.centres_m()
    r_m = np.hypot(east - 75.0, north - (-40.0))
    for r_km in (0.6, 1.8, 3.2, 9.9):
        assert mass[r_m <= r_km * 1000].sum() == pytest.approx(fit.cdf(r_km), abs=0.01)
    assert mass.sum() < 1.0 and mass.sum() == pytest.approx(1.0, abs=0.05)  # the rest lies beyond 15 km


def test_features_take_their_find_location_share_of_the_mass():
    mass = np.full((4, 5), 0.05)
    trail = np.zeros((4, 5), dtype=bool)
    trail[1] = True
    hut = np.zeros((4, 5), dtype=bool)
    hut[3, 4] = True
    out = feature_weighted(mass, {"linear": trail, "structure": hut})
    p_trail, p_hut = FIND_LOCATION["linear"], FIND_LOCATION["structure"]
    rest = 1 - p_trail - p_hut
    assert out.sum() == pytest.approx(1.0)
    assert out[trail].sum() == pytest.approx(p_trail + rest * 5 / 20)
    assert out[3, 4] == pytest.approx(p_hut + rest / 20)
    assert out[0, 0] == pytest.approx(rest / 20)


def test_segments_hold_their_poa_and_keep_the_shape_within():
    mass = np.array([[1.0, 3.0], [0.0, 0.0]])
    searchable = np.ones((2, 2), dtype=bool)
    west = np.array([[True, True], [False, False]])
    east = ~west
    out = segment_scaled(mass, [(west, 0.7), (east, 0.3)], searchable)
    assert out[0] == pytest.approx([0.175, 0.525])  # 0.7 split 1:3
    assert out[1] == pytest.approx([0.15, 0.15])  # no mass there: the POA evenly
    assert math.isclose(out.sum(), 1.0)
