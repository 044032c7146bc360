"""The upper bound on expected finds (`planner.bound`): no plan of the planner's exceeds it, and on
tiny areas it is at least the exact optimum (the `HEADINGS` model solved as a MIP to
optimality), which is at least the planner's plan. Larger checks: benchmarks/success_bound.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from planner.bound import BoundModel, exact_optimum, scenario_dual, success_bound
from planner.bound_lagrange import _best_walk
from planner.dtscs import MissionConfig, fly
from planner.environment import Sensor
from planner.horizon import HorizonValue
from planner.improve import ImproveSettings
from planner.motion import HEADING_DX, HEADING_DY, OC3, OC4, STEPS, cell_lengths
from planner.plan import Plan
from planner.scenario import Scenario
from tests.planner.helpers import JIT_OFF, jit_off_examples, random_scenario, without_jit

METRES = cell_lengths()


def _scenario(seed: int, size: int, uavs: int, range_cells: int, footprint: int) -> Scenario | None:
    scenario = random_scenario(seed, nx=size, ny=size, n_uavs=uavs, range_steps=range_cells, oc=OC3, costs=METRES)
    if scenario is None:
        return None
    scenario.sensor = Sensor(0.9, 0.1, footprint)
    return scenario


def _expected(plan: Plan) -> float:
    assert plan.success is not None
    return plan.success.expected


def _plans(scenario: Scenario, seed: int) -> dict[str, float]:
    """Expected finds of the planner's default plan for an area (CPIO + horizon value, the whole
    mission improved), of DTSCS's (the same, not improved) and of paper CPIO."""
    configs = {"default": MissionConfig(strategy="cpio", horizon=HorizonValue(), improve=ImproveSettings())}
    if not JIT_OFF:     # the pass without the JIT: the default plan reaches every kernel the other two do
        configs |= {"cpio + horizon": MissionConfig(strategy="cpio", horizon=HorizonValue()),
                    "cpio": MissionConfig(strategy="cpio")}
    return {name: _expected(fly(scenario, config, seed=seed)) for name, config in configs.items()}


@jit_off_examples(dict(seed=7, size=8, uavs=2, range_cells=10, footprint=1, model=BoundModel.BLOCKS))
@settings(max_examples=without_jit(6, 1))
@given(seed=st.integers(0, 10_000), size=st.integers(6, 12), uavs=st.integers(1, 3),
       range_cells=st.integers(4, without_jit(30, 10)),
       footprint=st.sampled_from([0, 0, 1]), model=st.sampled_from(list(BoundModel)))
def test_no_plan_exceeds_the_bound(seed, size, uavs, range_cells, footprint, model) -> None:
    scenario = _scenario(seed, size, uavs, range_cells, footprint)
    if scenario is None:
        return
    seconds = 1.0 if model is BoundModel.LAGRANGIAN else 60.0     # the dual: every iterate bounds
    bound = success_bound(scenario, OC3, time_limit_s=seconds, mip=False, model=model, block=2)
    assert bound.finished
    for name, expected in _plans(scenario, seed).items():
        assert expected <= bound.value + 1e-6, f"{name}: {expected} > bound {bound.value} ({model.value})"


