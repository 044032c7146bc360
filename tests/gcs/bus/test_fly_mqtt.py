"""`gcs fly --mqtt` end to end: a simulated 4-UAV flight shares its fleet on a real broker; the
broker is killed and restarted mid-flight; the flight completes and a plain subscriber gets
every event of every UAV, in order, each valid against its schema."""

from __future__ import annotations

import asyncio
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import aiomqtt

from gcs.bus import MessageType, schema_errors

ROOT = Path(__file__).resolve().parents[3]


async def _subscriber(port: int, fleet: str, events: list, telemetry: list) -> None:
    while True:
        try:
            async with aiomqtt.Client("127.0.0.1", port, identifier=f"{fleet}-e2e", clean_session=False) as client:
                await client.subscribe(f"gcs/{fleet}/uav/+/event", qos=1)
                await client.subscribe(f"gcs/{fleet}/uav/+/telemetry", qos=0)
                async for message in client.messages:
                    payload = json.loads(message.payload)
                    (events if str(message.topic).endswith("/event") else telemetry).append(payload)
        except aiomqtt.MqttError:
            await asyncio.sleep(0.1)


def test_a_flight_survives_a_broker_restart_and_every_event_arrives(make_broker, fleet_name, tmp_path, flight_area):
    broker = make_broker()

    async def scenario():
        events: list = []
        telemetry: list = []
        subscriber = asyncio.create_task(_subscriber(broker.port, fleet_name, events, telemetry))
        await asyncio.sleep(0.5)
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "gcs.cli", "fly", "--area", str(flight_area), "--sim",
            "--speedup", "20", "--no-rrd", "--mqtt", broker.url, "--fleet", fleet_name, "--out", str(tmp_path / "run"),
            cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
        deadline = time.monotonic() + 60
        while not any(e["kind"] == "takeoff" for e in events) and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        assert any(e["kind"] == "takeoff" for e in events), "the flight never took off on the bus"
        assert proc.returncode is None, "the broker must go away mid-flight"
        broker.stop()
        await asyncio.sleep(1.0)
        broker.start()
        out, err = await asyncio.wait_for(proc.communicate(), 180)
        await asyncio.sleep(1.0)
        subscriber.cancel()
        return proc.returncode, out.decode(), err.decode(), events, telemetry

    code, out, err, events, telemetry = asyncio.run(scenario())
    assert code == 0, err[-2000:]
    assert "4/4 landed" in out
    per_uav: dict[int, list] = defaultdict(list)
    for event in events:
        assert schema_errors(MessageType.EVENT, event) == []
        seen = per_uav[event["uav"]]
        if seen and event["seq"] <= seen[-1]["seq"]:
            assert event == next(e for e in seen if e["seq"] == event["seq"])  # at-least-once repeat
            continue
        seen.append(event)
    assert sorted(per_uav) == [1, 2, 3, 4]
    for uav, got in per_uav.items():
        assert [e["seq"] for e in got] == list(range(1, len(got) + 1)), f"UAV {uav}: a gap in {[e['seq'] for e in got]}"
        kinds = [e["kind"] for e in got]
        assert kinds.count("takeoff") == 1 and kinds.count("landed") == 1, kinds
        assert kinds.index("takeoff") < kinds.index("landed")
    for sample in telemetry[:50]:
        assert schema_errors(MessageType.TELEMETRY, sample) == []
    assert {s["uav"] for s in telemetry} == {1, 2, 3, 4}
