"""Bad input: one `error: ...` line on stderr, exit code 2, no traceback."""

from __future__ import annotations

import json
import shutil
import socket

import pytest

from gcs.cli import main
from tests.gcs.flight.conftest import ROOT


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


@pytest.mark.parametrize("command", ["fly", "upload"])
def test_missing_plan_folder(tmp_path, capsys, command):
    assert main([command, "--plan", str(tmp_path / "nowhere"), "--connect", "udpout:127.0.0.1:14540"]) == 2
    assert "does not exist" in _one_error_line(capsys)


@pytest.mark.parametrize("conn", ["udpout:127.0.0.1", "tcp:127.0.0.1", "udpout:127.0.0.1:http",
                                  "udpout:127.0.0.1:70000", "udpout::14540", "/dev/ttyUSB0,1234", "ttyUSB0"])
def test_bad_connection_string(plan_dir, capsys, conn):
    assert main(["fly", "--plan", str(plan_dir), "--connect", conn]) == 2
    assert "connection string" in _one_error_line(capsys)


@pytest.mark.parametrize("command", ["fly", "upload"])
def test_links_that_cannot_open_are_one_line(plan_dir, capsys, tmp_path, command):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))  # bound, not listening: connections are refused
        port = s.getsockname()[1]
        assert main([command, "--plan", str(plan_dir), "--connect", f"tcp:127.0.0.1:{port}", "--no-rrd"]
                    if command == "fly" else [command, "--plan", str(plan_dir), "--connect",
                                              f"tcp:127.0.0.1:{port}"]) == 2
    assert "connection refused" in _one_error_line(capsys)
    assert main([command, "--plan", str(plan_dir), "--connect", str(tmp_path / "ttyUSB7")]) == 2
    assert (f"link {tmp_path / 'ttyUSB7'},57600: cannot open the serial device: no such device"
            in _one_error_line(capsys))
    key = tmp_path / "missing.key"
    assert main([command, "--plan", str(plan_dir), "--sim", "--signing-key", str(key)]) == 2
    assert "cannot read signing key file" in _one_error_line(capsys)


def test_unknown_uav_in_a_return_order(plan_dir, capsys):
    assert main(["fly", "--plan", str(plan_dir), "--sim", "--return-after", "9:5"]) == 2
    assert "unknown UAV 9" in _one_error_line(capsys)


def test_malformed_return_order(plan_dir, capsys):
    assert main(["fly", "--plan", str(plan_dir), "--sim", "--return-after", "two"]) == 2
    assert "UAV:NUMBER" in _one_error_line(capsys)


@pytest.mark.parametrize("extra, message", [
    (["--area", str(ROOT / "missions" / "paper.geojson")], "give --plan or --area, not both"),
    (["--online"], "--online needs --area"),
])
def test_fly_takes_a_plan_folder_or_an_area_not_both(plan_dir, capsys, extra, message):
    """--plan and --area together, or --online without --area: one line, nothing written."""
    before = sorted(p.name for p in plan_dir.iterdir())
    assert main(["fly", "--plan", str(plan_dir), "--sim", *extra]) == 2
    assert message in _one_error_line(capsys)
    assert sorted(p.name for p in plan_dir.iterdir()) == before


@pytest.mark.parametrize("seconds, message", [("-1", "must be 0 or more seconds"), ("soon", "not a number of seconds")])
def test_fly_area_bound_time_is_0_or_more_seconds(tmp_path, capsys, seconds, message):
    """`gcs fly --area --bound-time`: one line naming the option, nothing planned or flown."""
    out = tmp_path / "out"
    assert main(["fly", "--area", str(ROOT / "missions" / "paper.geojson"), "--sim", "--out", str(out),
                 "--bound-time", seconds]) == 2
    line = _one_error_line(capsys)
    assert "--bound-time" in line and message in line, line
    assert not out.exists()


def test_plan_without_geo_reference(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["plan", "--scenario", "paper", "--strategy", "exhaustive", "--range", "20", "--out", str(out),
                 "--quiet"]) == 0
    capsys.readouterr()
    assert main(["upload", "--plan", str(tmp_path), "--sim"]) == 2
    assert "geo-reference" in _one_error_line(capsys)


@pytest.mark.parametrize("tamper, named", [
    (lambda d: d.pop("grid"), "the top level: 'grid' is a required property"),
    (lambda d: d["uavs"][1].pop("trajectory"), "uavs[1]: 'trajectory' is a required property"),
    (lambda d: d["grid"].update(nx="fifty"), "grid.nx: 'fifty' is not of type 'integer'"),
])
def test_a_tampered_plan_file_names_the_field(plan_dir, tmp_path, capsys, tamper, named):
    folder = tmp_path / "tampered"
    shutil.copytree(plan_dir, folder)
    data = json.loads((folder / "plan.json").read_text())
    tamper(data)
    (folder / "plan.json").write_text(json.dumps(data))
    assert main(["upload", "--plan", str(folder), "--sim"]) == 2
    line = _one_error_line(capsys)
    assert "does not follow the plan schema" in line and named in line, line


def test_vehicles_that_never_answer_are_named_with_the_links_listened_on(plan_dir, capsys):
    assert main(["upload", "--plan", str(plan_dir), "--connect", "udpout:127.0.0.1:9",
                 "--connect", "udpin:127.0.0.1:0", "--connect-timeout", "0.5"]) == 1
    out = capsys.readouterr().out
    for uid in (1, 2, 3, 4):
        assert (f"UAV {uid}: FAILED: no HEARTBEAT from system id {uid} within 0.5 s on udpout:127.0.0.1:9, "
                "udpin:127.0.0.1:0") in out
    assert "0/4 vehicles verified" in out


def test_a_terrain_following_plan_is_refused_for_px4_before_any_upload(tmp_path, capsys):
    """PX4 has no terrain frame (it answers MAV_MISSION_UNSUPPORTED_FRAME): the station says so
    per vehicle and uploads nothing, rather than failing half-way through the list."""
    out = tmp_path / "terrain"
    assert main(["plan", "--area", str(ROOT / "missions" / "paper.geojson"), "--seed", "0", "--strategy",
                 "exhaustive", "--terrain-follow", "--out", str(out), "--quiet", "--no-rrd"]) == 0
    capsys.readouterr()
    assert main(["upload", "--plan", str(out), "--sim", "--sim-profile", "px4", "--speedup", "20"]) == 1
    said = capsys.readouterr().out
    for uid in (1, 2, 3, 4):
        assert f"UAV {uid}: FAILED: mission not uploaded: PX4 refuses terrain-following frames: plan without " \
               "--terrain-follow for this vehicle" in said, said


def test_a_simulated_fleet_needs_uav_ids_one_to_n(plan):
    """`--sim` numbers its vehicles 1..N (MAVLink system ids): a plan with a gap is refused,
    as one error line from the command, before any vehicle starts."""
    from gcs.cli.sim_options import simulated_fleet
    from gcs.errors import UserError
    from sim.plan_fleet import fleet_for_plan

    del plan.uavs[2]
    with pytest.raises(ValueError, match=r"needs UAV ids 1..N, the plan has \[1, 3, 4\]"):
        fleet_for_plan(plan, speedup=1.0)
    with pytest.raises(UserError, match=r"^--sim: the simulated fleet needs UAV ids 1..N"):
        simulated_fleet(plan, speedup=1.0)
