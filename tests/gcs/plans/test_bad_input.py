"""Bad area files and options: one clear error line, exit 2, and no output."""

import json

import pytest


def _fails(run_gcs, doc, match, *extra):
    code, err, out = run_gcs(doc, *extra)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    assert match in lines[0], lines[0]
    assert not out.exists()
    return lines[0]


def test_the_small_area_is_valid(run_gcs, area_doc):
    code, err, out = run_gcs(area_doc)
    assert code == 0, err
    assert (out / "plan.json").exists()


def test_not_json(run_gcs):
    _fails(run_gcs, "{ this is not json", "not JSON")


def test_not_geojson(run_gcs):
    _fails(run_gcs, json.dumps({"type": "Feature", "geometry": None}), "not a GeoJSON FeatureCollection")
    _fails(run_gcs, json.dumps([1, 2, 3]), "not a GeoJSON FeatureCollection")


@pytest.mark.parametrize("properties", ["x", [], 30])
def test_collection_properties_that_are_not_an_object(run_gcs, area_doc, properties):
    area_doc["properties"] = properties
    _fails(run_gcs, area_doc, f"the FeatureCollection's properties must be an object, got {properties!r}")


def test_no_area(run_gcs, area_doc):
    area_doc["features"] = [f for f in area_doc["features"] if f["properties"]["role"] != "area"]
    _fails(run_gcs, area_doc, "no feature with role 'area'")


def test_unknown_role(run_gcs, area_doc):
    area_doc["features"][1]["properties"]["role"] = "nofly"
    _fails(run_gcs, area_doc, "'role' must be one of")


def test_self_intersecting_polygon_says_where(run_gcs, area_doc, shapes):
    bow_tie = shapes.ring([(-300, -300), (300, 300), (300, -300), (-300, 300)])
    area_doc["features"][0]["geometry"]["coordinates"] = [bow_tie]
    _fails(run_gcs, area_doc, "feature 0 (area 'square'): invalid polygon: Self-intersection at lon 8.000000, "
                              "lat 47.000000")


def test_unclosed_ring(run_gcs, area_doc):
    area_doc["features"][1]["geometry"]["coordinates"][0].pop()
    _fails(run_gcs, area_doc, "not closed")


def test_airport_outside_the_area(run_gcs, area_doc, shapes):
    area_doc["features"][3]["geometry"]["coordinates"] = shapes.lonlat([(-400, 0)])[0]
    _fails(run_gcs, area_doc, "airport 'west' (UAV 1) is outside the area")


def test_airport_inside_a_no_fly_zone(run_gcs, area_doc, shapes):
    area_doc["features"][3]["geometry"]["coordinates"] = shapes.lonlat([(60, 60)])[0]
    _fails(run_gcs, area_doc, "airport 'west' (UAV 1) is inside a no-fly zone")


def _short_ranges(area_doc, west_m: float, south_east_m: float) -> None:
    area_doc["features"][3]["properties"]["range_m"] = west_m
    area_doc["features"][4]["properties"].pop("endurance_s")
    area_doc["features"][4]["properties"]["range_m"] = south_east_m


def test_airports_that_cannot_leave_and_return(run_gcs, area_doc):
    """No UAV can fly: the refusal names each with its reason. 50 m does not reach the airport's
    cell and back; 130 m (3 axis steps) flies no loop back to the start cell under 3OC."""
    _short_ranges(area_doc, 50, 130)
    line = _fails(run_gcs, area_doc, "no UAV can leave its airport and come back: UAV 1 ('west'): range 50 m leaves")
    assert "UAV 2 ('south-east'): range 130 m (" in line and "is too short to leave its airport and come back " \
                                                             "under 3OC" in line


@pytest.mark.parametrize("west_m, why", [(50, "cannot leave its airport and come back"),
                                         (130, "too short to leave its airport and come back under 3OC")])
def test_a_uav_that_cannot_leave_its_airport_stays_on_the_ground_and_the_others_are_planned(run_gcs, area_doc,
                                                                                         west_m, why):
    assert run_gcs(area_doc)[0] == 0  # planned with both, into the same folder
    _short_ranges(area_doc, west_m, 3000)
    code, err, out = run_gcs(area_doc)
    assert code == 0, err
    assert err.strip().startswith(f"warning: UAV 1 (west) stays on the ground, planned without it: range {west_m} m")
    assert why in err
    plan = json.loads((out / "plan.json").read_text())
    assert [u["id"] for u in plan["uavs"]] == [2] and len(plan["uavs"][0]["trajectory"]) > 10
    assert [(g["id"], g["name"]) for g in plan["grounded"]] == [(1, "west")] and why in plan["grounded"][0]["reason"]
    assert sorted(path.name for path in out.glob("uav*")) == ["uav2.plan", "uav2.waypoints"]  # UAV 1's old ones gone


