"""Mass priors in area files: raster priors (GeoTIFF, .npy) resampled onto the grid, lost-person
priors from an IPP with features and segments, the camera's sensor, several UAVs launched from
one airport point; bad priors are one error line."""

import json

import numpy as np
import pyproj
import pytest
import rasterio
from rasterio.transform import from_origin

from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.planning import area_outputs, build_area_search
from planner.priors.lost_person import DISTANCE_KM, distance_mass, fit_quartiles, subjects

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


def _feature(geometry, **props):
    return {"type": "Feature", "geometry": geometry, "properties": props}


def _lost_person(doc, shapes, *extra, **ipp):
    doc = json.loads(json.dumps(doc))
    doc["features"] = [f for f in doc["features"] if f["properties"]["role"] != "prior"]
    point = {"type": "Point", "coordinates": shapes.lonlat([(-150, 150)])[0]}
    doc["features"].append(_feature(point, role="ipp", name="PLS", **({"subject": "hiker", "terrain": "flat"} | ipp)))
    doc["features"] += list(extra)
    return doc


def test_an_ipp_with_a_trail_and_two_segments_and_a_camera(tmp_path, area_doc, shapes):
    trail = _feature({"type": "LineString", "coordinates": shapes.lonlat([(-300, 200), (300, 200)])},
                     role="feature", kind="Trail")
    west = _feature({"type": "Polygon", "coordinates": [shapes.ring([(-300, -300), (0, -300), (0, 300),
                                                                      (-300, 300)])]}, role="segment", poas=[60, 70])
    east = _feature({"type": "Polygon", "coordinates": [shapes.ring([(0, -300), (300, -300), (300, 300),
                                                                      (0, 300)])]}, role="segment", poa=35)
    path = tmp_path / "ipp.geojson"
    path.write_text(json.dumps(_lost_person(area_doc, shapes)))
    alone = build_area_search(path, AreaOptions(), SearchOptions(strategy="exhaustive"))
    path.write_text(json.dumps(_lost_person(area_doc, shapes, trail, west, east)))
    setup = build_area_search(path, AreaOptions(), SearchOptions(strategy="exhaustive", camera_fov_deg=45.0))
    grid, free = setup.area.grid, setup.area.free
    east_m, north_m = grid.centres_m()
    r = np.hypot(east_m + 150, north_m - 150)
    plain = alone.prior_mass.mass
    assert plain[r < 200].sum() > plain[r > 400].sum() / 50  # the ring density around the IPP
    # 0.6 km holds 25 % of flat-terrain hikers, the 600 m square (less its no-fly box) some 9 %
    assert 0.05 < alone.prior_mass.inside < 0.15
    mass = setup.prior_mass.mass
    assert mass[(east_m < 0) & free].sum() == pytest.approx(0.65) and mass.sum() == pytest.approx(1.0)
    on_trail = np.abs(north_m - 200) < 15 + 15  # centres within 15 m and half a cell of it
    assert mass[on_trail & (east_m < 0)].mean() > 3 * mass[~on_trail & (east_m < 0) & free].mean()
    assert setup.camera is not None and setup.camera.altitude_m == 50.0  # the lowest layer's
    sensor = setup.search.scenario.sensor
    assert sensor.footprint_radius == 0 and sensor.pc == pytest.approx(setup.camera.pc)  # a 41 m swath, 30 m cells
    assert setup.search.scenario.p0 is not None and setup.search.scenario.p0.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("key", sorted(DISTANCE_KM))
def test_every_row_of_the_lost_person_table_is_an_ipp_an_area_file_can_give(tmp_path, area_doc, shapes, key):
    subject, terrain, climate = key
    path = tmp_path / "ipp.geojson"  # in a search manager's capitals: the words are matched lower-cased
    path.write_text(json.dumps(_lost_person(area_doc, shapes, subject=subject.title(), terrain=terrain.title(),
                                            climate=climate.upper())))
    setup = build_area_search(path, AreaOptions(), SearchOptions(strategy="exhaustive"))
    (ipp,) = setup.source.ipps
    assert (ipp.subject, ipp.terrain, ipp.climate) == key
    prior, area = setup.prior_mass, setup.area
    assert prior is not None and prior.mass.sum() == pytest.approx(1.0)
    mass = distance_mass(area.grid, area.point_m(ipp.lon_deg, ipp.lat_deg), fit_quartiles(DISTANCE_KM[key]))
    assert prior.inside == pytest.approx(float(mass[area.free].sum()))  # this row's distances on the square


