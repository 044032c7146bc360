"""The PNG overview of a plan."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from gcs.display.overview import HEIGHT_PX, WIDTH_PX, draw_overview, uav_colour
from tests.gcs.recording.conftest import RecordedRun


def _near(image: np.ndarray, colour, tolerance: int = 30) -> int:
    return int((np.abs(image - np.array(colour)).sum(axis=-1) < tolerance).sum())


def test_overview_png_shows_every_uav_path_and_the_targets(recorded_run: RecordedRun, tmp_path: Path):
    out = draw_overview(recorded_run.plan, recorded_run.scenario, tmp_path / "nested" / "plan.png")
    assert out == tmp_path / "nested" / "plan.png"
    assert [p.name for p in out.parent.iterdir()] == ["plan.png"]  # no staging file left behind
    image = Image.open(out)
    assert image.size == (WIDTH_PX, HEIGHT_PX)
    rgb = np.asarray(image.convert("RGB"), dtype=np.int64)
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 200
    assert (rgb.sum(axis=-1) < 700).mean() > 0.2  # not a white page
    for i, _ in enumerate(recorded_run.plan.uavs):
        assert _near(rgb, uav_colour(i)) > 200, f"UAV {i + 1}'s path is missing"
    assert _near(rgb, (203, 105, 105)) > 10_000  # the no-fly zones
    found = sum(t.found_step is not None for t in recorded_run.plan.targets)
    missed = len(recorded_run.plan.targets) - found
    assert missed == 0 or _near(rgb, (220, 20, 60)) > 40 * missed  # crimson crosses
    assert found == 0 or _near(rgb, (255, 215, 0)) > 40 * found  # gold stars


def test_overview_differs_between_plans(recorded_run: RecordedRun, tmp_path: Path):
    from planner.dtscs import MissionConfig, fly
    from planner.scenario import paper_scenario

    other_scenario = paper_scenario(11, range_steps=30)
    other = fly(other_scenario, MissionConfig(), seed=11)
    a = np.asarray(Image.open(draw_overview(recorded_run.plan, recorded_run.scenario, tmp_path / "a.png"))
                   .convert("RGB"))
    b = np.asarray(Image.open(draw_overview(other, other_scenario, tmp_path / "b.png")).convert("RGB"))
    assert a.shape == b.shape and (a != b).any(axis=-1).mean() > 0.01


def test_a_later_sortie_hatches_what_earlier_sorties_searched(tmp_path: Path):
    """A campaign's second sortie: the cells the first read are greyed and hatched, the title
    gives the campaign's probability of success before and after."""
    from dataclasses import replace

    from gcs.display.overview import campaign_outcome, hatch_image
    from planner.campaign import Belief, predicted_after
    from planner.dtscs import MissionConfig, fly
    from planner.scenario import paper_scenario

    mask = np.zeros((5, 4), dtype=bool)
    mask[1, 2] = mask[4, 0] = True
    image = hatch_image(mask, 4)
    assert image.shape == (16, 20, 4)
    inked = image[..., 3] > 0
    assert np.array_equal(inked.reshape(4, 4, 5, 4).any(axis=(1, 3)), mask.T)  # exactly the masked cells
    assert len({tuple(p) for p in image[inked]}) == 2  # grey fill and dark lines

    scenario = paper_scenario(5, range_steps=40)
    first = fly(scenario, MissionConfig(np_steps=3), seed=5)
    belief = predicted_after(Belief.prior(scenario.search_map), first, scenario.sensor)
    later = belief.scenario(scenario)
    second = fly(later, MissionConfig(np_steps=3), seed=6)
    assert campaign_outcome(first, scenario) is None
    line = campaign_outcome(second, later)
    assert line.startswith(f"campaign PoS {first.success.share:.1%} -> ")
    left = second.success.available - first.success.expected  # the POS its segments sum to: of what was left
    assert line.endswith(f"(this sortie +{second.success.share:.1%}, {second.success.expected / left:.1%} of what "
                         "earlier sorties left)")
    unread = replace(later, looks_before=np.zeros_like(later.looks_before))  # the same picture but the hatch
    plain = np.asarray(Image.open(draw_overview(second, unread, tmp_path / "a.png")).convert("RGB"), dtype=np.int64)
    hatched = np.asarray(Image.open(draw_overview(second, later, tmp_path / "b.png")).convert("RGB"), dtype=np.int64)
    changed = (np.abs(hatched - plain).sum(axis=-1) > 30).mean()
    read = int((later.looks_before > 0).sum())
    # the map is drawn in at most 0.6 x 0.84 of the figure: at least half of the read cells changed
    assert changed > 0.5 * read / later.search_map.tep.size * 0.6 * 0.84


