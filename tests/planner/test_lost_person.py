"""Lost-person priors: Koester's quartile radii (each row checked against the mile column of the same
table), the log-normal fitted to them, its ring-area density on the grid, the find-location weights
and the segments' POAs."""

import math

import numpy as np
import pytest

from planner.georef import Grid
from planner.priors.lost_person import (
    DISTANCE_KM,
    FIND_LOCATION,
    QUANTILE_Z,
    QUANTILES,
    climates,
    distance_mass,
    feature_weighted,
    fit_quartiles,
    segment_scaled,
    subjects,
    terrains,
)

MILE_KM = 1.609344

#: The mile column of Koester's distance tables as IGT4SAR tabulates it (github.com/dferguso/IGT4SAR,
#: IPP_EuclideanDistance2.py at 18e222b6bf30ba5c3a5c0136944efcd91a14a8cd; its one figure for a whole
#: ecoregion, or for all of them, is given for each row it stands for): the independent check of
#: every row of DISTANCE_KM, which holds the kilometre column (docs/areas.md#lost-person-priors).
MILES = {
    ("hiker", "flat", "temperate"): (0.4, 1.1, 2.0, 6.1),
    ("hiker", "flat", "dry"): (0.8, 1.3, 4.1, 8.1),
    ("hiker", "mountainous", "temperate"): (0.7, 1.9, 3.6, 11.3),
    ("hiker", "mountainous", "dry"): (1.0, 2.0, 4.0, 11.9),
    ("dementia", "flat", "temperate"): (0.2, 0.6, 1.5, 7.9),
    ("dementia", "flat", "dry"): (0.3, 1.0, 2.2, 7.3),
    ("dementia", "mountainous", "temperate"): (0.2, 0.5, 1.2, 5.1),
    ("dementia", "mountainous", "dry"): (0.6, 1.2, 1.9, 3.8),
    ("angler", "mountainous", "temperate"): (0.2, 0.9, 3.4, 6.1),
    ("atv", "mountainous", "temperate"): (1.0, 2.0, 3.5, 5.0),
    ("camper", "flat", "temperate"): (0.1, 0.7, 2.0, 8.0),
    ("child 1-3", "flat", "temperate"): (0.1, 0.2, 0.6, 2.0),
    ("child 4-6", "flat", "temperate"): (0.1, 0.4, 0.9, 4.1),
    ("child 4-6", "mountainous", "temperate"): (0.1, 0.5, 0.9, 2.3),
    ("child 7-9", "flat", "temperate"): (0.1, 0.5, 1.3, 5.0),
    ("child 7-9", "mountainous", "temperate"): (0.5, 1.0, 2.0, 7.0),
    ("child 7-9", "mountainous", "dry"): (0.3, 0.8, 2.0, 4.5),
    ("child 10-12", "flat", "temperate"): (0.3, 1.0, 3.0, 6.2),
    ("child 10-12", "mountainous", "temperate"): (0.5, 1.0, 2.0, 5.6),
    ("child 10-12", "mountainous", "dry"): (0.5, 1.3, 4.5, 10.0),
    ("child 13-15", "flat", "temperate"): (0.4, 0.8, 2.0, 6.2),
    ("child 13-15", "mountainous", "temperate"): (0.5, 1.3, 3.0, 13.3),
    ("child 13-15", "mountainous", "dry"): (1.5, 2.0, 3.0, 7.4),
    ("despondent", "flat", "temperate"): (0.2, 0.5, 1.4, 10.7),
    ("despondent", "flat", "dry"): (0.3, 1.2, 2.3, 12.8),
    ("despondent", "mountainous", "dry"): (0.5, 1.0, 2.1, 11.1),
    ("gatherer", "mountainous", "temperate"): (0.9, 2.0, 4.0, 8.0),
    ("hunter", "flat", "temperate"): (0.4, 1.0, 1.9, 8.5),
    ("hunter", "flat", "dry"): (1.0, 1.9, 4.0, 7.0),
    ("hunter", "mountainous", "temperate"): (0.6, 1.3, 3.0, 10.7),
    ("hunter", "mountainous", "dry"): (1.3, 3.0, 5.0, 13.8),
    ("intellectual disability", "flat", "temperate"): (0.2, 0.6, 1.3, 7.3),
    ("intellectual disability", "mountainous", "temperate"): (0.4, 1.0, 2.0, 7.0),
    ("mental illness", "flat", "temperate"): (0.5, 0.6, 1.4, 5.0),
    ("mental illness", "mountainous", "temperate"): (0.4, 1.4, 5.1, 9.0),
    ("mountain biker", "mountainous", "temperate"): (1.9, 2.5, 7.0, 15.5),
    ("skier-alpine", "mountainous", "temperate"): (0.7, 1.7, 3.0, 9.4),
    ("skier-nordic", "mountainous", "temperate"): (1.0, 2.2, 4.0, 12.2),
    ("skier-nordic", "mountainous", "dry"): (1.2, 2.7, 4.0, 12.1),
    ("snowboarder", "mountainous", "temperate"): (1.0, 2.0, 3.8, 9.5),
    ("snowmobiler", "flat", "temperate"): (0.8, 2.9, 25.5, 59.7),
    ("snowmobiler", "mountainous", "temperate"): (2.0, 4.0, 6.9, 10.0),
    ("autistic", "flat", "temperate"): (0.4, 1.0, 2.3, 9.5),
    ("autistic", "mountainous", "temperate"): (0.4, 1.0, 2.3, 9.5),
    ("child 1-3", "flat", "dry"): (0.4, 0.8, 2.4, 5.6),
    ("child 1-3", "mountainous", "dry"): (0.4, 0.8, 2.4, 5.6),
    ("child 4-6", "flat", "dry"): (0.4, 1.2, 2.0, 5.1),
    ("child 4-6", "mountainous", "dry"): (0.4, 1.2, 2.0, 5.1),
    ("climber", "flat", "temperate"): (0.1, 1.0, 2.0, 9.2),
    ("climber", "mountainous", "temperate"): (0.1, 1.0, 2.0, 9.2),
    ("gatherer", "flat", "dry"): (1.0, 1.6, 3.6, 6.9),
    ("gatherer", "mountainous", "dry"): (1.0, 1.6, 3.6, 6.9),
    ("intellectual disability", "flat", "dry"): (0.7, 2.5, 5.4, 38.9),
    ("intellectual disability", "mountainous", "dry"): (0.7, 2.5, 5.4, 38.9),
    ("runner", "flat", "temperate"): (0.9, 1.6, 2.1, 3.6),
    ("runner", "mountainous", "temperate"): (0.9, 1.6, 2.1, 3.6),
    **{(subject, "urban", climate): miles for climate in ("temperate", "dry") for subject, miles in (
        ("autistic", (0.2, 0.6, 2.4, 5.0)), ("child 1-3", (0.1, 0.3, 0.5, 0.7)),
        ("child 4-6", (0.06, 0.3, 0.6, 2.1)), ("child 7-9", (0.1, 0.3, 0.9, 3.2)),
        ("dementia", (0.2, 0.7, 2.0, 7.8)),
        ("despondent", (0.06, 0.3, 0.9, 8.1)), ("intellectual disability", (0.2, 0.5, 2.3, 6.14)),
        ("mental illness", (0.2, 0.4, 0.9, 7.7)))},
}


