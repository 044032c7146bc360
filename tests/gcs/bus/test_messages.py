"""Pure parts of the bus: broker URLs, the topic tree, payload checks, the bounded event queue."""

from __future__ import annotations

import asyncio
import json

import pytest

from gcs.bus import FleetBus, MessageType, Telemetry, TlsOptions, Topics, parse_broker_url, parse_command, schema_errors
from gcs.bus.messages import InvalidCommand


def test_broker_urls():
    b = parse_broker_url("mqtt://127.0.0.1")
    assert (b.host, b.port, b.tls, b.username) == ("127.0.0.1", 1883, None, None)
    b = parse_broker_url("mqtts://op:p%40ss@broker.lan")
    assert (b.port, b.username, b.password, b.tls) == (8883, "op", "p@ss", TlsOptions())
    assert str(b) == "mqtts://op@broker.lan:8883"
    assert parse_broker_url("mqtt://u:x@h:1", username="v", password="y").username == "v"
    for bad, what in [("http://h", "mqtt://"), ("mqtt://", "no host"), ("mqtt://h:99999", "bad port"),
                      ("mqtt://h/x", "no path")]:
        with pytest.raises(ValueError, match=what):
            parse_broker_url(bad)
    with pytest.raises(ValueError, match="mqtts"):
        parse_broker_url("mqtt://h", tls=TlsOptions(ca_file="ca.crt"))


def test_password_from_the_environment(monkeypatch):
    monkeypatch.setenv("GCS_MQTT_PASSWORD", "from-env")
    assert parse_broker_url("mqtt://operator@h").password == "from-env"
    assert parse_broker_url("mqtt://h").password is None


def test_topic_tree_round_trip():
    t = Topics("demo")
    assert t.classify(t.telemetry(3)) == (MessageType.TELEMETRY, 3)
    assert t.classify(t.state(12)) == (MessageType.STATE, 12)
    assert t.classify(t.event(1)) == (MessageType.EVENT, 1)
    assert t.classify(t.station("gcs1")) == (MessageType.STATION, None)
    assert t.classify(t.command) == (MessageType.COMMAND, None)
    assert t.classify(t.reply("abc")) == (MessageType.REPLY, None)
    for other in ("gcs/other/uav/1/state", "gcs/demo/uav/x/state", "gcs/demo/uav/1/gossip", "gcs/demo"):
        assert t.classify(other) is None
    with pytest.raises(ValueError, match="fleet name"):
        Topics("a/b")
    with pytest.raises(ValueError):
        Topics("#")


def test_telemetry_payload_has_no_infinity_and_validates():
    p = Telemetry(2, "return", 45.0, 7.0, 30.0, -90.0, 55.0, float("inf"), float("nan")).payload("demo")
    assert p["heading_deg"] == 270.0 and p["range_left_m"] is None and p["margin_m"] is None
    assert schema_errors(MessageType.TELEMETRY, p) == []
    json.dumps(p, allow_nan=False)
    with pytest.raises(ValueError, match="unknown stage"):
        Telemetry(1, "cruising").payload("demo")
    assert schema_errors(MessageType.TELEMETRY, {**p, "battery_pct": 130}) != []


@pytest.mark.parametrize("raw, reason", [
    (b"", "not JSON"),
    (b'{"request_id": "a b", "kind": "return", "uav": 1}', "request_id"),
    (b'{"request_id": "a", "kind": "return", "uav": "some"}', "uav"),
    (b'{"request_id": "a", "kind": "range", "uav": "all", "range_m": 500}', "uav"),
    (b'{"request_id": "a", "kind": "abort", "uav": 1, "range_m": 500}', "range_m is only for kind range"),
    (b'{"request_id": "a", "kind": "abort", "uav": 1, "extra": true}', "Additional properties"),
])
def test_invalid_commands_name_the_problem(raw, reason):
    with pytest.raises(InvalidCommand, match=reason):
        parse_command(raw)


def test_a_full_event_queue_drops_the_oldest_and_counts_it():
    async def scenario():
        # no broker at this address: everything stays queued
        bus = FleetBus(parse_broker_url("mqtt://127.0.0.1:1"), fleet="q", event_queue_size=5, reconnect_min_s=0.05)
        async with bus:
            seqs = [bus.event(1, "note", text=str(i)) for i in range(8)]
            await asyncio.sleep(0.2)
            assert not bus.connected
            queued = [json.loads(item.payload)["seq"] for item in bus._outgoing]
        return seqs, queued, bus.stats

    seqs, queued, stats = asyncio.run(scenario())
    assert seqs == list(range(1, 9))
    assert queued == [4, 5, 6, 7, 8] and stats.events_dropped == 3 and stats.events_raised == 8
    assert stats.connects == 0 and "refused" in stats.last_error.lower()


def test_fly_bus_settings_are_checked_before_the_flight():
    from gcs.bus.flight_feed import bus_feed

    feed = bus_feed("mqtts://op@h:8884", fleet="north", ca_file="ca.crt")
    assert (feed.broker.port, feed.broker.tls.ca_file, feed.fleet, feed.station) == (8884, "ca.crt", "north", "gcs")
    for url, settings, what in [("tcp://h", {}, "mqtt://"), ("mqtt://h", {"fleet": "a/b"}, "--fleet"),
                                ("mqtt://h", {"ca_file": "ca.crt"}, "mqtts")]:
        with pytest.raises(ValueError, match=what):
            bus_feed(url, **settings)


def test_fly_bus_arguments_become_one_error_line():
    from gcs.cli import main

    assert main(["fly", "--plan", "nowhere", "--sim", "--mqtt", "mqtt://h", "--fleet", "a/b"]) == 2
