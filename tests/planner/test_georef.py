"""The local frame (round trips, an independent geodesic check) and the grid arithmetic."""

import math

import numpy as np
import pymap3d
import pyproj
import pytest

from planner.georef import Grid, LocalFrame, heading_from_degrees


@pytest.mark.parametrize("lat0, lon0", [(47.397742, 8.545594), (-35.363261, 149.16523), (69.68, 18.87), (0.0, -179.9)])
def test_geodetic_local_round_trip_is_sub_micrometre(lat0, lon0):
    frame = LocalFrame(lat0, lon0)
    rng = np.random.default_rng(1)
    east = rng.uniform(-20_000, 20_000, 500)
    north = rng.uniform(-20_000, 20_000, 500)
    lat, lon = frame.local2geodetic(east, north)
    e2, n2 = frame.geodetic2local(lat, lon)
    assert np.max(np.hypot(e2 - east, n2 - north)) < 1e-6
    lat2, lon2 = frame.local2geodetic(e2, n2)
    assert np.max(np.abs(lat2 - lat)) < 1e-11 and np.max(np.abs(lon2 - lon)) < 1e-11


@pytest.mark.parametrize("lat0, lon0", [(47.397742, 8.545594), (-35.363261, 149.16523), (84.39861077543975, -141.2268),
                                        (0.0, -179.9)])
def test_the_frame_converts_exactly_as_from_epsg_4326(lat0, lon0):
    """The transformers are built from a PROJ-string WGS84 (no database search): the same
    pipelines as from EPSG:4326, and the same numbers to the last bit."""
    frame = LocalFrame(lat0, lon0)
    local = pyproj.CRS.from_proj4(frame.proj_string)
    forward = pyproj.Transformer.from_crs("EPSG:4326", local, always_xy=True)
    inverse = pyproj.Transformer.from_crs(local, "EPSG:4326", always_xy=True)
    assert (frame._forward.definition, frame._inverse.definition) == (forward.definition, inverse.definition)
    rng = np.random.default_rng(3)
    lon, lat = lon0 + rng.uniform(-0.2, 0.2, 500), lat0 + rng.uniform(-0.2, 0.2, 500)
    east, north = rng.uniform(-20_000, 20_000, 500), rng.uniform(-20_000, 20_000, 500)
    assert np.array_equal(np.stack(frame.geodetic2local(lat, lon)), np.stack(forward.transform(lon, lat)))
    assert np.array_equal(np.stack(frame.local2geodetic(east, north)), np.stack(inverse.transform(east, north)[::-1]))
    assert frame.geodetic2en(float(lat[0]), float(lon[0])) == forward.transform(float(lon[0]), float(lat[0]))


def test_distance_and_bearing_from_origin_match_the_geodesic():
    frame = LocalFrame(47.397742, 8.545594)
    geod = pyproj.Geod(ellps="WGS84")
    rng = np.random.default_rng(2)
    for east, north in rng.uniform(-10_000, 10_000, size=(50, 2)):
        lat, lon = frame.local2geodetic(east, north)
        azimuth, _, distance = geod.inv(8.545594, 47.397742, float(lon), float(lat))
        assert distance == pytest.approx(math.hypot(east, north), abs=1e-6)
        assert math.degrees(math.atan2(east, north)) == pytest.approx(azimuth, abs=1e-7)


def test_local_frame_agrees_with_pymap3d_enu_near_the_origin():
    frame = LocalFrame(47.397742, 8.545594)
    lat, lon = frame.local2geodetic(np.array([300.0, -800.0]), np.array([-450.0, 1200.0]))
    e, n, _ = pymap3d.geodetic2enu(lat, lon, 0.0, 47.397742, 8.545594, 0.0)
    assert np.allclose(e, [300.0, -800.0], atol=0.01) and np.allclose(n, [-450.0, 1200.0], atol=0.01)


