import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import gcs.flight.return_trigger
from planner.dtscs import ClosedSearch, MissionConfig, first_step_feasible, fly
from planner.motion import OC3, OC4, OC8, STEPS, cell_lengths
from planner.plan import ReturnReason, Stage
from planner.range_check import check_return
from planner.scenario import paper_scenario
from tests.planner.helpers import assert_plan_safe, random_scenario

OCS = [OC3, OC4, OC8]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(seed=st.integers(0, 100_000), oc_index=st.integers(0, 2), np_steps=st.integers(1, 4),
       n_uavs=st.integers(1, 4), range_steps=st.integers(12, 45), return_planner=st.sampled_from(["exact", "st"]),
       range_aware=st.booleans(), costs=st.sampled_from([STEPS, cell_lengths()]))
def test_random_closed_plans_are_safe(seed, oc_index, np_steps, n_uavs, range_steps, return_planner, range_aware,
                                      costs):
    """Steps charged as steps (the paper) or as lengths (a real area): the invariants hold."""
    oc = OCS[oc_index]
    scenario = random_scenario(seed, n_uavs=n_uavs, range_steps=range_steps, oc=oc, costs=costs)
    if scenario is None:
        return
    config = MissionConfig(np_steps=np_steps, oc=oc, return_planner=return_planner, range_aware_search=range_aware)
    plan = fly(scenario, config, seed=seed)
    assert_plan_safe(plan, scenario, oc)
    assert all(u.eta <= 1.0 for u in plan.uavs)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 100_000), order_step=st.integers(1, 15), cut=st.integers(1, 40))
def test_return_orders_and_range_changes_keep_plans_safe(seed, order_step, cut):
    scenario = random_scenario(seed, n_uavs=3, range_steps=40, oc=OC3)
    if scenario is None:
        return
    search = ClosedSearch(scenario, MissionConfig(np_steps=3), seed=seed)
    first, second = scenario.uavs[0].uav_id, scenario.uavs[-1].uav_id
    for record in search.run():
        if record.step == order_step:
            search.order_return(first)
        if record.step == order_step + 1 and len(scenario.uavs) > 1:
            search.set_range(second, max(record.step + 1, cut))
    plan = search.plan()
    by_id = {u.uav_id: u for u in plan.uavs}
    ordered = by_id[first]
    assert ordered.return_step is not None and ordered.return_step <= order_step
    if ordered.return_step == order_step:
        assert ordered.return_reason is ReturnReason.ORDER
    for u in plan.uavs:
        assert (u.trajectory[-1].x, u.trajectory[-1].y) == u.airport
    # a range cut below what the way home needs is overrun only by a UAV already on its way home
    cut_step = order_step + 1
    for u in plan.uavs:
        on_way_home_at_cut = u.uav_id == second and u.return_step is not None and u.return_step <= cut_step
        if not on_way_home_at_cut:
            assert len(u.trajectory) - 1 <= u.range_units
        if u.return_reason is ReturnReason.RANGE_CUT:
            assert u.uav_id == second and u.return_step == cut_step
    assert_plan_safe_except_range(plan, scenario)


def assert_plan_safe_except_range(plan, scenario):
    import copy
    relaxed = copy.deepcopy(plan)
    for u in relaxed.uavs:
        u.range_units = max(u.range_units, len(u.trajectory) - 1)
    assert_plan_safe(relaxed, scenario, OC3)


def test_paper_plan_is_closed_safe_and_uses_its_range():
    scenario = paper_scenario(seed=7, range_steps=130)
    plan = fly(scenario, MissionConfig(np_steps=5), seed=7)
    assert_plan_safe(plan, scenario, OC3)
    assert len(plan.uavs) == 4 and len(plan.targets) == 10
    for u in plan.uavs:
        assert u.return_reason is ReturnReason.RANGE
        assert u.search_steps > 60 and u.return_steps >= 1
        assert 0.9 <= u.eta <= 1.0
        switch = u.trajectory[u.search_steps + 1]
        assert switch.stage is Stage.RETURN and u.trajectory[u.search_steps].stage is Stage.SEARCH


def test_the_switch_is_the_last_step_that_gets_home():
    """At the switch the chosen search step would have broken eq. (23); one step earlier it did not."""
    scenario = paper_scenario(seed=3, range_steps=100)
    search = ClosedSearch(scenario, MissionConfig(np_steps=5), seed=3)
    records = list(search.run())
    for event in (e for r in records for e in r.returns):
        uav = search.uavs[event.uav_id]
        assert event.reason is ReturnReason.RANGE
        assert event.step + event.return_steps <= uav.range_units
        assert uav.search_steps == event.step


def test_same_seed_same_plan_and_different_seed_differs():
    a = fly(paper_scenario(seed=5, range_steps=80), MissionConfig(np_steps=3), seed=5)
    b = fly(paper_scenario(seed=5, range_steps=80), MissionConfig(np_steps=3), seed=5)
    c = fly(paper_scenario(seed=6, range_steps=80), MissionConfig(np_steps=3), seed=6)
    assert [u.trajectory for u in a.uavs] == [u.trajectory for u in b.uavs]
    assert a.targets == b.targets and a.false_alarms == b.false_alarms
    assert a.targets != c.targets or a.false_alarms != c.false_alarms


