"""The dynamic two-stage closed search (DTSCS) scheme of Section 5, Algorithm 3.

Every UAV searches while one more search step still leaves it able to get home within its range
(eq. 23, read as T_i1(k) + T_i2(k) <= T_i), and switches to the return stage at the last step
that does (eq. 24). Return orders and range changes may arrive at any step.

Steps are the time index k: every UAV moves one cell per step, and two UAVs never share a cell at
a step. What a step charges against the range is the scenario's `MoveCosts`: one unit per step
in the paper (T_i counts steps), its length over a real area (a diagonal is sqrt 2 cells), so a
range in metres is spent as the flown path spends it.

`ClosedSearch` is a step-by-step state machine: each `step()` returns a `StepRecord` that
loggers and live front-ends read; `run()` flies to the end and returns the `Plan`."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from planner.environment import footprint_cells, sense
from planner.horizon import Flyer, HorizonValue, block_size, horizon_window, team_fields, visit_reward
from planner.improve import ImproveSettings, improve_plan
from planner.motion import HEADING_DX, HEADING_DY, OC3, STEPS, MoveCosts, OrientationConstraint
from planner.plan import Plan, ReturnReason, Stage, TargetOutcome, TrajectoryPoint, UavPlan
from planner.range_check import check_return
from planner.return_exact import follow_table, return_around_reservations, return_table
from planner.return_st import st_return
from planner.reward import RewardWeights, airport_reward_map
from planner.scenario import Scenario, UavSpec
from planner.search import SearchStrategy, make_strategy
from planner.search.problem import Decision, Searcher, StepProblem
from planner.sensor_noise import reading_draw
from planner.success import Success, SuccessTally, plan_looks, success_of_looks

RETURN_PLANNERS = ("exact", "st")


@dataclass(frozen=True)
class MissionConfig:
    """Settings of one closed search. `reserve_steps` axis steps (cell sides) of range are kept
    back from every range check.

    The switch follows Algorithm 3: the strategy picks its best path, and when that path's first
    step would leave the UAV unable to get home (eq. 24) the UAV returns now. With
    `range_aware_search` the range check instead prunes candidates (eq. 8), so the UAV keeps
    searching among the moves that still get it home and its return stage shrinks to the last
    forced steps: more cells searched, but no distinct return leg.

    `horizon` adds to J1 a value for where each Np-step path ends (`planner.horizon`): the belief
    mass the UAV can still reach and come back from, discounted by distance. None (the default)
    keeps J1 as the paper defines it.

    `improve` re-solves windows of the finished plan against the whole mission
    (`planner.improve`); None (the default) keeps the plan DTSCS flew."""

    np_steps: int = 5
    oc: OrientationConstraint = OC3
    weights: RewardWeights = field(default_factory=RewardWeights)
    strategy: str = "exhaustive"
    return_planner: str = "exact"
    reserve_steps: int = 0
    range_aware_search: bool = False
    st_tracker: str = "pio"
    horizon: HorizonValue | None = None
    improve: ImproveSettings | None = None

    def __post_init__(self) -> None:
        if self.np_steps < 1:
            raise ValueError(f"Np must be at least 1, got {self.np_steps}")
        if self.np_steps > 12:
            raise ValueError(f"Np above 12 is not supported (got {self.np_steps})")
        if self.return_planner not in RETURN_PLANNERS:
            raise ValueError(f"unknown return planner {self.return_planner!r} (choose from exact, st)")
        if self.reserve_steps < 0:
            raise ValueError("reserve steps must be >= 0")


@dataclass(frozen=True)
class RangeStatus:
    """The return trigger's inputs for one UAV after a step (in the scenario's move-cost units)."""

    range_left: int
    return_cost: int
    margin: int


@dataclass
class ReturnEvent:
    uav_id: int
    step: int
    reason: ReturnReason
    return_steps: int


@dataclass
class StepRecord:
    """What happened in one step. `tep` and `eu` are the live maps: copy them to keep them.
    `expected_found[uav_id]`: that UAV's expected targets found so far (`planner.success`)."""

    step: int
    poses: dict[int, tuple[int, int, int, Stage]]
    decisions: dict[int, Decision]
    returns: list[ReturnEvent]
    reports: np.ndarray
    found: list[tuple[int, int | None]]
    ranges: dict[int, RangeStatus]
    tep: np.ndarray
    eu: np.ndarray
    expected_found: dict[int, float] = field(default_factory=dict)


