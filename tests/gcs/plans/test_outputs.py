"""Output folder handling: atomic publication, winding independence, vehicle types, altitudes."""

import json
import math

import pytest

from gcs.plans.planning import altitude_layers, write_outputs


def _snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_a_failure_while_writing_leaves_the_folder_untouched(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "plan.json").write_text("old plan\n")
    (out / "uav1.waypoints").write_text("old mission\n")
    before = _snapshot(out)
    files = {"plan.json": "new plan\n", "uav1.waypoints": "new\n", "uav2.waypoints": "bad \udc80 text\n",
             "uav3.waypoints": "never written\n"}
    with pytest.raises(UnicodeEncodeError):
        write_outputs(out, files)
    assert _snapshot(out) == before


def test_a_failure_leaves_no_new_folder_behind(tmp_path):
    out = tmp_path / "new" / "out"
    with pytest.raises(UnicodeEncodeError):
        write_outputs(out, {"plan.json": "ok\n", "paths.geojson": "\udc80"})
    assert not out.exists()


def test_a_successful_run_replaces_old_files(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc)
    assert code == 0, err
    first = _snapshot(out)
    assert set(first) == {"plan.json", "paths.geojson", "paths.kml", "paths.gpx", "uav1.waypoints", "uav1.plan",
                          "uav2.waypoints", "uav2.plan", "plan.png", "plan.rrd", "belief.json", "segments.geojson",
                          "segments.kml"}
    code, _, _ = run_gcs(area_doc, "--seed", "5")
    assert code == 0
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert json.loads((out / "plan.json").read_text())["seed"] == 5


def test_a_bad_run_keeps_the_previous_outputs(run_gcs, area_doc):
    assert run_gcs(area_doc)[0] == 0
    out = run_gcs(area_doc)[2]
    before = _snapshot(out)
    area_doc["features"][3]["properties"]["range_m"] = 10  # no UAV can leave its airport
    area_doc["features"][4]["properties"]["endurance_s"] = 1
    assert run_gcs(area_doc)[0] == 2
    assert _snapshot(out) == before


def test_ring_winding_does_not_matter(run_gcs, area_doc):
    assert run_gcs(area_doc)[0] == 0
    out = run_gcs(area_doc)[2]
    ccw = json.loads((out / "plan.json").read_text())
    for f in area_doc["features"]:
        if f["geometry"]["type"] == "Polygon":
            f["geometry"]["coordinates"] = [r[::-1] for r in f["geometry"]["coordinates"]]
    assert run_gcs(area_doc)[0] == 0
    cw = json.loads((out / "plan.json").read_text())
    assert cw["grid"] == ccw["grid"] and cw["uavs"] == ccw["uavs"]


def test_plane_missions_land_on_the_runway_after_an_approach_lined_up_with_it(run_gcs, area_doc, shapes):
    airports = [f for f in area_doc["features"] if f["properties"]["role"] == "airport"]
    airports[0]["properties"]["heading"] = "W"   # lands westwards: the approach comes from the east, inside
    airports[1]["properties"]["heading"] = "N"   # lands northwards: the approach comes from the south... outside
    airports[1]["geometry"]["coordinates"] = shapes.lonlat([(255, -15)])[0]  # so it moves north, where there is room
    code, err, out = run_gcs(area_doc, "--vehicle", "plane", "--approach-m", "400", "--approach-alt", "35",
                             "--speed", "20")
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    for uav, bearing in zip(plan["uavs"], (270.0, 0.0)):
        lines = (out / f"uav{uav['id']}.waypoints").read_text().splitlines()
        takeoff = lines[2].split("\t")
        assert takeoff[3] == "22" and float(takeoff[4]) == 15.0       # NAV_TAKEOFF, climb pitch
        land_start, approach, land = (line.split("\t") for line in lines[-3:])
        assert [land_start[3], approach[3], land[3]] == ["189", "16", "21"]
        assert float(land[10]) == 0.0
        airport = shapes.frame.geodetic2local(*uav["airport_lat_lon"])
        point = shapes.frame.geodetic2local(float(approach[8]), float(approach[9]))
        east, north = float(point[0] - airport[0]), float(point[1] - airport[1])
        distance = (east ** 2 + north ** 2) ** 0.5
        assert 250.0 - 1e-3 <= distance <= 400.0 + 1e-3
        behind = (bearing + 180.0) % 360.0  # the approach lies behind the airport on the runway axis
        assert abs((math.degrees(math.atan2(east, north)) - behind + 180.0) % 360.0 - 180.0) < 0.01, (east, north)
        # at --approach-alt, or lower only as far as a glide no steeper than PX4's FW_LND_ANG (5 degrees) needs
        alt = float(approach[10])
        glide = round(math.degrees(math.atan2(alt, distance)), 1)
        assert alt <= 35.0 and glide <= 5.0 and (alt == 35.0 or glide >= 4.9), (alt, distance)
        assert uav["approach"]["alt_m"] == alt and uav["length_m"] <= uav["range_m"]
    qgc = json.loads((out / "uav1.plan").read_text())
    assert qgc["mission"]["vehicleType"] == 1 and [i["command"] for i in qgc["mission"]["items"][-3:]] == [189, 16, 21]


