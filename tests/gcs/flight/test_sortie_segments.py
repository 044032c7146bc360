"""A flight over an area file with its own segments (`gcs fly --plan ... --sim`): the sortie record
and the summary at the end report the area file's segments, by name, as the plan did, not the
grid's blocks. A 600 m square, 30 m cells, one copter with 1500 m of range and a 45 degree camera,
at 60 times real time: the simulated vehicle reads at the camera's Pc, as the plan and the sortie
record count its readings; the flight's recording holds the segments and their figures."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gcs.cli import main
from gcs.flight.sortie import SortieLog
from gcs.plans.belief_file import validate_sortie_dict
from gcs.plans.plan_folder import load_plan_dir
from gcs.plans.segments import FROM_AREA_FILE, FROM_GRID, REST, SEGMENTS_FILE
from planner.search_theory import block_segments

#: The flight (`flown`) is flown once: every test here in one worker (pytest-xdist's loadgroup).
pytestmark = pytest.mark.xdist_group("sortie-segments")

WEST, EAST, SOUTH, NORTH = 7.996056, 8.003944, 46.997301, 47.002698
MIDDLE_LON, MIDDLE_LAT = (WEST + EAST) / 2, (SOUTH + NORTH) / 2


def _box(w: float, s: float, e: float, n: float) -> dict:
    return {"type": "Polygon", "coordinates": [[[w, s], [e, s], [e, n], [w, n], [w, s]]]}


def _feature(geometry: dict, **props) -> dict:
    return {"type": "Feature", "properties": props, "geometry": geometry}


def segments_area(folder: Path) -> Path:
    """The square with two segments (north-west 70 %, east 30 %): the south-west quarter is the
    rest of the area; a likelier west half, one airport, one target, and a hiker's IPP in the
    middle whose distance rings reach kilometres past the square (most of the subject's
    probability lies outside it: the rest of the world)."""
    doc = {"type": "FeatureCollection", "properties": {"cell_size_m": 30}, "features": [
        _feature(_box(WEST, SOUTH, EAST, NORTH), role="area", name="square"),
        _feature(_box(WEST, SOUTH, MIDDLE_LON, NORTH), role="prior", name="west", tep=0.6, eu=0.5),
        _feature(_box(WEST, MIDDLE_LAT, MIDDLE_LON, NORTH), role="segment", name="North-west", poa=70),
        _feature(_box(MIDDLE_LON, SOUTH, EAST, NORTH), role="segment", name="East", poa=30),
        _feature({"type": "Point", "coordinates": [7.996647, 46.999865]}, role="airport", name="a", heading="E",
                 range_m=1500),
        _feature({"type": "Point", "coordinates": [7.998, 47.001]}, role="target", name="t"),
        _feature({"type": "Point", "coordinates": [MIDDLE_LON, MIDDLE_LAT]}, role="ipp", subject="hiker",
                 terrain="flat")]}
    path = folder / "segments.geojson"
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """The square planned with a camera by `gcs plan --area` (no bound: it costs 5 s) and flown by
    `gcs fly --plan ... --sim` (recorded to flight.rrd); what the flight printed, and the sensor
    the simulated fleet gcs fly started was configured with."""
    from gcs.cli import sim_options
    from gcs.cli.commands import fly

    base = tmp_path_factory.mktemp("sortie-segments")
    out = base / "square"
    assert main(["plan", "--area", str(segments_area(base)), "--out", str(out), "--strategy", "exhaustive",
                 "--no-improve", "--bound-time", "0", "--no-rrd", "--quiet", "--camera-fov", "45"]) == 0
    fleets = []

    def kept_fleet(plan, **settings):
        fleets.append(sim_options.simulated_fleet(plan, **settings))
        return fleets[-1]

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), pytest.MonkeyPatch.context() as patch:
        patch.setattr(fly, "simulated_fleet", kept_fleet)
        assert main(["fly", "--plan", str(out), "--sim", "--speedup", "60", "--link-timeout", "2"]) == 0
    (fleet,) = fleets
    return SimpleNamespace(folder=out, printed=printed.getvalue(), sensor=fleet.config.sensor)


def _json(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def test_the_sortie_reports_the_area_files_segments_by_name(flown):
    record, plan = _json(flown.folder / "sortie.json"), _json(flown.folder / "plan.json")
    validate_sortie_dict(record)
    assert record["finished"] and record["observed"]
    theory, planned = record["search_theory"], plan["search_theory"]
    assert theory["segments_from"] == planned["segments_from"] == FROM_AREA_FILE
    names = [s["name"] for s in theory["segments"]]
    assert names == ["North-west", "East", REST] == [s["name"] for s in planned["segments"]]
    assert [s["cells"] for s in theory["segments"]] == [s["cells"] for s in planned["segments"]]
    # the flight's POAs before are the plan's (sortie 1: the prior's shares), the rest of the world
    # keeps what lies outside the square, and they sum to 1
    assert 0.5 < planned["rest_of_world_poa"] < 1
    assert theory["rest_of_world_poa"] == pytest.approx(planned["rest_of_world_poa"], abs=1e-6)
    assert theory["inside_area"] == planned["inside_area"] == pytest.approx(1 - planned["rest_of_world_poa"], abs=1e-6)
    assert [s["poa"] for s in theory["segments"]] == pytest.approx([s["poa"] for s in planned["segments"]], abs=2e-6)
    assert sum(s["poa"] for s in theory["segments"]) + theory["rest_of_world_poa"] == pytest.approx(1.0, abs=1e-5)
    # the sortie's POS is the whole subject's; the campaign's, of the share inside the area
    assert theory["pos"] == pytest.approx(record["campaign"]["pos_after"] * theory["inside_area"], abs=1e-5)
    assert any(s["pod"] > 0 for s in theory["segments"])
    # the summary at the end of gcs fly: the same table
    assert "segment          cells    POA    POD    POS cum POD POA after" in flown.printed
    assert all(f"\n{name:<16} " in flown.printed for name in names)


def test_a_changed_segments_file_falls_back_to_the_grids_blocks_and_says_why(flown, tmp_path):
    """segments.geojson no longer the plan's (a team edited it): blocks, and the summary says so."""
    import shutil

    folder = tmp_path / "square"
    shutil.copytree(flown.folder, folder)
    geo = _json(folder / SEGMENTS_FILE)
    geo["features"][0]["properties"]["segment"] = "Renamed"
    (folder / SEGMENTS_FILE).write_text(json.dumps(geo))
    log = SortieLog(load_plan_dir(folder))
    assert log.segments_from == FROM_GRID
    assert [s.name for s in log.segments] == [b.name for b in block_segments(~log.plan.no_fly)]
    assert "changed since the plan?" in (log.segments_note or "")
    (folder / SEGMENTS_FILE).unlink()
    assert "segments.geojson is not readable" in (SortieLog(load_plan_dir(folder)).segments_note or "")


