"""The SAREnv benchmark's checks (`sarenv_checks.py`: one scenario scored by SAREnv's own
evaluator, gcs's closed paths at the IPP, bad input) run by pytest in `.venv-bench`, the project
with its `bench` extra that `tools/setup --test` makes: SAREnv's evaluator needs geopandas, and
geopandas in the tests' own environment would slow every process that imports pyogrio. Skipped,
saying why, where ../shared/peers/sarenv is absent."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from benchmarks import sarenv_bench as sb

ROOT = Path(__file__).resolve().parents[2]
BENCH_PYTHON = ROOT / ".venv-bench" / "bin" / "python"

pytestmark = pytest.mark.skipif(not (sb.DEFAULT_SOURCE / "sarenv").is_dir() or not sb.DEFAULT_DATASETS.is_dir(),
                                reason=f"SAREnv is not in the peers folder ({sb.PEERS})")


def test_the_sarenv_checks_pass_in_the_benchmarks_environment() -> None:
    assert BENCH_PYTHON.exists(), f"{BENCH_PYTHON} is missing: run tools/setup --test"
    done = subprocess.run([str(BENCH_PYTHON), "-m", "pytest", "-q", "--noconftest", "-o", "addopts=", "-p",
                           "no:cacheprovider", str(Path(__file__).with_name("sarenv_checks.py"))],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert "3 passed" in done.stdout, done.stdout[-2000:]
