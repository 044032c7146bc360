"""Coevolution PIO with the cooperation-competition mechanism (Section 3.3).

One subgroup of C1 pigeons per searching UAV, all run in lock-step by one kernel
(`planner.search.pio.pio_flocks`).

Cooperation: every subgroup scores its pigeons against the shared map and against the other
subgroups' *current* best paths (re-read every iteration), so F_r of eq. (10) steers the UAVs
apart while they are being optimised. Each subgroup's row starts as its UAV's previous prediction,
and its first pigeon on the rest of that path (warm start, as for PIO, PSO and GA).

Competition: the shared rule (`planner.search.competition.compete`) with two best paths
conflicting when, at the same future step, they claim the same cell or come within `proximity`
(sqrt 2, where F_r turns into the -100 penalty); a conflicting subgroup re-optimises (a fresh
basic-PIO run) with the kept paths hard and the undecided ones soft (F_r). A re-optimised path
may stay within sqrt 2 only when no path avoids it."""

from __future__ import annotations

import numpy as np

from planner.search.competition import compete, fixed_others
from planner.search.flock import decision_from_choices, turn_ordered
from planner.search.pio import PioParams, PioStrategy, run_pio
from planner.search.problem import Decision, StepProblem

PROXIMITY = float(np.sqrt(2.0))


class CpioStrategy(PioStrategy):
    """CPIO: coevolving subgroups (cooperation), then the competition rule. `best_path` (one
    subgroup alone against fixed others) is basic PIO."""

    name = "cpio"

    def __init__(self, params: PioParams | None = None, seed: int = 0, proximity: float = PROXIMITY,
                 warm_start: bool = True) -> None:
        super().__init__(params, seed, warm_start)
        self.proximity = proximity

    def coevolve(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        """Cooperation: all subgroups optimised together, each against the others' current bests."""
        searchers = problem.searchers
        ids = {s.uav_id for s in searchers}
        fixed, fixed_hard = fixed_others(problem, ids)
        start = [problem.predicted.get(s.uav_id) for s in searchers]
        warm = None
        if self.memory is not None:
            table = turn_ordered(problem.successors)
            warm = [self.memory.warm_row(s, table, problem.np_steps) for s in searchers]
        best, others, trace, evaluations = run_pio(problem, searchers, fixed, fixed_hard, self.params, rng, start,
                                                   warm)
        n_fixed = fixed.shape[0]
        out: dict[int, Decision | None] = {}
        for g, s in enumerate(searchers):
            keep = np.ones(others.shape[0], dtype=np.bool_)
            keep[n_fixed + g] = False
            o = np.ascontiguousarray(others[keep])
            h = np.concatenate([fixed_hard, np.zeros(len(searchers) - 1, dtype=np.bool_)])
            out[s.uav_id] = decision_from_choices(problem, s, o, h, best[g], evaluations // len(searchers), trace[g])
        return out

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        decided = compete(problem, lambda p, s, o, h: self.best_path(p, s, o, h, rng), self.coevolve(problem, rng),
                          self.proximity, undecided_soft=True)
        if self.memory is not None:
            for uid, d in decided.items():
                self.memory.remember(uid, d)
        return decided
