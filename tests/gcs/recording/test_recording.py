"""The Rerun recording of a real closed search, read back with Rerun's own chunk reader."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gcs.recording.plan import PlanRecorder, cell_to_view, map_to_rgb, read_recording, view_to_cell
from gcs.recording.replay import stop_server, viewer_command, wait_for_port
from planner.plan import Stage
from tests.gcs.recording.conftest import RecordedRun, record_search
from tests.peers.ports import free_port

HERE = Path(__file__).parent


def test_one_state_row_per_step_flown_per_uav_equal_to_the_plan(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    for u in recorded_run.plan.uavs:
        state = tables.temporal[f"uav/{u.uav_id}/state"].to_pydict()
        assert state["step"] == [p.step for p in u.trajectory]
        assert [v[0] for v in state["x"]] == [p.x + 1 for p in u.trajectory]
        assert [v[0] for v in state["y"]] == [p.y + 1 for p in u.trajectory]
        assert [v[0] for v in state["heading"]] == [p.heading for p in u.trajectory]
        assert [v[0] for v in state["stage"]] == [p.stage.value for p in u.trajectory]


def test_stage_switches_to_return_at_the_return_step_with_its_reason(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    events = tables.temporal["events"].to_pydict()
    returned = [u for u in recorded_run.plan.uavs if u.return_step is not None]
    assert any(u.return_steps > 0 for u in returned), "the run must contain a return leg to mean anything"
    for u in returned:
        steps, stages = tables.column(f"uav/{u.uav_id}/state", "stage")
        assert all(v == ["search"] for s, v in zip(steps, stages) if s <= u.return_step)
        if u.return_steps:
            first_return = next(s for s, v in zip(steps, stages) if v == ["return"])
            assert first_return == u.return_step + 1
        else:  # it had to turn home while on its airport: no return leg
            assert steps[-1] == u.return_step
        lines = [t[0] for s, t in zip(events["step"], events["TextLog:text"])
                 if s == u.return_step and t[0].startswith(f"UAV {u.uav_id} returns")]
        assert len(lines) == 1 and f"[{u.return_reason.value}]" in lines[0]


def test_grid_view_poses_and_trails_are_the_plan_trajectories(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    ny = recorded_run.scenario.search_map.shape[1]
    for u in recorded_run.plan.uavs:
        cells = [(p.x, p.y) for p in u.trajectory]
        steps, positions = tables.column(f"world/uav/{u.uav_id}", "Points2D:positions")
        assert steps == [p.step for p in u.trajectory]
        assert [tuple(view_to_cell(np.array(p), ny)[0]) for p in positions] == cells
        steps, segments = tables.column(f"world/uav/{u.uav_id}/trail", "LineStrips2D:strips")
        _, colours = tables.column(f"world/uav/{u.uav_id}/trail", "LineStrips2D:colors")
        assert steps == [p.step for p in u.trajectory] and segments[0] == []
        for p, before, (segment,), (colour,) in zip(u.trajectory[1:], u.trajectory, segments[1:], colours[1:]):
            assert view_to_cell(np.array(segment), ny).tolist() == [[before.x, before.y], [p.x, p.y]]
            assert colour == colours[1][0] if p.stage is Stage.SEARCH else colour != colours[1][0]


def test_maps_are_logged_as_they_were_at_each_step(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    last = max(recorded_run.tep)
    for entity, maps in (("maps/tep", recorded_run.tep), ("maps/eu", recorded_run.eu)):
        steps, buffers = tables.column(entity, "Image:buffer")
        assert steps == list(range(last + 1))
        images = {s: np.frombuffer(bytes(b[0]), dtype=np.uint8) for s, b in zip(steps, buffers)}
        prior = getattr(recorded_run.scenario.search_map, entity.split("/")[1])
        assert np.array_equal(images[0], map_to_rgb(prior).ravel())
        for k in (1, last // 2, last):
            assert np.array_equal(images[k], map_to_rgb(maps[k]).ravel())
        assert not np.array_equal(images[1], images[last])


def test_return_trigger_inputs_and_j1_are_plotted_per_uav(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    for u in recorded_run.plan.uavs:
        flown = [p.step for p in u.trajectory if p.step > 0]
        steps, values = tables.column(f"uav/{u.uav_id}/range", "Scalars:scalars")
        assert steps == flown
        assert [tuple(v) for v in values] == [recorded_run.ranges[k][u.uav_id] for k in flown]
        assert values[-1][1] == 0  # landed: nothing left to fly home
        steps, values = tables.column(f"uav/{u.uav_id}/j1", "Scalars:scalars")
        decided = [k for k in flown if u.uav_id in recorded_run.j1[k]]
        assert steps == decided and len(decided) == u.search_steps
        for k, (chosen, runner) in zip(steps, values):
            want_chosen, want_runner = recorded_run.j1[k][u.uav_id]
            assert chosen == pytest.approx(want_chosen)
            assert (math.isnan(runner) and want_runner is None) or runner == pytest.approx(want_runner)


def test_decision_paths_shown_while_searching_and_cleared_on_return(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    ny = recorded_run.scenario.search_map.shape[1]
    for u in recorded_run.plan.uavs:
        stage_at = {p.step: p.stage for p in u.trajectory}
        steps, strips = tables.column(f"world/uav/{u.uav_id}/plan", "LineStrips2D:strips")
        _, labels = tables.column(f"world/uav/{u.uav_id}/plan", "LineStrips2D:labels")
        by_step = {p.step: (p.x, p.y) for p in u.trajectory}
        for k, row, label in zip(steps, strips, labels):
            if k == 0 or stage_at[k] is not Stage.SEARCH:
                assert row == []
                continue
            chosen = view_to_cell(np.array(row[0]), ny).tolist()
            assert chosen[0] == list(by_step[k - 1]) and chosen[1] == list(by_step[k])
            assert label[0] == f"J1 {recorded_run.j1[k][u.uav_id][0]:.3f}"


def test_targets_found_and_false_alarms_accumulate(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    ny = recorded_run.scenario.search_map.shape[1]
    plan = recorded_run.plan
    found = sorted((t.x, t.y) for t in plan.targets if t.found_step is not None)
    if found:
        steps, positions = tables.column("world/found", "Points2D:positions")
        assert sorted(map(tuple, view_to_cell(np.array(positions[-1]), ny).tolist())) == found
        assert sorted(steps) == sorted({t.found_step for t in plan.targets if t.found_step is not None})
    steps, positions = tables.column("world/false_alarms", "Points2D:positions")
    assert len(positions[-1]) == plan.false_alarms > 0
    assert [len(p) for p in positions] == [recorded_run.false_alarms_by_step[k] for k in steps]


def test_probability_of_success_is_plotted_per_step_per_uav_and_for_the_team(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    success = recorded_run.plan.success
    last = recorded_run.plan.steps
    steps, expected = tables.column("success/expected", "Scalars:scalars")
    assert steps == list(range(1, last + 1))
    series = dict(zip(success.steps.tolist(), success.cumulative))
    assert [v[0] for v in expected] == pytest.approx([series[k] for k in steps])
    _, share = tables.column("success/share", "Scalars:scalars")
    assert share[-1][0] == pytest.approx(100 * success.share)
    for u in recorded_run.plan.uavs:
        steps, values = tables.column(f"uav/{u.uav_id}/success", "Scalars:scalars")
        assert steps == list(range(1, last + 1))
        assert values[-1][0] == pytest.approx(success.by_uav[u.uav_id])
        assert all(a[0] <= b[0] for a, b in zip(values, values[1:]))


def test_static_scene_and_blueprint(recorded_run: RecordedRun):
    tables = read_recording(recorded_run.rrd)
    assert tables.blueprints == 1
    for entity in ("world/no_fly", "world/regions/known", "world/regions/key", "world/airports", "world/targets"):
        assert entity in tables.static
    for u in recorded_run.plan.uavs:
        assert f"plan/uav/{u.uav_id}" in tables.static
    airports = tables.static["world/airports"].column("Points2D:positions").to_pylist()[0]
    ny = recorded_run.scenario.search_map.shape[1]
    assert view_to_cell(np.array(airports), ny).tolist() == [list(u.airport) for u in recorded_run.scenario.uavs]


def test_geo_hook_logs_trajectories_as_lat_lon(tmp_path: Path):
    def cell_to_lat_lon(x: float, y: float) -> tuple[float, float]:
        return 47.0 + 1e-4 * y, 8.0 + 1.5e-4 * x

    def cells_to_lat_lon(cells: np.ndarray) -> np.ndarray:
        return np.array([cell_to_lat_lon(x, y) for x, y in cells])

    run = record_search(tmp_path / "geo.rrd", range_steps=30, cells_to_lat_lon=cells_to_lat_lon)
    tables = read_recording(run.rrd)
    for u in run.plan.uavs:
        steps, positions = tables.column(f"geo/uav/{u.uav_id}", "GeoPoints:positions")
        assert steps == [p.step for p in u.trajectory]
        assert [tuple(p[0]) for p in positions] == [cell_to_lat_lon(p.x, p.y) for p in u.trajectory]
        _, strings = tables.column(f"geo/uav/{u.uav_id}/trail", "GeoLineStrings:line_strings")
        flown = [tuple(strings[1][0][0])] + [tuple(row[0][1]) for row in strings[1:]]
        assert flown == [cell_to_lat_lon(p.x, p.y) for p in u.trajectory]
    outline = tables.static["geo/no_fly"].column("GeoLineStrings:line_strings").to_pylist()[0]
    nx, ny = run.scenario.search_map.shape
    west, east = cell_to_lat_lon(-0.5, 0)[1], cell_to_lat_lon(nx - 0.5, 0)[1]
    assert all(west <= lon <= east for segment in outline for _, lon in segment)
    assert len(outline) == 2 * (16 + 11) + 2 * (11 + 11)  # cell edges around the two no-fly boxes


def test_mask_outline_follows_cell_edges():
    from gcs.display.overview import mask_outline

    mask = np.zeros((5, 4), dtype=bool)
    mask[1:3, 1:2] = True  # cells (1, 1) and (2, 1): a 2 x 1 block
    segments = {tuple(map(tuple, s)) for s in mask_outline(mask).tolist()}
    # image rows count from the north edge: y = 1 spans rows 2..3
    assert segments == {((1, 2), (2, 2)), ((2, 2), (3, 2)), ((1, 3), (2, 3)), ((2, 3), (3, 3)),
                        ((1, 2), (1, 3)), ((3, 2), (3, 3))}


def test_cell_view_round_trip():
    cells = np.array([[0, 0], [49, 0], [0, 49], [12, 31]])
    assert np.array_equal(view_to_cell(cell_to_view(cells[:, 0], cells[:, 1], 50), 50), cells)
    assert cell_to_view(0, 49, 50).tolist() == [0.5, 0.5]  # north-west cell: top-left pixel


def test_map_every_keeps_first_and_last_maps(tmp_path: Path):
    run = record_search(tmp_path / "sparse.rrd", range_steps=30, map_every=7)
    last = max(run.tep)
    steps, _ = read_recording(run.rrd).column("maps/tep", "Image:buffer")
    assert steps == sorted(set(range(0, last + 1, 7)) | {last})


def test_disabled_recorder_writes_nothing(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = record_search(None, range_steps=30)
    assert run.plan.steps > 0
    assert list(tmp_path.iterdir()) == []
    assert not PlanRecorder(None, None, run.scenario).enabled


def test_exception_mid_run_leaves_a_readable_recording(tmp_path: Path):
    from planner.dtscs import ClosedSearch, MissionConfig
    from planner.scenario import paper_scenario

    scenario = paper_scenario(1, range_steps=60)
    search = ClosedSearch(scenario, MissionConfig(), seed=1)
    with pytest.raises(RuntimeError, match="link lost"):
        with PlanRecorder(tmp_path / "cut.rrd", None, scenario, flush_interval_s=60.0) as rec:
            for record in search.run():
                rec.log_step(record)
                if record.step == 17:
                    raise RuntimeError("link lost")
    tables = read_recording(tmp_path / "cut.rrd")
    assert tables.column("uav/1/state", "x")[0] == list(range(18))
    assert tables.column("maps/tep", "Image:buffer")[0][-1] == 17
    texts = [t[0] for t in tables.temporal["events"].column("TextLog:text").to_pylist()]
    assert texts[-1] == "run interrupted after step 17 (RuntimeError: link lost)"


def _run_until(out: Path, stop_after: int, sig: int, flush_interval_s: float) -> tuple[int, int]:
    """Start record_run.py, send `sig` once it printed step `stop_after`; (last step printed, exit code)."""
    env = dict(os.environ, PYTHONPATH=str(HERE.parents[2]))
    proc = subprocess.Popen([sys.executable, str(HERE / "record_run.py"), str(out), str(flush_interval_s), "0.02"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    last = -1
    for line in proc.stdout:
        last = int(line.split()[1])
        if last == stop_after:
            proc.send_signal(sig)
            break
    for line in proc.stdout:
        last = int(line.split()[1])
    return last, proc.wait(timeout=60)


def test_sigint_mid_run_leaves_a_readable_recording(tmp_path: Path):
    last, code = _run_until(tmp_path / "sigint.rrd", 20, signal.SIGINT, flush_interval_s=60.0)
    assert code != 0 and 20 <= last < 100
    tables = read_recording(tmp_path / "sigint.rrd")
    steps = tables.column("uav/1/state", "x")[0]
    assert steps == list(range(len(steps))) and steps[-1] in (last, last + 1)  # Ctrl-C may land mid-step
    texts = [t[0] for t in tables.temporal["events"].column("TextLog:text").to_pylist()]
    assert texts[-1] in {f"run interrupted after step {k} (Ctrl-C)" for k in (last, last + 1)}


def test_killed_run_is_readable_up_to_the_last_flushed_step(tmp_path: Path):
    last, code = _run_until(tmp_path / "killed.rrd", 20, signal.SIGKILL, flush_interval_s=0.0)
    assert code == -signal.SIGKILL and 20 <= last < 100
    steps = read_recording(tmp_path / "killed.rrd").column("uav/1/state", "x")[0]
    assert steps[: last + 1] == list(range(last + 1))


def test_streams_to_a_running_viewer_server(tmp_path: Path):
    """`connect` sends the same recording to a Rerun gRPC server (here one that saves what it gets)."""
    port = free_port()
    saved = tmp_path / "received.rrd"
    server = subprocess.Popen(viewer_command() + ["--serve-grpc", "--bind", "127.0.0.1", "--port", str(port),
                                                  "--save", str(saved)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        wait_for_port(port, server)
        run = record_search(None, range_steps=30, connect=f"rerun+http://127.0.0.1:{port}/proxy")
    finally:
        stop_server(server)
    tables = read_recording(saved)
    assert tables.blueprints == 1
    for u in run.plan.uavs:
        assert tables.column(f"uav/{u.uav_id}/state", "x")[0] == [p.step for p in u.trajectory]


def test_no_viewer_listening_is_one_clear_error_and_no_file(tmp_path: Path):
    from gcs.errors import UserError
    from planner.scenario import paper_scenario

    with pytest.raises(UserError, match="no Rerun viewer listening at rerun\\+http://127.0.0.1:"):
        with PlanRecorder(tmp_path / "x.rrd", f"rerun+http://127.0.0.1:{free_port()}/proxy", paper_scenario(0)):
            pass
    with pytest.raises(UserError, match="not a Rerun viewer address"):
        PlanRecorder(None, "http://example", paper_scenario(0)).open()
    assert list(tmp_path.iterdir()) == []


def test_viewer_going_away_mid_run_does_not_stop_the_run_or_the_file(tmp_path: Path, capsys):
    from planner.dtscs import ClosedSearch, MissionConfig
    from planner.scenario import paper_scenario

    port = free_port()
    server = subprocess.Popen(viewer_command() + ["--serve-grpc", "--bind", "127.0.0.1", "--port", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    scenario = paper_scenario(2, range_steps=40)
    search = ClosedSearch(scenario, MissionConfig(), seed=2)
    try:
        wait_for_port(port, server)
        with PlanRecorder(tmp_path / "both.rrd", f"rerun+http://127.0.0.1:{port}/proxy", scenario,
                          flush_interval_s=0.0) as rec:
            for record in search.run():
                rec.log_step(record)
                if record.step == 10:
                    stop_server(server)
            rec.log_plan(search.plan())
    finally:
        stop_server(server)
    assert "warning: Rerun:" in capsys.readouterr().err
    steps = read_recording(tmp_path / "both.rrd").column("uav/1/state", "x")[0]
    assert steps == [p.step for p in search.plan().uavs[0].trajectory]


def test_big_grids_log_their_maps_less_often():
    from planner.environment import SearchMap
    from planner.scenario import Scenario, UavSpec, paper_scenario

    big = SearchMap(np.full((300, 200), 0.5), np.full((300, 200), 0.5), np.zeros((300, 200), dtype=bool))
    scenario = Scenario("big", big, [UavSpec(1, (0, 0), 0, 50)], np.zeros((0, 2)))
    assert PlanRecorder(None, None, scenario).map_every == 6
    assert PlanRecorder(None, None, paper_scenario(0)).map_every == 1
