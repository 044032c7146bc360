"""`gcs upload` and `gcs fly` on real PX4 SITL (v1.15.3, SIH copter): the mission reads back as PX4
stores it, the copter waits for PX4's pre-arm checks, flies its search and lands at its own
airport. Flights are read back from their Rerun recordings. (PX4 in a mixed fleet with
ArduCopters: `test_energy_fleets.py`.)"""

from __future__ import annotations

import re
import subprocess
import sys
import threading

import pytest

from tests.gcs.autopilots.flights import (
    assert_fence_holds_the_area,
    assert_landed_home_and_clear_of_no_fly,
    ctrl_c_while_its_way_home_is_lost,
    fly,
    fly_with_a_dropout,
    planned_fence,
    recorded,
)
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import STEADY_BATTERY, Px4Sitl
from tests.peers.recorder import SpareRecorder
from tests.peers.relay import UdpRelay, losing_uploads
from tests.peers.site import PX4_SOLO, PX4_WILDLAND, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]



def _px4_home(site: Site, index: int) -> tuple[float, float, float]:
    return site.home(index)[:3]


@pytest.mark.parametrize("link", ["udpout", "udpin"])
def test_a_planned_mission_uploads_to_px4_and_reads_back_as_px4_stores_it(tmp_path, link):
    """Over the instance's GCS port (`udpout:127.0.0.1:18570+I`), or listening where every PX4
    SITL sends its telemetry (`udpin:127.0.0.1:14550`, vehicles told apart by system id). Over
    the GCS port the site is the issue's wildland (a traced outline of 96 vertices and a round
    no-fly zone of 28: 124 fence vertices where PX4 holds 64), its fence fitted by the plan: PX4
    accepts it and reads back what was sent (`upload_verified` compares them item by item; a
    second link opened on the GCS port after the station left got no answer to a read-back, so
    the test does not read it again), and that fence holds the area and the zone."""
    site = PX4_WILDLAND if link == "udpout" else PX4_SOLO
    plan_dir = site.plan(tmp_path)
    with Px4Sitl(home=_px4_home(site, 0), alone=link == "udpin") as px4:
        connection = px4.gcs_connection if link == "udpout" else "udpin:127.0.0.1:14550"
        done = subprocess.run([sys.executable, "-m", "gcs.cli", "upload", "--plan", str(plan_dir), "--connect",
                               connection, "--connect-timeout", "30"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "UAV 1: ready: GPS fix" in done.stdout  # PX4's pre-arm checks passed
    assert re.search(r"UAV 1: verified: mission \d+ items \(0 re-sends\), fence \d+ items", done.stdout)
    if link == "udpout":
        assert "fence 64 items" in done.stdout and "simplified" not in done.stdout, done.stdout
        assert_fence_holds_the_area(tmp_path / "site.geojson", planned_fence(plan_dir), 64)


def test_ctrl_c_while_the_px4_waits_for_its_way_home_sends_it_home_by_rtl(tmp_path):
    """As on ArduCopter (`test_ardupilot_flight`): the radio loses the upload of the PX4's return
    leg while it holds (AUTO_LOITER), the operator presses Ctrl-C, the station commands PX4's RTL
    (MAV_CMD_NAV_RETURN_TO_LAUNCH) and ends; read on its payload port, it lands at its airport."""
    plan_dir = PX4_SOLO.plan(tmp_path)
    uploads_lost = threading.Event()
    with Px4Sitl(home=_px4_home(PX4_SOLO, 0), params=STEADY_BATTERY) as px4, \
            UdpRelay(px4.gcs_port, losing_uploads(uploads_lost, station_calls_first=True)) as relay, \
            SpareRecorder(f"udpin:127.0.0.1:{14030 + px4.instance}", 1) as recorder:
        ctrl_c_while_its_way_home_is_lost(plan_dir, f"udpout:127.0.0.1:{relay.port}", recorder, uploads_lost,
                                          20.0 / px4.speedup, PX4_SOLO.home(0)[:2])
    assert relay.dropped > 0


def test_operator_orders_on_a_px4_a_shorter_range_then_home(tmp_path):
    """The operator's `range 1 N` mid-search (a range of N metres along its plan from take-off) makes the trigger
    send the PX4 home along its planned way as soon as that way no longer fits in it."""
    plan_dir = PX4_SOLO.plan(tmp_path)
    with Px4Sitl(home=_px4_home(PX4_SOLO, 0), params=STEADY_BATTERY) as px4:
        done = fly(plan_dir, [px4.gcs_connection], "--no-rrd",
                   orders=(("UAV 1: search", "range 1 360", 0.0),))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    out = done.stdout
    assert "UAV 1: range set to 360 m" in out, out[-3000:]
    assert re.search(r"UAV 1: return - going home \((range|operator)", out), out[-3000:]
    row = next(line.split() for line in out.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and float(row[3]) <= 3.0


def test_a_px4_whose_link_goes_silent_flies_its_mission_on_and_is_picked_up_again(tmp_path):
    """The station's link to PX4 goes through a relay that drops everything for 50 s of vehicle
    time, 15 s into the search: the station marks it lost; PX4 (NAV_DLL_ACT 0, its default) flies
    its mission on; the station picks it up when the link is back, and it flies its whole search
    and its planned way home and lands at its airport. (The PX4 flight without a dropout, a test
    of its own until 2026-11-29, is this one's superset.)"""
    plan_dir = PX4_SOLO.plan(tmp_path)
    with Px4Sitl(home=_px4_home(PX4_SOLO, 0), params=STEADY_BATTERY) as px4, UdpRelay(px4.gcs_port) as relay:
        done = fly_with_a_dropout(plan_dir, [f"udpout:127.0.0.1:{relay.port}"], relay, 1,
                                  "--lost-giveup", "60", after_s=15.0 / px4.speedup, silent_s=50.0 / px4.speedup)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert relay.dropped > 20
    assert "UAV 1: lost - no telemetry" in done.stdout and "UAV 1: search - link back" in done.stdout
    assert "px4 autopilot" in done.stdout and "1/1 landed" in done.stdout
    row = next(line.split() for line in done.stdout.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and row[5] == "plan"
    _, _, stages = recorded(plan_dir)
    assert "lost" in stages[1] and stages[1][-1] == "landed"
    assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=3.0, tolerance_m=3.0)
