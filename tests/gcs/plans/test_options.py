"""Planning from Python, without the command line: typed options in, a search or plan folder
out; the command line calls the same functions and gets the same files; plan.json's record of
the options reads back, old folders' too."""

import json
import subprocess
import sys
import textwrap
from dataclasses import replace

import pytest

from gcs.cli import main
from gcs.errors import UserError
from gcs.missions.items import Vehicle
from gcs.plans.make import plan_area, plan_scenario
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions, options_from_record, options_record
from gcs.plans.planning import build_area_search, build_scenario_search
from planner.area_grid import AREA_MOVE_COSTS
from planner.motion import constraint_by_name
from tests.gcs.plans.conftest import small_area

QUIET = OutputOptions(record=False, progress=False)

#: plan.json's `campaign.options` as gcs plan --area wrote it before the options were typed
OLD_RECORD = {"altitude_m": 50.0, "altitude_step_m": 10.0, "approach_alt_m": 30.0, "approach_m": 500.0,
              "ceiling_m": 120.0, "cell_size_m": None, "default_eu": 0.5, "default_tep": 0.5, "endurance_s": 900.0,
              "footprint": 0, "horizon_value": None, "margin_m": 0.0, "max_cells": 1000000, "np_steps": 5, "oc": "3",
              "pc": 0.9, "pf": 0.1, "range_aware_search": False, "range_m": None, "range_steps": 130, "reserve": 0,
              "return_planner": "exact", "seed": 2, "speed_m_s": 12.0, "strategy": "cpio", "terrain_follow": False,
              "vehicle": "copter"}

#: the keys a record gained since: the vehicles file ranges are planned from, the reserve kept, the camera,
#: whether the finished plan is improved
NEW_KEYS = {"reserve_pct": 30.0, "vehicles": None, "camera_fov_deg": None, "camera_pixels": None, "camera_pd": 1.0,
            "improve": None}


@pytest.fixture
def area_file(tmp_path):
    path = tmp_path / "area.geojson"
    path.write_text(json.dumps(small_area()), encoding="utf-8")
    return path


def test_an_area_search_from_typed_options(area_file):
    search = SearchOptions(seed=3, np_steps=3, oc="8", strategy="exhaustive", reserve=2, pc=0.8, pf=0.05, footprint=1)
    setup = build_area_search(area_file, AreaOptions(cell_size_m=40, speed_m_s=10, altitude_m=30, vehicle="copter"),
                              search)
    closed = setup.search
    assert setup.area.grid.cell_size_m == 40 and closed.seed == 3
    config = closed.config
    assert (config.np_steps, config.oc, config.strategy, config.reserve_steps) == (3, constraint_by_name("8"),
                                                                                  "exhaustive", 2)
    assert config.horizon is not None  # on by default for an area
    sensor = closed.scenario.sensor
    assert (sensor.pc, sensor.pf, sensor.footprint_radius) == (0.8, 0.05, 1)
    # west: range_m 3000 from the file; south-east: endurance_s 250 at 10 m/s
    assert setup.ranges_m == {1: 3000.0, 2: 2500.0}
    assert closed.scenario.move_costs == AREA_MOVE_COSTS and closed.scenario.unit_m == 40 / 1000
    for u in closed.scenario.uavs:  # metres in thousandths of a 40 m cell, less the legs to the airport's cell
        overhead = setup.overheads_m[u.uav_id]
        assert u.range_units == int((setup.ranges_m[u.uav_id] - overhead) / 40 * 1000) and 0 <= overhead < 2 * 40
    assert setup.layers.altitudes_m == {1: 30.0, 2: 40.0}
    off = build_area_search(area_file, search=replace(search, horizon_value=False))
    assert off.search.config.horizon is None and off.area.grid.cell_size_m == 30  # the file's cell size


def test_defaults_are_the_options_defaults(area_file):
    setup = build_area_search(area_file)
    assert setup.search.config.strategy == "cpio" and setup.search.config.np_steps == 5
    assert setup.vehicle is Vehicle.COPTER and setup.layers.altitudes_m == {1: 50.0, 2: 60.0}


def test_a_built_in_scenario_from_typed_options():
    closed = build_scenario_search("paper", SearchOptions(seed=5, np_steps=2, range_steps=40))
    assert closed.seed == 5 and closed.config.np_steps == 2 and closed.config.horizon is None  # the paper's J1
    assert all(u.range_units == 40 for u in closed.scenario.uavs)
    assert build_scenario_search(search=SearchOptions(horizon_value=True)).config.horizon is not None
    with pytest.raises(UserError, match="unknown scenario 'moon'"):
        build_scenario_search("moon")
    with pytest.raises(UserError, match="range must be at least 1 step"):
        build_scenario_search(search=SearchOptions(range_steps=0))


def test_bad_area_options_name_the_option(area_file):
    with pytest.raises(UserError, match="--cell-size must be a positive number"):
        build_area_search(area_file, AreaOptions(cell_size_m=-1))
    with pytest.raises(UserError, match=r"area.geojson: unknown search strategy"):
        build_area_search(area_file, search=SearchOptions(strategy="magic"))


