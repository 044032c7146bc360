"""Search-stage decision strategies (one Np-step decision per step for every searching UAV).

Every strategy scores paths with the same fitness (`planner.reward.score_paths`) and resolves
conflicts between UAVs with the same competition rule (`planner.search.competition`)."""


from typing import Protocol

import numpy as np

from planner.search.cpio import CpioStrategy
from planner.search.exhaustive import ExhaustiveStrategy
from planner.search.ga import GaStrategy
from planner.search.lawnmower import LawnmowerStrategy
from planner.search.pio import PioStrategy
from planner.search.problem import Decision, Searcher, StepProblem
from planner.search.pso import PsoStrategy


class SearchStrategy(Protocol):
    """One decision per step for all searching UAVs, and one UAV's best path against fixed others."""

    name: str

    def decide(self, problem: StepProblem, rng: np.random.Generator) -> dict[int, Decision | None]: ...

    def best_path(self, problem: StepProblem, searcher: Searcher, others: np.ndarray,
                  others_hard: np.ndarray) -> Decision | None: ...


STRATEGIES: dict[str, type[SearchStrategy]] = {
    "cpio": CpioStrategy,
    "exhaustive": ExhaustiveStrategy,
    "ga": GaStrategy,
    "lawnmower": LawnmowerStrategy,
    "pio": PioStrategy,
    "pso": PsoStrategy,
}


def make_strategy(name: str) -> SearchStrategy:
    """A strategy by name; ValueError listing the known ones otherwise."""
    if name not in STRATEGIES:
        raise ValueError(f"unknown search strategy {name!r} (choose from {', '.join(sorted(STRATEGIES))})")
    return STRATEGIES[name]()