def test_too_many_cells(run_gcs, area_doc):
    line = _fails(run_gcs, area_doc, "more than the maximum of 1000000", "--cell-size", "0.5")
    assert "use a cell size of at least" in line


@pytest.mark.parametrize("position, match", [([8.0, 91.0], "latitude 91.0 is out of range"),
                                             ([181.0, 47.0], "longitude 181.0 is out of range"),
                                             (["8", 47.0], "is not a finite number")])
def test_coordinates_out_of_range(run_gcs, area_doc, position, match):
    area_doc["features"][5]["geometry"]["coordinates"] = position
    _fails(run_gcs, area_doc, match)


def test_nan_is_refused(run_gcs, area_doc):
    text = json.dumps(area_doc).replace('"range_m": 3000', '"range_m": NaN')
    assert "NaN" in text
    _fails(run_gcs, text, "NaN")


def test_prior_values_outside_zero_one(run_gcs, area_doc):
    area_doc["features"][2]["properties"]["tep"] = 1.5
    _fails(run_gcs, area_doc, "tep must lie in [0.0, 1.0]")


def test_bad_heading(run_gcs, area_doc):
    area_doc["features"][3]["properties"]["heading"] = "up"
    _fails(run_gcs, area_doc, "heading 'up' is not one of N, NE")


def test_target_outside_the_area(run_gcs, area_doc, shapes):
    area_doc["features"].append(shapes.feature("Point", shapes.lonlat([(500, 500)])[0], role="target", name="far"))
    _fails(run_gcs, area_doc, "target 'far'")


def test_out_must_be_a_folder(run_gcs, area_doc, tmp_path):
    code, err, _ = run_gcs(area_doc, "--out", str(tmp_path / "x.json"))
    assert code == 2 and "give a folder" in err
    assert not (tmp_path / "x.json").exists()


def test_missing_file(tmp_path, capsys):
    from gcs.cli import main
    assert main(["plan", "--area", str(tmp_path / "nope.geojson"), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "cannot read area file" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("option, value, match", [("--cell-size", "-5", "--cell-size must be a positive number"),
                                                  ("--cell-size", "0", "--cell-size must be a positive number"),
                                                  ("--cell-size", "nan", "--cell-size must be a positive number"),
                                                  ("--speed", "0", "--speed must be a positive number"),
                                                  ("--margin", "-1", "margin must be >= 0")])
def test_bad_options(run_gcs, area_doc, option, value, match):
    _fails(run_gcs, area_doc, match, option, value)


def test_both_range_and_endurance(run_gcs, area_doc):
    area_doc["features"][3]["properties"]["endurance_s"] = 100
    _fails(run_gcs, area_doc, "give range_m or endurance_s, not both")


def test_a_plane_approach_through_a_no_fly_zone(run_gcs, area_doc, shapes):
    """The west airport lands eastwards: its approach runs west, outside the square (allowed),
    across a no-fly zone 100-200 m out (refused: no approach of 250 m or more is clear)."""
    area_doc["features"].append(shapes.feature("Polygon", [shapes.ring([(-455, -65), (-355, -65), (-355, 35),
                                                                        (-455, 35)])], role="no_fly", name="mast"))
    line = _fails(run_gcs, area_doc, "airport 'west' (UAV 1): no landing approach of 250 m or more along heading 90 "
                  "degrees is clear of the no-fly zones", "--vehicle", "plane")
    assert "--approach-m" in line
    area_doc["features"].pop()
    assert run_gcs(area_doc, "--vehicle", "plane")[0] == 0  # without the zone, the approach outside the square flies


def test_a_fence_no_autopilot_can_hold_is_refused_saying_what_it_needs(run_gcs):
    """17 square no-fly zones: a square loses no vertex growing outward (its sides are parallel),
    so 68 vertices stay where ArduCopter and PX4 hold 64: refused before anything is written."""
    from tests.peers.site import WILDLAND

    doc = WILDLAND.geojson()
    for k in range(17):
        x, y = -100.0 + 50.0 * (k % 5), -100.0 + 50.0 * (k // 5)
        ring = WILDLAND._ring([(x, y), (x + 10, y), (x + 10, y + 10), (x, y + 10)])
        doc["features"].append({"type": "Feature", "properties": {"role": "no_fly"},
                                "geometry": {"type": "Polygon", "coordinates": [ring]}})
    line = _fails(run_gcs, doc, "does not fit the vehicle's fence storage (ArduCopter and PX4: 64 vertices")
    assert line.endswith("draw the zones with fewer vertices")
