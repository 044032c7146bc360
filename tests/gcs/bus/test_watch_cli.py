"""`gcs watch` as a subprocess: the fleet table from the broker alone, and commands."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from pathlib import Path

from gcs.bus import FleetBus, parse_broker_url
from tests.gcs.bus.helpers import ScriptedFleet

GCS = [str(Path(sys.executable).parent / "gcs")]


async def _gcs(*args: str) -> tuple[int, str, str]:
    process = await asyncio.create_subprocess_exec(*GCS, "watch", *args, stdout=subprocess.PIPE,
                                                   stderr=subprocess.PIPE)
    out, err = await asyncio.wait_for(process.communicate(), 30)
    return process.returncode, out.decode(), err.decode()


def test_gcs_watch_shows_the_fleet_and_sends_commands(broker, fleet_name):
    async def scenario():
        holder: dict = {}

        async def handler(command):
            return await holder["fleet"].handle(command)

        results = {}
        async with FleetBus(parse_broker_url(broker.url), fleet=fleet_name, station="gcs1", handler=handler) as bus:
            fleet = holder["fleet"] = ScriptedFleet(bus)
            fleet.tick()
            await bus.wait_connected(5)
            fleet.stage[4] = "landed"
            fleet.raise_event(4, "landed", text="battery 40%")

            async def feed():
                while True:
                    fleet.tick()
                    await asyncio.sleep(0.05)

            feeder = asyncio.create_task(feed())
            common = ("--mqtt", broker.url, "--fleet", fleet_name)
            results["table"] = await _gcs(*common, "--duration-s", "3")  # 1 s missed retained states on a busy machine
            results["return 2"] = await _gcs(*common, "--return", "2")
            results["return 9"] = await _gcs(*common, "--return", "9")
            results["range"] = await _gcs(*common, "--range", "1=1500")
            results["abort all"] = await _gcs(*common, "--abort", "all")
            results["nobody"] = await _gcs("--mqtt", broker.url, "--fleet", fleet_name + "-empty", "--return", "1",
                                           "--timeout", "0.5")
            feeder.cancel()
        results["no broker"] = await _gcs("--mqtt", "mqtt://127.0.0.1:1", "--once")
        results["bad range"] = await _gcs(*common, "--range", "1=x")
        results["bad url"] = await _gcs("--mqtt", "http://127.0.0.1:1883", "--once")
        return fleet, results

    fleet, results = asyncio.run(scenario())
    code, out, err = results["table"]
    assert code == 0, err
    rows = {int(line.split()[0]): line.split() for line in out.splitlines()[1:]}
    assert sorted(rows) == [1, 2, 3, 4]
    assert rows[4][1] == "landed" and rows[4][-2:] == ["#2", "landed"]
    assert rows[1][1] == "search" and rows[1][2].startswith("45.0") and rows[1][-1] == "takeoff"
    assert results["return 2"][0] == 0 and "return UAV 2: done (station gcs1)" in results["return 2"][1]
    code, out, err = results["return 9"]
    assert code == 2 and err.strip() == "error: return refused by gcs1: unknown UAV 9 (the fleet has 1, 2, 3, 4)"
    assert results["range"][0] == 0 and fleet.ranges[1] == 1500.0
    assert results["abort all"][0] == 0 and fleet.stage == {1: "rtl", 2: "return", 3: "rtl", 4: "landed"}
    code, _, err = results["nobody"]
    assert code == 2 and err.startswith("error: no reply to return within 0.5 s")
    for name in ("no broker", "bad range", "bad url"):
        code, out, err = results[name]
        assert code == 2 and err.startswith("error: ") and len(err.strip().splitlines()) == 1, (name, err)
