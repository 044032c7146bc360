"""Fig. 10: tracking efficiency phi (Definition 6) of the ST return under 3OC, 4OC and 8OC as the
grid is subdivided, with the exact planner's return lengths beside ST's.

The paper map (Section 6.1) is subdivided s x s (s = 1..4): each cell becomes s x s cells, a pose
in cell (x, y) moves to the centre cell (x s + s//2, y s + s//2) with the same heading. Four
tracking tasks cross the map around the no-fly zones: from each UAV's start pose to the airport
of the UAV on the opposite side (1 -> 4, 2 -> 3, 3 -> 2, 4 -> 1). ST uses basic PIO as its
tracker (as the paper does), Np = 5, and a budget of twice the exact length plus 20 steps, so
the range never binds; run r seeds the tracker with `seed + r`."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gcs.experiments.common import (
    ExperimentSettings,
    csv_text,
    mean_std,
    progress,
    publish,
)
from planner.motion import OC3, OC4, OC8
from planner.return_exact import UNREACHABLE, return_table
from planner.return_st import st_return
from planner.scenario import paper_scenario
from planner.search.pio import PioStrategy

SUBDIVISIONS = (1, 2, 3, 4)
CONSTRAINTS = (OC3, OC4, OC8)
TASKS = ((0, 3), (1, 2), (2, 1), (3, 0))
DEFAULT_RUNS = 2
NP_STEPS = 5


def subdivided(no_fly: np.ndarray, s: int) -> np.ndarray:
    return np.ascontiguousarray(np.kron(no_fly, np.ones((s, s), dtype=bool)))


def scaled(cell: tuple[int, int], s: int) -> tuple[int, int]:
    return cell[0] * s + s // 2, cell[1] * s + s // 2


def run(settings: ExperimentSettings, subdivisions: tuple[int, ...] = SUBDIVISIONS) -> list:
    seeds = settings.seeds(DEFAULT_RUNS)
    base = paper_scenario(settings.seed)
    rows = []
    with progress(len(subdivisions) * len(CONSTRAINTS) * len(seeds), "fig10", settings.quiet) as bar:
        for s in subdivisions:
            blocked = subdivided(base.search_map.no_fly, s)
            for oc in CONSTRAINTS:
                successors = oc.successors
                for seed in seeds:
                    tracker = PioStrategy(seed=seed)
                    for start, goal in TASKS:
                        u, g = base.uavs[start], base.uavs[goal]
                        x, y = scaled(u.airport, s)
                        target = scaled(g.airport, s)
                        table = return_table(blocked, target, oc)
                        exact = int(table[u.heading, x, y])
                        if exact >= UNREACHABLE:
                            continue
                        st = st_return(blocked, (x, y, u.heading), target, successors, table, NP_STEPS,
                                       2 * exact + 20, tracker.best_path)
                        task = f"{u.uav_id}->{g.uav_id}"
                        if st is None:
                            rows.append([s, oc.name, task, seed, "", exact, "", ""])
                            continue
                        rows.append([s, oc.name, task, seed, len(st.path), exact, len(st.astar_cells) - 1,
                                     st.tracking_efficiency])
                    bar.update(1)
    summary = []
    for s in subdivisions:
        for oc in CONSTRAINTS:
            mine = [r for r in rows if r[0] == s and r[1] == oc.name and r[4] != ""]
            phi = mean_std([r[7] for r in mine])
            summary.append([s, oc.name, len(mine), *phi, float(np.mean([r[4] for r in mine])),
                            float(np.mean([r[5] for r in mine])), float(np.mean([r[6] for r in mine]))])
    tables = {
        "": csv_text(["subdivision", "oc", "returns", "phi_mean", "phi_std", "st_steps_mean", "exact_steps_mean",
                      "astar_steps_mean"], summary),
        "_returns": csv_text(["subdivision", "oc", "task", "seed", "st_steps", "exact_steps", "astar_steps", "phi"],
                             rows),
    }
    return publish(settings.out, "fig10", tables, figure(summary), settings.on_figure)


def figure(summary: list) -> Figure:
    fig = Figure(figsize=(11, 4))
    a, b = fig.subplots(1, 2)
    for oc in CONSTRAINTS:
        rows = [r for r in summary if r[1] == oc.name]
        a.errorbar([r[0] for r in rows], [r[3] for r in rows], yerr=[r[4] for r in rows], marker="o", capsize=3,
                   label=oc.name)
        b.plot([r[0] for r in rows], [r[5] / r[6] for r in rows], marker="o", label=oc.name)
    a.set(xlabel="subdivision s (cells per paper cell side)", ylabel="tracking efficiency phi",
          title="(a) ST tracking efficiency")
    a.legend()
    b.axhline(1.0, color="grey", lw=0.8)
    b.set(xlabel="subdivision s", ylabel="ST steps / exact steps", title="(b) ST return length vs exact")
    b.legend()
    fig.tight_layout()
    return fig