CAPTION = ("E = 306.22 of a bound 396.36 (77.3%): the most any plan of these airports and ranges could expect "
           "(PoS <= 32.8%; the LP over blocks 17x17)")


def _all_at_once(plan, scenario, path: Path, caption: str | None = None, segments=(), theory=None) -> Path:
    from gcs.display.overview import OverviewPicture, map_layers, plan_layers

    layers = map_layers(scenario, segments)
    picture = OverviewPicture(layers, draw_map=False)
    picture.render(plan_layers(plan, scenario, layers.places, theory))
    picture.finish(caption)
    return picture.save(path)


def test_the_map_drawn_ahead_gives_the_picture_drawn_all_at_once(recorded_run: RecordedRun, tmp_path: Path):
    """The map is drawn before the plan is known, the plan over it and the caption last: the
    same PNG, byte for byte, as drawing everything at once (a first sortie with and without a
    caption, and a later one with the hatch)."""
    from planner.campaign import Belief, predicted_after
    from planner.dtscs import MissionConfig, fly

    cases = [(recorded_run.plan, recorded_run.scenario, CAPTION), (recorded_run.plan, recorded_run.scenario, None)]
    first = cases[0]
    later = predicted_after(Belief.prior(first[1].search_map), first[0], first[1].sensor).scenario(first[1])
    cases.append((fly(later, MissionConfig(np_steps=2), seed=4), later, CAPTION))
    pictures = []
    for k, (plan, scenario, caption) in enumerate(cases):
        ahead = draw_overview(plan, scenario, tmp_path / f"ahead{k}.png", caption).read_bytes()
        assert ahead == _all_at_once(plan, scenario, tmp_path / f"once{k}.png", caption).read_bytes()
        pictures.append(np.asarray(Image.open(tmp_path / f"ahead{k}.png").convert("RGB"), dtype=np.int64))
    inked = np.nonzero((pictures[0] != pictures[1]).any(axis=-1))  # the caption alone
    assert inked[0].min() > 0.91 * HEIGHT_PX and inked[1].min() >= 0.05 * WIDTH_PX - 1  # under the axes, left


def test_the_caption_says_the_bound_or_why_there_is_none():
    """`bound_caption` from plan.json's summary.bound: E of the bound and the share; E alone when
    no bound was asked for or had in time; nothing without expected finds."""
    from gcs.display.overview import bound_caption

    had = {"time_limit_s": 5.0, "finished": True, "model": "blocks", "block": 17, "expected_targets_found_max": 396.36,
           "probability_of_success_max": 0.328133, "share_of_max": 0.772583}
    assert bound_caption(306.2234, had) == CAPTION
    cells = {**had, "model": "headings", "block": 1, "expected_targets_found_max": 2.55, "share_of_max": 0.905882}
    assert bound_caption(2.31, cells).startswith("E = 2.31 of a bound 2.55 (90.6%): ")
    assert bound_caption(2.31, cells).endswith("(PoS <= 32.8%; the LP over headings)")
    late = {"time_limit_s": 0.5, "finished": False, "model": "cells", "block": 1}
    assert bound_caption(2.31, late) == ("E = 2.31 expected finds; no bound: not had within --bound-time 0.5 s "
                                         "(cells model)")
    assert bound_caption(2.31, None) == "E = 2.31 expected finds; no bound asked for (--bound-time 0)"
    assert bound_caption(None, had) is None