def test_every_row_is_the_kilometre_column_of_a_table_whose_mile_column_agrees():
    assert set(MILES) == set(DISTANCE_KM)
    for key, radii in DISTANCE_KM.items():
        for km, mi in zip(radii, MILES[key]):
            # both columns rounded to 0.1: 0.08 km from the miles, 0.05 from the kilometres, and
            # the book's own columns a little apart (hiker, dry, mountainous: 19.3 km, 11.9 mi)
            assert abs(km - mi * MILE_KM) <= 0.15, (key, km, mi)


def test_the_categories_a_search_manager_uses_are_there_in_the_words_an_area_file_gives():
    for subject in ("child 1-3", "child 4-6", "child 7-9", "child 10-12", "child 13-15", "dementia", "despondent",
                    "hunter", "mountain biker", "skier-alpine", "skier-nordic", "climber", "autistic", "hiker"):
        assert subject in subjects()
    for subject, terrain, climate in DISTANCE_KM:
        assert subject == subject.strip().lower()  # the area file matches the lower-cased word
        assert terrain in ("flat", "mountainous", "urban") and climate in ("temperate", "dry")
    assert terrains("atv") == ["mountainous"] and climates("gatherer", "flat") == ["dry"]
    assert terrains("dementia") == ["flat", "mountainous", "urban"] and terrains("hiker") == ["flat", "mountainous"]
    assert DISTANCE_KM[("child 4-6", "urban", "dry")] == DISTANCE_KM[("child 4-6", "urban", "temperate")]
    assert climates("hunter", "mountainous") == ["dry", "temperate"]


@pytest.mark.parametrize("key", sorted(DISTANCE_KM))
def test_every_row_grows_from_25_to_95_percent(key):
    radii = DISTANCE_KM[key]
    assert len(radii) == 4 and radii[0] > 0
    assert all(a < b for a, b in zip(radii, radii[1:])), (key, radii)


@pytest.mark.parametrize("key", sorted(DISTANCE_KM))
def test_the_fit_is_the_least_squares_log_normal_through_the_four_quantiles(key):
    radii = DISTANCE_KM[key]
    fit = fit_quartiles(radii)
    residuals = np.log(radii) - (fit.mu + fit.sigma * np.array(QUANTILE_Z))
    assert residuals.sum() == pytest.approx(0, abs=1e-12)  # normal equations: orthogonal to 1 and z
    assert residuals @ np.array(QUANTILE_Z) == pytest.approx(0, abs=1e-12)
    # every row is nearly log-normal: its log radii within 0.45 (RMS) of the fitted line, and the
    # fitted share within each radius within 12 points of the table's (the hiker rows within 8;
    # the rows of a few dozen cases are lumpier: climber, n 25, 11.5 points at 1.6 km)
    assert float(np.sqrt(np.mean(residuals**2))) < 0.45, (key, residuals)
    worst = 0.08 if key[0] == "hiker" else 0.12
    for r, p in zip(radii, QUANTILES):
        assert abs(fit.cdf(r) - p) < worst, (key, r, fit.cdf(r), p)
    assert fit.sigma > 0 and fit.cdf(fit.quantile_km(0.0)) == pytest.approx(0.5)


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
