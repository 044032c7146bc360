"""`python -m planner.precompile` (what `tools/setup` runs) compiles every kernel the planner has,
so a fresh install's first plan compiles none; checked in a process of its own, where no other
test has compiled anything."""

from __future__ import annotations

import json
import subprocess
import sys

#: Imports every planner module, precompiles, and prints the kernels neither compiled (or loaded
#: from the cache) nor called by one that was: a kernel loaded from the cache brings the kernels
#: it calls compiled inside it, without compiling them on their own.
PROBE = """
import importlib, json, pkgutil, sys
from numba.core.registry import CPUDispatcher
import planner
for module in pkgutil.walk_packages(planner.__path__, "planner."):
    importlib.import_module(module.name)
from planner.precompile import precompile
precompile()
kernels = {v.py_func: v for name, m in list(sys.modules.items()) if name.startswith("planner.")
           for v in vars(m).values() if isinstance(v, CPUDispatcher)}
reached = [f for f, k in kernels.items() if k.signatures]
for func in reached:
    for callee in (func.__globals__.get(n) for n in func.__code__.co_names):
        if isinstance(callee, CPUDispatcher) and callee.py_func not in reached:
            reached.append(callee.py_func)
print(json.dumps({"kernels": len(kernels),
                  "not reached": sorted(f"{f.__module__}.{f.__qualname__}" for f in kernels if f not in reached)}))
"""


def test_precompiling_compiles_every_kernel_of_the_planner():
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout)
    assert found["kernels"] >= 20  # planner.config.njit's kernels were found at all
    assert found["not reached"] == []


def test_kernels_compiled_from_other_sources_are_dropped_before_precompiling(tmp_path):
    """numba checks a cached kernel against its own file only: when any planner source changes
    (a callee in another file), every cached kernel is dropped; while none does, none is."""
    from planner.precompile import drop_stale_kernels, stamp_sources

    (tmp_path / "search").mkdir()
    (tmp_path / "reward.py").write_text("def score(): return 1\n")
    (tmp_path / "search" / "pio.py").write_text("def flocks(): return 2\n")
    cache = tmp_path / "search" / "__pycache__"
    cache.mkdir()

    def compiled() -> None:
        for name in ("pio.flocks-1.py311.nbi", "pio.flocks-1.py311.1.nbc"):
            (cache / name).write_text("kernel")

    compiled()
    assert drop_stale_kernels(tmp_path) == 2  # never stamped: compiled from unknown sources
    compiled()
    stamp_sources(tmp_path)
    assert drop_stale_kernels(tmp_path) == 0 and len(list(cache.iterdir())) == 2
    (tmp_path / "reward.py").write_text("def score(): return 3\n")  # the callee changes, not pio.py
    assert drop_stale_kernels(tmp_path) == 2 and list(cache.iterdir()) == []
