"""`TakFeed` as `gcs fly` hands it to the flight: a vehicle whose link goes silent mid-flight is
said lost in its track's remarks and fades when its last track goes stale, while the other one
flies on and lands (the simulated fleet, read back from the mesh's group on loopback)."""

from __future__ import annotations

from gcs.plans.plan_folder import load_plan_dir
from gcs.tak.destination import parse_tak_url
from gcs.tak.flight_feed import TakFeed
from gcs.tak.settings import TakSettings
from gcs.telemetry.status import Stage
from tests.gcs.flight.conftest import fast_options, fly
from tests.gcs.tak.helpers import MulticastReader
from tests.peers.ports import free_udp_port


def test_a_vehicle_that_goes_silent_fades_on_the_map_and_the_other_lands(square_plan_dir):
    plan = load_plan_dir(square_plan_dir)
    port = free_udp_port()
    feed = TakFeed([parse_tak_url(f"udp://239.2.3.1:{port}", interface="127.0.0.1")],
                   TakSettings("silent", every_s=0.3, stale_s=2.0))
    with MulticastReader(port) as mesh:
        # 180 s of vehicle time: in flight (the simulated ArduCopter is ready to arm after 42 s)
        controller, _ = fly(plan, fast_options(), during=lambda f: f.call(f.stop_answering, 2, 180.0),
                            watchers=[feed])
    assert controller.status[2].stage is Stage.LOST and controller.status[1].stage is Stage.LANDED
    silent = sorted((e for e in mesh.events if e.uid == "gcs.silent.uav.2"), key=lambda e: e.time())
    searching = [t for t in silent if "stage search" in t.remarks and "link lost" not in t.remarks]
    assert len({t.point for t in searching}) >= 3  # it was followed until it went silent
    last = silent[-1]
    assert last.remarks.endswith("link lost") and last.time() > silent[-2].time()
    assert last.time("stale") == silent[-2].time("stale")  # not kept alive by the news
    assert not mesh.of("gcs.silent.uav.2.landed")
    flown = sorted((e for e in mesh.events if e.uid == "gcs.silent.uav.1"), key=lambda e: e.time())
    assert "stage landed" in flown[-1].remarks and mesh.of("gcs.silent.uav.1.landed")
