"""What every experiment runner shares: settings, the progress bar, and all-or-nothing output
of a figure's CSV files and PNG plot."""

from __future__ import annotations

import csv
import io
import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from tqdm import tqdm

from gcs.atomic import staged_outputs
from planner.dtscs import ClosedSearch, MissionConfig, StepRecord
from planner.environment import Sensor
from planner.plan import Plan
from planner.scenario import Scenario, paper_scenario
from planner.search import make_strategy


@dataclass(frozen=True)
class ExperimentSettings:
    """`runs` None means the figure's own default. Run r uses seed `seed + r` for the targets,
    the sensor and the optimisers, so every strategy meets the same scenarios."""

    out: Path
    runs: int | None = None
    seed: int = 0
    footprint: int = 0
    range_steps: int = 130
    quiet: bool = False
    on_figure: Callable[[str, Figure], None] | None = None  # called with each figure once published

    def runs_or(self, default: int) -> int:
        return self.runs if self.runs is not None else default

    def seeds(self, default_runs: int) -> range:
        return range(self.seed, self.seed + self.runs_or(default_runs))

    def scenario(self, seed: int) -> Scenario:
        return paper_scenario(seed, self.range_steps, Sensor(footprint_radius=self.footprint))


@contextmanager
def progress(total: int, desc: str, quiet: bool) -> Iterator[tqdm]:
    with tqdm(total=total, desc=desc, unit="run", disable=quiet or None, leave=False, file=sys.stderr) as bar:
        yield bar


@dataclass
class MissionResult:
    plan: Plan
    records: list[StepRecord]
    run_time_s: float


def fly_mission(scenario: Scenario, config: MissionConfig, seed: int, strategy=None,
                keep_records: bool = False) -> MissionResult:
    """One closed search, timed; `records` kept only when asked (they hold live maps)."""
    search = ClosedSearch(scenario, config, seed=seed, strategy=strategy or make_strategy(config.strategy))
    records = []
    start = time.perf_counter()
    for record in search.run():
        if keep_records:
            records.append(record)
    return MissionResult(search.plan(), records, time.perf_counter() - start)


def csv_text(header: list[str], rows: list[list]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([f"{v:.6g}" if isinstance(v, (float, np.floating)) else v for v in row])
    return buffer.getvalue()


def publish(out: Path, name: str, tables: dict[str, str], figure: Figure,
            on_figure: Callable[[str, Figure], None] | None = None) -> list[Path]:
    """Write `tables` (file suffix -> CSV text) and the figure as `name*.csv` and `name.png`,
    all or none; then hand the figure to `on_figure` (the experiment's recording)."""
    paths = [out / f"{name}{suffix}.csv" for suffix in tables] + [out / f"{name}.png"]
    with staged_outputs(paths) as staged:
        for text, path in zip(tables.values(), paths):
            staged[path].write_text(text, encoding="utf-8")
        figure.savefig(staged[paths[-1]], format="png", dpi=120, bbox_inches="tight")
        for tmp in staged.values():
            os.chmod(tmp, 0o666 & ~_umask())       # temporary files are created 0600
    if on_figure is not None:
        on_figure(name, figure)
    return paths


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def mean_std(values) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return (float(a.mean()), float(a.std())) if a.size else (float("nan"), float("nan"))