def test_a_shortened_approach_glides_no_steeper_than_px4_accepts(run_gcs, area_doc, shapes):
    """An approach shortened to 250 m from 30 m would glide at 6.8 degrees, which PX4 refuses
    (FW_LND_ANG 5; `tests/sim/test_px4_vehicle.py` holds our model of that refusal): it starts lower."""
    from gcs.missions.approach import ApproachOptions

    assert ApproachOptions().alt_for(500.0) == 30.0 and ApproachOptions(alt_m=35.0).alt_for(400.0) == 35.0
    assert ApproachOptions().alt_for(250.0) == 21.8  # 250 m x tan 5 degrees = 21.87 m
    airports = [f for f in area_doc["features"] if f["properties"]["role"] == "airport"]
    airports[0]["properties"]["heading"] = "W"
    airports[1]["properties"]["heading"] = "N"
    airports[1]["geometry"]["coordinates"] = shapes.lonlat([(255, -15)])[0]
    code, err, out = run_gcs(area_doc, "--vehicle", "plane", "--approach-m", "250", "--speed", "20")
    assert code == 0, err
    for uav in json.loads((out / "plan.json").read_text())["uavs"]:
        assert uav["approach"]["alt_m"] == 21.8
        approach = (out / f"uav{uav['id']}.waypoints").read_text().splitlines()[-2].split("\t")
        assert float(approach[10]) == 21.8


def test_a_plane_lands_from_outside_the_area_inside_a_fence_that_covers_its_approach(run_gcs, area_doc):
    """Both airports face out of the 600 m square: their approaches lie outside it. The search stays
    inside; the fence each UAV's .plan carries (and `gcs fly` uploads) is one simple polygon, the
    square joined with the corridor of its landing."""
    from shapely.geometry import LineString, Point, Polygon

    from gcs.plans.plan_folder import load_plan_dir

    code, err, out = run_gcs(area_doc, "--vehicle", "plane", "--speed", "20")
    assert code == 0, err
    fleet = load_plan_dir(out)
    square = Polygon([(-300, -300), (300, -300), (300, 300), (-300, 300)])
    box = Polygon([(0, 0), (120, 0), (120, 120), (0, 120)])
    for uav in json.loads((out / "plan.json").read_text())["uavs"]:
        task = fleet.uavs[uav["id"]]
        local = [fleet.local_m(lat, lon) for lat, lon in task.waypoints]
        airport, point = fleet.local_m(*uav["airport_lat_lon"]), fleet.local_m(*uav["approach"]["lat_lon"])
        assert math.dist(airport, point) == pytest.approx(500.0, abs=1e-3)  # the full --approach-m
        assert square.distance(Point(point)) > 400.0
        assert all(square.buffer(0.01).covers(Point(p)) for p in local)  # the search stays inside
        qgc = json.loads((out / f"uav{uav['id']}.plan").read_text())["geoFence"]["polygons"]
        assert [p["inclusion"] for p in qgc] == [True, False]
        assert task.fence == [(p["inclusion"], [tuple(v) for v in p["polygon"]]) for p in qgc]  # what is uploaded
        assert len(task.fence_wire()) == sum(len(p["polygon"]) for p in qgc) <= 4 + 12 + 4
        inclusion = Polygon([fleet.local_m(*v) for v in qgc[0]["polygon"]])
        assert inclusion.is_valid and inclusion.covers(square.buffer(-0.01))
        for leg in ([local[-1], point], [point, airport]):  # from the last waypoint (or over the airport)
            assert inclusion.covers(LineString(leg).buffer(149.0, cap_style="square"))
        assert Polygon([fleet.local_m(*v) for v in qgc[1]["polygon"]]).hausdorff_distance(box) < 0.1