def test_bound_holds_in_metres_and_is_tighter_than_in_steps() -> None:
    """The same ranges counted in steps (diagonals free) bound more than in metres, and the metre
    bound still holds over the plan made in metres."""
    scenario = _scenario(3, 10, 2, 16, 0)
    assert scenario is not None
    metres = success_bound(scenario, OC3, 60, mip=False, model=BoundModel.CELLS)
    steps = Scenario(scenario.name, scenario.search_map, [
        type(u)(u.uav_id, u.airport, u.heading, u.range_units // METRES.straight) for u in scenario.uavs],
        scenario.targets, scenario.sensor, move_costs=STEPS)
    in_steps = success_bound(steps, OC3, 60, mip=False, model=BoundModel.CELLS)
    plan = max(_plans(scenario, 3).values())
    assert plan <= metres.value < in_steps.value


@pytest.mark.parametrize("seed, size, uavs, range_cells", [(5, 8, 2, 14), (12, 10, 3, 12)])
def test_bound_exact_optimum_and_plan_in_order(seed, size, uavs, range_cells) -> None:
    scenario = _scenario(seed, size, uavs, range_cells, 0)
    assert scenario is not None
    exact = exact_optimum(scenario, OC3, time_limit_s=60)
    assert exact.optimal, "the tiny MIP solves to optimality"
    bound = success_bound(scenario, OC3, 60, mip=False)
    for expected in _plans(scenario, seed).values():
        assert bound.value + 1e-6 >= exact.mip_best >= expected - 1e-6
    assert math.isclose(exact.mip_best, exact.mip_dual, rel_tol=1e-5)


def test_campaign_looks_before_lower_the_bound() -> None:
    """A later sortie can add only what the earlier looks left: every cell read once before."""
    scenario = _scenario(5, 8, 2, 14, 0)
    assert scenario is not None
    first = success_bound(scenario, OC3, 60, mip=False)
    scenario.looks_before = np.ones(scenario.search_map.shape, dtype=np.int64)
    later = success_bound(scenario, OC3, 60, mip=False)
    assert math.isclose(later.value, first.value * 0.1, rel_tol=1e-6)
    success = fly(scenario, MissionConfig(strategy="cpio", horizon=HorizonValue()), seed=5).success
    assert success is not None
    plan = success.expected
    assert plan <= later.value + 1e-6


def test_time_out_is_said_not_guessed() -> None:
    scenario = _scenario(5, 8, 2, 14, 0)
    assert scenario is not None
    late = success_bound(scenario, OC3, time_limit_s=0.0)
    assert not late.finished and late.share(1.0) is None


def test_a_block_no_node_can_read_then_builds() -> None:
    """Tiny area 11 of benchmarks/success_bound.py: in 2 x 2 blocks, a block readable in a window
    with no node of that window near it (its reading cap holds no occupancy) once failed to build."""
    from benchmarks.success_bound import tiny_instance

    scenario = tiny_instance(11)
    bound = success_bound(scenario, OC3, 60, mip=False, model=BoundModel.BLOCKS, block=2)
    assert bound.finished
    assert max(_plans(scenario, 11).values()) <= bound.value


def _walks(successors: np.ndarray, free: np.ndarray, airport: tuple[int, int], heading: int, steps: int):
    """Every walk of at most `steps` moves from the airport pose, on free cells, along
    `successors`, landing on the airport after one move at least: the naive reference."""
    nx, ny = free.shape
    stack = [((airport[0], airport[1], heading),)]
    while stack:
        walk = stack.pop()
        x, y, h = walk[-1]
        if len(walk) > 1 and (x, y) == airport:
            yield walk[1:]
        if len(walk) > steps:
            continue
        for g in successors[h]:
            if g < 0:
                break
            qx, qy = x + int(HEADING_DX[g]), y + int(HEADING_DY[g])
            if 0 <= qx < nx and 0 <= qy < ny and free[qx, qy]:
                stack.append((*walk, (qx, qy, int(g))))


def _kernel(reward, free, successors, move_cost, airport, heading, steps):
    nx, ny = free.shape
    tmin = np.zeros((nx, ny), dtype=np.int64)
    tmax = np.where(free[None], steps, -1).repeat(8, axis=0).astype(np.int64)
    choice = np.empty((steps + 1, 8, nx, ny), dtype=np.int8)
    path = np.zeros((steps + 1, 3), dtype=np.int64)
    value, n = _best_walk(reward, tmin, tmax, successors, HEADING_DX, HEADING_DY, move_cost, airport[0], airport[1],
                          heading, steps, choice, path)
    return value, [tuple(int(v) for v in p) for p in path[:n]]


def test_best_walk_on_a_corridor_by_hand() -> None:
    """A 4 x 1 corridor, axis moves only (4OC), the airport at its west end: in 4 steps the best
    walk goes two cells east and back (rewards 1 + 2 + 1 + 0); in 6 it reaches the third cell
    (1 + 2 + 4 + 2 + 1 + 0); a move's price comes off every move."""
    reward = np.array([[0.0], [1.0], [2.0], [4.0]])
    free = np.ones((4, 1), dtype=bool)
    succ = OC4.successors
    value, walk = _kernel(reward, free, succ, np.zeros(8), (0, 0), 2, 4)
    assert value == 4.0 and walk == [(1, 0, 2), (2, 0, 2), (1, 0, 6), (0, 0, 6)]
    assert _kernel(reward, free, succ, np.zeros(8), (0, 0), 2, 6)[0] == 10.0
    assert _kernel(reward, free, succ, np.full(8, 0.5), (0, 0), 2, 4)[0] == 2.0
    assert _kernel(reward, free, succ, np.zeros(8), (0, 0), 2, 1)[0] == -math.inf    # one move cannot come back


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_best_walk_is_the_best_of_every_walk(seed) -> None:
    """The DP's value against every walk enumerated (3OC on a 7 x 7 grid with a no-fly cell,
    at most 10 moves, each move priced by its heading), and its walk is worth that value."""
    rng = np.random.default_rng(seed)
    free = np.ones((7, 7), dtype=bool)
    free[4, 2] = False
    reward = rng.random((7, 7))
    move_cost = np.where(np.arange(8) % 2 == 1, 0.3, 0.2)
    airport, heading, steps = (3, 3), int(rng.integers(8)), 10
    value, walk = _kernel(reward, free, OC3.successors, move_cost, airport, heading, steps)
    worth = [sum(reward[x, y] - move_cost[h] for x, y, h in w) for w in _walks(OC3.successors, free, airport,
                                                                              heading, steps)]
    assert math.isclose(value, max(worth))
    assert math.isclose(value, sum(reward[x, y] - move_cost[h] for x, y, h in walk))


@pytest.mark.parametrize("seed, size, uavs, range_cells, footprint", [(5, 8, 2, 14, 0), (12, 10, 3, 12, 1)])
def test_every_lagrangian_value_bounds_the_exact_optimum(seed, size, uavs, range_cells, footprint) -> None:
    """Each value of the dual is >= the HEADINGS LP >= the exact optimum >= the planner's plans,
    and its column generation meets the LP (Lagrangian duality: the minimum is the LP's), its
    master's floor from below."""
    scenario = _scenario(seed, size, uavs, range_cells, footprint)
    assert scenario is not None
    exact = exact_optimum(scenario, OC3, time_limit_s=60)
    lp = success_bound(scenario, OC3, 60, mip=False, model=BoundModel.HEADINGS)
    trace: list[float] = []
    dual = scenario_dual(scenario, OC3, 60, max_iterations=without_jit(300, 6), trace=trace)
    assert len(trace) == dual.iterations and dual.value == min(trace)
    assert min(trace) >= lp.lp * (1 - 1e-6) and dual.floor <= lp.lp * (1 + 1e-6)
    if exact.optimal:
        assert lp.lp + 1e-6 >= exact.mip_best
    if not JIT_OFF:
        assert dual.value == pytest.approx(lp.lp, rel=1e-5)
        assert max(_plans(scenario, seed).values()) <= dual.value + 1e-6


def test_the_dual_joins_a_loose_lp_model() -> None:
    """Where HEADINGS does not fit `max_arcs`, success_bound runs the LP and then the dual in the
    time left: the bound is the smaller, named by its model, and no plan passes it."""
    scenario = _scenario(5, 8, 2, 14, 0)
    assert scenario is not None
    bound = success_bound(scenario, OC3, 3.0, mip=False, max_arcs=100)
    assert bound.finished and bound.iterations >= 2
    assert bound.value == min(bound.lp, bound.lagrangian)
    assert bound.model is (BoundModel.LAGRANGIAN if bound.lagrangian < bound.lp else BoundModel.BLOCKS)
    assert max(_plans(scenario, 5).values()) <= bound.value + 1e-6
