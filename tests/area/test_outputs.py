"""Output folder handling: atomic publication, winding independence, vehicle types, altitudes."""

import json

import pytest

from gcs.missions.planning import mission_altitudes, write_outputs


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
    assert set(first) == {"plan.json", "paths.geojson", "uav1.waypoints", "uav1.plan", "uav2.waypoints", "uav2.plan",
                          "plan.png", "plan.rrd"}
    code, _, _ = run_gcs(area_doc, "--seed", "5")
    assert code == 0
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert json.loads((out / "plan.json").read_text())["seed"] == 5


def test_a_bad_run_keeps_the_previous_outputs(run_gcs, area_doc):
    assert run_gcs(area_doc)[0] == 0
    out = run_gcs(area_doc)[2]
    before = _snapshot(out)
    area_doc["features"][3]["properties"]["range_m"] = 10
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


def test_plane_missions_end_with_return_to_launch(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc, "--vehicle", "plane")
    assert code == 0, err
    lines = (out / "uav1.waypoints").read_text().splitlines()
    takeoff, last = lines[2].split("\t"), lines[-1].split("\t")
    assert takeoff[3] == "22" and float(takeoff[4]) == 15.0       # NAV_TAKEOFF, minimum pitch
    assert last[3] == "20"                                       # NAV_RETURN_TO_LAUNCH
    plan = json.loads((out / "uav1.plan").read_text())
    assert plan["mission"]["vehicleType"] == 1 and plan["mission"]["items"][-1]["command"] == 20


def test_endurance_and_range_convert_to_conservative_steps(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc, "--speed", "10")
    assert code == 0, err
    uavs = json.loads((out / "plan.json").read_text())["uavs"]
    assert uavs[0]["range_m"] == 3000 and uavs[1]["range_m"] == 2500      # range_m; 250 s at 10 m/s
    for u in uavs:
        assert u["range"] <= u["range_m"] / (30 * 2 ** 0.5)               # every step paid as a diagonal
        assert u["length_m"] <= u["range_m"]


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


def test_default_altitudes_are_distinct_and_skip_explicit_ones():
    assert mission_altitudes([None, None, None], 60, 10) == {1: 60, 2: 70, 3: 80}
    assert mission_altitudes([None, 70, None], 60, 10) == {1: 60, 2: 70, 3: 80}
    assert mission_altitudes([100, None, None, None], 60, 20) == {1: 100, 2: 60, 3: 80, 4: 120}
    with pytest.raises(ValueError):
        mission_altitudes([None, None], 10, -20)


def test_the_documented_example_plans(run_gcs):
    from pathlib import Path
    text = (Path(__file__).resolve().parents[2] / "docs" / "areas.md").read_text()
    block = text.split("```json\n", 1)[1].split("```", 1)[0]
    code, err, out = run_gcs(block)
    assert code == 0, err
    plan = json.loads((out / "plan.json").read_text())
    assert [u["name"] for u in plan["uavs"]] == ["west", "south-east"]
    assert [u["altitude_m"] for u in plan["uavs"]] == [60, 80]
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
