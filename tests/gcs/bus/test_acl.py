"""Mosquitto with the password file and ACL of docs/bus.md: only the command role commands."""

from __future__ import annotations

import asyncio
import json

import aiomqtt
import pytest

from gcs.bus import Command, CommandKind, FleetBus, FleetWatcher, parse_broker_url
from tests.gcs.bus.helpers import ScriptedFleet, docs_acl, make_password_file


def test_only_the_command_role_may_command_the_fleet(make_broker, tmp_path, fleet_name):
    passwords = make_password_file(tmp_path / "passwd", {"station": "s3cret", "operator": "0per"})
    acl = tmp_path / "acl"
    acl.write_text(docs_acl())
    broker = make_broker(f"password_file {passwords}\nacl_file {acl}\n", allow_anonymous=True)
    url = f"mqtt://127.0.0.1:{broker.port}"

    async def scenario():
        holder: dict = {}

        async def handler(command):
            return await holder["fleet"].handle(command)

        out: dict = {}
        async with FleetBus(parse_broker_url(url, username="station", password="s3cret"), fleet=fleet_name,
                            handler=handler) as bus:
            fleet = holder["fleet"] = ScriptedFleet(bus)
            fleet.tick()
            await bus.wait_connected(5)
            await bus.drain(5)
            async with FleetWatcher(parse_broker_url(url), fleet=fleet_name) as anonymous:
                for _ in range(100):  # the retained states, within 10 s (0.5 s was too short on a busy machine)
                    if len(anonymous.uavs) == 4:
                        break
                    await asyncio.sleep(0.1)
                out["anonymous sees"] = sorted(anonymous.uavs)  # reading is allowed
                with pytest.raises(TimeoutError):
                    await anonymous.command(Command("anon1", CommandKind.RETURN, 1), timeout_s=1.0)
                await anonymous.publish_raw(json.dumps({"request_id": "anon2", "kind": "abort", "uav": "all"}))
                async with aiomqtt.Client("127.0.0.1", broker.port) as spoofer:  # a fake state for UAV 1
                    await spoofer.publish(f"gcs/{fleet_name}/uav/1/state", b"{}", qos=1, retain=True)
                await asyncio.sleep(0.5)
                out["invalid seen by anonymous"] = list(anonymous.stats.invalid)
            out["commands after anonymous"] = list(fleet.commands)
            operator = parse_broker_url(url, username="operator", password="0per")
            async with FleetWatcher(operator, fleet=fleet_name) as op:
                out["operator reply"] = await op.command(Command("op1", CommandKind.RETURN, 1), timeout_s=5)
            with pytest.raises(ConnectionError):
                async with FleetWatcher(parse_broker_url(url, username="operator", password="wrong"), fleet=fleet_name):
                    pass
        return fleet, out

    fleet, out = asyncio.run(scenario())
    assert out["anonymous sees"] == [1, 2, 3, 4]
    assert out["commands after anonymous"] == []  # the broker dropped them: never reached the handler
    assert out["invalid seen by anonymous"] == []  # the spoofed state was dropped too
    assert out["operator reply"].ok
    assert [c.request_id for c in fleet.commands] == ["op1"] and fleet.stage[1] == "return"
