"""The bus attached to a real flight: the paper's area flown by the simulated fleet with the
FlightController of `gcs fly`, watched and commanded over MQTT."""

from __future__ import annotations

import asyncio
import json
from collections import defaultdict
from contextlib import AsyncExitStack

import aiomqtt

from gcs.bus import Command, CommandKind, FleetWatcher, MessageType, Topics, parse_broker_url, schema_errors
from gcs.bus.flight_feed import bus_feed
from gcs.cli import main
from gcs.flight.controller import FlightController
from gcs.links import MavLink
from gcs.plans.plan_folder import load_plan_dir
from gcs.telemetry.status import Stage
from sim.plan_fleet import fleet_for_plan
from tests.gcs.flight.conftest import SPEEDUP, fast_options


def test_a_flight_is_published_and_obeys_a_return_order_from_the_bus(broker, fleet_name, tmp_path, flight_area):
    out = tmp_path / "plan"
    assert main(["plan", "--area", str(flight_area), "--seed", "0", "--strategy",
                 "exhaustive", "--out", str(out), "--quiet"]) == 0
    plan = load_plan_dir(out)
    options = fast_options()
    sim = fleet_for_plan(plan, speedup=SPEEDUP).start()

    async def scenario():
        received = []
        replies = {}
        url = parse_broker_url(broker.url)
        async with aiomqtt.Client("127.0.0.1", broker.port) as sub, AsyncExitStack() as stack:
            await sub.subscribe(f"gcs/{fleet_name}/#", qos=1)

            async def collect():
                async for message in sub.messages:
                    received.append((message.topic.value, json.loads(message.payload)))

            reader = asyncio.create_task(collect())
            links = [await stack.enter_async_context(MavLink(c)) for c in sim.connection_strings()]
            controller = FlightController(plan, links, options, out=lambda line: None)
            feed = bus_feed(broker.url, fleet=fleet_name, station="flyer", telemetry_hz=5.0)  # as gcs fly would
            async with feed.attach(controller):
                flight = asyncio.create_task(controller.run())
                async with FleetWatcher(url, fleet=fleet_name) as watcher:
                    while not controller.status[2].airborne_seen:  # ordered on the ground, it would stay there
                        assert not flight.done() and controller.status[2].stage is not Stage.FAILED, \
                            f"UAV 2 will not take off: {controller.status[2].note}"
                        await asyncio.sleep(0.05)
                    replies["return 2"] = await watcher.command(Command("r2", CommandKind.RETURN, 2), 5)
                    replies["return 2 again"] = await watcher.command(Command("r2b", CommandKind.RETURN, 2), 5)
                    replies["return 9"] = await watcher.command(Command("r9", CommandKind.RETURN, 9), 5)
                    replies["range"] = await watcher.command(Command("g1", CommandKind.RANGE, 1, range_m=900.0), 5)
                    await asyncio.wait_for(flight, 90)
            await asyncio.sleep(0.3)
            reader.cancel()
        return controller, received, replies

    try:
        controller, received, replies = asyncio.run(scenario())
    finally:
        sim.stop()
    assert replies["return 2"].ok and replies["return 2"].station == "flyer"
    assert replies["return 2 again"].reason == "UAV 2 is already returning"
    assert replies["return 9"].reason.startswith("unknown UAV 9")
    ranges = {uid: v.operator_range for uid, v in controller.vehicles.items() if v.operator_range is not None}
    assert replies["range"].ok and ranges == {1: 900.0}  # the live trigger honours it
    assert controller.status[2].return_reason == "mqtt"
    assert all(st.stage is Stage.LANDED for st in controller.status.values())
    topics = Topics(fleet_name)
    events = defaultdict(list)
    states = {}
    for topic, payload in received:
        kind, uav = topics.classify(topic)
        assert schema_errors(kind, payload) == [], (topic, payload)
        if kind is MessageType.EVENT:
            events[uav].append(payload)
        elif kind is MessageType.STATE:
            states[uav] = payload
    for uav in plan.uavs:
        kinds = [e["kind"] for e in events[uav]]
        assert [e["seq"] for e in events[uav]] == list(range(1, len(kinds) + 1))
        assert kinds.count("takeoff") == 1 and kinds[-1] == "landed", kinds
        stages = [e["data"]["to"] for e in events[uav] if e["kind"] == "stage"]
        assert stages == ["preparing", "uploading", "arming", "search"], stages  # every stage: events are pushed
        assert states[uav]["stage"] == "landed" and states[uav]["last_event"]["kind"] == "landed"
    returns = [e for e in events[2] if e["kind"] == "return"]
    assert len(returns) == 1 and returns[0]["reason"] == "mqtt"
    kinds2 = [e["kind"] for e in events[2]]
    assert kinds2.index("takeoff") < kinds2.index("return") < kinds2.index("landed")
