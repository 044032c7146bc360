"""`gcs plan --area` end to end on the example areas: the paper reproduced, every leg safe,
mission files that parse back, the plan JSON valid and geo-referenced."""

import json
import os
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from pymavlink import mavutil, mavwp
from shapely.geometry import shape
from shapely.ops import unary_union

from gcs.cli import main
from gcs.flight.sortie import SortieLog
from gcs.plans.plan_file import validate_plan_dict
from gcs.plans.plan_folder import load_plan_dir
from planner.camera import Camera, camera_sensor

#: The four examples are planned once (`planned`, about 40 s of the 2-core machine): every test here in
#: one worker (pytest-xdist's loadgroup), not the fixture once in each (ci80: twice, 87 s).
pytestmark = pytest.mark.xdist_group("examples")

MISSIONS = Path(__file__).resolve().parents[3] / "missions"
EXAMPLES = ("paper", "irregular", "large", "hiker")
#: Options beyond the defaults: the large example's exhaustive search keeps the suite quick (legs are
#: checked alike); the hiker is searched with a camera's sensor. No bound (`--bound-time 0`: its line
#: and record are tested in tests/gcs/recording/test_overview.py and tests/planner/test_bound.py), and
#: the irregular area without the whole-mission improvement (its best responses take some 40 s of CPU
#: there, docs/benchmarks.md; the improvement's invariants are property tests in tests/planner/test_improve.py).
COMMON = ["--bound-time", "0"]
OPTIONS = {"large": ["--strategy", "exhaustive"],
           "irregular": ["--no-improve"],
           "hiker": ["--strategy", "exhaustive", "--camera-fov", "45", "--no-rrd"]}


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """Each example planned once: name -> output folder."""
    root = tmp_path_factory.mktemp("examples")
    out = {}
    for name in EXAMPLES:
        args = ["plan", "--area", str(MISSIONS / f"{name}.geojson"), "--out", str(root / name), "--quiet",
                *COMMON, *OPTIONS.get(name, [])]
        assert main(args) == 0
        out[name] = root / name
    return out


def _load(path: Path):
    return json.loads(path.read_text(encoding="utf-8"))


def _area_and_no_fly(name: str):
    doc = _load(MISSIONS / f"{name}.geojson")
    area = unary_union([shape(f["geometry"]) for f in doc["features"] if f["properties"]["role"] == "area"])
    no_fly = [shape(f["geometry"]) for f in doc["features"] if f["properties"]["role"] == "no_fly"]
    return doc, area, no_fly


def _to_local(plan: dict):
    proj = pyproj.Transformer.from_crs("EPSG:4326", pyproj.CRS.from_proj4(plan["grid"]["georef"]["projection"]),
                                       always_xy=True)
    return lambda coords: np.column_stack(proj.transform(coords[:, 0], coords[:, 1]))


def _waypoint_file(path: Path) -> list:
    """pymavlink's own reader. It picks the MISSION_ITEM layout from the MAVLINK20 environment
    variable but the loaded dialect decides the real one; other suites set the variable, so make
    them agree for the duration of the read."""
    wire2 = mavutil.mavlink.WIRE_PROTOCOL_VERSION == "2.0"
    saved = os.environ.get("MAVLINK20")
    if wire2:
        os.environ["MAVLINK20"] = "1"
    else:
        os.environ.pop("MAVLINK20", None)
    try:
        loader = mavwp.MAVWPLoader()
        loader.load(str(path))
        return [loader.wp(i) for i in range(loader.count())]
    finally:
        if saved is None:
            os.environ.pop("MAVLINK20", None)
        else:
            os.environ["MAVLINK20"] = saved


def test_paper_area_is_the_built_in_paper_scenario_flown_in_metres(planned, tmp_path):
    """The paper's region on real coordinates: the same grid, no-fly cells and targets as the
    built-in scenario; its ranges are metres (3700 m of 20 m cells, the built-in 130 steps charged
    as diagonals), spent by length, so every UAV flies more of the region than the 130 steps."""
    assert main(["plan", "--scenario", "paper", "--seed", "0", "--horizon-value", "--out", str(tmp_path / "paper.json"),
                 "--quiet"]) == 0
    built_in = _load(tmp_path / "paper.json")
    from_area = _load(planned["paper"] / "plan.json")
    assert from_area["grid"]["no_fly"] == built_in["grid"]["no_fly"]
    assert [(t["x"], t["y"]) for t in from_area["targets"]] == [(t["x"], t["y"]) for t in built_in["targets"]]
    assert "move_costs" not in built_in["settings"]
    assert from_area["settings"]["move_costs"] == {"straight": 1000, "diagonal": 1415}
    for a, b in zip(from_area["uavs"], built_in["uavs"]):
        assert b["range"] == 130 and a["range_m"] == 3700 and abs(a["range"] - 3700 / 20 * 1000) <= 1
        assert len(a["trajectory"]) > len(b["trajectory"]) and a["range_used_m"] / a["range_m"] >= 0.97


