"""`.ci/run` fails when either of its pytest runs fails: the tests and, beside them, the tests
without the JIT; or when mypy, also beside them, fails (its commands replaced by ones that exit
as asked; the control flow is its own)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run_with(tmp_path: Path, tests_exit: int, without_jit_exit: int, mypy_exit: int = 0
              ) -> subprocess.CompletedProcess:
    script = (ROOT / ".ci" / "run").read_text()
    script = re.sub(r"^phase (setup|ruff) .*$", ":", script, flags=re.MULTILINE)
    script, mypy = re.subn(r"^phase mypy \.venv/bin/mypy ", f"phase mypy bash -c 'exit {mypy_exit}' ", script,
                           flags=re.MULTILINE)
    script, beside = re.subn(r"^NUMBA_DISABLE_JIT=1 nice .*\\\n", f"(sleep 0.2; exit {without_jit_exit}) \\\n", script,
                             flags=re.MULTILINE)
    script, tests = re.subn(r"^phase tests \.venv/bin/python -m pytest -q", f"phase tests bash -c 'exit {tests_exit}'",
                            script, flags=re.MULTILINE)
    assert beside == 1 and tests == 1 and mypy == 1, \
        "the pytest runs and mypy of .ci/run are no longer where this test looks"
    (tmp_path / ".ci").mkdir()
    (tmp_path / ".ci" / "run").write_text(script)
    return subprocess.run(["bash", str(tmp_path / ".ci" / "run")], capture_output=True, text=True, timeout=30)


@pytest.mark.parametrize("tests_exit, without_jit_exit, mypy_exit", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (5, 2, 0),
                                                                    (0, 0, 1)])
def test_ci_passes_only_when_both_pytest_runs_and_mypy_pass(tmp_path, tests_exit, without_jit_exit, mypy_exit):
    run = _run_with(tmp_path, tests_exit, without_jit_exit, mypy_exit)
    last = run.stdout.strip().splitlines()[-1]
    if tests_exit == without_jit_exit == mypy_exit == 0:
        assert run.returncode == 0 and last.startswith("ci: passed in"), run.stdout + run.stderr
    else:
        assert run.returncode == 1, run.stdout + run.stderr
        assert (f"tests: exit {tests_exit}, tests without the JIT: exit {without_jit_exit}, mypy: exit {mypy_exit}"
                in last)
