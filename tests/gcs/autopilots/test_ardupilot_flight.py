"""`gcs fly` on real ArduCopter and ArduPlane SITL: each vehicle waits until it is ready, flies its
planned search in AUTO and lands at its own airport (the plane on its runway, after the landing
approach); a vehicle that refuses to arm stays on the ground with ArduPilot's reason while the
other flies. Each test reads the flight back from its Rerun recording: where each vehicle
landed, that no recorded position entered a no-fly cell, and that the stages came in order."""

from __future__ import annotations

import json
import re
import threading
from contextlib import ExitStack
from dataclasses import replace

import numpy as np
import pytest
import shapely

from tests.gcs.autopilots.flights import (
    assert_landed_home_and_clear_of_no_fly,
    ctrl_c_while_its_way_home_is_lost,
    fly,
    fly_with_a_dropout,
    recorded,
)
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.ports import free_udp_port
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import STEADY_BATTERY, Px4Sitl
from tests.peers.recorder import SpareRecorder
from tests.peers.relay import UdpRelay, losing_uploads
from tests.peers.site import COPTERS, MEADOW, PLANE, Airport, Site

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

SPEEDUP = 20.0  # the highest these flights pass at (docs/tests.md): wall-clock moments below are vehicle time / SPEEDUP
SHORT_PLANE = replace(PLANE, airports=(replace(PLANE.airports[0], range_m=5000.0),))
#: COPTERS and a third airport for a PX4 that never leaves the ground
NOT_ARMED = Site((*COPTERS.airports, Airport("east", 240.0, 30.0, "W", 1300.0)))


@pytest.mark.parametrize("vehicle", ["copter", "plane"])
def test_ctrl_c_while_a_vehicle_waits_for_its_way_home_sends_it_home_by_rtl(tmp_path, vehicle):
    """The operator orders the vehicle home; the radio loses the station's upload of its return
    leg (it holds meanwhile, heard all along), and the operator presses Ctrl-C: the station cuts
    the upload short and, the vehicle holding in the air and not on any way home, commands
    ArduPilot's RTL before it ends (exit 130). Read on its spare port, it lands at its airport:
    the copter at its home, the plane through its mission's landing sequence (RTL_AUTOLAND 2,
    which the station set) on its runway, within the 60 m issue 23 allows a plane."""
    site = Site(COPTERS.airports[:1]) if vehicle == "copter" else PLANE
    plan_dir = site.plan(tmp_path) if vehicle == "copter" else site.plan(tmp_path, "--vehicle", "plane",
                                                                          "--approach-m", "400")
    uploads_lost = threading.Event()
    port = free_udp_port()
    with UdpRelay(port, losing_uploads(uploads_lost)) as relay, \
            ArduPilotSitl(vehicle, home=site.home(0), gcs_port=relay.port, speedup=SPEEDUP) as sitl, \
            SpareRecorder(f"tcp:127.0.0.1:{sitl.tcp_port_2}", 1) as recorder:
        ctrl_c_while_its_way_home_is_lost(plan_dir, f"udpin:127.0.0.1:{port}", recorder, uploads_lost,
                                          60.0 / SPEEDUP, site.home(0)[:2], 5.0 if vehicle == "copter" else 60.0)
    assert relay.dropped > 0


def test_a_plane_takes_off_along_its_runway_searches_and_lands_on_it(tmp_path):
    """On PLANE's runway with half its 10 km range (25 s of the real autopilots' worker at 10 km):
    the take-off, a search and the landing are what is checked, not how long it searches."""
    plan_dir = SHORT_PLANE.plan(tmp_path, "--vehicle", "plane", "--approach-m", "400")
    plan = json.loads((plan_dir / "plan.json").read_text())
    assert plan["uavs"][0]["approach"] is not None
    with ArduPilotSitl("plane", home=SHORT_PLANE.home(0), speedup=SPEEDUP, params={"NAVL1_PERIOD": 10}) as sitl:
        done = fly(plan_dir, sitl.gcs_port)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert "RTL_AUTOLAND set to 2" in done.stdout
    fleet_plan, tracks, _ = recorded(plan_dir)
    # on the runway: along its axis (north) within the measured stopping distance, close to the line
    east, north = np.subtract(fleet_plan.local_m(*tracks[1][-1]),
                              fleet_plan.local_m(*fleet_plan.uavs[1].airport_lat_lon))
    assert abs(east) <= 5.0 and -30.0 <= north <= 5.0, (east, north)
    assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=30.0, tolerance_m=15.0)


def test_a_plane_lands_on_a_runway_at_the_area_edge_from_an_approach_outside_it_inside_its_fence(tmp_path):
    """The meadow's runway starts on its south edge and lands northwards: the 500 m approach lies
    wholly outside the area. ArduPlane flies with the fence `gcs fly` uploads enabled
    (FENCE_ENABLE 1, FENCE_ACTION 1 = RTL): it leaves the area by the approach's length, never
    leaves the fence, the vehicle counts no breach, and it lands on its runway. SPEEDUP 30: the
    fastest wall time measured (`benchmarks/fly_approach.py`; 50 is no faster on 2 loaded cores)."""
    plan_dir = MEADOW.plan(tmp_path, "--vehicle", "plane")
    with ArduPilotSitl("plane", home=MEADOW.home(0), speedup=30, params={"NAVL1_PERIOD": 10, "FENCE_ENABLE": 1}) \
            as sitl:
        done = fly(plan_dir, sitl.gcs_port)
        fence = sitl.fence_status()
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert re.search(r"mission verified: \d+ items \+ 12 fence", done.stdout)  # area and corridor 8, no-fly box 4
    plan, tracks, _ = recorded(plan_dir)
    task = plan.uavs[1]
    h = MEADOW.half_m
    area = shapely.Polygon([(-h, -h), (h, -h), (h, h), (-h, h)])
    inclusion = shapely.Polygon([plan.local_m(*v) for v in task.fence[0][1]])
    track = shapely.points(np.array([plan.local_m(*p) for p in tracks[1]]))
    assert shapely.distance(area, track).max() > 400.0  # it flew the approach, out of the area
    assert shapely.covers(inclusion, track).all()
    assert fence is not None and fence.breach_count == 0 and fence.breach_status == 0, fence
    landed = assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=60.0, tolerance_m=15.0)
    east, north = np.subtract(plan.local_m(*tracks[1][-1]), plan.local_m(*task.airport_lat_lon))
    assert abs(east) <= 5.0 and -30.0 <= north <= 5.0, (east, north)  # on the runway, inside the area
    assert landed[1] <= 60.0


