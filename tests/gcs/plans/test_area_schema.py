"""The area file's JSON Schema (`gcs/schemas/area.schema.json`) against the reader
(`gcs.plans.area_file`): every example area follows it; files the reader accepts in their less
common spellings follow it; files the reader refuses for what a schema can say fail it."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import jsonschema
import pytest

from gcs.errors import UserError
from gcs.plans.area_file import area_schema, parse_area, read_area_file, validate_area_dict

ROOT = Path(__file__).resolve().parents[3]
AREAS = sorted((ROOT / "missions").glob("*.geojson")) + [ROOT / "tests" / "gcs" / "plans" / "gis" / "square.geojson",
                                                         ROOT / "tests" / "gcs" / "tak" / "square.geojson"]
SQUARE = [[[7.996056, 46.997301], [8.003944, 46.997301], [8.003944, 47.002698], [7.996056, 47.002698],
           [7.996056, 46.997301]]]


def _feature(role: str, geometry: dict | None, **props) -> dict:
    return {"type": "Feature", "properties": {"role": role, **props}, "geometry": geometry}


def _point(lon: float = 7.996647, lat: float = 46.999865) -> dict:
    return {"type": "Point", "coordinates": [lon, lat]}


BASE = {"type": "FeatureCollection", "properties": {"cell_size_m": 30}, "features": [
    _feature("area", {"type": "Polygon", "coordinates": SQUARE}, name="square"),
    _feature("airport", _point(), name="west", heading="E", range_m=3000)]}


def _with(*features: dict, **collection) -> dict:
    doc = copy.deepcopy(BASE)
    doc["features"] += list(features)
    doc.update(collection)
    return doc


def _airport(**props) -> dict:
    return _feature("airport", _point(8.003353, 46.997706), **{"heading": 315, **props})


def test_the_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(area_schema())


@pytest.mark.parametrize("path", AREAS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_example_area_follows_the_schema(path):
    read_area_file(path)  # the reader takes it ...
    validate_area_dict(json.loads(path.read_text(encoding="utf-8")))  # ... and the schema does


GOOD = {
    "compass heading in lower case with spaces": _with(_airport(heading=" nw ")),
    "endurance with a null range": _with(_airport(range_m=None, endurance_s=250, altitude_m=80, elevation_m=437)),
    "a position with an altitude": _with(_feature("target", {"type": "Point", "coordinates": [7.9987, 46.9991, 12]})),
    "a multipolygon no-fly zone": _with(_feature("no_fly", {"type": "MultiPolygon", "coordinates": [[[
        [8.0, 47.0], [8.0015, 47.0], [8.0015, 47.001], [8.0, 47.001], [8.0, 47.0]]]]})),
    "segments by poa and by poas": _with(
        _feature("segment", {"type": "Polygon", "coordinates": SQUARE}, name="A", poa=40),
        _feature("segment", {"type": "Polygon", "coordinates": SQUARE}, name="B", poas=[50, 70])),
    "an ipp and a trail": _with(
        _feature("ipp", _point(7.999, 47.0), subject="Hiker", terrain="mountainous"),
        _feature("feature", {"type": "LineString", "coordinates": [[7.997, 46.998], [8.002, 47.002]]}, kind="trail")),
    "a georeferenced .npy raster": _with(_feature("raster_prior", None, path="heat.NPY", crs="EPSG:32632",
                                                  bounds=[0, 0, 100, 100], row0="south", weight=2)),
    "a GeoTIFF raster without geometry member": _with({"type": "Feature",
                                                       "properties": {"role": "raster_prior", "path": "heat.tif"}}),
    "a null collection cell size": _with(properties={"cell_size_m": None}),
}


@pytest.mark.parametrize("doc", GOOD.values(), ids=GOOD.keys())
def test_what_the_reader_takes_follows_the_schema(doc):
    parse_area(doc)
    validate_area_dict(doc)


def _bad_airport(**props) -> dict:
    return _with(_airport(**props))


BAD = {
    "not a feature collection": {**BASE, "type": "Feature"},
    "a feature without a role": _with({"type": "Feature", "properties": {"name": "x"}, "geometry": _point()}),
    "an unknown role": _with(_feature("base", _point())),
    "an airport without a heading": _with(_feature("airport", _point())),
    "a heading that is no compass point": _bad_airport(heading="north-east"),
    "range and endurance both": _bad_airport(range_m=1000, endurance_s=100),
    "a negative range": _bad_airport(range_m=-5),
    "an airport that is a polygon": _with(_feature("airport", {"type": "Polygon", "coordinates": SQUARE},
                                                   heading="N")),
    "an area without geometry": _with(_feature("area", None)),
    "a ring of three positions": _with(_feature("no_fly", {"type": "Polygon", "coordinates": [SQUARE[0][:3]]})),
    "a latitude past the pole": _with(_feature("target", _point(8.0, 91.0))),
    "a prior without eu": _with(_feature("prior", {"type": "Polygon", "coordinates": SQUARE}, tep=0.5)),
    "a prior probability above 1": _with(_feature("prior", {"type": "Polygon", "coordinates": SQUARE}, tep=1.5,
                                                  eu=0.5)),
    "a segment with poa and poas": _with(_feature("segment", {"type": "Polygon", "coordinates": SQUARE}, poa=100,
                                                  poas=[100])),
    "a segment without poa": _with(_feature("segment", {"type": "Polygon", "coordinates": SQUARE})),
    "a raster prior with a geometry": _with(_feature("raster_prior", _point(), path="heat.tif")),
    "a .npy raster without crs": _with(_feature("raster_prior", None, path="heat.npy", bounds=[0, 0, 1, 1])),
    "a GeoTIFF raster with bounds": _with(_feature("raster_prior", None, path="heat.tif", bounds=[0, 0, 1, 1])),
    "an ipp without terrain": _with(_feature("ipp", _point(7.999, 47.0), subject="hiker")),
    "a feature without kind": _with(_feature("feature", _point(7.999, 47.0))),
    "a zero cell size": _with(properties={"cell_size_m": 0}),
    "a heading that is true": _bad_airport(heading=True),
    "no area": {**BASE, "features": BASE["features"][1:]},
    "no airport": {**BASE, "features": BASE["features"][:1]},
    "collection properties that are text": _with(properties="x"),
    "collection properties that are a list": _with(properties=[]),
}


@pytest.mark.parametrize("doc", BAD.values(), ids=BAD.keys())
def test_what_the_reader_refuses_fails_the_schema(doc):
    with pytest.raises(UserError):
        parse_area(doc)
    with pytest.raises(jsonschema.ValidationError):
        validate_area_dict(doc)
