"""Bad input: one `error: ...` line on stderr, exit code 2, no traceback."""

from __future__ import annotations

import pytest

from gcs.cli import main


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


@pytest.mark.parametrize("command", ["fly", "upload"])
def test_missing_plan_folder(tmp_path, capsys, command):
    assert main([command, "--plan", str(tmp_path / "nowhere"), "--connect", "udpout:127.0.0.1:14540"]) == 2
    assert "does not exist" in _one_error_line(capsys)


@pytest.mark.parametrize("conn", ["udpout:127.0.0.1", "tcp:127.0.0.1:5760", "udpout:127.0.0.1:http",
                                  "udpout:127.0.0.1:70000", "udpout::14540"])
def test_bad_connection_string(plan_dir, capsys, conn):
    assert main(["fly", "--plan", str(plan_dir), "--connect", conn]) == 2
    assert "connection string" in _one_error_line(capsys)


def test_unknown_uav_in_a_return_order(plan_dir, capsys):
    assert main(["fly", "--plan", str(plan_dir), "--sim", "--return-after", "9:5"]) == 2
    assert "unknown UAV 9" in _one_error_line(capsys)


def test_malformed_return_order(plan_dir, capsys):
    assert main(["fly", "--plan", str(plan_dir), "--sim", "--return-after", "two"]) == 2
    assert "UAV:NUMBER" in _one_error_line(capsys)


def test_plan_without_geo_reference(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["plan", "--scenario", "paper", "--strategy", "exhaustive", "--range", "20", "--out", str(out),
                 "--quiet"]) == 0
    capsys.readouterr()
    assert main(["upload", "--plan", str(tmp_path), "--sim"]) == 2
    assert "geo-reference" in _one_error_line(capsys)


def test_wrong_number_of_connections(plan_dir, capsys):
    assert main(["upload", "--plan", str(plan_dir), "--connect", "udpout:127.0.0.1:14540",
                 "--connect", "udpout:127.0.0.1:14541"]) == 2
    assert "2 connections for 4 UAVs" in _one_error_line(capsys)
