"""Start-up of the command line: `gcs --help`, and a second `gcs plan --area missions/paper.geojson`
end to end (numba's on-disk cache filled; plan, missions, picture and recording written), each a
fresh process, as the user runs them. Targets: under 0.3 s and under 2 s.

Prints the median and the fastest wall time of --repeats runs (the fastest is the least disturbed
by other work on a shared machine) and the median CPU time of all its processes; with --imports
the heaviest modules `gcs plan` imports.
Usage: python benchmarks/bench_startup.py [--repeats 7] [--imports] [--tree DIR]"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed(command: list[str], repeats: int, root: Path) -> tuple[list[float], list[float]]:
    """Wall and CPU seconds (all processes, helpers included) of each of `repeats` runs."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), cpu_s()
        subprocess.run(command, check=True, cwd=root, stdout=subprocess.DEVNULL)
        wall.append(time.perf_counter() - start)
        cpu.append(cpu_s() - start_cpu)
    return wall, cpu


def heaviest_imports(command: list[str], root: Path, count: int = 12) -> list[tuple[float, str]]:
    """The `count` top-level imports of `command` taking longest, cumulative seconds."""
    err = subprocess.run([sys.executable, "-X", "importtime", "-m", "gcs.cli", *command[1:]], cwd=root, check=True,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True).stderr
    rows = []
    for line in err.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cumulative, name = line[len("import time:"):].split("|")
            if cumulative.strip().isdigit() and name.startswith(" ") and not name.startswith("  "):
                rows.append((int(cumulative) / 1e6, name.strip()))
    return sorted(rows, reverse=True)[:count]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--imports", action="store_true", help="also list the heaviest imports of gcs plan")
    parser.add_argument("--tree", type=Path, default=ROOT,
                        help="another copy of the code to time with this Python (e.g. `git archive` of an older "
                             "commit)")
    args = parser.parse_args()
    root = args.tree.resolve()
    # the installed console script for this tree, `python -m gcs.cli` for another
    gcs = [str(Path(sys.executable).with_name("gcs"))] if root == ROOT else [sys.executable, "-m", "gcs.cli"]
    with tempfile.TemporaryDirectory() as tmp:
        plan = [*gcs, "plan", "--area", "missions/paper.geojson", "--out", str(Path(tmp) / "paper")]
        timed(plan, 1, root)  # the first plan fills numba's cache if it is empty
        cases = {"gcs --help": timed([*gcs, "--help"], args.repeats, root),
                 "gcs plan --area missions/paper.geojson": timed(plan, args.repeats, root)}
        outputs = sorted(p.name for p in (Path(tmp) / "paper").iterdir())
        if args.imports:
            print("heaviest imports of gcs plan (cumulative s):")
            for seconds, name in heaviest_imports(plan, root):
                print(f"  {seconds:6.3f}  {name}")
    print(f"wall and CPU seconds of {args.repeats} fresh processes (load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores)")
    print(f"{'command':<40} {'median':>7} {'fastest':>8} {'CPU median':>11}")
    for name, (wall, cpu) in cases.items():
        print(f"{name:<40} {statistics.median(wall):>7.2f} {min(wall):>8.2f} {statistics.median(cpu):>11.2f}")
    print(f"plan outputs: {', '.join(outputs)}")


if __name__ == "__main__":
    main()
