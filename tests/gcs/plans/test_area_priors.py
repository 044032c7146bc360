"""Mass priors in area files: raster priors (GeoTIFF, .npy) resampled onto the grid, several UAVs
launched from one airport point; bad priors are one error line."""

import json

import numpy as np
import pyproj
import pytest
import rasterio
from rasterio.transform import from_origin

from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.planning import area_outputs, build_area_search

UTM32 = "EPSG:32632"


def _utm_box(frame, half_m=360.0):
    """West, south, east, north in UTM 32N of a box around the frame's centre."""
    east, north = pyproj.Transformer.from_crs("EPSG:4326", UTM32, always_xy=True).transform(frame.lon0_deg,
                                                                                           frame.lat0_deg)
    return east - half_m, north - half_m, east + half_m, north + half_m


def _heat(rows=24, cols=24):
    """Row 0 north; the mass in the south-west quarter, most of it in one pixel."""
    values = np.zeros((rows, cols))
    values[rows // 2:, : cols // 2] = 1.0
    values[rows - 5, 4] = 40.0
    return values


def _write_tiff(path, values, bounds, crs=UTM32):
    west, _, east, north = bounds
    pixel = (east - west) / values.shape[1]
    with rasterio.open(path, "w", driver="GTiff", height=values.shape[0], width=values.shape[1], count=1,
                       dtype="float64", crs=crs, transform=from_origin(west, north, pixel, pixel)) as out:
        out.write(values, 1)


def _with_raster(doc, shapes, **props):
    doc = json.loads(json.dumps(doc))
    doc["features"] = [f for f in doc["features"] if f["properties"]["role"] != "prior"]
    doc["features"].append({"type": "Feature", "geometry": None, "properties": {"role": "raster_prior", **props}})
    return doc


def _setup(tmp_path, doc):
    path = tmp_path / "area.geojson"
    path.write_text(json.dumps(doc))
    return build_area_search(path, AreaOptions(), SearchOptions(strategy="exhaustive"))


def test_a_geotiff_and_the_same_npy_give_one_prior_that_keeps_its_mass(tmp_path, area_doc, shapes):
    bounds = _utm_box(shapes.frame)
    values = _heat()
    _write_tiff(tmp_path / "heat.tif", values, bounds)
    tiff = _setup(tmp_path, _with_raster(area_doc, shapes, path="heat.tif", name="heat"))
    np.save(tmp_path / "heat.npy", values[::-1])  # SAREnv's heatmaps: row 0 along the south edge
    npy = _setup(tmp_path, _with_raster(area_doc, shapes, path="heat.npy", crs=UTM32, bounds=list(bounds),
                                        row0="south"))
    prior = tiff.prior_mass
    assert prior is not None and npy.prior_mass is not None
    assert npy.prior_mass.mass == pytest.approx(prior.mass, abs=1e-12)
    assert prior.mass.sum() == pytest.approx(1.0)
    free = tiff.area.free
    assert prior.mass[~free].sum() == 0
    # the 720 m raster over the 600 m square less its no-fly box: the raster's own mass inside, by area
    grid = tiff.area.grid
    east, north = grid.centres_m()
    assert prior.inside == pytest.approx(1.0 * (free & (east < 0) & (north < 0)).sum() * 900 / (360 * 360 * 1.0)
                                         * (values[12:, :12].sum() - 40 + 40) / values.sum(), rel=0.2)
    x, y = np.unravel_index(np.argmax(prior.mass), prior.mass.shape)
    assert east[x, y] < -150 and north[x, y] < -150  # the hot pixel, 210 m west and 210 m south of the centre
    tep = tiff.search.scenario.search_map.tep
    assert tep.max() == pytest.approx(0.9) and tep[x, y] == pytest.approx(0.9)
    assert tep[(east > 50) & (north > 50)].max() == 0  # no mass, no belief: the defaults no longer apply


def test_several_uavs_launch_from_one_airport_point_each_from_its_own_cell(tmp_path, area_doc):
    west = area_doc["features"][3]
    area_doc["features"][4:5] = [json.loads(json.dumps(west)) for _ in range(3)]
    for k, f in enumerate(area_doc["features"][3:6]):
        f["properties"]["name"] = f"car park {k + 1}"
        f["properties"]["range_m"] = 1500
    setup = _setup(tmp_path, area_doc)
    for _ in setup.search.run():
        pass
    plan = json.loads(area_outputs(setup, setup.search.plan(), 0, 12.0)["plan.json"])
    uavs = plan["uavs"]
    assert len(uavs) == 4 and len({tuple(u["airport_lat_lon"]) for u in uavs}) == 1
    assert len({(u["trajectory"][0]["x"], u["trajectory"][0]["y"]) for u in uavs}) == 4  # four cells at step 0
    cells = {}
    for u in uavs:
        for p in u["trajectory"]:
            step, x, y = p["step"], p["x"], p["y"]
            assert cells.setdefault((step, x, y), u["id"]) == u["id"], f"two UAVs in cell {(x, y)} at step {step}"
        assert u["length_m"] <= u["range_m"] + 1e-6
        assert u["waypoints"][0] != u["airport_lat_lon"]  # each flies out to its own cell first


def _fails(run_gcs, doc, match):
    code, err, out = run_gcs(doc)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and match in lines[0], err
    assert not out.exists()


def test_bad_raster_priors_are_one_line_naming_the_feature(run_gcs, area_doc, shapes, tmp_path):
    bounds = _utm_box(shapes.frame)
    _write_tiff(tmp_path / "nocrs.tif", _heat(), bounds, crs=None)
    _fails(run_gcs, _with_raster(area_doc, shapes, path="nocrs.tif", name="lpb"), "has no coordinate system")
    negative = _heat()
    negative[0, 0] = -1.0
    _write_tiff(tmp_path / "neg.tif", negative, bounds)
    _fails(run_gcs, _with_raster(area_doc, shapes, path="neg.tif"), "holds negative values")
    np.save(tmp_path / "heat.npy", _heat())
    _fails(run_gcs, _with_raster(area_doc, shapes, path="heat.npy", bounds=list(bounds)), "needs 'crs'")
    _fails(run_gcs, _with_raster(area_doc, shapes, path="heat.npy", crs=UTM32, bounds=[0, 0, 1]), "needs 'bounds'")
    _fails(run_gcs, _with_raster(area_doc, shapes, path="missing.tif"), "cannot read")
    far = (bounds[0] + 50_000, bounds[1], bounds[2] + 50_000, bounds[3])
    _fails(run_gcs, _with_raster(area_doc, shapes, path="heat.npy", crs=UTM32, bounds=list(far)),
           "no mass on a searchable cell")