def test_targets_are_found_only_by_reports_in_their_cell():
    scenario = paper_scenario(seed=1, range_steps=130)
    scenario.sensor = type(scenario.sensor)(1.0, 0.0)
    plan = fly(scenario, MissionConfig(np_steps=4), seed=1)
    visited = {}
    for u in plan.uavs:
        for p in u.trajectory[1:]:
            visited.setdefault((p.x, p.y), []).append(p.step)
    assert plan.false_alarms == 0
    for t in plan.targets:
        steps = visited.get((t.x, t.y))
        assert t.found_step == (min(steps) if steps else None)


def test_a_range_too_short_to_leave_and_return_is_rejected():
    with pytest.raises(ValueError, match="too short"):
        ClosedSearch(paper_scenario(range_steps=2), MissionConfig())


def test_return_order_at_the_airport_lands_at_once():
    scenario = paper_scenario(seed=2, range_steps=60)
    search = ClosedSearch(scenario, MissionConfig(np_steps=2), seed=2)
    search.order_return(1)
    list(search.run())
    first = search.plan().uavs[0]
    assert first.return_reason is ReturnReason.ORDER and first.return_step == 0
    assert len(first.trajectory) == 1 and first.eta == 0.0
    with pytest.raises(ValueError):
        search.order_return(99)


def test_observed_search_changes_the_map_only_through_readings():
    scenario = paper_scenario(seed=4, range_steps=60)
    search = ClosedSearch(scenario, MissionConfig(np_steps=2), seed=4, simulate_sensing=False)
    before = search.map.tep.copy()
    record = search.step()
    assert len(record.reports) == 0 and np.array_equal(search.map.tep, before)
    tx, ty = (int(v) for v in scenario.targets[0])
    assert search.observe((tx, ty), True, 0.9, 0.1, by=2) is True
    assert search.map.tep[tx, ty] > before[tx, ty]
    assert search.map.eu[tx, ty] == scenario.search_map.eu[tx, ty] / 2
    assert search.observe((tx, ty), True, 0.9, 0.1) is False
    empty = next((x, y) for x in range(50) for y in range(50)
                 if not search.target_grid[x, y] and not search.map.no_fly[x, y])
    assert search.observe(empty, True, 0.9, 0.1) is False and search.false_alarms == 1
    plan = search.plan()
    assert plan.targets[0].found_step == 1 and plan.targets[0].found_by == 2


def test_set_position_moves_a_searcher_to_the_observed_cell():
    search = ClosedSearch(paper_scenario(seed=4, range_steps=60), MissionConfig(np_steps=2), seed=4)
    search.step()
    search.set_position(1, (3, 20))
    assert (search.uavs[1].x, search.uavs[1].y) == (3, 20)
    search.set_position(1, (10, 35))  # a no-fly cell: ignored
    assert (search.uavs[1].x, search.uavs[1].y) == (3, 20)
    record = search.step()
    x, y, _h, _stage = record.poses[1]
    assert max(abs(x - 3), abs(y - 20)) == 1


def test_simulated_readings_are_fixed_by_seed_uav_cell_and_visit():
    """Every UAV reads its airport on the way up (step 0); each reading's noise is
    `reading_draw(seed, uav, cell, visit)`, so a replay of the readings in any order agrees."""
    from planner.sensor_noise import reading_draw

    scenario = paper_scenario(2, range_steps=60)
    search = ClosedSearch(scenario, MissionConfig(strategy="exhaustive"), seed=11)
    for u in scenario.uavs:
        assert search.map.visits[u.airport] == 1
    for _ in search.run():
        pass
    plan = search.plan()
    pc, pf = scenario.sensor.pc, scenario.sensor.pf
    targets = {tuple(t) for t in scenario.targets}
    expected_finds: dict[tuple[int, int], int] = {}
    alarms = 0
    for u in plan.uavs:
        visits: dict[tuple[int, int], int] = {}
        for p in u.trajectory:
            cell = (p.x, p.y)
            n = visits.get(cell, 0)
            visits[cell] = n + 1
            if reading_draw(11, u.uav_id, *cell, n) < (pc if cell in targets else pf):
                if cell in targets:
                    expected_finds[cell] = min(expected_finds.get(cell, p.step), p.step)
                else:
                    alarms += 1
    assert {(t.x, t.y): t.found_step for t in plan.targets if t.found_step is not None} == expected_finds
    assert plan.false_alarms == alarms and alarms > 0


def test_the_planner_and_the_live_trigger_share_one_range_check():
    """Eq. (23) at k+1 is written once (`planner.range_check`): the live trigger uses it, and the
    planner's first-step test agrees with it on every range, step count and way home."""
    assert gcs.flight.return_trigger.check_return is check_return
    blocked = np.zeros((3, 3), dtype=np.bool_)
    for home, flown, range_steps in itertools.product(range(6), range(4), range(10)):
        table = np.full((8, 3, 3), home, dtype=np.int32)
        feasible = first_step_feasible(table, OC3.successors, blocked, (1, 1, 0), flown, range_steps)
        assert feasible == (not check_return(range_steps - flown, home).must_return)