@pytest.mark.parametrize("lat0, lon0", [(47.397742, 8.545594), (-35.363261, 149.16523), (69.68, 18.87), (0.0, -179.9)])
def test_scalar_conversions_round_trip_and_match_the_array_api(lat0, lon0):
    """The simulator's one-point calls: floats out, the array API's values exactly, round trips
    to the projection's precision."""
    frame = LocalFrame(lat0, lon0)
    rng = np.random.default_rng(3)
    east = rng.uniform(-20_000, 20_000, 200)
    north = rng.uniform(-20_000, 20_000, 200)
    lats, lons = frame.local2geodetic(east, north)
    for e, n, lat_a, lon_a in zip(east, north, lats, lons, strict=True):
        lat, lon = frame.en2geodetic(e, n)
        assert type(lat) is float and type(lon) is float
        assert (lat, lon) == (lat_a, lon_a)
        e2, n2 = frame.geodetic2en(lat, lon)
        assert type(e2) is float and type(n2) is float
        assert math.hypot(e2 - e, n2 - n) < 1e-6
        assert (e2, n2) == tuple(float(v[0]) for v in frame.geodetic2local([lat], [lon]))
        lat2, lon2 = frame.en2geodetic(e2, n2)
        assert abs(lat2 - lat) < 1e-11 and abs(lon2 - lon) < 1e-11
    assert frame.geodetic2en(lat0, lon0) == pytest.approx((0.0, 0.0), abs=1e-9)


@pytest.mark.parametrize(("east", "north"), [(0, 0), (1000, -500), (-3000, 4000), (5000, 5000), (-7000, 0)])
def test_scalar_conversions_against_pymap3d_enu(east, north):
    """A tangent plane and the azimuthal equidistant map part by d^3 / (6 R^2) at d from the
    centre: micrometres at 1 km, a millimetre or two at 7 km."""
    lat0, lon0 = -35.363261, 149.165230
    lat, lon = LocalFrame(lat0, lon0).en2geodetic(east, north)
    e, n, _ = pymap3d.geodetic2enu(lat, lon, 0.0, lat0, lon0, 0.0)
    d = math.hypot(east, north)
    assert math.hypot(e - east, n - north) <= d**3 / (6 * 6_335_000.0**2) + 1e-7


def test_frames_with_one_origin_share_their_transformers():
    a, b = LocalFrame(-35.363261, 149.16523), LocalFrame(-35.363261, 149.16523)
    assert a.geodetic2en(-35.36, 149.17) == b.geodetic2en(-35.36, 149.17)
    assert a._forward is b._forward and a._inverse is b._inverse


def test_grid_covering_counts_cells_and_tolerates_round_off():
    grid = Grid.covering((-500.0, -500.000001, 500.0000001, 500.0), 20.0)
    assert (grid.nx, grid.ny) == (50, 50)
    assert grid.east0_m == pytest.approx(-500.0)
    assert Grid.covering((0, 0, 101, 10), 20.0).nx == 6
    grid = Grid(0.0, 0.0, 10.0, 4, 3)
    assert grid.cell_of(0.0, 0.0) == (0, 0)
    assert grid.cell_of(39.99, 29.99) == (3, 2)
    assert tuple(map(float, grid.centre_m(1, 2))) == (15.0, 25.0)
    with pytest.raises(ValueError):
        grid.cell_of(40.0, 5.0)
    with pytest.raises(ValueError):
        Grid.covering((0, 0, 1, 1), float("nan"))


@pytest.mark.parametrize("degrees, heading", [(0, 0), (22.4, 0), (22.6, 1), (90, 2), (135, 3), (180, 4), (224, 5),
                                              (270, 6), (337.4, 7), (337.6, 0), (360, 0), (-45, 7), (405, 1)])
def test_heading_from_degrees_picks_the_nearest_of_eight(degrees, heading):
    assert heading_from_degrees(degrees) == heading