def test_the_summarys_bound_line_says_the_captions_bound():
    """`gcs.display.plan_tables.bound_line`, the summary's line, of the same summary.bound: one
    formatter of its figures (`gcs.display.bound_text`) for both."""
    from gcs.display.plan_tables import bound_line

    had = {"time_limit_s": 5.0, "finished": True, "model": "blocks", "block": 17, "expected_targets_found_max": 396.36,
           "probability_of_success_max": 0.328133, "share_of_max": 0.772583}
    assert bound_line(had) == ("bound: at least 77.3% of the most any plan of these airports and ranges could expect "
                               "(E <= 396.36, PoS <= 32.8%; the LP over blocks 17x17)")
    assert bound_line({**had, "model": "headings", "block": 1}).endswith("; the LP over headings)")
    dual = bound_line({**had, "model": "lagrangian", "block": 1})
    assert dual is not None and dual.endswith("; the Lagrangian dual of the LP over headings)")
    late = {"time_limit_s": 0.5, "finished": False, "model": "cells", "block": 1}
    assert bound_line(late) == ("bound: not had within --bound-time 0.5 s (cells model); a longer --bound-time may "
                                "have it")
    assert bound_line(None) is None


def test_gcs_plan_draws_the_bound_plan_json_holds(tmp_path: Path):
    """The picture `gcs plan --area` writes states the bound its plan.json holds (the caption
    drawn once the bound is had, in the pictures helper): the PNG is the one drawn with
    `bound_caption` of plan.json's summary.bound (and the segments with the plan's figures);
    with the bound off, it says so."""
    import json

    from gcs.display.overview import bound_caption
    from gcs.plans.make import plan_area, plan_scenario
    from gcs.plans.options import OutputOptions, SearchOptions
    from gcs.plans.segments import sortie_segments

    output = OutputOptions(record=False, progress=False)
    result = plan_area(Path(__file__).parents[1] / "plans" / "gis" / "caltopo.kml",
                       search=SearchOptions(np_steps=2, improve=False), out=tmp_path / "area", output=output)
    [sortie] = result.sorties
    summary = json.loads((tmp_path / "area" / "plan.json").read_text())["summary"]
    assert summary["bound"]["finished"]
    caption = bound_caption(summary["expected_targets_found"], summary["bound"])
    assert caption is not None and f"of a bound {summary['bound']['expected_targets_found_max']:.2f}" in caption
    scenario = sortie.setup.search.scenario
    figures = sortie_segments(sortie.setup)
    segments, theory = figures.segments, figures.figures(sortie.plan)
    assert sortie.picture.read_bytes() == draw_overview(sortie.plan, scenario, tmp_path / "a.png", caption, segments,
                                                        theory).read_bytes()

    off = plan_scenario("paper", SearchOptions(np_steps=2, range_steps=30), tmp_path / "paper",
                        OutputOptions(record=False, progress=False, bound_time_s=0))
    assert off.bound is None
    caption = bound_caption(off.plan.success.expected, None)
    assert caption.endswith("no bound asked for (--bound-time 0)")
    assert off.picture.read_bytes() == draw_overview(off.plan, off.scenario, tmp_path / "b.png", caption).read_bytes()


