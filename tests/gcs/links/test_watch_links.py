"""`gcs watch --connect`: vehicles seen straight over their links (two simulated vehicles, one
over TCP and one over a serial cable), and the refusals of a malformed watch."""

from __future__ import annotations

import subprocess
import sys


def _gcs(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, timeout=60)


def test_watch_lists_every_vehicle_heard_on_tcp_and_serial(make_fleet, serial_cable):
    fleet = make_fleet(2, tcp=True, serial_devices=("", serial_cable.vehicle_end))  # vehicle 2 on the cable
    done = _gcs("watch", "--connect", fleet.tcp_connection_strings()[0], "--connect",
                f"{serial_cable.station_end},57600", "--once", "--duration-s", "2")
    assert done.returncode == 0, done.stderr
    rows = {line.split()[0]: line.split() for line in done.stdout.splitlines()[1:] if line[:3].strip().isdigit()}
    assert set(rows) == {"1", "2"}
    for sysid, row in rows.items():
        home = fleet.vehicle(int(sysid)).home
        assert row[1] == "ardupilot" and row[2] == "copter" and row[4] == "no"  # disarmed on the ground
        assert abs(float(row[5]) - home.lat_deg) < 1e-4 and abs(float(row[6]) - home.lon_deg) < 1e-4


def test_watch_refuses_a_bus_command_on_a_link_and_needs_one_source():
    both = _gcs("watch", "--connect", "tcp:127.0.0.1:1", "--mqtt", "mqtt://127.0.0.1:1")
    assert both.returncode == 2 and "one of them" in both.stderr
    order = _gcs("watch", "--connect", "tcp:127.0.0.1:1", "--return", "2")
    assert order.returncode == 2 and "give --mqtt" in order.stderr
    bad = _gcs("watch", "--connect", "tcp:127.0.0.1")
    assert bad.returncode == 2 and "bad connection string" in bad.stderr
