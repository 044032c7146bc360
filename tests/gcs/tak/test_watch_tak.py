"""`gcs watch --mqtt ... --tak ...`: a second station puts the fleet it reads from a real broker on
a real FreeTAKServer, with the plan's shapes when given its folder."""

from __future__ import annotations

import asyncio
import math
import subprocess
import sys
import time
from pathlib import Path

from gcs.bus import FleetBus, parse_broker_url
from gcs.plans.plan_folder import load_plan_dir
from tests.gcs.bus.helpers import Mosquitto, ScriptedFleet
from tests.gcs.tak.helpers import SHARED_TAK_SERVER, TakClient

GCS = str(Path(sys.executable).parent / "gcs")


@SHARED_TAK_SERVER
def test_a_second_station_puts_the_fleet_on_the_bus_on_tak(tak_server, square_plan_dir, tmp_path):
    broker = Mosquitto(tmp_path)
    broker.start()
    tak_url = f"tcp://127.0.0.1:{tak_server.cot_port}"

    async def scenario():
        async with TakClient(tak_server.cot_port, "command post") as client, \
                FleetBus(parse_broker_url(broker.url), fleet="watchtak", station="gcs1") as bus:
            fleet = ScriptedFleet(bus)
            fleet.tick()
            await bus.wait_connected(5)

            async def feed():
                began = time.time()
                while True:  # the UAVs move with the clock: a late turn of a busy loop is not a slow UAV
                    fleet.step = round((time.time() - began) / 0.05, 1)  # (positions in whole 1e-6 degrees)
                    fleet.tick()
                    await asyncio.sleep(0.05)

            feeder = asyncio.create_task(feed())
            watch = await asyncio.create_subprocess_exec(
                GCS, "watch", "--mqtt", broker.url, "--fleet", "watchtak", "--duration-s", "20", "--tak", tak_url,
                "--tak-every-s", "0.5", "--tak-stale-s", "3", "--plan", str(square_plan_dir),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            # three updates of every UAV before UAV 4 lands (a loaded machine may be slow to relay them)
            await client.wait_for(lambda: all(len(client.of(f"gcs.watchtak.uav.{u}")) >= 3 for u in (1, 2, 3, 4)), 30)
            sample = fleet.last_sample[2]
            fleet.raise_event(2, "detection", text="positive reading", lat_deg=sample.lat_deg,
                              lon_deg=sample.lon_deg, image_index=5, cell=[3, 4])
            fleet.stage[3] = "return"
            fleet.raise_event(3, "return", reason="range", text="going home")
            fleet.stage[4] = "landed"
            fleet.raise_event(4, "landed", text="battery 40%")
            # the watch lives 20 s: a UAV 4 track after the landing comes within it (at 12 s, the real
            # CI of edc4c3d's slow relay let the watch end before it sent one)
            await client.wait_for(lambda: any("stage landed" in e.remarks for e in client.of("gcs.watchtak.uav.4")), 15)
            out, err = await asyncio.wait_for(watch.communicate(), 60)
            feeder.cancel()
            # FreeTAKServer relays markers and routes through its slower path: let them all through
            items = ("uav.1.path", "uav.2.path", "area.1", "keep-out.1", "uav.2.reading.5", "uav.3.return",
                     "uav.4.landed")
            await client.wait_for(lambda: all(client.of(f"gcs.watchtak.{item}") for item in items), 30)
            await asyncio.sleep(1.0)
        return watch.returncode, out.decode(), err.decode(), client.events, sample

    try:
        code, out, err, events, seen_at = asyncio.run(scenario())
    finally:
        broker.stop()
    assert code == 0, err
    assert "watchtak" not in out and " 4 landed" in out  # the table, as without --tak
    assert err.splitlines()[0] == f"TAK {tak_url}: connected"
    assert err.splitlines()[-1].startswith(f"TAK {tak_url}: ") and err.splitlines()[-1].endswith("CoT events sent")

    def of(uid: str):
        return [e for e in events if e.uid == uid]

    for uav in (1, 2, 3, 4):
        tracks = of(f"gcs.watchtak.uav.{uav}")
        assert len(tracks) >= 3 and tracks[0].callsign == f"watchtak UAV{uav}"
        # the bus has no speed: it comes from successive positions and their times, 1e-5 degree north x uav
        # and east every 0.05 s (in a CI run the loop's turns once came ten times slower than that)
        nominal = math.hypot(1.112 * uav, 1.112 * math.cos(math.radians(45.0))) / 0.05
        speed = float(tracks[-1].element.find("detail/track").get("speed"))
        assert 0.9 * nominal < speed < 1.05 * nominal, (uav, speed, nominal)
    assert {t.type for t in of("gcs.watchtak.uav.1")} == {"a-f-A-M-H-Q"}  # a copter in the plan
    assert {t.type for t in of("gcs.watchtak.uav.3")} == {"a-f-A-M-F-Q"}  # not in the plan: a UAV
    hit = of("gcs.watchtak.uav.2.reading.5")
    assert hit and "positive reading: cell (3, 4)" in hit[0].remarks
    assert hit[0].point == (round(seen_at.lat_deg, 7), round(seen_at.lon_deg, 7))
    home = of("gcs.watchtak.uav.3.return")
    assert home and "going home: range" in home[0].remarks
    landed = of("gcs.watchtak.uav.4.landed")
    assert landed and "battery 40%" in landed[0].remarks
    last = max(of("gcs.watchtak.uav.4"), key=lambda e: e.time())
    assert "stage landed" in last.remarks and last.point == landed[0].point
    plan = load_plan_dir(square_plan_dir)
    for uav in plan.uavs:
        path = of(f"gcs.watchtak.uav.{uav}.path")
        assert path and len(path[0].element.findall("detail/link")) == len(plan.uavs[uav].waypoints) + 2
    assert of("gcs.watchtak.area.1") and of("gcs.watchtak.keep-out.1")