def test_the_pictures_helper_is_sent_plain_data(recorded_run: RecordedRun, tmp_path: Path):
    """What the pictures helper is sent, and drawing it, loads neither the planner nor numba; a
    picture renders and finishes once, in that order, and keeps only its PNG."""
    import pickle
    import subprocess
    import sys

    import pytest

    from gcs.display.overview import OverviewPicture, map_layers, plan_layers

    layers = map_layers(recorded_run.scenario), plan_layers(recorded_run.plan, recorded_run.scenario)
    sent = tmp_path / "layers.pickle"
    sent.write_bytes(pickle.dumps(layers))
    script = (f"import pickle, sys; from gcs.display.overview import OverviewPicture; "
              f"m, p = pickle.loads(open({str(sent)!r}, 'rb').read()); o = OverviewPicture(m); o.render(p); "
              f"o.finish('E = 1.00 of a bound 2.00 (50.0%)'); "
              f"print(sorted({{n.split('.')[0] for n in sys.modules}} & {{'planner', 'numba'}}))")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["[]"]
    picture = OverviewPicture(layers[0])
    with pytest.raises(RuntimeError, match="not rendered"):
        picture.save("never.png")
    with pytest.raises(RuntimeError, match="not rendered"):
        picture.finish(None)
    picture.render(layers[1])
    with pytest.raises(RuntimeError, match="not finished"):
        picture.save("never.png")
    with pytest.raises(RuntimeError, match="rendered already"):
        picture.render(layers[1])
    picture.finish(None)
    assert picture.png.startswith(b"\x89PNG")
    with pytest.raises(RuntimeError, match="finished already"):
        picture.finish(None)
    with pytest.raises(RuntimeError, match="rendered already"):
        picture.render(layers[1])


def test_an_area_plan_is_drawn_in_metres_with_its_segments(tmp_path: Path):
    """Over a real area: axes in metres from the grid's corner, a scale bar and a north arrow,
    the segments (those of plan.json: the grid's blocks, or the area file's outlined along cell
    edges) labelled with the POA and POD plan.json gives them, the title wrapped to fit; the map
    drawn ahead still gives the picture drawn all at once."""
    from gcs.display.overview import TITLE_CHARS, map_layers, plan_layers, segment_edges
    from gcs.plans.make import fly_with_progress
    from gcs.plans.options import SearchOptions
    from gcs.plans.planning import build_area_search
    from gcs.plans.segments import sortie_segments
    from tests.gcs.flight.test_sortie_segments import segments_area

    for k, area_file in enumerate([Path(__file__).parents[1] / "plans" / "gis" / "caltopo.kml",
                                   segments_area(tmp_path)]):
        setup = build_area_search(area_file, search=SearchOptions(np_steps=2, strategy="exhaustive"))
        plan = fly_with_progress(setup.search, progress=False)
        scenario = setup.search.scenario
        figures = sortie_segments(setup)
        segments, theory = figures.segments, figures.figures(plan)  # plan.json's
        layers = map_layers(scenario, segments)
        assert layers.cell_m == 30.0
        labels = plan_layers(plan, scenario, layers.places, theory)
        if k == 0:  # no segments in the file: the grid's blocks
            assert [b[0] for b in layers.blocks] == [s.name for s in segments] and layers.outlines is None
            assert [text for *_, text, _ in labels.segments] == [f"{f.name} POA {f.poa:.0%}\nPOD {f.pod:.0%}"
                                                                 for f in theory.segments]
        else:
            assert layers.blocks == ()
            assert np.array_equal(layers.outlines, segment_edges([s.cells for s in segments]))
            assert [text for *_, text, _ in labels.segments] == [f"{f.name}\nPOA {f.poa:.1%}, POD {f.pod:.1%}"
                                                                 for f in theory.segments]
            assert labels.rest_poa == theory.rest_poa > 0
        assert max(len(line) for line in labels.title.splitlines()) <= TITLE_CHARS
        ahead = draw_overview(plan, scenario, tmp_path / "ahead.png", None, segments, theory).read_bytes()
        assert ahead == _all_at_once(plan, scenario, tmp_path / "once.png", None, segments, theory).read_bytes()
        image = np.asarray(Image.open(tmp_path / "ahead.png").convert("RGB")).astype(int)
        assert image[:, :8].min() > 240  # nothing runs off the left edge (the title did)


