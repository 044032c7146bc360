"""A station that survives its own restart, on ArduCopter SITL: `gcs fly` is SIGKILLed while the
copter searches in AUTO; the copter flies on by itself (ArduPilot's GCS failsafe is off by
default); `gcs fly --resume` listens on the same port, reattaches (its mode, mission item and
battery, its mission downloaded and compared with the one uploaded), and carries on: the copter's
battery (its current sensor reads 3300/2600 of what it draws, BATT_AMP_PERVLT scaled: a copter thirstier
than its stock profile, whose search does not fit) sends it
home by the fuel-based trigger, from the consumption learned before the kill and after, above
the 30 % reserve, and it lands at its airport.
The flight is read back from the journal and from both segments of its Rerun recording."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time

import pytest

from gcs.flight.journal import read_journal
from gcs.plans.plan_folder import load_plan_dir
from gcs.recording.flight import FLIGHT_TIME, segment_path
from gcs.recording.plan import read_recording
from tests.gcs.autopilots.flights import metres
from tests.gcs.flight.resume_peers import flight_events, kill_when, station
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.process import SITL_WORKER
from tests.peers.site import COPTERS, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

AWAY_S = 1.0  # and the restarted station's own start: some 20 s of the copter's time at SITL's speed-up 7
#: At 10 a restart slowed by a loaded machine (13.5 s in ci80) let the copter reach its planned way
#: home, and land by its plan at 25 %, before the restarted station could send it home on fuel
SPEEDUP = 7


def test_a_copter_flies_on_while_the_station_is_dead_and_the_restarted_station_brings_it_home_on_fuel(tmp_path):
    site = Site(COPTERS.airports[1:2])
    plan_dir = site.plan(tmp_path)
    with ArduPilotSitl("copter", home=site.home(0), speedup=SPEEDUP,
                       params={"BATT_AMP_PERVLT": 17.0 * 3300 / 2600}) as sitl:
        first = station(plan_dir, [sitl.udp_connection])
        before = kill_when(first, plan_dir, lambda s: 1 in s.vehicles and len(s.vehicles[1].battery_samples) >= 10,
                           timeout_s=300)  # 10 s of the copter's time in the air, searching
        time.sleep(AWAY_S)
        started = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "gcs.cli", "fly", "--resume", str(plan_dir)],
                              capture_output=True, text=True, timeout=600)
        took = time.monotonic() - started
    out = done.stdout
    assert done.returncode == 0, out[-3000:] + done.stderr
    after = read_journal(plan_dir)
    v_before, v_after = before.vehicles[1], after.vehicles[1]
    away = after.resumed_t[0] - before.last_t
    assert v_before.stage.value == "search" and v_before.return_reason is None
    assert "UAV 1: reattached: flying its search (mode AUTO, mission item" in out
    # home on fuel after the restart, above the reserve, at its own airport
    assert v_after.return_reason == "battery" and v_after.stage.value == "landed", \
        "\n".join(line for line in out.splitlines() if "UAV 1" in line or "station" in line)
    returns = [t for t, line in after.events if line.uav_id == 1 and "return triggered (reason: battery)" in line.text]
    assert len(returns) == 1 and returns[0] > after.resumed_t[0]
    battery = int(re.search(r"UAV 1: landed - battery (\d+)%", out).group(1))
    assert battery >= 25
    plan = load_plan_dir(plan_dir)
    airport = plan.uavs[1].airport_lat_lon
    resumed = read_recording(segment_path(plan_dir / "flight.rrd", 1), FLIGHT_TIME)
    _, positions = resumed.column("geo/uav/1", "GeoPoints:positions")
    landed_m = metres(plan, tuple(positions[-1][0]), airport)
    assert landed_m <= 3.0
    # where it flew while nobody watched: it kept to its mission (the resumed station placed it
    # further along its plan than the kill left it)
    assert v_after.track_index > v_before.track_index
    # the event log of both halves, in the journal and in the one recording
    ids, logs = flight_events(plan_dir, 2)
    assert len(set(ids)) == 1
    recorded = [line for log in logs for _, line in log]
    for lines in (recorded, [line.line for _, line in after.events]):
        assert sum(line.startswith("UAV 1: take-off") for line in lines) == 1
        assert sum(line.startswith("UAV 1: landed") for line in lines) == 1
    take_off = next(t for t, line in after.events if line.text.startswith("take-off"))
    assert take_off < before.last_t
    record = json.loads((plan_dir / "sortie.json").read_text())
    assert record["finished"] is True and record["vehicles"][0]["end"] == "landed"
    print(next(line for line in out.splitlines() if "reattached" in line))
    print(f"killed at flight second {before.last_t:.0f} (plan step {v_before.track_index}, battery "
          f"{v_before.battery_samples[-1][1]:.0f}%); the copter flew {away:.1f} s alone; reattached at step "
          f"{v_after.track_index}; the resumed station ran {took:.0f} s; landed {landed_m:.1f} m from its airport "
          f"with {battery}%")
