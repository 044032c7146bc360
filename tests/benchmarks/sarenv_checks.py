"""The SAREnv benchmark on one scenario (SAREnv's dataset 1, medium, 5 UAVs, 100 km), scored by
SAREnv's own evaluator from the peers folder: its deterministic baselines reproduce the
published scores, gcs's closed paths start and end at the IPP within each UAV's share of the
budget, and the table ends with the comparison line. Run in .venv-bench by
`test_sarenv_bench.py`; skipped, saying why, where ../shared/peers/sarenv is absent."""

from __future__ import annotations

import json
import re

import pytest
from shapely.geometry import Point

from benchmarks import sarenv_bench as sb

pytestmark = pytest.mark.skipif(not (sb.DEFAULT_SOURCE / "sarenv").is_dir() or not sb.DEFAULT_DATASETS.is_dir(),
                                reason=f"SAREnv is not in the peers folder ({sb.PEERS})")


@pytest.fixture(scope="module")
def sarenv() -> sb.Sarenv:
    return sb.load_sarenv(sb.DEFAULT_SOURCE)


def test_one_scenario_through_the_evaluator(sarenv, capsys) -> None:
    assert sb.main(["--ids", "1", "--baselines", "Spiral,Pizza"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[1]: line.split() for line in out.splitlines() if re.match(r"\s*1 \w", line)}
    for name in ("Spiral", "Pizza"):
        likelihood, published = float(rows[name][2]), float(rows[name][3])
        assert abs(likelihood / published - 1) < 0.03, rows[name]
    gcs, best = float(rows["gcs"][2]), max(float(rows[n][2]) for n in ("Spiral", "Pizza"))
    assert float(rows["bound"][2]) > float(rows["seen"][2]) > gcs > 0.9 * best
    assert float(rows["seen"][2]) == pytest.approx(sb.camera_bound(
        sb.load_scenario(sarenv, sb.DEFAULT_DATASETS, 1, "medium"), 100_000), rel=1e-3)
    assert float(rows["gcs"][4]) > max(float(rows[n][5]) for n in ("Spiral", "Pizza"))  # time-discounted
    assert ("gcs plan --area FILE --cell-size 22.1 --footprint 1 --pc 0.95 --pf 0.01 --np 7 --strategy exhaustive"
            in out)  # the options a crew would pass for gcs's column
    ratio = out.strip().splitlines()[-1]
    assert re.fullmatch(r"gcs vs the best baseline: likelihood mean [\d.]+x, min [\d.]+x; "
                        r"time-discounted mean [\d.]+x, min [\d.]+x", ratio)


def test_gcs_paths_are_closed_at_the_ipp_within_each_share(sarenv, tmp_path) -> None:
    """gcs's default plan (improved, cells a third of the swath) and, with --no-improve, DTSCS's plan."""
    scenario = sb.load_scenario(sarenv, sb.DEFAULT_DATASETS, 1, "small")
    ipp = Point(scenario.centre_xy)
    for improve in (None, False):
        paths = sb.plan_gcs(scenario, 3, 6000, 0, tmp_path, sb.GcsSettings(improve=improve))
        assert len(paths) == 3
        for path in paths:
            assert Point(path.coords[0]).distance(ipp) < 1e-6 and Point(path.coords[-1]).distance(ipp) < 1e-6
            assert 1000 < path.length <= 2000 + 1e-6
        settings = json.loads((tmp_path / "plan.json").read_text())["settings"]
        assert settings.get("improved", False) is (improve is None)


def test_bad_input_is_one_line(capsys) -> None:
    assert sb.main(["--ids", "1,x"]) == 2
    assert capsys.readouterr().err == "error: --ids must be comma-separated dataset ids, got '1,x'\n"
    assert sb.main(["--baselines", "Greedy,Lawn"]) == 2
    assert capsys.readouterr().err.startswith("error: --baselines: unknown Lawn")
    assert sb.main(["--strategy", "lawn"]) == 2
    assert capsys.readouterr().err.startswith("error: --strategy: unknown lawn (of cpio, exhaustive")
