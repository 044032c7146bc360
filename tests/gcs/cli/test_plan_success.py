"""What `gcs plan` says about a plan's worth: the probability of success in the summary, the plan
file and the picture's title, with and without targets, and the horizon-value option."""

import json
import re

import pytest

from gcs.cli import main
from gcs.plans.plan_file import validate_plan_dict
from tests.gcs.plans.conftest import small_area


def summary_lines(out: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(("probability of success", "simulated:"))]


def test_the_summary_leads_with_the_probability_of_success(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["plan", "--np", "3", "--range", "60", "--seed", "1", "--out", str(out), "--no-rrd"]) == 0
    printed = capsys.readouterr().out
    data = json.loads(out.read_text())
    validate_plan_dict(data)
    s = data["summary"]
    assert 0 < s["expected_targets_found"] <= s["expected_targets_in_area"]
    assert s["probability_of_success"] == pytest.approx(s["expected_targets_found"] / s["expected_targets_in_area"],
                                                        abs=1e-6)
    assert sum(u["expected_targets_found"] for u in data["uavs"]) == pytest.approx(s["expected_targets_found"],
                                                                                    abs=1e-5)
    assert sum(u["probability_of_success"] for u in data["uavs"]) == pytest.approx(s["probability_of_success"],
                                                                                   abs=1e-5)
    first, second = summary_lines(printed)
    share, found, total = re.fullmatch(r"probability of success ([\d.]+)%: expected targets found ([\d.]+) of the "
                                       r"([\d.]+) the prior puts in the area", first).groups()
    assert float(share) == pytest.approx(100 * s["probability_of_success"], abs=0.051)
    assert float(found) == pytest.approx(s["expected_targets_found"], abs=0.0051)
    assert float(total) == pytest.approx(s["expected_targets_in_area"], abs=0.0051)
    assert second.startswith(f"simulated: targets found {s['targets_found']}/10")
    rows = {int(line.split()[0]): line.split() for line in printed.splitlines() if line[:3].strip().isdigit()}
    for u in data["uavs"]:
        assert float(rows[u["id"]][6]) == pytest.approx(u["expected_targets_found"], abs=0.0051)
    assert "horizon_value" not in data["settings"]


def test_an_area_without_targets_still_says_what_the_plan_is_worth(tmp_path, capsys):
    doc = small_area()
    doc["features"] = [f for f in doc["features"] if f["properties"]["role"] != "target"]
    area = tmp_path / "area.geojson"
    area.write_text(json.dumps(doc))
    assert main(["plan", "--area", str(area), "--out", str(tmp_path / "out"), "--no-rrd"]) == 0
    first, second = summary_lines(capsys.readouterr().out)
    assert first.startswith("probability of success ") and "0/0" not in first + second
    assert second.startswith("simulated: no targets placed")
    data = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert data["summary"]["expected_targets_found"] > 0
    assert data["settings"]["horizon_value"] == {"weight": 1.0, "length": 1.0, "radius": 5, "every": 1}


def test_area_plans_look_past_the_horizon_unless_told_not_to(tmp_path):
    area = tmp_path / "area.geojson"
    area.write_text(json.dumps(small_area()))
    assert main(["plan", "--area", str(area), "--out", str(tmp_path / "off"), "--no-rrd", "--quiet",
                 "--no-horizon-value"]) == 0
    assert main(["plan", "--scenario", "paper", "--range", "40", "--horizon-value", "--out", str(tmp_path / "on.json"),
                 "--no-rrd", "--quiet"]) == 0
    assert "horizon_value" not in json.loads((tmp_path / "off" / "plan.json").read_text())["settings"]
    assert json.loads((tmp_path / "on.json").read_text())["settings"]["horizon_value"]["weight"] == 1.0
