"""Fig. 6: the look-ahead Np = 1..7 with CPIO: run time of a mission, average fitness per step,
targets found."""

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
from planner.motion import OC3

NP_VALUES = tuple(range(1, 8))
DEFAULT_RUNS = 10


def run(settings: ExperimentSettings) -> list:
    seeds = settings.seeds(DEFAULT_RUNS)
    fly_mission(settings.scenario(settings.seed), MissionConfig(strategy="cpio"), settings.seed)  # compile first
    summary, steps = [], []
    with progress(len(NP_VALUES) * len(seeds), "fig6", settings.quiet) as bar:
        for np_steps in NP_VALUES:
            config = MissionConfig(np_steps=np_steps, strategy="cpio")
            times, found, per_step, evaluations = [], [], defaultdict(list), []
            for seed in seeds:
                result = fly_mission(settings.scenario(seed), config, seed, keep_records=True)
                times.append(result.run_time_s)
                found.append(result.plan.targets_found)
                for record in result.records:
                    for d in record.decisions.values():
                        per_step[record.step].append(d.j1 / np_steps)
                        evaluations.append(d.evaluations)
                bar.update(1)
            all_fitness = [v for values in per_step.values() for v in values]
            summary.append([np_steps, len(seeds), *mean_std(times), float(np.mean(all_fitness)), *mean_std(found),
                            float(np.mean(evaluations)), OC3.branching ** np_steps])
            steps += [[np_steps, k, float(np.mean(v))] for k, v in sorted(per_step.items())]
    tables = {
        "": csv_text(["np", "runs", "run_time_s_mean", "run_time_s_std", "fitness_per_step_mean", "targets_mean",
                      "targets_std", "paths_scored_per_decision", "paths_per_uav"], summary),
        "_steps": csv_text(["np", "step", "fitness_per_step_mean"], steps),
    }
    return publish(settings.out, "fig6", tables, figure(summary, steps), settings.on_figure)


def figure(summary: list, steps: list) -> Figure:
    fig = Figure(figsize=(13, 3.8))
    a, b, c = fig.subplots(1, 3)
    nps = [r[0] for r in summary]
    a.errorbar(nps, [r[2] for r in summary], yerr=[r[3] for r in summary], marker="o", capsize=3)
    a.set(xlabel="Np", ylabel="mission run time (s)", title="(a) run time")
    for np_steps in nps:
        rows = [r for r in steps if r[0] == np_steps]
        b.plot([r[1] for r in rows], [r[2] for r in rows], label=f"Np={np_steps}", lw=1)
    b.set(xlabel="time step", ylabel="J1 / Np of the chosen path", title="(b) average fitness")
    b.legend(fontsize=7, ncol=2)
    c.errorbar(nps, [r[5] for r in summary], yerr=[r[6] for r in summary], marker="s", capsize=3)
    c.set(xlabel="Np", ylabel="targets found (of 10)", title="(c) targets found")
    fig.tight_layout()
    return fig