@pytest.mark.parametrize("geometry", [{"type": "Circle", "coordinates": [8.0, 47.0], "radius": 50},
                                      {"type": "Polygon", "coordinates": [[[8.0, 47.0], [8.001, 47.0]]]}],
                         ids=["unknown type", "two-point ring"])
def test_a_segments_file_with_a_geometry_shapely_refuses_falls_back_to_the_grids_blocks(flown, tmp_path, geometry):
    """An edited segments.geojson whose geometry shapely cannot build (GeometryTypeError, not a
    ValueError): the flight reports the grid's blocks and says why, it does not stop."""
    import shutil

    folder = tmp_path / "square"
    shutil.copytree(flown.folder, folder)
    geo = _json(folder / SEGMENTS_FILE)
    geo["features"][0]["geometry"] = geometry
    (folder / SEGMENTS_FILE).write_text(json.dumps(geo))
    log = SortieLog(load_plan_dir(folder))
    assert log.segments_from == FROM_GRID
    assert [s.name for s in log.segments] == [b.name for b in block_segments(~log.plan.no_fly)]
    assert "segments.geojson is not readable" in (log.segments_note or "")


def test_the_segments_are_laid_on_the_plans_grid_as_the_plan_laid_them(flown):
    log = SortieLog(load_plan_dir(flown.folder))
    assert log.segments_note is None and log.segments_from == FROM_AREA_FILE
    cells = np.zeros(log.plan.no_fly.shape, dtype=int)
    for seg in log.segments:
        cells += seg.cells
    assert np.array_equal(cells, ~log.plan.no_fly)  # every searchable cell in exactly one segment