def test_vehicles_that_cannot_arm_stay_on_the_ground_with_their_reasons_while_the_other_flies_home_on_an_order(
        tmp_path):
    """UAV 2, an ArduCopter, refuses to arm (its battery below BATT_ARM_VOLT): it stays on the
    ground with ArduPilot's reason. UAV 3, a PX4, fails its pre-arm checks (COM_ARMABLE 0 puts it
    in its safety configuration, its pre-arm bit stays off): the station never arms it and names
    PX4's own reason after `--ready-timeout`. UAV 1, an ArduCopter, flies meanwhile; the
    operator's `r 1` typed 80 s of its time into its search: it is held, its planned way home is
    uploaded and flown (not RTL), and it lands at its airport with the order as the reason. Only
    UAV 1 flies: UAV 2 runs at speed-up 10 (ready in about 5 s), the PX4 at 5 (its pre-arm reason
    comes 0.2 s in); with them at 20 and 8 the three took 1.9 cores, 1.6 so. (Until 2026-12-02
    three flights of their own: the order on a lone copter, 17 s of the real autopilots' worker,
    and the PX4's refusal beside an ArduCopter in test_px4_flight.py, 27 s.)"""
    plan_dir = NOT_ARMED.plan(tmp_path)
    port = free_udp_port()
    with ExitStack() as stack:
        stack.enter_context(ArduPilotSitl("copter", home=NOT_ARMED.home(0), sysid=1, gcs_port=port, speedup=SPEEDUP))
        stack.enter_context(ArduPilotSitl("copter", home=NOT_ARMED.home(1), sysid=2, gcs_port=port, speedup=10.0,
                                          params={"BATT_ARM_VOLT": 13.0}))  # the sim battery gives 12.6 V
        px4 = stack.enter_context(Px4Sitl(home=NOT_ARMED.home(2)[:3], sysid=3, speedup=5.0,
                                          params={**STEADY_BATTERY, "COM_ARMABLE": 0}))
        done = fly(plan_dir, [f"udpin:127.0.0.1:{port}", px4.gcs_connection], "--no-rrd", "--arm-timeout", "10",
                   "--ready-timeout", "15", orders=(("UAV 1: search", "r 1", 80.0 / SPEEDUP),))
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr
    out = done.stdout
    assert "UAV 2: arming refused: Arm: Battery 1 below minimum arming voltage" in out
    assert "UAV 2: failed - cannot arm" in out and "left on the ground" in out
    assert re.search(r"UAV 3: failed - not ready after 15 s: no PX4's pre-arm checks \(.*safety configuration",
                     out), out
    assert "UAV 3: arming" not in out
    assert "UAV 1: landed" in out and "1/3 landed" in out
    assert "UAV 1: return ordered (order)" in out and re.search(r"UAV 1: return leg of \d+ waypoints uploaded", out)
    assert "RTL" not in out.split("UAV 1: return ordered", 1)[1]
    row = next(line.split() for line in out.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and row[5] == "order" and float(row[3]) <= 3.0


def test_a_vehicle_whose_link_goes_silent_flies_on_by_itself_and_never_stalls_the_other(tmp_path):
    """UAV 2's radio drops out for 100 s of the vehicles' time, 30 s into its search: the station
    marks it lost and keeps flying UAV 1; ArduPilot (GCS failsafe off, its default) flies its
    mission on; when the link comes back the station picks it up again; both land at home. UAV 1
    waits until it is ready, flies its whole search and the plan's own way home in AUTO and lands
    at its airport (a one-copter flight of its own until 2026-12-02, 21 s of the real autopilots'
    worker)."""
    plan_dir = COPTERS.plan(tmp_path)
    port = free_udp_port()
    with UdpRelay(port) as relay, ExitStack() as stack:
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port, speedup=SPEEDUP))
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=relay.port,
                                          speedup=SPEEDUP))

        done = fly_with_a_dropout(plan_dir, port, relay, 2, "--lost-giveup", "60",
                                  after_s=30.0 / SPEEDUP, silent_s=100.0 / SPEEDUP)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr
    assert relay.dropped > 50
    assert "UAV 2: lost - no telemetry" in done.stdout and "UAV 2: search - link back" in done.stdout
    assert "UAV 1: lost" not in done.stdout
    _, _, stages = recorded(plan_dir)
    assert "lost" in stages[2] and stages[2][-1] == "landed" and "lost" not in stages[1]
    landed = assert_landed_home_and_clear_of_no_fly(plan_dir, max_from_airport_m=3.0, tolerance_m=3.0)
    assert landed[1] <= 3.0
    assert "UAV 1: ready: GPS fix" in done.stdout and "UAV 1: mission verified" in done.stdout
    assert "2/2 landed" in done.stdout
    row = next(line.split() for line in done.stdout.splitlines() if line.startswith("  1 west"))
    assert row[2] == "landed" and row[5] == "plan"  # it flew its whole search and the plan's own way home
