"""What a search strategy is given at one step, and what it answers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planner.motion import STEPS
from planner.reward import add_terminal_value, best_two, score_paths

NO_HORIZON = np.zeros((0, 0))


@dataclass(frozen=True)
class Searcher:
    """A UAV in the search stage at this step: its pose, the range it has `flown` and its
    `budget` (range T_i less the reserve, in the units of the problem's `move_costs`; -1: no
    range check in the candidates, eq. 8). `horizon`, when given, is the value of ending a path
    on each cell around the UAV (`planner.horizon.horizon_window`), added to J1."""

    uav_id: int
    x: int
    y: int
    heading: int
    flown: int
    budget: int
    home_table: np.ndarray = field(repr=False)
    horizon: np.ndarray | None = field(default=None, repr=False)

    @property
    def horizon_window(self) -> np.ndarray:
        """The horizon window, or an empty one (J1 alone)."""
        return NO_HORIZON if self.horizon is None else self.horizon


@dataclass
class StepProblem:
    """The shared map, the fitness settings and every vehicle's known or predicted future.

    `committed[uav_id]` and `predicted[uav_id]` are (Np, 2) arrays of cells for steps k+1..k+Np
    (x < 0 where unknown): committed paths (returning UAVs, competition winners) must not be
    shared; predicted ones (the other searchers' previous best paths) only enter F_r."""

    tep: np.ndarray
    eu: np.ndarray
    blocked: np.ndarray
    fa_map: np.ndarray
    weights: np.ndarray
    successors: np.ndarray
    np_steps: int
    searchers: list[Searcher]
    committed: dict[int, np.ndarray]
    predicted: dict[int, np.ndarray]
    tep_once: bool = False
    move_costs: np.ndarray = field(default_factory=lambda: STEPS.by_heading)

    @property
    def branching(self) -> int:
        return int(self.successors.shape[1])


@dataclass
class Decision:
    """A strategy's answer for one UAV: the chosen Np-step path (rows x, y, heading), its J1
    (plus the horizon value of its last cell when that is on), the runner-up, how many paths were
    scored, and the best fitness per iteration (optimisers)."""

    uav_id: int
    path: np.ndarray
    j1: float
    runner_up: np.ndarray | None
    runner_up_j1: float | None
    evaluations: int
    trace: np.ndarray | None = None

    def first_step(self) -> tuple[int, int, int]:
        x, y, h = self.path[0]
        return int(x), int(y), int(h)


class PathScorer:
    """Scores batches of turn-choice rows for one searcher against fixed other vehicles."""

    def __init__(self, problem: StepProblem, searcher: Searcher, others: np.ndarray, others_hard: np.ndarray) -> None:
        self.problem = problem
        self.searcher = searcher
        self.others = others
        self.others_hard = others_hard
        self.evaluations = 0

    def __call__(self, choices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p, s = self.problem, self.searcher
        choices = np.ascontiguousarray(choices, dtype=np.int64)
        n = choices.shape[0]
        scores = np.empty(n)
        depths = np.empty(n, dtype=np.int64)
        cells = np.zeros((n, p.np_steps, 3), dtype=np.int64)
        score_paths(choices, s.x, s.y, s.heading, p.successors, p.tep, p.eu, p.blocked, p.fa_map,
                    self.others, self.others_hard, p.weights, s.flown, s.budget, p.move_costs, s.home_table,
                    p.tep_once, scores, depths, cells)
        add_terminal_value(scores, depths, cells, s.x, s.y, s.horizon_window)
        self.evaluations += n
        return scores, depths, cells

    def decision(self, scores: np.ndarray, depths: np.ndarray, cells: np.ndarray,
                 trace: np.ndarray | None = None) -> Decision | None:
        best, second = best_two(scores, depths)
        if best < 0:
            return None
        runner = cells[second, : depths[second]] if second >= 0 else None
        return Decision(self.searcher.uav_id, cells[best, : depths[best]].copy(), float(scores[best]),
                        None if runner is None else runner.copy(),
                        None if second < 0 else float(scores[second]), self.evaluations, trace)
