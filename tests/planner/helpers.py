"""Shared builders and checkers for planner tests: small random scenarios and the safety
invariants every closed plan must satisfy."""

from __future__ import annotations

import os

import numba
import numpy as np
from hypothesis import example

from planner.environment import SearchMap, Sensor
from planner.motion import HEADING_DX, HEADING_DY, STEPS, MoveCosts, OrientationConstraint
from planner.plan import Plan
from planner.return_exact import UNREACHABLE, return_table
from planner.scenario import Scenario, UavSpec

#: Whether the tests take the cases of `.ci/run`'s pass without the JIT (NUMBA_DISABLE_JIT=1), where
#: every kernel runs as Python, 30-100 times slower than compiled; `GCS_JIT_OFF_CASES=1` takes them
#: with the JIT on, where the kernel record checks that they reach the kernels the full cases reach.
JIT_OFF = bool(numba.config.DISABLE_JIT) or os.environ.get("GCS_JIT_OFF_CASES") == "1"


def without_jit(jit_on, jit_off):
    """`jit_off` in the pass without the JIT, else `jit_on`: the cheaper case (fewer property
    examples, a shorter range) that a test of whole plans runs there. Every kernel's Python body
    still runs and is checked; the full case runs with the JIT on (docs/tests.md, "Tests without
    the JIT")."""
    return jit_off if JIT_OFF else jit_on


def jit_off_examples(*cases: dict):
    """Explicit Hypothesis examples (each the test's arguments) run only in the cases without the
    JIT, above a `@given` whose `max_examples` is cut there: a few drawn examples need not reach
    every kernel the full run reaches (every optimiser's, say); these do."""
    def apply(test):
        if JIT_OFF:
            for case in reversed(cases):
                test = example(**case)(test)
        return test
    return apply


def random_scenario(seed: int, nx: int = 14, ny: int = 12, n_uavs: int = 3, range_steps: int = 40,
                    blocked_fraction: float = 0.12, oc: OrientationConstraint | None = None,
                    costs: MoveCosts = STEPS) -> Scenario | None:
    """A small random scenario whose airports can leave and come back, or None if the draw has
    none. Ranges are `range_steps` axis steps (cell sides), charged by `costs`."""
    rng = np.random.default_rng(seed)
    no_fly = rng.random((nx, ny)) < blocked_fraction
    tep = rng.random((nx, ny))
    eu = rng.random((nx, ny))
    free = np.argwhere(~no_fly)
    if len(free) < n_uavs + 3:
        return None
    picks = rng.choice(len(free), size=n_uavs + 3, replace=False)
    uavs = []
    for i in range(n_uavs):
        x, y = (int(v) for v in free[picks[i]])
        heading = int(rng.integers(8))
        if oc is not None:
            table = return_table(no_fly, (x, y), oc, costs)
            ok = False
            for g in oc.successors[heading]:
                if g < 0:
                    break
                qx, qy = x + HEADING_DX[g], y + HEADING_DY[g]
                if 0 <= qx < nx and 0 <= qy < ny and not no_fly[qx, qy] \
                        and costs.of(int(g)) + table[g, qx, qy] <= range_steps * costs.straight:
                    ok = True
            if not ok:
                return None
        uavs.append(UavSpec(i + 1, (x, y), heading, range_steps * costs.straight))
    targets = free[picks[n_uavs:]]
    return Scenario("random", SearchMap(tep, eu, no_fly), uavs, targets, Sensor(0.9, 0.1), move_costs=costs)


def assert_plan_safe(plan: Plan, scenario: Scenario, oc: OrientationConstraint) -> None:
    """The safety invariants of a closed plan (in the grid, out of no-fly cells, OC on every
    step, home within range, no two UAVs in one cell at one step)."""
    nx, ny = scenario.search_map.shape
    no_fly = scenario.search_map.no_fly
    occupied: dict[tuple[int, int, int], int] = {}
    specs = {u.uav_id: u for u in scenario.uavs}
    for u in plan.uavs:
        spec = specs[u.uav_id]
        traj = u.trajectory
        assert (traj[0].x, traj[0].y, traj[0].heading) == (*spec.airport, spec.heading), "starts at its airport pose"
        assert (traj[-1].x, traj[-1].y) == spec.airport, f"UAV {u.uav_id} ends at its airport"
        spent = sum(scenario.move_costs.of(p.heading) for p in traj[1:])
        assert spent <= u.range_units, f"UAV {u.uav_id} spent {spent} > range {u.range_units}"
        assert u.spent == spent and u.eta <= 1.0
        assert u.search_steps + u.return_steps == len(traj) - 1
        seen_return = False
        for a, b in zip(traj, traj[1:]):
            assert b.step == a.step + 1
            assert oc.allows(a.heading, b.heading), f"UAV {u.uav_id} turn {a.heading}->{b.heading} at step {b.step}"
            assert (b.x - a.x, b.y - a.y) == (HEADING_DX[b.heading], HEADING_DY[b.heading])
            assert 0 <= b.x < nx and 0 <= b.y < ny
            assert not no_fly[b.x, b.y], f"UAV {u.uav_id} in a no-fly cell at step {b.step}"
            if b.stage.value == "return":
                seen_return = True
            else:
                assert not seen_return, "no search after the return stage began"
        for p in traj:
            key = (p.step, p.x, p.y)
            assert key not in occupied, \
                f"UAVs {occupied.get(key)} and {u.uav_id} share cell ({p.x},{p.y}) at step {p.step}"
            occupied[key] = u.uav_id


def brute_force_steps_home(blocked: np.ndarray, goal: tuple[int, int], oc: OrientationConstraint,
                           start: tuple[int, int, int]) -> int:
    """Forward breadth-first search over (cell, heading) from one start pose: the reference."""
    nx, ny = blocked.shape
    if start[:2] == goal:
        return 0
    frontier = [start]
    seen = {start}
    depth = 0
    while frontier:
        depth += 1
        nxt = []
        for x, y, h in frontier:
            for g in range(8):
                if not oc.allows(h, g):
                    continue
                qx, qy = x + int(HEADING_DX[g]), y + int(HEADING_DY[g])
                if not (0 <= qx < nx and 0 <= qy < ny) or blocked[qx, qy]:
                    continue
                if (qx, qy) == goal:
                    return depth
                if (qx, qy, g) not in seen:
                    seen.add((qx, qy, g))
                    nxt.append((qx, qy, g))
        frontier = nxt
    return int(UNREACHABLE)


def brute_force_cost_home(blocked: np.ndarray, goal: tuple[int, int], oc: OrientationConstraint,
                          start: tuple[int, int, int], costs: MoveCosts) -> int:
    """Forward Dijkstra with a heap over (cell, heading) from one start pose, each move charged
    by `costs`: the reference for the weighted table."""
    import heapq

    nx, ny = blocked.shape
    if start[:2] == goal:
        return 0
    best = {start: 0}
    frontier = [(0, start)]
    while frontier:
        cost, (x, y, h) = heapq.heappop(frontier)
        if (x, y) == goal:
            return cost
        if cost > best[(x, y, h)]:
            continue
        for g in range(8):
            if not oc.allows(h, g):
                continue
            qx, qy = x + int(HEADING_DX[g]), y + int(HEADING_DY[g])
            if not (0 <= qx < nx and 0 <= qy < ny) or blocked[qx, qy]:
                continue
            nxt, c = (qx, qy, g), cost + costs.of(g)
            if c < best.get(nxt, int(UNREACHABLE)):
                best[nxt] = c
                heapq.heappush(frontier, (c, nxt))
    return int(UNREACHABLE)
