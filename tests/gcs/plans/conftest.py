"""A small valid area file built in local metres, and a runner for `gcs` commands."""

import copy
import json
from types import SimpleNamespace

import numpy as np
import pytest

from gcs.cli import main
from planner.georef import LocalFrame

FRAME = LocalFrame(47.0, 8.0)


def lonlat(points_m):
    pts = np.asarray(points_m, dtype=float)
    lat, lon = FRAME.local2geodetic(pts[:, 0], pts[:, 1])
    return [[float(a), float(b)] for a, b in zip(np.atleast_1d(lon), np.atleast_1d(lat))]


def ring(points_m):
    coords = lonlat(points_m)
    return coords + [coords[0]]


def feature(kind, coords, **props):
    return {"type": "Feature", "geometry": {"type": kind, "coordinates": coords}, "properties": props}


def small_area() -> dict:
    """600 m square (20x20 cells of 30 m), one no-fly box, two airports, one prior, one target."""
    return {"type": "FeatureCollection", "properties": {"cell_size_m": 30}, "features": [
        feature("Polygon", [ring([(-300, -300), (300, -300), (300, 300), (-300, 300)])], role="area", name="square"),
        feature("Polygon", [ring([(0, 0), (120, 0), (120, 120), (0, 120)])], role="no_fly", name="box"),
        feature("Polygon", [ring([(-300, -300), (0, -300), (0, 0), (-300, 0)])], role="prior", tep=0.9, eu=0.8),
        feature("Point", lonlat([(-255, -15)])[0], role="airport", name="west", heading="E", range_m=3000),
        feature("Point", lonlat([(255, -255)])[0], role="airport", name="south-east", heading=315,
                endurance_s=250),
        feature("Point", lonlat([(-100, -100)])[0], role="target"),
    ]}


@pytest.fixture
def shapes():
    """Helpers that build GeoJSON from local metres around FRAME."""
    return SimpleNamespace(feature=feature, lonlat=lonlat, ring=ring, frame=FRAME)


@pytest.fixture
def area_doc():
    return copy.deepcopy(small_area())


@pytest.fixture
def run_gcs(tmp_path, capsys):
    """Write `doc` (dict or raw text) to a file, run `gcs plan --area` on it; (code, stderr, out dir)."""
    def run(doc, *extra):
        path = tmp_path / "area.geojson"
        path.write_text(doc if isinstance(doc, str) else json.dumps(doc), encoding="utf-8")
        out = tmp_path / "out"
        code = main(["plan", "--area", str(path), "--out", str(out), "--quiet", *extra])
        return code, capsys.readouterr().err, out
    return run


def vehicles_file(tmp_path, profiles) -> str:
    """A vehicles.json in `tmp_path` of ArduPilot vehicles sysid:N with the given profiles {N: profile}."""
    from gcs.plans.vehicle_file import VehicleRecord, vehicles_to_dict

    records = {f"sysid:{uav}": VehicleRecord(f"sysid:{uav}", uav, uav, "ardupilot", 1, "2026-12-02T10:00:00+00:00", p)
               for uav, p in profiles.items()}
    path = tmp_path / "vehicles.json"
    path.write_text(json.dumps(vehicles_to_dict(records)))
    return str(path)
