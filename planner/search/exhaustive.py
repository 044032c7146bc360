"""Exhaustive enumeration of every Np-step path: the exact single-UAV optimum of J1 and the
reference every optimiser is judged against (3^Np paths under 3OC)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from planner.search.competition import compete
from planner.search.problem import Decision, PathScorer, Searcher, StepProblem


@lru_cache(maxsize=32)
def all_choices(branching: int, np_steps: int) -> np.ndarray:
    """Every turn-choice row, (branching^Np x Np), in lexicographic order."""
    grids = np.indices((branching,) * np_steps).reshape(np_steps, -1).T
    return np.ascontiguousarray(grids, dtype=np.int64)


class ExhaustiveStrategy:
    """Scores all branching^Np paths of each UAV and applies the competition rule."""

    name = "exhaustive"

    def best_path(self, problem: StepProblem, searcher: Searcher, others: np.ndarray,
                  others_hard: np.ndarray) -> Decision | None:
        scorer = PathScorer(problem, searcher, others, others_hard)
        return scorer.decision(*scorer(all_choices(problem.branching, problem.np_steps)))

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]:
        return compete(problem, self.best_path)