def test_the_simulated_vehicle_read_at_the_cameras_pc(flown):
    """The fleet gcs fly --sim started reads at the Pc of a 45 degree camera at 50 m over 30 m
    cells (worked out here, not taken from the plan), as the sortie record counts its readings."""
    from planner.camera import Camera, camera_sensor

    camera_pc = camera_sensor(Camera(45.0), 50.0, 30.0).pc
    assert abs(camera_pc - 0.9) > 0.05  # the camera's, not --pc's default
    assert (flown.sensor.pc, flown.sensor.pf) == (pytest.approx(camera_pc), 0.1)
    assert f"simulated fleet: 1 vehicles (ardupilot), speedup 60, sensor Pc {camera_pc:.3g} Pf 0.1" in flown.printed
    record = _json(flown.folder / "sortie.json")
    assert record["sensor"]["pc"] == pytest.approx(camera_pc) == record["search_theory"]["pc"]


def test_the_flight_recording_holds_the_segments_and_the_flights_figures(flown):
    """Read back with Rerun's reader: the segments' outlines on the map (static), and at the end of
    the flight one row of their figures, those of sortie.json."""
    from gcs.recording.flight import FLIGHT_TIME
    from gcs.recording.plan import read_recording

    rec = read_recording(flown.folder / "flight.rrd", FLIGHT_TIME)
    figures = _json(flown.folder / "sortie.json")["search_theory"]["segments"]
    assert len(figures) == 3
    edges = rec.static["geo/segments"].column("GeoLineStrings:line_strings").to_pylist()[0]
    lat_lon = np.array([point for edge in edges for point in edge])
    assert len(edges) >= 12 and SOUTH - 1e-6 <= lat_lon[:, 0].min() and lat_lon[:, 0].max() <= NORTH + 1e-6
    assert WEST - 1e-6 <= lat_lon[:, 1].min() and lat_lon[:, 1].max() <= EAST + 1e-6
    times, names = rec.column("segments", "name")
    assert names == [[f["name"] for f in figures]] and times[0] > 0
    for field in ("cells", "poa", "pod", "pos", "cumulative_pod", "poa_after"):
        assert rec.column("segments", field)[1][0] == pytest.approx([f[field] for f in figures], abs=1e-6), field


def test_segment_figures_that_fail_lose_no_row_and_hide_not_the_flights_own_error(flown, tmp_path, capsys):
    """The recorder's way out: the figures raise, yet every buffered row is written (close runs),
    an event and a warning say so, and the error that ended the flight is the one raised."""
    import asyncio
    import time

    from gcs.recording.flight import FLIGHT_TIME, FlightRecorder
    from gcs.recording.plan import read_recording

    plan = load_plan_dir(flown.folder)
    recorder = FlightRecorder(tmp_path / "flight.rrd", None, plan, flush_interval_s=3600)
    recorder.sortie = log = SortieLog(plan)
    controller = SimpleNamespace(t0=time.monotonic(), status={}, interrupted=False,
                                 subscribe=lambda listener: lambda: None)

    def figures_fail():
        raise KeyError("no figures")

    async def fly():
        async with recorder.attach(controller):  # type: ignore[arg-type]
            log.search_theory = figures_fail  # the outlines were drawn at the start; the figures fail
            raise RuntimeError("the flight's own")

    with pytest.raises(RuntimeError, match="the flight's own"):
        asyncio.run(fly())
    _, texts = read_recording(tmp_path / "flight.rrd", FLIGHT_TIME).column("events", "TextLog:text")
    lines = [t for row in texts for t in row]
    assert "flight interrupted (RuntimeError: the flight's own)" in lines
    assert "the segments' figures are not recorded (KeyError: 'no figures')" in lines
    assert "warning: Rerun: the segments' figures are not recorded (KeyError: 'no figures')" in capsys.readouterr().err
