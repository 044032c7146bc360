"""mqtts://: a Mosquitto TLS listener with a certificate from a throw-away CA."""

from __future__ import annotations

import asyncio
import subprocess
from pathlib import Path

import pytest

from gcs.bus import FleetBus, FleetWatcher, TlsOptions, parse_broker_url
from tests.gcs.bus.helpers import ScriptedFleet


def _openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


def make_certificates(folder: Path) -> dict[str, Path]:
    ec = ("-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes")
    _openssl("req", "-x509", *ec, "-keyout", "ca.key", "-out", "ca.crt", "-days", "2", "-subj", "/CN=gcs test CA",
             cwd=folder)
    _openssl("req", *ec, "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=127.0.0.1", cwd=folder)
    (folder / "san.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    _openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial",
             "-out", "server.crt", "-days", "2", "-extfile", "san.ext", cwd=folder)
    return {name: folder / name for name in ("ca.crt", "server.crt", "server.key")}


def test_the_bus_over_tls(make_broker, tmp_path, fleet_name):
    certs = make_certificates(tmp_path)
    broker = make_broker(f"cafile {certs['ca.crt']}\ncertfile {certs['server.crt']}\nkeyfile {certs['server.key']}\n")
    url = f"mqtts://127.0.0.1:{broker.port}"
    trusted = parse_broker_url(url, tls=TlsOptions(ca_file=str(certs["ca.crt"])))

    async def scenario():
        async with FleetBus(trusted, fleet=fleet_name) as bus:
            fleet = ScriptedFleet(bus)
            fleet.tick()
            await bus.wait_connected(5)
            await bus.drain(5)
            await asyncio.sleep(0.3)
            async with FleetWatcher(trusted, fleet=fleet_name) as watcher:
                await asyncio.sleep(0.5)
                seen = sorted(watcher.uavs)
            with pytest.raises(ConnectionError, match="(?i)certificate"):
                async with FleetWatcher(parse_broker_url(url), fleet=fleet_name):  # system CAs: not trusted
                    pass
        return seen

    assert asyncio.run(scenario()) == [1, 2, 3, 4]