def test_the_command_line_writes_what_the_python_call_writes(area_file, tmp_path, capsys):
    by_hand = plan_area(area_file, AreaOptions(cell_size_m=40, margin_m=5), SearchOptions(seed=3, np_steps=3),
                        tmp_path / "python", QUIET)
    assert main(["plan", "--area", str(area_file), "--cell-size", "40", "--margin", "5", "--seed", "3", "--np", "3",
                 "--out", str(tmp_path / "cli"), "--no-rrd", "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    assert by_hand.out_dir == tmp_path / "python" and [s.folder for s in by_hand.sorties] == [tmp_path / "python"]
    written = sorted(p.name for p in (tmp_path / "python").iterdir())
    assert written == sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert "plan.png" in written and "plan.rrd" not in written
    def text(folder, name):  # (the campaign rows name the folder)
        return (tmp_path / folder / name).read_text().replace(str(tmp_path / folder), "OUT")

    for name in written:
        if name != "plan.png":
            assert text("python", name) == text("cli", name), name
    assert by_hand.sorties[0].files["plan.json"] == (tmp_path / "python" / "plan.json").read_text()


def test_a_scenario_plan_from_python_is_the_command_line_s(tmp_path):
    result = plan_scenario("paper", SearchOptions(seed=2, np_steps=2, range_steps=30), tmp_path / "python", QUIET)
    assert result.path == tmp_path / "python" / "plan.json" and result.picture.exists() and result.rrd is None
    assert main(["plan", "--seed", "2", "--np", "2", "--range", "30", "--out", str(tmp_path / "cli.json"), "--quiet",
                 "--no-rrd"]) == 0
    assert result.path.read_text() == (tmp_path / "cli.json").read_text()


def test_planning_from_python_never_loads_the_command_line(area_file, tmp_path):
    script = textwrap.dedent(f"""
        import sys
        from gcs.plans.make import plan_area
        from gcs.plans.options import OutputOptions
        plan_area({str(area_file)!r}, out={str(tmp_path / "out")!r}, output=OutputOptions(record=False))
        print(sorted(m for m in sys.modules if m == "gcs.cli" or m.startswith("gcs.cli.")))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["[]"]
    assert (tmp_path / "out" / "plan.json").exists()


def test_the_options_record_keeps_its_keys_and_reads_back():
    area, search = AreaOptions(cell_size_m=25.0, vehicle=Vehicle.PLANE, terrain_follow=True), \
        SearchOptions(seed=9, strategy="pso", horizon_value=False)
    record = options_record(area, search)
    assert list(record) == sorted({**OLD_RECORD, **NEW_KEYS})  # the keys plan folders have had, and the new ones
    assert record["vehicle"] == "plane" and json.loads(json.dumps(record)) == record
    assert options_from_record(record) == (area, search)
    assert AreaOptions(margin_m=5, vehicle="plane") == AreaOptions(margin_m=5.0, vehicle=Vehicle.PLANE)
    assert isinstance(AreaOptions(margin_m=5).margin_m, float) and isinstance(SearchOptions(pc=1).pc, float)


def test_an_old_folders_record_reads_back_and_extra_keys_are_ignored():
    area, search = options_from_record({**OLD_RECORD, "no_longer_an_option": 1})
    assert search == SearchOptions(seed=2) and area == AreaOptions()
    assert options_record(area, search) == {**OLD_RECORD, **NEW_KEYS}
    assert options_from_record({"np_steps": 3}) == (AreaOptions(), SearchOptions(np_steps=3))  # missing: defaults
    with pytest.raises(ValueError):
        options_from_record({"vehicle": "zeppelin"})


def test_the_recording_goes_beside_the_plan_or_where_asked(tmp_path):
    default = tmp_path / "plan.rrd"
    assert OutputOptions().recording_path(default) == default
    assert OutputOptions(rrd=tmp_path / "run.rrd").recording_path(default) == tmp_path / "run.rrd"
    assert OutputOptions(record=False, rrd="run.rrd").recording_path(default) is None
    with pytest.raises(UserError, match="--rrd must name a .rrd file, got run.txt"):
        OutputOptions(rrd="run.txt").recording_path(default)


def test_a_terminal_sees_the_planning_bar_and_then_the_improvement_s_elapsed_time(area_file, monkeypatch):
    """On a terminal the search's steps show as a bar, and the whole-mission improvement after it,
    which can take many seconds and has no steps to count, as its elapsed time; a pipe gets
    neither."""
    import io

    from gcs.plans.make import fly_with_progress
    from gcs.plans.planning import build_area_search

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    for stream, shown in ((Terminal(), True), (io.StringIO(), False)):
        monkeypatch.setattr(sys, "stderr", stream)
        setup = build_area_search(area_file, search=SearchOptions(np_steps=2))
        assert setup.search.config.improve is not None
        plan = fly_with_progress(setup.search)
        assert plan.settings.get("improved") is True
        text = stream.getvalue()
        assert ("planning:" in text and "improving the whole mission: 00:0" in text) is shown, text
        assert bool(text) is shown
