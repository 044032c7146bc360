"""`gcs plan --area X --sorties N`: an area too big for one sortie, split into closed sorties, each
planned from the belief the one before is predicted to leave; and the campaign section every
area plan carries."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gcs.cli import main
from gcs.plans.belief_file import file_sha256, validate_belief_dict
from gcs.plans.plan_file import validate_plan_dict
from planner.success import expected_finds
from tests.gcs.plans.conftest import small_area


def _json(path):
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture
def area(tmp_path):
    path = tmp_path / "area.geojson"
    doc = small_area()
    for f in doc["features"]:  # short flights: the square takes several sorties
        if f["properties"]["role"] == "airport":
            f["properties"].pop("endurance_s", None)
            f["properties"]["range_m"] = 900
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_an_area_plan_is_sortie_one_of_its_campaign(area, tmp_path):
    out = tmp_path / "one"
    assert main(["plan", "--area", str(area), "--out", str(out), "--no-rrd", "--quiet", "--seed", "4"]) == 0
    plan = _json(out / "plan.json")
    validate_plan_dict(plan)
    c = plan["campaign"]
    assert c["sortie"] == 1 and c["belief"] == "prior" and c["seed"] == 4 and plan["seed"] == 4
    assert c["area"] == {"file": str(area.resolve()), "sha256": file_sha256(area)}
    assert c["options"]["seed"] == 4 and c["options"]["pc"] == 0.9 and "out" not in c["options"]
    assert c["expected_before"] == 0 and c["pos_after"] == pytest.approx(plan["summary"]["probability_of_success"])
    belief = _json(out / "belief.json")
    validate_belief_dict(belief)
    assert belief["source"] == "prior" and belief["tep"] == belief["p0"] and not np.any(belief["looks"])


def test_sorties_are_each_closed_and_add_up_to_the_campaign(area, tmp_path, capsys):
    out = tmp_path / "split"
    assert main(["plan", "--area", str(area), "--sorties", "3", "--out", str(out), "--no-rrd"]) == 0
    printed = capsys.readouterr().out
    campaign = _json(out / "campaign.json")
    rows = campaign["sorties"]
    assert [(r["sortie"], r["status"], r["belief"]) for r in rows] == \
        [(1, "planned", "prior"), (2, "planned", "predicted"), (3, "planned", "predicted")]
    cumulative = 0.0
    looks_so_far = None
    for k, row in enumerate(rows, start=1):
        folder = out / f"sortie{k}"
        plan, belief = _json(folder / "plan.json"), _json(folder / "belief.json")
        validate_plan_dict(plan)
        validate_belief_dict(belief)
        assert plan["campaign"]["sorties"] == rows[:k]
        for u in plan["uavs"]:  # closed: home within range, every sortie on a fresh battery
            t = u["trajectory"]
            assert (t[0]["x"], t[0]["y"]) == (t[-1]["x"], t[-1]["y"]) == tuple(u["airport"])
            assert len(t) - 1 <= u["range"] == _json(out / "sortie1" / "plan.json")["uavs"][u["id"] - 1]["range"]
            assert all(max(abs(a["x"] - b["x"]), abs(a["y"] - b["y"])) == 1 for a, b in zip(t, t[1:]))
        no_fly = {tuple(c) for c in plan["grid"]["no_fly"]}
        assert not any((p["x"], p["y"]) in no_fly for u in plan["uavs"] for p in u["trajectory"])
        cumulative += row["expected_targets_found"]
        assert row["cumulative_expected"] == pytest.approx(cumulative, abs=1e-5)
        p0, looks = np.asarray(belief["p0"]), np.asarray(belief["looks"])
        searchable = np.ones(p0.shape, dtype=bool)
        for x, y in no_fly:
            searchable[x - 1, y - 1] = False
        expected_before = expected_finds(p0, searchable, 0.9, looks)
        assert plan["campaign"]["expected_before"] == pytest.approx(expected_before, abs=1e-5)
        if looks_so_far is not None:  # the planned looks of the sortie before, reporting nothing
            assert np.all(looks >= looks_so_far) and looks.sum() > looks_so_far.sum()
            read = looks > 0
            assert np.all(np.asarray(belief["tep"])[read] <= p0[read] + 1e-12)
        looks_so_far = looks
        assert (folder / "plan.png").exists()
    assert [r["cumulative_pos"] for r in rows] == sorted(r["cumulative_pos"] for r in rows)
    assert rows[-1]["cumulative_pos"] > rows[0]["cumulative_pos"]
    assert campaign["pos"] == rows[-1]["cumulative_pos"]
    assert "campaign: the prior puts" in printed and printed.count("-- sortie ") == 3


@pytest.mark.parametrize("args, message", [
    (["--sorties", "0"], "--sorties must be 1..100"),
    (["--sorties", "two"], "invalid int value"),
    (["--scenario", "paper", "--sorties", "2", "--area", None], "--sorties needs --area"),
])
def test_bad_sorties_are_one_line_and_write_nothing(area, tmp_path, capsys, args, message):
    out = tmp_path / "out"
    words = ["plan", "--area", str(area), *args] if None not in args else ["plan", *args[:-2]]
    assert main([*words, "--out", str(out), "--no-rrd"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0], err
    assert not out.exists()
