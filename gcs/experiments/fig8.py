"""Fig. 8: CPIO against basic PIO, PSO and GA (plus exhaustive choice, the exact per-UAV
optimum, and a lawnmower sweep, the plan a survey tool would give).

(b) Targets found over `runs` seeded closed missions per strategy (the same scenarios and sensor
seeds for all). (a) Convergence on identical decision states: along the CPIO missions of the first
`CONVERGENCE_RUNS` seeds, every searcher's decision is also handed to each optimiser, and its
best J1 after each iteration is divided by the exact optimum of that state (exhaustive
enumeration against the same other vehicles). PIO, PSO and GA score against fixed others (the
other UAVs' predicted paths); a CPIO subgroup scores against the other subgroups' current bests,
which move while it iterates, so its trace is divided by the optimum against the others' final
bests: exact at the last iteration, approximate before."""

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
from planner.search import make_strategy
from planner.search.competition import fixed_others, others_for
from planner.search.cpio import CpioStrategy
from planner.search.exhaustive import ExhaustiveStrategy
from planner.search.flock import path_cells
from planner.search.ga import GaParams, GaStrategy
from planner.search.lawnmower import LawnmowerStrategy
from planner.search.pio import PioParams, PioStrategy
from planner.search.problem import StepProblem
from planner.search.pso import PsoParams, PsoStrategy

STRATEGY_NAMES = ("cpio", "pio", "pso", "ga", "exhaustive", "lawnmower")
OPTIMISERS = ("cpio", "pio", "pso", "ga")
DEFAULT_RUNS = 100
CONVERGENCE_RUNS = 10


def paths_scored_per_iteration(name: str) -> np.ndarray:
    """Cumulative paths scored after each iteration of an optimiser's trace (Table 1 budgets)."""
    if name in ("cpio", "pio"):
        p = PioParams()
        sizes = [p.pigeons] * (1 + p.compass_iterations) + p.landmark_sizes()
    elif name == "pso":
        p = PsoParams()
        sizes = [p.particles] * (1 + p.iterations)
    else:
        g = GaParams()
        sizes = [g.population] + [g.population - g.elites] * g.generations
    return np.cumsum(sizes)


class ConvergenceProbe:
    """A CPIO strategy that, at every decision, also runs every optimiser on the same state and
    keeps its trace as a fraction of the exact optimum."""

    name = "cpio"

    def __init__(self, seed: int) -> None:
        self.inner = CpioStrategy()
        self.rng = np.random.default_rng([seed, 8])
        self.exact = ExhaustiveStrategy()
        self.single = {"pio": PioStrategy(), "pso": PsoStrategy(), "ga": GaStrategy()}
        self.traces: dict[str, list[np.ndarray]] = defaultdict(list)

    def best_path(self, problem, searcher, others, others_hard):
        return self.inner.best_path(problem, searcher, others, others_hard)

    def decide(self, problem: StepProblem, rng: np.random.Generator):
        optimum = {}
        for s in problem.searchers:
            others, hard = others_for(problem, s.uav_id, {})
            best = self.exact.best_path(problem, s, others, hard)
            if best is None or best.j1 <= 0:
                continue
            optimum[s.uav_id] = best.j1
            for name, strategy in self.single.items():
                d = strategy.best_path(problem, s, others, hard, self.rng)
                if d is not None:
                    self.traces[name].append(d.trace / best.j1)
        coevolved = self.inner.coevolve(problem, self.rng)
        final = {uid: path_cells(d, problem.np_steps) for uid, d in coevolved.items() if d is not None}
        for s in problem.searchers:
            d = coevolved.get(s.uav_id)
            if d is None or s.uav_id not in optimum:
                continue
            others, hard = fixed_others(problem, {s.uav_id}, None, final)
            best = self.exact.best_path(problem, s, others, hard)
            if best is not None and best.j1 > 0:
                self.traces["cpio"].append(d.trace / best.j1)
        return self.inner.decide(problem, rng)


