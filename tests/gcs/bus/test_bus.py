"""The fleet bus against a real broker: what a plain MQTT subscriber receives, commands and
their replies, malformed commands, retained states for a late subscriber."""

from __future__ import annotations

import asyncio
import json
import time
from collections import defaultdict

import aiomqtt

from gcs.bus import Command, CommandKind, FleetBus, FleetWatcher, MessageType, Topics, parse_broker_url, schema_errors
from tests.gcs.bus.helpers import ScriptedFleet


async def _collect(client: aiomqtt.Client, into: list) -> None:
    async for message in client.messages:
        into.append((message.topic.value, json.loads(message.payload), message.retain))


def test_four_uavs_reach_a_plain_subscriber_and_every_message_validates(broker, fleet_name):
    async def scenario():
        received: list = []
        async with aiomqtt.Client("127.0.0.1", broker.port, identifier=f"{fleet_name}-sub") as sub:
            await sub.subscribe(f"gcs/{fleet_name}/#", qos=1)
            reader = asyncio.create_task(_collect(sub, received))
            bus = FleetBus(parse_broker_url(broker.url), fleet=fleet_name, station="gcs1", telemetry_hz=5.0)
            async with bus:
                fleet = ScriptedFleet(bus)
                await bus.wait_connected(5)
                started = time.monotonic()
                while time.monotonic() - started < 2.0:  # the fleet reports at 50 Hz, the bus sends 5 Hz
                    fleet.tick()
                    if fleet.step == 40:
                        fleet.stage[3] = "return"
                        fleet.raise_event(3, "return", reason="battery", text="margin 0.4 steps")
                    if fleet.step % 25 == 0:
                        fleet.raise_event(1, "detection", text="hit", cell=[fleet.step, 4], hit=True)
                    await asyncio.sleep(0.02)
                await bus.drain(5)
                await asyncio.sleep(0.5)
                elapsed = time.monotonic() - started
                assert bus.stats.telemetry_replaced > 0 and bus.stats.events_dropped == 0
            await asyncio.sleep(0.2)
            reader.cancel()
        return fleet, received, elapsed

    fleet, received, elapsed = asyncio.run(scenario())
    topics = Topics(fleet_name)
    by_type: dict[MessageType, list] = defaultdict(list)
    for topic, payload, _ in received:
        kind, uav = topics.classify(topic)
        assert schema_errors(kind, payload) == [], (topic, payload)
        by_type[kind].append((uav, payload))
    telemetry = defaultdict(list)
    for uav, payload in by_type[MessageType.TELEMETRY]:
        telemetry[uav].append(payload)
    assert sorted(telemetry) == [1, 2, 3, 4]
    for uav, samples in telemetry.items():
        assert len(samples) <= 5.0 * elapsed + 2, f"UAV {uav}: {len(samples)} samples in {elapsed:.1f} s at 5 Hz"
        assert len(samples) >= 5
        assert samples[-1]["lat_deg"] == fleet.last_sample[uav].lat_deg  # the newest sample got out
        assert [s["t_s"] for s in samples] == sorted(s["t_s"] for s in samples)
    events = defaultdict(list)
    for uav, payload in by_type[MessageType.EVENT]:
        events[uav].append(payload)
    for uav, raised in fleet.raised.items():
        got = [{k: e[k] for k in ("seq", "kind", "reason", "text", "data")} for e in events[uav]]
        assert got == raised
    assert events[3][-1]["kind"] == "return" and events[3][-1]["reason"] == "battery"
    states = dict(by_type[MessageType.STATE])
    assert states[3]["stage"] == "return" and states[3]["return_reason"] == "battery"
    assert states[1]["last_event_seq"] == len(fleet.raised[1])
    presence = [p for _, p in by_type[MessageType.STATION]]
    assert presence[0]["online"] is True and presence[-1]["online"] is False


def test_commands_reach_the_handler_and_are_acknowledged(broker, fleet_name):
    async def scenario():
        holder: dict = {}

        async def handler(command):
            return await holder["fleet"].handle(command)

        url = parse_broker_url(broker.url)
        async with FleetBus(url, fleet=fleet_name, station="gcs1", handler=handler) as bus:
            fleet = holder["fleet"] = ScriptedFleet(bus)
            await bus.wait_connected(5)
            async with FleetWatcher(url, fleet=fleet_name) as watcher:
                replies = {}
                for name, command in [
                    ("return 2", Command("r2", CommandKind.RETURN, 2)),
                    ("return 2 again", Command("r2b", CommandKind.RETURN, 2)),
                    ("range 1", Command("g1", CommandKind.RANGE, 1, range_m=1500.0)),
                    ("abort 3", Command("a3", CommandKind.ABORT, 3)),
                    ("return 9", Command("r9", CommandKind.RETURN, 9)),
                    ("return all", Command("rall", CommandKind.RETURN, None)),
                ]:
                    replies[name] = await watcher.command(command, timeout_s=5)
        return fleet, replies

    fleet, replies = asyncio.run(scenario())
    assert replies["return 2"].ok and replies["return 2"].reason is None and replies["return 2"].station == "gcs1"
    assert not replies["return 2 again"].ok and replies["return 2 again"].reason == "UAV 2 is already returning"
    assert replies["range 1"].ok and fleet.ranges[1] == 1500.0
    assert replies["abort 3"].ok and fleet.stage[3] == "rtl"
    assert not replies["return 9"].ok and replies["return 9"].reason.startswith("unknown UAV 9")
    assert replies["return all"].ok
    assert fleet.stage == {1: "return", 2: "return", 3: "rtl", 4: "return"}
    assert [c.request_id for c in fleet.commands] == ["r2", "r2b", "g1", "a3", "r9", "rall"]
    assert fleet.raised[2][-1] == {"seq": 2, "kind": "return", "reason": "mqtt", "text": "ordered by the bus",
                                   "data": {}}