def test_segment_labels_are_the_plans_figures():
    """`segment_labels`: each segment's name, POA and POD as the plan's figures (plan.json's
    `search_theory`) have them, at its place: a block's north-west corner, a cell inside an
    area file's segment (the one nearest its centroid), none for a segment without a cell;
    places and figures of other segments refused. The area file's segments are outlined along
    cell edges, an edge two share once."""
    import pytest

    from gcs.display.overview import (
        SegmentLabel,
        SegmentPlace,
        mask_outline,
        segment_edges,
        segment_labels,
        segment_place,
    )
    from planner.search_theory import SearchTheory, Segment

    def row(name, cells, poa, pod):
        return {"name": name, "cells": cells, "poa": poa, "pod": pod, "pos": poa * pod, "cumulative_pod": pod,
                "poa_after": poa * (1 - pod)}

    theory = SearchTheory.from_dict({
        "pc": 0.9, "pos": 0.05, "cumulative_pos": 0.05, "rest_of_world_poa": 0.6, "rest_of_world_poa_after": 0.63,
        "inside_area": 0.4, "segments": [row("North-west", 3, 0.28, 0.1234), row("East", 2, 0.12, 0.0351),
                                         row("rest of the area", 0, 0.0, 0.0)]})
    west, east, empty = np.zeros((3, 2, 3), dtype=bool)
    west[0, :] = west[1, 1] = True  # the west column and the middle of the east one
    east[1, 0] = True
    segments = [Segment("North-west", west), Segment("East", east), Segment("rest of the area", empty)]
    places = tuple(segment_place(s) for s in segments)
    assert places == (SegmentPlace("North-west", 1.0, 2.0, True), SegmentPlace("East", 2.0, 1.0, True), None)
    assert segment_labels(places, theory.segments) == (
        SegmentLabel(1.0, 2.0, "North-west\nPOA 28.0%, POD 12.3%", True),
        SegmentLabel(2.0, 1.0, "East\nPOA 12.0%, POD 3.5%", True))
    blocks = (SegmentPlace("A1", 0.6, 10.4), SegmentPlace("A2", 0.6, 5.4), None)
    assert segment_place(Segment("A1", west, (0, 5, 5, 10))) == blocks[0]
    block_rows = [row("A1", 25, 0.28, 0.1234), row("A2", 25, 0.12, 0.0351), row("A3", 0, 0.0, 0.0)]
    block_theory = SearchTheory.from_dict({**theory.as_dict(), "segments": block_rows})
    assert segment_labels(blocks, block_theory.segments) == (
        SegmentLabel(0.6, 10.4, "A1 POA 28%\nPOD 12%"), SegmentLabel(0.6, 5.4, "A2 POA 12%\nPOD 4%"))
    with pytest.raises(ValueError, match="segment 'East''s place paired with 'North-west''s figures"):
        segment_labels((places[1], places[0], places[2]), theory.segments)
    with pytest.raises(ValueError, match="2 segments' places for 3"):
        segment_labels(places[:2], theory.segments)
    edges = segment_edges([west, east])
    assert len(edges) == 12  # 10 + 4 edges, the two west and north of the east segment's cell shared
    assert {tuple(e.ravel()) for e in edges} == {tuple(e.ravel()) for e in (*mask_outline(west), *mask_outline(east))}


