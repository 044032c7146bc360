"""Fig. 12: range utilisation eta (eq. 25) of every UAV in CPIO closed missions, under 3OC (the
paper's 97% on average) and 8OC (the paper: higher).

eta_i(k) = (T_i1(k) + T_i2(k)) / T_i: steps flown plus the steps of the way home from the
current pose, over the range; its final value is the UAV's range utilisation."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
from matplotlib.figure import Figure

from gcs.experiments.common import (
    ExperimentSettings,
    csv_text,
    fly_mission,
    mean_std,
    progress,
    publish,
)
from planner.dtscs import MissionConfig
from planner.motion import OC3, OC8

CONSTRAINTS = (OC3, OC8)
DEFAULT_RUNS = 20


def run(settings: ExperimentSettings) -> list:
    seeds = settings.seeds(DEFAULT_RUNS)
    rows, curves = [], []
    with progress(len(CONSTRAINTS) * len(seeds), "fig12", settings.quiet) as bar:
        for oc in CONSTRAINTS:
            config = MissionConfig(oc=oc, strategy="cpio")
            for i, seed in enumerate(seeds):
                result = fly_mission(settings.scenario(seed), config, seed, keep_records=(i == 0))
                for u in result.plan.uavs:
                    rows.append([oc.name, seed, u.uav_id, u.search_steps, u.return_steps, u.range_units, u.eta])
                for record in result.records:
                    for uid, status in record.ranges.items():
                        rng = result.plan.uavs[[p.uav_id for p in result.plan.uavs].index(uid)].range_units
                        flown = rng - status.range_left
                        curves.append([oc.name, uid, record.step, (flown + status.return_cost) / rng])
                bar.update(1)
    summary = []
    per_uav = defaultdict(list)
    for oc_name, _, uid, _, _, _, eta in rows:
        per_uav[(oc_name, uid)].append(eta)
    for (oc_name, uid), etas in sorted(per_uav.items()):
        summary.append([oc_name, uid, len(etas), *mean_std(etas)])
    for oc in CONSTRAINTS:
        summary.append([oc.name, "all", len(seeds), *mean_std([r[6] for r in rows if r[0] == oc.name])])
    tables = {
        "": csv_text(["oc", "uav", "runs", "eta_mean", "eta_std"], summary),
        "_runs": csv_text(["oc", "seed", "uav", "search_steps", "return_steps", "range_steps", "eta"], rows),
        "_steps": csv_text(["oc", "uav", "step", "eta"], curves),
    }
    return publish(settings.out, "fig12", tables, figure(summary, curves), settings.on_figure)


def figure(summary: list, curves: list) -> Figure:
    fig = Figure(figsize=(11, 4))
    a, b = fig.subplots(1, 2)
    first = [r for r in curves if r[0] == CONSTRAINTS[0].name]
    for uid in sorted({r[1] for r in first}):
        rows = [r for r in first if r[1] == uid]
        a.plot([r[2] for r in rows], [r[3] for r in rows], label=f"UAV{uid}")
    a.set(xlabel="time step", ylabel="eta_i(k)", title=f"(a) range utilisation, {CONSTRAINTS[0].name}, first run")
    a.legend()
    width = 0.8 / len(CONSTRAINTS)
    for i, oc in enumerate(CONSTRAINTS):
        rows = [r for r in summary if r[0] == oc.name]
        xs = np.arange(len(rows)) + i * width
        b.bar(xs, [r[3] for r in rows], width, yerr=[r[4] for r in rows], capsize=3, label=oc.name)
        b.set_xticks(np.arange(len(rows)) + width / 2, [str(r[1]) for r in rows])
    b.set(xlabel="UAV", ylabel="eta (mean ± std)", ylim=(0.8, 1.02), title="(b) range utilisation per UAV")
    b.legend()
    fig.tight_layout()
    return fig