def test_malformed_commands_are_refused_with_a_reason_and_the_bus_carries_on(broker, fleet_name):
    async def scenario():
        calls = []

        async def handler(command):
            calls.append(command)
            if command.uav == 4:
                raise RuntimeError("fleet layer bug")
            if command.uav == 3:
                await asyncio.sleep(10)
            return None

        url = parse_broker_url(broker.url)
        replies = defaultdict(list)
        async with FleetBus(url, fleet=fleet_name, handler=handler, handler_timeout_s=0.5) as bus, \
                aiomqtt.Client("127.0.0.1", broker.port) as client:
            await bus.wait_connected(5)
            await client.subscribe(f"gcs/{fleet_name}/cmd/reply/+", qos=1)
            for raw in [b"{not json", b"\xff\xfe", b"[1, 2]", json.dumps({"request_id": "m1", "kind": "fly", "uav": 1}),
                        json.dumps({"request_id": "m2", "kind": "range", "uav": 1}),
                        json.dumps({"request_id": "m3", "kind": "return", "uav": 0}),
                        json.dumps({"request_id": "m4", "kind": "return", "uav": 4}),
                        json.dumps({"request_id": "m5", "kind": "return", "uav": 3}),
                        json.dumps({"request_id": "ok1", "kind": "return", "uav": 1})]:
                await client.publish(f"gcs/{fleet_name}/cmd", raw, qos=1)
            async with asyncio.timeout(5):
                async for message in client.messages:
                    payload = json.loads(message.payload)
                    assert schema_errors(MessageType.REPLY, payload) == []
                    replies[message.topic.value.rsplit("/", 1)[1]].append(payload)
                    if sum(map(len, replies.values())) == 9:
                        break
        return calls, replies

    calls, replies = asyncio.run(scenario())
    invalid = [r["reason"] for r in replies["_invalid"]]
    assert len(invalid) == 3 and all(r["request_id"] is None and not r["ok"] for r in replies["_invalid"])
    assert sum("not JSON" in r for r in invalid) == 2 and any("is not of type 'object'" in r for r in invalid)
    assert replies["m1"][0]["reason"] == "invalid command: kind: 'fly' is not one of ['return', 'range', 'abort']"
    assert replies["m2"][0]["reason"] == "invalid command: (top): 'range_m' is a required property"
    assert "uav" in replies["m3"][0]["reason"]
    assert replies["m4"][0]["reason"] == "command failed: RuntimeError: fleet layer bug"
    assert replies["m5"][0]["reason"] == "no answer from the fleet within 0.5 s"
    assert replies["ok1"][0]["ok"] is True
    assert [c.request_id for c in calls] == ["m4", "m5", "ok1"]  # nothing malformed reached the handler


def test_a_late_subscriber_sees_the_fleet_at_once_from_retained_states(broker, fleet_name):
    async def scenario():
        url = parse_broker_url(broker.url)
        async with FleetBus(url, fleet=fleet_name, station="early") as bus:
            fleet = ScriptedFleet(bus)
            fleet.tick()
            fleet.stage[2] = "landed"
            fleet.raise_event(2, "landed", text="battery 41%")
            fleet.tick()
            await bus.wait_connected(5)
            await bus.drain(5)
            await asyncio.sleep(0.5)
        # the publishing station is gone; a new station joins
        started = time.monotonic()
        states = {}
        async with aiomqtt.Client("127.0.0.1", broker.port) as late:
            await late.subscribe(f"gcs/{fleet_name}/uav/+/state", qos=1)
            async with asyncio.timeout(3):
                async for message in late.messages:
                    assert message.retain
                    payload = json.loads(message.payload)
                    states[payload["uav"]] = payload
                    if len(states) == 4:
                        break
        return fleet, states, time.monotonic() - started

    fleet, states, waited = asyncio.run(scenario())
    assert waited < 1.0
    for uav, state in states.items():
        assert schema_errors(MessageType.STATE, state) == []
        assert state["telemetry"]["lat_deg"] == fleet.last_sample[uav].lat_deg
    assert states[2]["stage"] == "landed" and states[2]["last_event_seq"] == 2
    assert {states[u]["stage"] for u in (1, 3, 4)} == {"search"}