def test_ranges_in_metres_are_spent_by_length(run_gcs, area_doc):
    """range_m and endurance_s x speed are metres; each step is charged its length (a diagonal
    sqrt 2 cells), so the mission path uses the range to within the last step or two, never more."""
    code, err, out = run_gcs(area_doc, "--speed", "10")
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert plan["settings"]["move_costs"] == {"straight": 1000, "diagonal": 1415}
    uavs = plan["uavs"]
    assert uavs[0]["range_m"] == 3000 and uavs[1]["range_m"] == 2500      # range_m; 250 s at 10 m/s
    for u in uavs:
        cell_m = plan["grid"]["georef"]["cell_size_m"]
        steps = u["trajectory"]
        grid_m = sum(cell_m * (2 ** 0.5 if p["heading"] % 2 else 1.0) for p in steps[1:])
        assert u["length_m"] <= u["range_used_m"] + 0.01 <= u["range_m"] + 0.01
        assert 0 <= u["range_used_m"] - u["length_m"] <= 0.00057 * u["range_m"]  # diagonals rounded up, 1415
        assert grid_m <= u["range"] * cell_m / 1000 + 1e-6 and u["eta"] == pytest.approx(
            sum(1415 if p["heading"] % 2 else 1000 for p in steps[1:]) / u["range"], abs=1e-6)
        assert u["range_used_m"] >= 0.97 * u["range_m"] - 2 * 1.415 * cell_m


def test_cell_size_option_overrides_the_file(run_gcs, area_doc):
    code, _, out = run_gcs(area_doc, "--cell-size", "20")
    assert code == 0
    grid = json.loads((out / "plan.json").read_text())["grid"]
    assert (grid["nx"], grid["ny"], grid["georef"]["cell_size_m"]) == (30, 30, 20.0)


def test_margin_blocks_cells_near_no_fly_zones(run_gcs, area_doc):
    plain = json.loads((run_gcs(area_doc)[2] / "plan.json").read_text())["grid"]["no_fly"]
    code, _, out = run_gcs(area_doc, "--margin", "20")
    assert code == 0
    assert len(json.loads((out / "plan.json").read_text())["grid"]["no_fly"]) > len(plain)


def test_altitude_layers_are_distinct_skip_explicit_ones_and_stay_under_the_ceiling():
    layers = altitude_layers([None, None, None], 50, 10, 120)
    assert layers.altitudes_m == {1: 50, 2: 60, 3: 70} and layers.layer == {1: 1, 2: 2, 3: 3} and not layers.shared
    assert altitude_layers([None, 60, None], 50, 10, 120).altitudes_m == {1: 50, 2: 60, 3: 70}
    assert altitude_layers([None, 60, None], 50, 10, 120).layer == {1: 1, 2: None, 3: 2}
    assert altitude_layers([100, None, None, None], 60, 20, 120).altitudes_m == {1: 100, 2: 60, 3: 80, 4: 120}
    crowded = altitude_layers([None] * 10, 50, 10, 120)  # 8 layers for 10 UAVs: two are shared
    assert max(crowded.altitudes_m.values()) <= 120 and crowded.levels_m == (50, 60, 70, 80, 90, 100, 110, 120)
    assert crowded.shared == {1: [1, 9], 2: [2, 10]}
    for bad in (([None], 10, -20, 120), ([None], 130, 10, 120), ([None], 0, 10, 120), ([121], 50, 10, 120)):
        with pytest.raises(ValueError):
            altitude_layers(*bad)