def test_gcs_plan_plans_a_lost_person_of_a_category_other_than_a_hiker(run_gcs, area_doc, shapes, tmp_path):
    """The plan's POAs are the child 4-6 row's distance mass: per block of the grid, and inside the area."""
    from planner.search_theory import block_segments

    code, err, out = run_gcs(_lost_person(area_doc, shapes, subject="Child 4-6", terrain="mountainous"),
                             "--strategy", "lawnmower", "--no-improve", "--bound-time", "0", "--no-rrd")
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert plan["uavs"]
    theory = plan["search_theory"]
    setup = build_area_search(tmp_path / "area.geojson", AreaOptions(), SearchOptions(strategy="lawnmower"))
    area, (ipp,) = setup.area, setup.source.ipps
    mass = distance_mass(area.grid, area.point_m(ipp.lon_deg, ipp.lat_deg),
                         fit_quartiles(DISTANCE_KM[("child 4-6", "mountainous", "temperate")]))
    assert theory["inside_area"] == pytest.approx(float(mass[area.free].sum()))
    blocks = block_segments(area.free)
    assert [s["name"] for s in theory["segments"]] == [b.name for b in blocks]
    assert [s["poa"] for s in theory["segments"]] == pytest.approx([float(mass[b.cells].sum()) for b in blocks],
                                                                   abs=2e-6)


@pytest.mark.parametrize("change, match", [
    ({"subject": "astronaut"},
     f"subject 'astronaut' is not in the lost-person table (it holds: {', '.join(subjects())})"),
    ({"terrain": "lunar"}, "terrain 'lunar' is not in the lost-person table (it holds: flat, mountainous)"),
    ({"climate": "polar"}, "climate 'polar' is not in the lost-person table"),
    ({"subject": None}, "an ipp needs 'subject'"),
    ({"subject": "atv"}, "terrain 'flat' is not in the lost-person table (it holds: mountainous)"),
    ({"subject": "gatherer"}, "an ipp needs 'climate' (one of dry)"),  # flat gatherers: the dry table only
    ({"terrain": "urban"}, "terrain 'urban' is not in the lost-person table (it holds: flat, mountainous)"),  # hiker
    ({"subject": "dementia", "terrain": "urban", "climate": "polar"},
     "climate 'polar' is not in the lost-person table (it holds: dry, temperate)"),
])
def test_bad_ipps_are_one_line(run_gcs, area_doc, shapes, change, match):
    doc = _lost_person(area_doc, shapes)
    props = doc["features"][-1]["properties"]
    for key, value in change.items():
        if value is None:
            props.pop(key)
        else:
            props[key] = value
    _fails(run_gcs, doc, match)


def test_bad_lost_person_features_and_segments_are_one_line(run_gcs, area_doc, shapes):
    doc = _lost_person(area_doc, shapes)
    doc["features"][-1]["geometry"]["coordinates"] = shapes.lonlat([(-500, 150)])[0]
    _fails(run_gcs, doc, "feature 5 (ipp 'PLS'): the IPP at lon")
    line = {"type": "LineString", "coordinates": shapes.lonlat([(-300, 200), (300, 200)])}
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(line, role="feature", kind="moat")),
           "kind 'moat' is not a kind of place subjects are found near")
    square = {"type": "Polygon", "coordinates": [shapes.ring([(-300, -300), (0, -300), (0, 300), (-300, 300)])]}
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(square, role="segment", name="A", poa=60),
                                 _feature(square, role="segment", name="B", poas=[20, 30])),
           "the segments' POAs sum to 85%, not 100% (A 60%, B 25%)")
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(square, role="segment", poa=60, poas=[60])),
           "give 'poa' or 'poas'")
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(square, role="segment", poa=160)),
           "poa must lie in [0.0, 100.0]")


def test_segments_sharing_a_name_or_named_as_the_rest_of_the_area_are_one_line(run_gcs, area_doc, shapes):
    """The reports, the team's map and a flight's read-back tell segments apart by their names."""
    west = {"type": "Polygon", "coordinates": [shapes.ring([(-300, -300), (0, -300), (0, 300), (-300, 300)])]}
    east = {"type": "Polygon", "coordinates": [shapes.ring([(0, -300), (300, -300), (300, 300), (0, 300)])]}
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(west, role="segment", name="A", poa=60),
                                 _feature(east, role="segment", name=" a ", poa=40)),
           "feature 7 (segment ' a '): the segment name 'a' is taken by feature 6 (segment 'A'): give each "
           "segment its own name")
    _fails(run_gcs, _lost_person(area_doc, shapes, _feature(west, role="segment", name="A", poa=60),
                                 _feature(east, role="segment", name="Rest of the area", poa=40)),
           "feature 7 (segment 'Rest of the area'): 'rest of the area' names the searchable cells no segment "
           "covers: give this segment another name")
