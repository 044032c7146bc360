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
    unread = replace(later, looks_before=np.zeros_like(later.looks_before))  # the same picture but the hatch
    plain = np.asarray(Image.open(draw_overview(second, unread, tmp_path / "a.png")).convert("RGB"), dtype=np.int64)
    hatched = np.asarray(Image.open(draw_overview(second, later, tmp_path / "b.png")).convert("RGB"), dtype=np.int64)
    changed = (np.abs(hatched - plain).sum(axis=-1) > 30).mean()
    read = int((later.looks_before > 0).sum())
    # the map is drawn in at most 0.6 x 0.84 of the figure: at least half of the read cells changed
    assert changed > 0.5 * read / later.search_map.tep.size * 0.6 * 0.84


def _all_at_once(plan, scenario, path: Path) -> Path:
    from gcs.display.overview import OverviewPicture, map_layers, plan_layers

    picture = OverviewPicture(map_layers(scenario), draw_map=False)
    picture.render(plan_layers(plan, scenario))
    return picture.save(path)


def test_the_map_drawn_ahead_gives_the_picture_drawn_all_at_once(recorded_run: RecordedRun, tmp_path: Path):
    """The map is drawn before the plan is known and the plan over it: the same PNG, byte for
    byte, as drawing everything at once (a first sortie, and a later one with the hatch)."""
    from planner.campaign import Belief, predicted_after
    from planner.dtscs import MissionConfig, fly

    cases = [(recorded_run.plan, recorded_run.scenario)]
    first = cases[0]
    later = predicted_after(Belief.prior(first[1].search_map), first[0], first[1].sensor).scenario(first[1])
    cases.append((fly(later, MissionConfig(np_steps=2), seed=4), later))
    for k, (plan, scenario) in enumerate(cases):
        ahead = draw_overview(plan, scenario, tmp_path / f"ahead{k}.png").read_bytes()
        assert ahead == _all_at_once(plan, scenario, tmp_path / f"once{k}.png").read_bytes()


def test_the_pictures_helper_is_sent_plain_data(recorded_run: RecordedRun, tmp_path: Path):
    """What the pictures helper is sent, and drawing it, loads neither the planner nor numba; a
    picture renders once and keeps only its PNG."""
    import pickle
    import subprocess
    import sys

    import pytest

    from gcs.display.overview import OverviewPicture, map_layers, plan_layers

    layers = map_layers(recorded_run.scenario), plan_layers(recorded_run.plan, recorded_run.scenario)
    sent = tmp_path / "layers.pickle"
    sent.write_bytes(pickle.dumps(layers))
    script = (f"import pickle, sys; from gcs.display.overview import OverviewPicture; "
              f"m, p = pickle.loads(open({str(sent)!r}, 'rb').read()); OverviewPicture(m).render(p); "
              f"print(sorted({{n.split('.')[0] for n in sys.modules}} & {{'planner', 'numba'}}))")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["[]"]
    picture = OverviewPicture(layers[0])
    with pytest.raises(RuntimeError, match="not rendered"):
        picture.save("never.png")
    picture.render(layers[1])
    assert picture.png.startswith(b"\x89PNG")
    with pytest.raises(RuntimeError, match="rendered already"):
        picture.render(layers[1])


def test_an_area_plan_is_drawn_in_metres_with_its_segments(tmp_path: Path):
    """Over a real area: axes in metres from the grid's corner, a scale bar and a north arrow,
    the segments (those of plan.json) labelled with their POA and POD, the title wrapped to fit;
    the map drawn ahead still gives the picture drawn all at once."""
    from gcs.display.overview import TITLE_CHARS, map_layers, plan_layers
    from gcs.plans.make import fly_with_progress
    from gcs.plans.options import SearchOptions
    from gcs.plans.planning import build_area_search
    from gcs.plans.segments import area_segments, plan_theory

    setup = build_area_search(Path(__file__).parents[1] / "plans" / "gis" / "caltopo.kml",
                              search=SearchOptions(np_steps=2, strategy="exhaustive"))
    plan = fly_with_progress(setup.search, progress=False)
    scenario = setup.search.scenario
    layers = map_layers(scenario)
    assert layers.cell_m == 30.0
    segments = area_segments(setup.area)
    assert [b[0] for b in layers.blocks] == [s.name for s in segments]
    labels = plan_layers(plan, scenario)
    theory = plan_theory(setup, plan, segments)
    assert [text for *_, text in labels.segments] == [f"{f.name} POA {f.poa:.0%}\nPOD {f.pod:.0%}"
                                                      for f in theory.segments]
    assert max(len(line) for line in labels.title.splitlines()) <= TITLE_CHARS
    ahead = draw_overview(plan, scenario, tmp_path / "ahead.png").read_bytes()
    assert ahead == _all_at_once(plan, scenario, tmp_path / "once.png").read_bytes()
    image = np.asarray(Image.open(tmp_path / "ahead.png").convert("RGB")).astype(int)
    assert image[:, :8].min() > 240  # nothing runs off the left edge (the title did)
