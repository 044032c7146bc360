"""A station that survives its own restart, on PX4 SITL: `gcs fly` talks to PX4's GCS port
(`udpout`) and is SIGKILLed mid-search; PX4 (NAV_DLL_ACT 0) flies its mission on, still sending
to the dead station's address, the only one it will ever answer. `gcs fly --resume` sends from
that same local port again (the journal kept it), reattaches and brings the copter home."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from gcs.flight.journal import read_journal
from tests.gcs.flight.resume_peers import kill_when, station
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import STEADY_BATTERY, Px4Sitl
from tests.peers.site import PX4_SOLO

pytestmark = [pytest.mark.autopilot, SITL_WORKER]


def test_a_px4_flies_on_while_the_station_is_dead_and_the_restarted_station_speaks_from_the_same_port(tmp_path):
    site = PX4_SOLO
    plan_dir = site.plan(tmp_path)
    with Px4Sitl(home=site.home(0)[:3], params=STEADY_BATTERY) as px4:
        first = station(plan_dir, [px4.gcs_connection])
        before = kill_when(first, plan_dir, lambda s: 1 in s.vehicles and len(s.vehicles[1].battery_samples) >= 10,
                           timeout_s=300)
        port = before.udp_source_ports[px4.gcs_connection]
        time.sleep(1.0)
        done = subprocess.run([sys.executable, "-m", "gcs.cli", "fly", "--resume", str(plan_dir)],
                              capture_output=True, text=True, timeout=600)
    out = done.stdout
    assert done.returncode == 0, out[-3000:] + done.stderr
    assert before.vehicles[1].stage.value == "search"
    assert "UAV 1: reattached: flying its search (mode MISSION" in out, out[-3000:]
    after = read_journal(plan_dir)
    assert after.udp_source_ports[px4.gcs_connection] == port  # the restarted station sent from the same port
    assert after.vehicles[1].stage.value == "landed"
    row = next(line.split() for line in out.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and float(row[3]) <= 3.0