def test_gcs_plan_labels_the_area_files_segments_with_plan_json_figures(tmp_path: Path, monkeypatch):
    """`gcs plan --area` of a square with two segments and the rest of the area (an IPP whose
    rings reach past it: the rest of the world holds most of the prior): the picture outlines the
    area file's segments, not the grid's blocks, along the edges of the cells plan.json gives
    them, and labels each, at a cell inside it, with its name and plan.json's POA and POD (the
    rest of the world's POA in the legend). What `plan_layers` and `map_layers` gave the
    pictures helper is what is checked: the labels' pixels are hard to assert."""
    import json

    from gcs.cli import main
    from gcs.display import overview
    from gcs.plans.plan_folder import load_plan_dir
    from gcs.plans.segments import FROM_AREA_FILE, REST, plan_folder_segments
    from tests.gcs.flight.test_sortie_segments import segments_area

    maps, plans = [], []
    map_layers, plan_layers = overview.map_layers, overview.plan_layers
    monkeypatch.setattr(overview, "map_layers", lambda *args: maps.append(map_layers(*args)) or maps[-1])
    monkeypatch.setattr(overview, "plan_layers", lambda *args: plans.append(plan_layers(*args)) or plans[-1])
    out = tmp_path / "square"
    assert main(["plan", "--area", str(segments_area(tmp_path)), "--out", str(out), "--strategy", "exhaustive",
                 "--no-improve", "--bound-time", "0", "--no-rrd", "--quiet"]) == 0
    assert Image.open(out / "plan.png").size == (WIDTH_PX, HEIGHT_PX)
    theory = json.loads((out / "plan.json").read_text())["search_theory"]
    assert theory["segments_from"] == FROM_AREA_FILE and theory["rest_of_world_poa"] > 0.5
    rows = theory["segments"]
    assert [s["name"] for s in rows] == ["North-west", "East", REST]
    [layers], [drawn] = maps, plans
    assert layers.blocks == ()
    segments = plan_folder_segments(load_plan_dir(out), ~layers.no_fly)  # plan.json's, on its grid
    assert np.array_equal(layers.outlines, overview.segment_edges([s.cells for s in segments]))
    assert [p.name for p in layers.places] == [s["name"] for s in rows]
    for place, segment in zip(layers.places, segments):
        assert segment.cells[round(place.x) - 1, round(place.y) - 1]  # its label on a cell inside it
    assert [label.text for label in drawn.segments] == [f"{s['name']}\nPOA {s['poa']:.1%}, POD {s['pod']:.1%}"
                                                        for s in rows]
    assert [(label.x, label.y) for label in drawn.segments] == [(p.x, p.y) for p in layers.places]
    assert round(drawn.rest_poa, 6) == theory["rest_of_world_poa"]
    assert sum(s["poa"] for s in rows) < 0.5  # plan.json's POAs: shares of the whole prior, not the area's


def test_the_title_says_the_settings_in_a_crews_words():
    from gcs.display.overview import settings_text

    area = {"np": 5, "oc": "3OC", "strategy": "cpio", "return_planner": "exact", "reserve_steps": 0,
            "move_costs": {"straight": 1000, "diagonal": 1415},
            "horizon_value": {"weight": 1.0, "length": 0.5, "radius": 5, "every": 1}, "improved": True}
    assert settings_text(area) == ("look-ahead 5 steps, 3OC turns, CPIO, exact return, horizon value w 1 L 0.5, "
                                   "whole-mission improvement")
    steps = {"np": 7, "oc": "5OC", "strategy": "exhaustive", "return_planner": "st", "reserve_steps": 3,
             "move_costs": {"straight": 1, "diagonal": 1}}
    assert settings_text(steps) == ("look-ahead 7 steps, 5OC turns, exhaustive search, ST return, "
                                    "reserve 3 cell sides, a diagonal costs 1 sides")


def test_a_long_legend_is_shrunk_to_fit_the_picture_and_a_short_one_is_not():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from gcs.display.overview import DPI, LEGEND_SIZE, fit_legend

    def legend_of(label: str, uavs: int):
        fig = Figure(figsize=(WIDTH_PX / DPI, HEIGHT_PX / DPI), dpi=DPI)
        FigureCanvasAgg(fig)
        legend = fit_legend(fig, [Line2D([], [], label=label.format(i)) for i in range(1, uavs + 1)])
        return legend, legend.get_window_extent(fig.canvas.get_renderer())

    eight = "UAV {}: 1014 + 3 steps, 28.76 of 28.76 km, eta 100%\n    PoS 0.8%, returned at step 1014: range"
    legend, box = legend_of(eight, 8)
    assert box.x1 <= WIDTH_PX and box.y0 >= 0 and box.y1 <= HEIGHT_PX
    assert legend.get_texts()[0].get_fontsize() < LEGEND_SIZE
    legend, box = legend_of("UAV {}: 90 + 3 steps", 4)
    assert legend.get_texts()[0].get_fontsize() == LEGEND_SIZE
