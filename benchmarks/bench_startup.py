"""Start-up of the command line: `gcs --help`, and a second `gcs plan --area missions/paper.geojson`
end to end (numba's on-disk cache filled; plan, missions, picture and recording written), each a
fresh process, as the user runs them. Targets: under 0.3 s and under 2 s.

Prints the median and the fastest wall time of --repeats runs (the fastest is the least disturbed
by other work on a shared machine) and the median CPU time of all its processes; with --imports
the heaviest modules `gcs plan` and its helper processes import (they share its stderr: the
pictures helper imports matplotlib, the recordings helper rerun). With --against DIR, another
copy of the code (e.g. `git archive` of an older commit) is timed too, its runs alternating with
these, so that both see the same load.
With --area FILE, that area file is planned instead (e.g. a KML, to time reading it through GDAL).
Usage: python benchmarks/bench_startup.py [--repeats 7] [--imports] [--tree DIR] [--against DIR] [--area FILE]"""

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


def alternating(commands: list[tuple[list[str], Path]], repeats: int) -> list[tuple[list[float], list[float]]]:
    """`timed` for several (command, folder), their runs taken in turn."""
    out: list[tuple[list[float], list[float]]] = [([], []) for _ in commands]
    for _ in range(repeats):
        for (command, root), (wall, cpu) in zip(commands, out):
            w, c = timed(command, 1, root)
            wall += w
            cpu += c
    return out


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


def gcs_command(root: Path) -> list[str]:
    """The installed console script for this tree, `python -m gcs.cli` for another."""
    return [str(Path(sys.executable).with_name("gcs"))] if root == ROOT else [sys.executable, "-m", "gcs.cli"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--imports", action="store_true", help="also list the heaviest imports of gcs plan")
    parser.add_argument("--tree", type=Path, default=ROOT,
                        help="another copy of the code to time with this Python (e.g. `git archive` of an older "
                             "commit)")
    parser.add_argument("--against", type=Path, default=None, metavar="DIR",
                        help="also time the copy of the code in DIR, its runs alternating with these")
    parser.add_argument("--area", default="missions/paper.geojson", help="the area file to plan (default: %(default)s)")
    args = parser.parse_args()
    roots = [args.tree.resolve()] + ([args.against.resolve()] if args.against else [])
    cases: dict[str, tuple[list[float], list[float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        plans = []
        for k, root in enumerate(roots):
            plan = [*gcs_command(root), "plan", "--area", str(ROOT / args.area), "--out", str(Path(tmp) / f"p{k}")]
            timed(plan, 1, root)  # the first plan fills numba's cache if it is empty
            plans.append((plan, root))
        labels = [f" [{root}]" if len(roots) > 1 else "" for root in roots]
        for root, label in zip(roots, labels):
            cases[f"gcs --help{label}"] = timed([*gcs_command(root), "--help"], args.repeats, root)
        for label, result in zip(labels, alternating(plans, args.repeats)):
            cases[f"gcs plan --area {args.area}{label}"] = result
        outputs = sorted(p.name for p in (Path(tmp) / "p0").iterdir())
        if args.imports:
            print("heaviest imports of gcs plan and its helpers (cumulative s):")
            for seconds, name in heaviest_imports(plans[0][0], roots[0]):
                print(f"  {seconds:6.3f}  {name}")
    print(f"wall and CPU seconds of {args.repeats} fresh processes (load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores)")
    width = max(40, *(len(name) for name in cases))
    print(f"{'command':<{width}} {'median':>7} {'fastest':>8} {'CPU median':>11}")
    for name, (wall, cpu) in cases.items():
        print(f"{name:<{width}} {statistics.median(wall):>7.2f} {min(wall):>8.2f} {statistics.median(cpu):>11.2f}")
    print(f"plan outputs: {', '.join(outputs)}")


if __name__ == "__main__":
    main()