@dataclass
class _Uav:
    spec: UavSpec
    table: np.ndarray
    x: int
    y: int
    heading: int
    range_units: int
    flown: int = 0
    stage: Stage = Stage.SEARCH
    search_steps: int = 0
    return_steps: int = 0
    return_reason: ReturnReason | None = None
    return_step: int | None = None
    return_plan: deque[tuple[int, int, int]] = field(default_factory=deque)
    predicted: np.ndarray | None = None
    tracking_efficiency: float | None = None
    home_path: list[tuple[int, int, int]] = field(default_factory=list)
    next_home_path: list[tuple[int, int, int]] = field(default_factory=list)
    trajectory: list[TrajectoryPoint] = field(default_factory=list)

    @property
    def home_cost(self) -> int:
        return int(self.table[self.heading, self.x, self.y])


def first_step_feasible(table: np.ndarray, successors: np.ndarray, blocked: np.ndarray, pose: tuple[int, int, int],
                        flown: int, range_units: int, costs: MoveCosts = STEPS) -> bool:
    """Whether any next step keeps flown + (its cost) + (cost home after it) within the range:
    eq. (23) at k+1."""
    x, y, h = pose
    nx, ny = blocked.shape
    for g in successors[h]:
        if g < 0:
            break
        qx, qy = x + HEADING_DX[g], y + HEADING_DY[g]
        if 0 <= qx < nx and 0 <= qy < ny and not blocked[qx, qy]:
            if not check_return(range_units - flown, int(table[g, qx, qy]), step=costs.of(int(g))).must_return:
                return True
    return False


def _leaves_and_returns(spec: UavSpec, table: np.ndarray, no_fly: np.ndarray, config: MissionConfig,
                        costs: MoveCosts) -> bool:
    """Whether UAV `spec` can fly one step out of its airport and home after it within its range
    less the reserve (eq. 23 at step 1); `table` is its return table."""
    pose = (spec.airport[0], spec.airport[1], spec.heading)
    return first_step_feasible(table, config.oc.successors, no_fly, pose, 0,
                               spec.range_units - config.reserve_steps * costs.straight, costs)


def range_text(costs: MoveCosts, units: int) -> str:
    """A range in move-cost units as a person reads it: steps, or cell sides over a real area."""
    return f"{units} steps" if costs.unit_steps else f"{units / costs.straight:.1f} cell sides"


def cannot_leave_reason(spec: UavSpec, costs: MoveCosts, config: MissionConfig) -> str:
    x, y = spec.airport
    return (f"range {range_text(costs, spec.range_units)} is too short to leave its airport ({x + 1}, {y + 1}) and "
            f"come back under {config.oc.name}")


def uavs_that_cannot_leave(scenario: Scenario, config: MissionConfig) -> list[UavSpec]:
    """The UAVs of `scenario` whose range cannot pay for one step out of their airport and the way
    home after it (eq. 23 at step 1): they stay on the ground."""
    no_fly, costs = scenario.search_map.no_fly, scenario.move_costs
    return [spec for spec in scenario.uavs
            if not _leaves_and_returns(spec, return_table(no_fly, spec.airport, config.oc, costs), no_fly, config,
                                       costs)]


