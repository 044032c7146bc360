"""The search team's segments in a plan's Rerun recording (`gcs plan --area`, plan.rrd), read back
with Rerun's own chunk reader: each segment's outline in the grid view and on the map, coloured by
its POA, its label, and its figures as values, those of plan.json. (A flight's recording:
tests/gcs/flight/test_sortie_segments.py.)"""

from __future__ import annotations

import json

import numpy as np
import pytest

from gcs.cli import main
from gcs.recording.plan import MAP_LUT, read_recording
from tests.gcs.flight.test_sortie_segments import EAST, NORTH, SOUTH, WEST, segments_area


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The square with two segments and the rest of the area, planned and recorded."""
    base = tmp_path_factory.mktemp("segments-recording")
    out = base / "square"
    assert main(["plan", "--area", str(segments_area(base)), "--out", str(out), "--strategy", "exhaustive",
                 "--no-improve", "--bound-time", "0", "--quiet"]) == 0
    return out


def _rgba(colour) -> int:
    r, g, b = (int(c) for c in colour)
    return (r << 24) | (g << 16) | (b << 8) | 255


def test_the_plan_recording_holds_the_segments_and_the_plans_figures(planned):
    rec = read_recording(planned / "plan.rrd")
    figures = json.loads((planned / "plan.json").read_text())["search_theory"]["segments"]
    assert [f["name"] for f in figures] == ["North-west", "East", "rest of the area"]
    values = rec.static["segments"]
    assert values.column("name").to_pylist()[0] == [f["name"] for f in figures]
    for field in ("cells", "poa", "pod", "pos", "cumulative_pod", "poa_after"):
        assert values.column(field).to_pylist()[0] == pytest.approx([f[field] for f in figures], abs=1e-6), field
    labels = rec.static["world/segments/labels"].column("Points2D:labels").to_pylist()[0]
    assert labels == [f"{f['name']}\nPOA {f['poa']:.0%} POD {f['pod']:.0%}" for f in figures]
    outline = rec.static["world/segments"]
    strips, colours = (outline.column(c).to_pylist()[0] for c in ("LineStrips2D:strips", "LineStrips2D:colors"))
    assert len(strips) == len(colours) >= 12
    likeliest = _rgba(MAP_LUT[255])  # yellow: the likeliest segment's edges, and only its
    poa = [f["poa"] for f in figures]
    assert any(c == likeliest for c in colours) and sum(c == likeliest for c in colours) < len(colours)
    assert poa.index(max(poa)) == 0  # North-west: its edges are drawn first
    assert colours[0] == likeliest
    edges = rec.static["geo/segments"].column("GeoLineStrings:line_strings").to_pylist()[0]
    assert len(edges) == len(strips)
    lat_lon = np.array([point for edge in edges for point in edge])
    assert SOUTH - 1e-6 <= lat_lon[:, 0].min() and lat_lon[:, 0].max() <= NORTH + 1e-6
    assert WEST - 1e-6 <= lat_lon[:, 1].min() and lat_lon[:, 1].max() <= EAST + 1e-6


def test_segments_cost_a_few_logs_not_one_per_segment(tmp_path):
    """The paper's 36 blocks: four entities, so the recording grows by tens of KB, not hundreds."""
    import os

    from gcs.plans.options import AreaOptions, SearchOptions
    from gcs.plans.planning import build_area_search
    from gcs.plans.segments import sortie_segments
    from gcs.recording.plan import PlanRecorder
    from tests.areas import PAPER_AREA

    setup = build_area_search(PAPER_AREA, AreaOptions(), SearchOptions(strategy="exhaustive", improve=False))
    search = setup.search
    for _ in search.run():
        pass
    plan = search.plan()
    figures = sortie_segments(setup)
    segments, theory = figures.segments, figures.figures(plan)
    assert len(segments) == 36
    sizes = []
    for k, logged in enumerate((False, True)):
        rec = PlanRecorder(tmp_path / f"{k}.rrd", None, search.scenario, cells_to_lat_lon=setup.area.cells_lonlat)
        rec.open()
        if logged:
            rec.log_segments(segments, theory)
        rec.close()
        sizes.append(os.path.getsize(tmp_path / f"{k}.rrd"))
    assert sizes[1] - sizes[0] < 100_000, sizes
