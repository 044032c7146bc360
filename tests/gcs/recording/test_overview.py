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
