"""POA / POD / POS per segment in an area plan's outputs: plan.json's `search_theory` agrees with
the plan's probability of success, the second sortie of a campaign starts from the POAs the
first leaves, and the map files carry the figures (segments.geojson, segments.kml)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import shape

from gcs.display.plan_tables import area_report
from gcs.plans.make import plan_area
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions
from gcs.plans.plan_file import validate_plan_dict
from gcs.plans.planning import build_area_search
from gcs.plans.segments import REST, area_segments, segments_geojson, theory_of_looks

AREA = Path(__file__).parent / "gis" / "caltopo.kml"


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("segments")
    result = plan_area(AREA, AreaOptions(), SearchOptions(seed=1, improve=False), out,
                       OutputOptions(record=False, progress=False),
                       sorties=2)
    return out, result


def test_the_segments_add_up_to_the_plans_probability_of_success(campaign) -> None:
    out, _ = campaign
    first = json.loads((out / "sortie1" / "plan.json").read_text())
    validate_plan_dict(first)
    theory = first["search_theory"]
    segments = theory["segments"]
    assert sum(s["poa"] for s in segments) == pytest.approx(1.0, abs=1e-5)
    assert sum(s["pos"] for s in segments) == pytest.approx(first["summary"]["probability_of_success"], abs=1e-5)
    assert theory["pos"] == theory["cumulative_pos"]
    assert any(s["pod"] == 0 for s in segments) and any(s["pod"] > 0.5 for s in segments)
    for s in segments:
        assert s["pos"] == pytest.approx(s["poa"] * s["pod"], abs=2e-6)
    assert segments[0]["name"] == "A1"


def test_the_next_sortie_starts_from_the_shifted_poas(campaign) -> None:
    out, _ = campaign
    first, second = (json.loads((out / f"sortie{k}" / "plan.json").read_text())["search_theory"] for k in (1, 2))
    after = {s["name"]: s["poa_after"] for s in first["segments"]}
    for s in second["segments"]:
        assert s["poa"] == pytest.approx(after[s["name"]], abs=2e-6)
        assert s["cumulative_pod"] >= s["pod"] - 1e-9
    assert second["cumulative_pos"] > first["cumulative_pos"]


def test_the_map_files_and_the_summary_carry_the_figures(campaign) -> None:
    out, result = campaign
    geo = json.loads((out / "sortie1" / "segments.geojson").read_text())
    theory = json.loads((out / "sortie1" / "plan.json").read_text())["search_theory"]
    assert [f["properties"]["segment"] for f in geo["features"]] == [s["name"] for s in theory["segments"]]
    a1 = geo["features"][0]
    assert a1["geometry"]["type"] in ("Polygon", "MultiPolygon")
    assert a1["properties"]["poa_pct"] == pytest.approx(100 * theory["segments"][0]["poa"], abs=0.01)
    kml = (out / "sortie1" / "segments.kml").read_text()
    assert kml.count("<Placemark") == len(geo["features"]) and kml.count("<Polygon>") == len(geo["features"])
    assert '<SimpleData name="pod_pct">' in kml and "POA after an unsuccessful sortie" in kml
    report = area_report(result)
    assert "segment  cells    POA    POD    POS cum POD POA after" in report
    assert f"POS this sortie {theory['pos']:.1%}" in report


def test_the_area_files_own_segments_are_the_ones_reported(tmp_path) -> None:
    """Segments drawn in the area file (west 70 %, east 30 %) replace the grid's blocks."""
    west, east, south, north = 7.996056, 8.003944, 46.997301, 47.002698
    middle = (west + east) / 2

    def box(w, s, e, n):
        return {"type": "Polygon", "coordinates": [[[w, s], [e, s], [e, n], [w, n], [w, s]]]}

    doc = {"type": "FeatureCollection", "properties": {"cell_size_m": 30}, "features": [
        {"type": "Feature", "properties": {"role": "area", "name": "square"},
         "geometry": box(west, south, east, north)},
        {"type": "Feature", "properties": {"role": "segment", "name": "West", "poa": 70},
         "geometry": box(west, south, middle, north)},
        {"type": "Feature", "properties": {"role": "segment", "name": "East", "poa": 30},
         "geometry": box(middle, south, east, north)},
        {"type": "Feature", "properties": {"role": "airport", "name": "a", "heading": "E", "range_m": 1500},
         "geometry": {"type": "Point", "coordinates": [7.996647, 46.999865]}}]}
    area = tmp_path / "segments.geojson"
    area.write_text(json.dumps(doc))
    plan_area(area, AreaOptions(), SearchOptions(np_steps=2, strategy="exhaustive", improve=False), tmp_path / "out",
              OutputOptions(record=False, progress=False))
    theory = json.loads((tmp_path / "out" / "plan.json").read_text())["search_theory"]
    poa = {s["name"]: s["poa"] for s in theory["segments"]}
    assert set(poa) == {"West", "East"} and poa["West"] == pytest.approx(0.7, abs=1e-3)
    kml = (tmp_path / "out" / "segments.kml").read_text()
    assert kml.count("<Polygon>") == 2 and "<name>West POA 70.0%" in kml


def test_the_team_map_pairs_each_segment_with_its_own_polygon(tmp_path) -> None:
    """segments.geojson gives the k-th segment the area file's k-th polygon, whatever their names
    (the reader refuses two of one name, but the map does not lean on it)."""
    west, east, south, north = 7.996056, 8.003944, 46.997301, 47.002698
    third = west + (east - west) / 3

    def box(w, s, e, n):
        return {"type": "Polygon", "coordinates": [[[w, s], [e, s], [e, n], [w, n], [w, s]]]}

    doc = {"type": "FeatureCollection", "properties": {"cell_size_m": 30}, "features": [
        {"type": "Feature", "properties": {"role": "area"}, "geometry": box(west, south, east, north)},
        {"type": "Feature", "properties": {"role": "segment", "name": "A", "poa": 70},
         "geometry": box(west, south, third, north)},
        {"type": "Feature", "properties": {"role": "segment", "name": "B", "poa": 30},
         "geometry": box(third, south, 2 * third - west, north)},
        {"type": "Feature", "properties": {"role": "airport", "heading": "E", "range_m": 1500},
         "geometry": {"type": "Point", "coordinates": [7.996647, 46.999865]}}]}
    path = tmp_path / "area.geojson"
    path.write_text(json.dumps(doc))
    setup = build_area_search(path, AreaOptions(), SearchOptions(strategy="exhaustive"))
    a, b = setup.source.segments
    source = dataclasses.replace(setup.source, segments=(a, dataclasses.replace(b, name="A")))
    segments = area_segments(setup.area, source)
    assert [s.name for s in segments] == ["A", "A", REST]
    free = setup.area.free
    theory = theory_of_looks(free.astype(float), free, 0.8, np.zeros(free.shape), segments, np.zeros(free.shape))
    features = segments_geojson(setup.area, segments, theory, "area", source)["features"]
    assert shape(features[0]["geometry"]).equals(a.geometry) and shape(features[1]["geometry"]).equals(b.geometry)
    assert features[2]["geometry"] is None
