"""Kill and restart the broker mid-stream: the publisher reconnects by itself and every event
arrives, in order, exactly as raised."""

from __future__ import annotations

import asyncio
import json
import time
from collections import defaultdict

import aiomqtt

from gcs.bus import FleetBus, MessageType, parse_broker_url, schema_errors
from tests.gcs.bus.helpers import ScriptedFleet


async def _persistent_subscriber(port: int, fleet: str, received: list, connects: list) -> None:
    """A plain subscriber with a persistent session (clean_session False, QoS 1): the broker keeps
    what arrives for it while it is away, across its own restart (persistence on)."""
    while True:
        try:
            async with aiomqtt.Client("127.0.0.1", port, identifier=f"{fleet}-watch", clean_session=False) as client:
                await client.subscribe(f"gcs/{fleet}/uav/+/event", qos=1)  # SUBACK'd: the broker keeps the rest
                connects.append(time.monotonic())
                async for message in client.messages:
                    received.append(json.loads(message.payload))
        except aiomqtt.MqttError:
            await asyncio.sleep(0.1)


def test_events_survive_a_broker_restart_in_order_and_complete(make_broker, fleet_name):
    broker = make_broker()

    async def scenario():
        received: list = []
        connects: list = []
        subscriber = asyncio.create_task(_persistent_subscriber(broker.port, fleet_name, received, connects))
        statuses: list[str] = []
        async with FleetBus(parse_broker_url(broker.url), fleet=fleet_name, telemetry_hz=10.0,
                            reconnect_min_s=0.05, reconnect_max_s=0.5, on_status=statuses.append) as bus:
            await bus.wait_connected(5)
            while len(connects) < 1:  # subscribed before the first event (its take-off): not retained
                await asyncio.sleep(0.01)
            fleet = ScriptedFleet(bus)
            loop = asyncio.get_running_loop()
            restart = None
            queued_while_down = 0
            for step in range(300):  # 3 s of events from 4 UAVs at 100 Hz, the broker away for ~1 s
                fleet.tick()
                uav = fleet.uav_ids[step % 4]
                fleet.raise_event(uav, "note", text=f"step {step}", step=step)
                if step == 80:
                    restart = loop.run_in_executor(None, _stop_wait_start, broker, 1.0)
                if not bus.connected:
                    queued_while_down = max(queued_while_down, bus.pending_events)
                await asyncio.sleep(0.01)
            await restart
            await bus.drain(10)
            stats = bus.stats
        raised = sum(len(events) for events in fleet.raised.values())
        for _ in range(100):  # the broker's deliveries to the subscriber, a loaded machine's seconds late
            if len({(e["uav"], e["seq"]) for e in received}) >= raised:
                break
            await asyncio.sleep(0.1)
        await asyncio.sleep(0.2)  # and any repeat on its way
        subscriber.cancel()
        return fleet, received, stats, queued_while_down, statuses

    fleet, received, stats, queued_while_down, statuses = asyncio.run(scenario())
    assert stats.disconnects >= 1 and stats.connects >= 2 and stats.events_dropped == 0
    assert queued_while_down > 20, "the broker was down while events were raised"
    assert any("retrying" in s for s in statuses)
    per_uav = defaultdict(list)
    repeats = 0
    for event in received:
        assert schema_errors(MessageType.EVENT, event) == []
        seen = per_uav[event["uav"]]
        if seen and event["seq"] <= seen[-1]["seq"]:
            repeats += 1  # at least once: a PUBACK lost in the crash makes the bus send it again
            assert event == next(e for e in seen if e["seq"] == event["seq"])
            continue
        seen.append(event)
    for uav, raised in fleet.raised.items():
        got = [{k: e[k] for k in ("seq", "kind", "reason", "text", "data")} for e in per_uav[uav]]
        assert got == raised, f"UAV {uav}: {len(got)} of {len(raised)} events, in order: {got[:3]}..."
    assert repeats <= 16  # at most the messages in flight when the broker went away


def _stop_wait_start(broker, down_s: float) -> None:
    broker.stop()
    time.sleep(down_s)
    broker.start()