class ClosedSearch:
    """The DTSCS scheme flown step by step over a scenario (Algorithm 3).

    With `simulate_sensing` (the default) every cell flown, and each airport as its UAV climbs out
    of it (step 0), is observed by the scenario's sensor against its targets; each reading's noise
    is `reading_draw(seed, UAV, cell, visit)`, the same world the simulated vehicles fly in.
    Without it the map changes only through `observe()`, the readings real vehicles report, and
    `set_position()` moves a searching UAV to the cell it was seen in: the planner in the loop of
    a live flight."""

    def __init__(self, scenario: Scenario, config: MissionConfig | None = None, seed: int = 0,
                 strategy: SearchStrategy | None = None, simulate_sensing: bool = True) -> None:
        self.scenario = scenario
        self.simulate_sensing = simulate_sensing
        self.config = config or MissionConfig()
        self.strategy = strategy or make_strategy(self.config.strategy)
        self.map = scenario.search_map.copy()
        self.successors = self.config.oc.successors
        self.costs = scenario.move_costs
        self.reserve = self.config.reserve_steps * self.costs.straight
        self.target_grid = scenario.target_grid()
        airports = np.array([u.airport for u in scenario.uavs], dtype=np.int64)
        self.fa_map = airport_reward_map(self.map.shape, airports)
        self.weights = self.config.weights.as_array()
        self.seed = seed
        self.strategy_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
        self._looks: dict[tuple[int, int, int], int] = {}
        self.step_index = 0
        self.false_alarms = 0
        self.found_step: list[int | None] = [None] * len(scenario.targets)
        self.found_by: list[int | None] = [None] * len(scenario.targets)
        self._orders: set[int] = set()
        self._horizon_fields: dict[int, np.ndarray] = {}
        self._horizon_ids: list[int] = []
        self._horizon_step = -1
        self._home_steps: dict[int, np.ndarray] = {}
        self._improved: Plan | None = None
        self.uavs: dict[int, _Uav] = {}
        for spec in scenario.uavs:
            table = return_table(self.map.no_fly, spec.airport, self.config.oc, self.costs)
            if not _leaves_and_returns(spec, table, self.map.no_fly, self.config, self.costs):
                raise ValueError(f"UAV {spec.uav_id}: {cannot_leave_reason(spec, self.costs, self.config)}")
            uav = _Uav(spec, table, spec.airport[0], spec.airport[1], spec.heading, spec.range_units)
            uav.trajectory.append(TrajectoryPoint(0, uav.x, uav.y, uav.heading, Stage.SEARCH))
            self.uavs[spec.uav_id] = uav
        self.tally = SuccessTally(scenario.success_prior, ~scenario.search_map.no_fly, scenario.sensor.pc, self.uavs,
                                  scenario.looks_before)
        self._count_looks([(uid, u.x, u.y) for uid, u in self.uavs.items()])
        self._simulate_sensing([(uid, u.x, u.y) for uid, u in self.uavs.items()], 0)

    @property
    def done(self) -> bool:
        return all(u.stage is Stage.LANDED for u in self.uavs.values())

    def order_return(self, uav_id: int) -> None:
        """A return order: the UAV turns home at the next step."""
        self._uav(uav_id)
        self._orders.add(uav_id)

    def set_range(self, uav_id: int, range_units: int) -> None:
        """Change a UAV's range T_i mid-task (move-cost units); a cut below what the way home
        needs sends it home."""
        if range_units < self.costs.cheapest:
            raise ValueError("range must be at least 1 step")
        self._uav(uav_id).range_units = int(range_units)

    def set_position(self, uav_id: int, cell: tuple[int, int]) -> None:
        """A searching UAV was observed in `cell` (heading kept): the next decision starts there.
        Ignored for UAVs on their way home (their committed path stands) and for blocked cells."""
        u = self._uav(uav_id)
        x, y = int(cell[0]), int(cell[1])
        nx, ny = self.map.shape
        if u.stage is Stage.SEARCH and 0 <= x < nx and 0 <= y < ny and not self.map.no_fly[x, y]:
            u.x, u.y = x, y

    def observe(self, cell: tuple[int, int], reported: bool, pc: float, pf: float, by: int | None = None) -> bool:
        """Fold one sensor reading (by UAV `by`) into the shared map (eq. 2 or 3, and eq. 4),
        counting first finds and false alarms; True when it found a target for the first time."""
        x, y = cell
        self.map.observe(x, y, reported, pc, pf)
        if not reported:
            return False
        if not self.target_grid[x, y]:
            self.false_alarms += 1
            return False
        found = False
        for i, (tx, ty) in enumerate(self.scenario.targets):
            if (tx, ty) == (x, y) and self.found_step[i] is None:
                self.found_step[i] = self.step_index
                self.found_by[i] = by
                found = True
        return found

    def _uav(self, uav_id: int) -> _Uav:
        if uav_id not in self.uavs:
            raise ValueError(f"unknown UAV {uav_id}")
        return self.uavs[uav_id]

    def _future(self, uav: _Uav) -> np.ndarray:
        """A returning UAV's committed cells for the next Np steps."""
        out = np.full((self.config.np_steps, 2), -1, dtype=np.int64)
        for q, pose in enumerate(list(uav.return_plan)[: self.config.np_steps]):
            out[q] = pose[:2]
        return out

    def _plan_home(self, uav: _Uav, pose: tuple[int, int, int], start_step: int, budget: int,
                   reserved: set[tuple[int, int, int]]) -> list[tuple[int, int, int]] | None:
        """The shortest way home from `pose` (held at `start_step`) within `budget` steps that
        shares no (step, x, y) with `reserved`; None when there is none."""
        x, y, h = pose
        if int(uav.table[h, x, y]) > budget:
            return None
        path = follow_table(uav.table, pose, self.successors, self.map.no_fly, self.costs)
        if not any((start_step + 1 + i, c[0], c[1]) in reserved for i, c in enumerate(path)):
            return path
        return return_around_reservations(uav.table, pose, start_step, budget, self.successors, self.map.no_fly,
                                          reserved, self.costs)

    def _ways_home(self, exclude: int) -> dict[int, list[tuple[int, int]]]:
        """Every other flying UAV's way home from now on: committed returns and searchers' plans."""
        return {uid: [(p[0], p[1]) for p in (u.return_plan if u.stage is Stage.RETURN else u.home_path)]
                for uid, u in self.uavs.items() if uid != exclude and u.stage is not Stage.LANDED}

    def _start_return(self, uav: _Uav, reason: ReturnReason) -> ReturnEvent:
        """Turn home now along this UAV's part of the joint way-home plan, or along the ST path
        when `return_planner` is `st` and that path is clear of every other UAV's way home."""
        k = self.step_index
        path = uav.home_path
        if self.config.return_planner == "st" and path:
            others = self._ways_home(uav.spec.uav_id)
            budget = uav.range_units - uav.flown
            st = st_return(self.map.no_fly, (uav.x, uav.y, uav.heading), uav.spec.airport, self.successors,
                           uav.table, self.config.np_steps, budget, make_strategy(self.config.st_tracker).best_path,
                           others, k, self.costs)
            taken = {(i, c[0], c[1]) for rows in others.values() for i, c in enumerate(rows)}
            if st is not None and not any((i, c[0], c[1]) in taken for i, c in enumerate(st.path)):
                path = st.path
                uav.tracking_efficiency = st.tracking_efficiency
        uav.stage = Stage.RETURN
        uav.return_reason = reason
        uav.return_step = k
        uav.return_plan = deque(path)
        return ReturnEvent(uav.spec.uav_id, k, reason, len(path))

    def _decide_searchers(self, returns: list[ReturnEvent]) -> dict[int, Decision]:
        """The strategy's decisions for every searcher, kept only while all UAVs keep a joint,
        conflict-free way home within their ranges (eq. 23 for the team).

        Invariant: the ways home of all flying UAVs (committed returns, and each searcher's plan
        from its current pose) never share a cell at a step. A searcher whose chosen step would
        break eq. (23) (reason `range`), that has no feasible step (`boxed_in`), or after whose
        step no way home clear of the others' exists (`separation`) turns home now along its
        plan, which the invariant keeps clear; the others then decide again around it."""
        k = self.step_index
        while True:
            searchers = [u for u in self.uavs.values() if u.stage is Stage.SEARCH]
            if not searchers:
                return {}
            answers = self.strategy.decide(self._problem(searchers), self.strategy_rng)
            reserved = {(k + 1 + i, p[0], p[1]) for u in self.uavs.values() if u.stage is Stage.RETURN
                        for i, p in enumerate(u.return_plan)}
            plans: dict[int, list[tuple[int, int, int]]] = {}
            turning: tuple[_Uav, ReturnReason] | None = None
            for u in searchers:
                d = answers.get(u.spec.uav_id)
                if d is None:
                    feasible = first_step_feasible(u.table, self.successors, self.map.no_fly, (u.x, u.y, u.heading),
                                                   u.flown, u.range_units - self.reserve, self.costs)
                    turning = (u, ReturnReason.BOXED_IN if feasible else ReturnReason.RANGE)
                    break
                x, y, h = d.first_step()
                step = self.costs.of(h)
                budget = u.range_units - self.reserve - u.flown - step
                if check_return(u.range_units - u.flown, int(u.table[h, x, y]), reserve=self.reserve,
                                step=step).must_return:
                    turning = (u, ReturnReason.RANGE)
                    break
                path = self._plan_home(u, (x, y, h), k + 1, budget, reserved)
                if path is None:
                    turning = (u, ReturnReason.SEPARATION)
                    break
                plans[u.spec.uav_id] = path
                reserved |= {(k + 2 + i, p[0], p[1]) for i, p in enumerate(path)}
            if turning is None:
                for uid, path in plans.items():
                    self.uavs[uid].next_home_path = path
                return {uid: d for uid, d in answers.items() if d is not None}
            returns.append(self._start_return(*turning))

    def _problem(self, searchers: list[_Uav]) -> StepProblem:
        committed = {uid: self._future(u) for uid, u in self.uavs.items() if u.stage is Stage.RETURN}
        predicted = {}
        for u in searchers:
            if u.predicted is not None:
                predicted[u.spec.uav_id] = u.predicted
        prune = self.config.range_aware_search
        windows = self._horizon_windows(searchers)
        states = [Searcher(u.spec.uav_id, u.x, u.y, u.heading, u.flown,
                           u.range_units - self.reserve if prune else -1, u.table,
                           windows.get(u.spec.uav_id)) for u in searchers]
        return StepProblem(self.map.tep, self.map.eu, self.map.no_fly, self.fa_map, self.weights, self.successors,
                           self.config.np_steps, states, committed, predicted, move_costs=self.costs.by_heading)

    def _horizon_windows(self, searchers: list[_Uav]) -> dict[int, np.ndarray]:
        """Each searcher's horizon-value window (none when the option is off). The fields are
        recomputed together every `HorizonValue.period` steps from the shared map
        (`planner.horizon.team_fields`)."""
        settings = self.config.horizon
        if settings is None or not searchers:
            return {}
        k = self.step_index
        ids = [u.spec.uav_id for u in searchers]
        if self._horizon_ids != ids or k - self._horizon_step >= settings.period(self.map.shape):
            flyers = []
            cell = self.costs.straight
            for u in searchers:
                if u.spec.uav_id not in self._home_steps:
                    self._home_steps[u.spec.uav_id] = u.table.min(axis=0).astype(np.int64) // cell
                flyers.append(Flyer((u.x, u.y), (u.range_units - self.reserve - u.flown) // cell,
                                    self._home_steps[u.spec.uav_id]))
            reward = visit_reward(self.map.tep, self.map.eu, self.weights, self.map.no_fly)
            radius = self.config.np_steps if settings.radius is None else settings.radius
            fields = team_fields(reward, self.map.no_fly, flyers, radius, settings.length, block_size(self.map.shape))
            self._horizon_fields = dict(zip(ids, fields))
            self._horizon_ids, self._horizon_step = ids, k
        scale = settings.weight * self.config.np_steps
        return {u.spec.uav_id: horizon_window(self._horizon_fields[u.spec.uav_id], (u.x, u.y), self.config.np_steps,
                                              scale) for u in searchers}

    def step(self) -> StepRecord:
        """Fly every UAV one step (Algorithm 3, one iteration of k)."""
        if self.done:
            raise RuntimeError("the mission is over")
        returns: list[ReturnEvent] = []
        for uid, u in self.uavs.items():
            if u.stage is not Stage.SEARCH:
                continue
            if uid in self._orders:
                returns.append(self._start_return(u, ReturnReason.ORDER))
            elif u.flown + u.home_cost > u.range_units - self.reserve:
                returns.append(self._start_return(u, ReturnReason.RANGE_CUT))
        self._orders.clear()

        decisions = self._decide_searchers(returns)

        self.step_index += 1
        k = self.step_index
        moved = []
        for uid, u in self.uavs.items():
            if u.stage is Stage.LANDED:
                continue
            if u.stage is Stage.SEARCH:
                u.x, u.y, u.heading = decisions[uid].first_step()
                u.flown += self.costs.of(u.heading)
                u.home_path = u.next_home_path
                u.search_steps += 1
                rest = decisions[uid].path[1:, :2]
                u.predicted = np.full((self.config.np_steps, 2), -1, dtype=np.int64)
                u.predicted[: len(rest)] = rest
            elif u.return_plan:
                u.x, u.y, u.heading = u.return_plan.popleft()
                u.flown += self.costs.of(u.heading)
                u.return_steps += 1
            else:
                u.stage = Stage.LANDED
                continue
            moved.append((uid, u.x, u.y))
            u.trajectory.append(TrajectoryPoint(k, u.x, u.y, u.heading, u.stage))
            if u.stage is Stage.RETURN and not u.return_plan:
                u.stage = Stage.LANDED

        self._count_looks(moved)
        reports, found = self._simulate_sensing(moved, k)
        ranges = {uid: RangeStatus(u.range_units - u.flown, u.home_cost, u.range_units - u.flown - u.home_cost)
                  for uid, u in self.uavs.items()}
        poses = {uid: (u.x, u.y, u.heading, u.stage) for uid, u in self.uavs.items()}
        return StepRecord(k, poses, decisions, returns, reports, found, ranges, self.map.tep, self.map.eu,
                          dict(self.tally.by_uav))

    def _count_looks(self, looks: list[tuple[int, int, int]]) -> None:
        """Credit each UAV of `looks` (uav, x, y) with what its reading adds to the expected finds."""
        radius = self.scenario.sensor.footprint_radius
        for uid, x, y in looks:
            for cell in footprint_cells(x, y, radius, self.map.shape):
                self.tally.look(uid, *cell)

    def _simulate_sensing(self, looks: list[tuple[int, int, int]], k: int
                          ) -> tuple[np.ndarray, list[tuple[int, int | None]]]:
        """The scenario's sensor reads under every (UAV, x, y) of `looks` (eq. 2-4); the reports
        and the first finds. Nothing happens without `simulate_sensing`."""
        if not (looks and self.simulate_sensing):
            return np.zeros((0, 4), dtype=np.int64), []
        draws = []
        for uid, x, y in looks:
            for cell in footprint_cells(x, y, self.scenario.sensor.footprint_radius, self.map.shape):
                visit = self._looks.get((uid, *cell), 0)
                self._looks[(uid, *cell)] = visit + 1
                draws.append(reading_draw(self.seed, uid, *cell, visit))
        cells = np.array([(x, y) for _, x, y in looks], dtype=np.int64)
        reports = sense(self.map, self.target_grid, cells, self.scenario.sensor, np.array(draws))
        return reports, self._score_reports(reports, k)

    def _score_reports(self, reports: np.ndarray, k: int) -> list[tuple[int, int | None]]:
        """Count false alarms and first finds; returns (target index, uav id) of new finds."""
        positions = {(u.x, u.y): uid for uid, u in self.uavs.items() if u.trajectory[-1].step == k}
        radius = self.scenario.sensor.footprint_radius
        found = []
        for x, y, reported, present in reports:
            if not reported:
                continue
            if not present:
                self.false_alarms += 1
                continue
            for i, (tx, ty) in enumerate(self.scenario.targets):
                if (tx, ty) == (x, y) and self.found_step[i] is None:
                    self.found_step[i] = k
                    self.found_by[i] = self._observer(x, y, radius, positions)
                    found.append((i, self.found_by[i]))
        return found

    @staticmethod
    def _observer(x: int, y: int, radius: int, positions: dict[tuple[int, int], int]) -> int | None:
        for (px, py), uid in positions.items():
            if abs(px - x) <= radius and abs(py - y) <= radius:
                return uid
        return None

    def run(self, max_steps: int | None = None) -> Iterator[StepRecord]:
        """Yield every step's record until all UAVs have landed."""
        limit = max_steps or (max(u.range_units for u in self.uavs.values()) // self.costs.cheapest + 1)
        while not self.done:
            if self.step_index > limit:
                raise RuntimeError("the mission did not end within the range")
            yield self.step()

    def plan(self) -> Plan:
        """The closed trajectories and outcomes so far; once every UAV has landed, improved by
        `planner.improve` when the config asks for it."""
        if self.config.improve is not None and self.done:
            if self._improved is None:
                tables = {uid: u.table for uid, u in self.uavs.items()}
                self._improved = improve_plan(self._dtscs_plan(), self.scenario, self.config.oc, self.reserve,
                                              self.seed, self.config.improve, tables)
            return self._improved
        return self._dtscs_plan()

    def _dtscs_plan(self) -> Plan:
        uavs = [UavPlan(u.spec.uav_id, u.spec.airport, u.spec.heading, u.range_units, list(u.trajectory),
                        u.search_steps, u.return_steps, u.return_reason, u.return_step, u.tracking_efficiency,
                        u.flown)
                for u in self.uavs.values()]
        targets = [TargetOutcome(int(x), int(y), self.found_step[i], self.found_by[i])
                   for i, (x, y) in enumerate(self.scenario.targets)]
        settings = {"np": self.config.np_steps, "oc": self.config.oc.name, "strategy": self.strategy.name,
                    "return_planner": self.config.return_planner, "reserve_steps": self.config.reserve_steps}
        if not self.costs.unit_steps:
            settings["move_costs"] = {"straight": self.costs.straight, "diagonal": self.costs.diagonal}
        if self.config.horizon is not None:
            settings["horizon_value"] = self.config.horizon.as_dict(self.config.np_steps, self.map.shape)
        return Plan(self.scenario.name, *self.map.shape, self.map.no_fly.copy(), uavs, targets, self.false_alarms,
                    settings, self.success(), self.costs, self.scenario.unit_m,
                    [(int(x), int(y), int(k)) for x, y, k in self.scenario.found_before])

    def success(self) -> Success:
        """Expected targets found by the trajectories so far, under the scenario's prior and
        sensor (`planner.success`): every cell flown and each airport at step 0 is one reading.
        A later sortie of a campaign counts against the campaign's first prior, after the
        earlier sorties' looks (`Scenario.looks_before`): what this sortie adds."""
        s = self.scenario
        trajectories = {uid: [(p.step, p.x, p.y) for p in u.trajectory] for uid, u in self.uavs.items()}
        looks = plan_looks(trajectories, s.sensor.footprint_radius, s.search_map.shape)
        return success_of_looks(s.success_prior, ~s.search_map.no_fly, s.sensor.pc, looks, self.uavs, s.looks_before)


def fly(scenario: Scenario, config: MissionConfig | None = None, seed: int = 0) -> Plan:
    """Run the whole closed search and return the plan."""
    search = ClosedSearch(scenario, config, seed)
    for _ in search.run():
        pass
    return search.plan()