@pytest.mark.parametrize("name", EXAMPLES)
def test_every_leg_stays_in_the_area_and_out_of_no_fly_zones(planned, name):
    doc, area, no_fly = _area_and_no_fly(name)
    plan = _load(planned[name] / "plan.json")
    to_local = _to_local(plan)
    area_m = shapely.transform(area, to_local).buffer(0.01)
    no_fly_m = unary_union([shapely.transform(z, to_local) for z in no_fly]).buffer(-0.01)
    legs = 0
    for uav in plan["uavs"]:
        items = _waypoint_file(planned[name] / f"uav{uav['id']}.waypoints")
        lonlat = np.array([(w.y, w.x) for w in items if w.command in (16, 21, 22)])   # home, take-off, waypoints, land
        path = to_local(lonlat)
        segments = shapely.linestrings(np.stack([path[:-1], path[1:]], axis=1))
        assert shapely.covered_by(segments, area_m).all()
        assert not shapely.intersects(segments, no_fly_m).any()
        legs += len(segments)
    assert legs > 100


@pytest.mark.parametrize("name", EXAMPLES)
def test_waypoint_files_parse_back_with_pymavlink(planned, name):
    plan = _load(planned[name] / "plan.json")
    for uav in plan["uavs"]:
        text = (planned[name] / f"uav{uav['id']}.waypoints").read_text()
        assert text.splitlines()[0] == "QGC WPL 110"
        assert all(len(line.split("\t")) == 12 for line in text.splitlines()[1:])
        items = _waypoint_file(planned[name] / f"uav{uav['id']}.waypoints")
        lat0, lon0 = uav["airport_lat_lon"]
        assert len(items) == 1 + 1 + len(uav["waypoints"]) + 1
        assert [w.seq for w in items] == list(range(len(items)))
        home, takeoff, land = items[0], items[1], items[-1]
        assert (home.command, home.frame, home.current) == (16, mavutil.mavlink.MAV_FRAME_GLOBAL, 1)
        assert (home.x, home.y) == pytest.approx((lat0, lon0), abs=1e-8)
        assert (takeoff.command, takeoff.frame, takeoff.z) == (22, 3, uav["altitude_m"])
        assert (land.command, land.z) == (21, 0.0)
        assert (land.x, land.y) == pytest.approx((lat0, lon0), abs=1e-8)
        for w, (lat, lon) in zip(items[2:-1], uav["waypoints"]):
            assert (w.command, w.frame, w.z) == (16, 3, uav["altitude_m"])
            assert (w.x, w.y) == pytest.approx((lat, lon), abs=1e-8)


@pytest.mark.parametrize("name", EXAMPLES)
def test_qgc_plan_files_follow_the_plan_format(planned, name):
    doc, area, no_fly = _area_and_no_fly(name)
    holes = sum(len(p.interiors) for p in getattr(area, "geoms", [area]))
    plan = _load(planned[name] / "plan.json")
    for uav in plan["uavs"]:
        qgc = _load(planned[name] / f"uav{uav['id']}.plan")
        assert (qgc["fileType"], qgc["version"], qgc["groundStation"]) == ("Plan", 1, "QGroundControl")
        mission = qgc["mission"]
        assert mission["version"] == 2 and mission["vehicleType"] == 2
        assert mission["plannedHomePosition"][:2] == uav["airport_lat_lon"]
        items = mission["items"]
        assert [i["doJumpId"] for i in items] == list(range(1, len(items) + 1))
        assert all(i["type"] == "SimpleItem" and len(i["params"]) == 7 for i in items)
        assert [i["command"] for i in items] == [22] + [16] * len(uav["waypoints"]) + [21]
        assert [i["params"][4:6] for i in items[1:-1]] == uav["waypoints"]
        fence = qgc["geoFence"]
        assert fence["version"] == 2 and fence["circles"] == []
        inclusion = [p for p in fence["polygons"] if p["inclusion"]]
        exclusion = [p for p in fence["polygons"] if not p["inclusion"]]
        assert len(inclusion) == len(getattr(area, "geoms", [area]))
        assert len(exclusion) == holes + len(no_fly)
        for p in fence["polygons"]:
            pts = p["polygon"]
            assert p["version"] == 1 and pts[0] != pts[-1] and len(pts) >= 3
            signed = sum(a[1] * b[0] - b[1] * a[0] for a, b in zip(pts, pts[1:] + pts[:1]))
            assert signed < 0, "QGC fence polygons are clockwise"
        assert qgc["rallyPoints"] == {"points": [[*uav["airport_lat_lon"], uav["altitude_m"]]], "version": 2}