def test_a_ceiling_too_low_for_the_layers_is_one_line(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc, "--ceiling", "40")
    assert code == 2 and "--ceiling 40 m is below the lowest layer" in err and not out.exists()


def test_the_documented_example_plans(run_gcs):
    from pathlib import Path
    text = (Path(__file__).resolve().parents[3] / "docs" / "areas.md").read_text()
    block = text.split("```json\n", 1)[1].split("```", 1)[0]
    code, err, out = run_gcs(block)
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert [u["name"] for u in plan["uavs"]] == ["west", "south-east"]
    assert [u["altitude_m"] for u in plan["uavs"]] == [50, 80]
    assert [u["altitude_layer"] for u in plan["uavs"]] == [1, None]
    assert [u["elevation_m"] for u in plan["uavs"]] == [None, 437]
    qgc = json.loads((out / "uav2.plan").read_text())["mission"]
    assert qgc["plannedHomePosition"] == [*plan["uavs"][1]["airport_lat_lon"], 437]
    assert plan["grid"]["georef"]["cell_size_m"] == 30
    assert plan["targets"] and plan["targets"][0]["x"] <= 10


def test_wpl_text_reads_back_item_by_item(run_gcs, area_doc):
    from gcs.missions import MavCmd, parse_wpl
    code, _, out = run_gcs(area_doc)
    assert code == 0
    plan = json.loads((out / "plan.json").read_text())["uavs"][0]
    items = parse_wpl((out / "uav1.waypoints").read_text())
    assert [i.command for i in items] == [MavCmd.NAV_WAYPOINT, MavCmd.NAV_TAKEOFF] + \
        [MavCmd.NAV_WAYPOINT] * len(plan["waypoints"]) + [MavCmd.NAV_LAND]
    assert [[i.lat_deg, i.lon_deg] for i in items[2:-1]] == plan["waypoints"]
    with pytest.raises(ValueError):
        parse_wpl("QGC WPL 120\n")


def test_terrain_following_missions_use_the_terrain_frame_in_files_and_on_the_wire(run_gcs, area_doc):
    from gcs.autopilots import Autopilot
    from gcs.missions import parse_wpl
    from gcs.plans.plan_folder import load_plan_dir

    code, err, out = run_gcs(area_doc, "--terrain-follow")
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert {u["altitude_reference"] for u in plan["uavs"]} == {"terrain"}
    items = parse_wpl((out / "uav1.waypoints").read_text())
    assert [int(i.frame) for i in items[2:-1]] == [10] * (len(items) - 3)  # waypoints above the ground
    assert (int(items[1].frame), int(items[-1].frame)) == (3, 3)  # take-off and landing above home
    qgc = json.loads((out / "uav1.plan").read_text())["mission"]
    assert qgc["globalPlanAltitudeMode"] == 0
    assert [i["AltitudeMode"] for i in qgc["items"]] == [1] + [4] * (len(qgc["items"]) - 2) + [1]
    wire = load_plan_dir(out).uavs[1].mission_wire(Autopilot.ARDUPILOT)
    assert [w.frame for w in wire[2:-1]] == [11] * (len(wire) - 3)  # MAV_FRAME_GLOBAL_TERRAIN_ALT_INT


def test_qgc_speeds_are_whole_numbers_other_stations_can_import(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc, "--speed", "12.4")
    assert code == 0, err
    text = (out / "uav1.plan").read_text()
    mission = json.loads(text)["mission"]
    assert mission["cruiseSpeed"] == 12 and isinstance(mission["cruiseSpeed"], int)
    assert mission["hoverSpeed"] == 12 and '"cruiseSpeed": 12,' in text