def run(settings: ExperimentSettings) -> list:
    seeds = settings.seeds(DEFAULT_RUNS)
    convergence_seeds = seeds[:CONVERGENCE_RUNS]
    results: dict[str, dict[str, list]] = {name: defaultdict(list) for name in STRATEGY_NAMES}
    probes = []
    with progress(len(STRATEGY_NAMES) * len(seeds) + len(convergence_seeds), "fig8", settings.quiet) as bar:
        for name in STRATEGY_NAMES:
            for seed in seeds:
                strategy = (LawnmowerStrategy(2 * settings.footprint + 1) if name == "lawnmower"
                            else make_strategy(name))
                result = fly_mission(settings.scenario(seed), MissionConfig(strategy=name), seed, strategy,
                                     keep_records=True)
                r = results[name]
                r["targets"].append(result.plan.targets_found)
                r["false_alarms"].append(result.plan.false_alarms)
                r["eta"].append(result.plan.mean_eta)
                r["time"].append(result.run_time_s)
                r["evaluations"] += [d.evaluations for rec in result.records for d in rec.decisions.values()]
                bar.update(1)
        for seed in convergence_seeds:
            probe = ConvergenceProbe(seed)
            fly_mission(settings.scenario(seed), MissionConfig(strategy="cpio"), seed, probe)
            probes.append(probe)
            bar.update(1)
    curves = {}
    for name in OPTIMISERS:
        traces = [t for probe in probes for t in probe.traces[name]]
        curves[name] = np.array(traces) if traces else np.zeros((0, 1))
    summary = []
    for name in STRATEGY_NAMES:
        r = results[name]
        if name in curves and len(curves[name]):
            final = float(curves[name][:, -1].mean())
        else:
            final = 1.0 if name == "exhaustive" else float("nan")
        summary.append([name, len(seeds), *mean_std(r["targets"]), float(np.mean(r["false_alarms"])),
                        float(np.mean(r["eta"])), float(np.mean(r["time"])),
                        float(np.mean(r["evaluations"])) if r["evaluations"] else 0.0, final])
    convergence = []
    for name in OPTIMISERS:
        scored = paths_scored_per_iteration(name)
        c = curves[name]
        for t in range(c.shape[1] if len(c) else 0):
            convergence.append([name, t, int(scored[t]), float(c[:, t].mean()), float(c[:, t].std()), len(c)])
    tables = {
        "": csv_text(["strategy", "runs", "targets_mean", "targets_std", "false_alarms_mean", "eta_mean",
                      "run_time_s_mean", "paths_scored_per_decision", "final_fraction_of_optimum"], summary),
        "_convergence": csv_text(["strategy", "iteration", "paths_scored", "fraction_of_optimum_mean",
                                  "fraction_of_optimum_std", "decisions"], convergence),
    }
    return publish(settings.out, "fig8", tables, figure(summary, convergence), settings.on_figure)


def figure(summary: list, convergence: list) -> Figure:
    fig = Figure(figsize=(11, 4))
    a, b = fig.subplots(1, 2)
    for name in OPTIMISERS:
        rows = [r for r in convergence if r[0] == name]
        a.plot([r[1] for r in rows], [r[3] for r in rows], label=name.upper(), lw=1.5)
    a.set(xlabel="iteration", ylabel="best J1 / exact optimum", title="(a) convergence (same decision states)")
    a.legend()
    names = [r[0] for r in summary]
    b.bar(range(len(names)), [r[2] for r in summary], yerr=[r[3] for r in summary], capsize=4,
          color=["C3" if n == "cpio" else "C0" for n in names])
    b.set_xticks(range(len(names)), [n.upper() if n in OPTIMISERS else n for n in names], fontsize=8)
    b.set(ylabel="targets found (mean ± std)", title=f"(b) targets found, {summary[0][1]} runs")
    fig.tight_layout()
    return fig