@pytest.mark.parametrize("name", EXAMPLES)
def test_plan_json_is_valid_and_geo_referenced(planned, name):
    plan = _load(planned[name] / "plan.json")
    trimmed = json.loads(json.dumps(plan))   # the schema check of the full large plan takes seconds
    trimmed["grid"]["no_fly"] = trimmed["grid"]["no_fly"][:200]
    for uav in trimmed["uavs"]:
        uav["trajectory"] = uav["trajectory"][:100] + uav["trajectory"][-5:]
    validate_plan_dict(trimmed)
    geo = plan["grid"]["georef"]
    inverse = pyproj.Transformer.from_crs(pyproj.CRS.from_proj4(geo["projection"]), "EPSG:4326", always_xy=True)
    size = geo["cell_size_m"]
    for uav in plan["uavs"]:
        assert uav["trajectory"][0]["x"] == uav["trajectory"][-1]["x"] == uav["airport"][0]
        assert uav["length_m"] <= uav["range_m"]
        for p in uav["trajectory"][:: max(1, len(uav["trajectory"]) // 20)]:
            east, north = geo["east0_m"] + (p["x"] - 0.5) * size, geo["north0_m"] + (p["y"] - 0.5) * size
            lon, lat = inverse.transform(east, north)
            assert (p["lat"], p["lon"]) == pytest.approx((lat, lon), abs=1e-8)


def test_large_example_is_at_least_400_by_400_with_8_uavs(planned):
    plan = _load(planned["large"] / "plan.json")
    assert plan["grid"]["nx"] >= 400 and plan["grid"]["ny"] >= 400
    assert len(plan["uavs"]) >= 8


def test_paths_geojson_has_one_closed_line_per_uav(planned):
    plan = _load(planned["irregular"] / "plan.json")
    paths = _load(planned["irregular"] / "paths.geojson")
    assert paths["type"] == "FeatureCollection" and len(paths["features"]) == len(plan["uavs"])
    for f, uav in zip(paths["features"], plan["uavs"]):
        coords = f["geometry"]["coordinates"]
        assert f["geometry"]["type"] == "LineString" and coords[0] == coords[-1]
        assert coords[0] == [uav["airport_lat_lon"][1], uav["airport_lat_lon"][0]]
        assert [[lat, lon] for lon, lat in coords[1:-1]] == uav["waypoints"]
        assert f["properties"]["length_m"] == pytest.approx(uav["length_m"], abs=0.1)


def test_uavs_fly_at_distinct_altitudes_by_default(planned):
    for name in EXAMPLES:
        altitudes = [u["altitude_m"] for u in _load(planned[name] / "plan.json")["uavs"]]
        assert len(set(altitudes)) == len(altitudes)


def test_the_hiker_is_searched_from_the_ipp_alone_by_three_uavs_from_one_car_park(planned):
    """The prior is the hiker's distance from the IPP with the trail, stream and hut: its mass in the
    area is the whole of what the plan can find (expected finds are a probability), and the
    camera's 45 degrees at the lowest layer (50 m: a 41 m swath over 50 m cells) is the sensor."""
    plan = _load(planned["hiker"] / "plan.json")
    summary = plan["summary"]
    assert summary["expected_targets_in_area"] == pytest.approx(1.0)
    assert 0.2 < summary["probability_of_success"] < 0.9
    assert len({tuple(u["airport_lat_lon"]) for u in plan["uavs"]}) == 1 and len(plan["uavs"]) == 3
    assert len({tuple(u["airport"]) for u in plan["uavs"]}) == 3
    assert plan["campaign"]["options"]["camera_fov_deg"] == 45.0
    camera = camera_sensor(Camera(45.0), 50.0, 50.0)
    assert SortieLog(load_plan_dir(planned["hiker"])).pc == pytest.approx(camera.pc)  # a flight's posterior reads alike


def test_merging_shortens_the_missions(planned):
    plan = _load(planned["large"] / "plan.json")
    for uav in plan["uavs"]:
        assert len(uav["waypoints"]) < 0.8 * len(uav["trajectory"])
