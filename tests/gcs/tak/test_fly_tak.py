"""`gcs fly --sim --tak ...` end to end: a simulated two-UAV flight of a small area published to a
real FreeTAKServer (its plain and TLS inputs) and to the mesh's multicast group, read back as TAK
clients read it; and a flight whose TAK server is killed mid-way."""

from __future__ import annotations

import asyncio
import json
import os
import ssl
import sys
import time
from datetime import timedelta
from pathlib import Path

from gcs.plans.plan_folder import load_plan_dir
from tests.gcs.tak.helpers import SHARED_TAK_SERVER, MulticastReader, Received, TakClient
from tests.peers.ports import free_udp_port

ROOT = Path(__file__).resolve().parents[3]
SQUARE = Path(__file__).with_name("square.geojson")
EVERY_S, STALE_S = 0.5, 4.0
RELAY_WAIT_S = 90.0


async def _fly(out: Path, *tak_args: str, speedup: str = "25", env: dict | None = None) -> asyncio.subprocess.Process:
    return await asyncio.create_subprocess_exec(
        sys.executable, "-m", "gcs.cli", "fly", "--area", str(SQUARE), "--sim", "--speedup", speedup, "--no-rrd",
        "--out", str(out), "--tak-every-s", str(EVERY_S), "--tak-stale-s", str(STALE_S), *tak_args, cwd=ROOT,
        env={**os.environ, **(env or {})}, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT)


def _tracks(events: list[Received], uav: int) -> list[Received]:
    """UAV `uav`'s tracks by time, each once (the server relays what the flight sends it on both of its inputs)."""
    tracks = {e.element.get("time"): e for e in events if e.uid == f"gcs.square.uav.{uav}"}
    return sorted(tracks.values(), key=lambda e: e.time())


def _missing(events: list[Received], tracks_only: bool = False) -> list[str]:
    """What a client has not received yet of what the flight sent: each UAV's landed track, and
    (unless `tracks_only`) the landings, the area, the keep-out zone, the paths and the return leg."""
    missing = [f"UAV {uav} landed track" for uav in (1, 2)
               if not (tracks := _tracks(events, uav)) or "stage landed" not in tracks[-1].remarks]
    items = () if tracks_only else ("uav.1.landed", "uav.2.landed", "area", "keep-out", "uav.1.path", "uav.2.path",
                                    "uav.1.return-leg")
    return missing + [item for item in items if not any(e.uid.startswith(f"gcs.square.{item}") for e in events)]


@SHARED_TAK_SERVER
def test_a_simulated_flight_is_on_the_tak_server_as_a_tak_client_sees_it(tak_server, tak_pki, tmp_path):
    certs, _ = tak_pki
    mesh_port = free_udp_port()
    context = ssl.create_default_context(cafile=str(certs.ca))
    context.load_cert_chain(str(certs.client_cert), str(certs.client_key))
    tcp_url, tls_url = f"tcp://127.0.0.1:{tak_server.cot_port}", f"tls://127.0.0.1:{tak_server.ssl_port}"
    mesh_url = f"udp://239.2.3.1:{mesh_port}"

    async def scenario():
        async with TakClient(tak_server.cot_port, "tcp team") as tcp, \
                TakClient(tak_server.ssl_port, "tls team", context) as tls, MulticastReader(mesh_port) as mesh:
            await asyncio.sleep(1.0)
            proc = await _fly(tmp_path / "square", "--tak", tcp_url, "--tak", tls_url, "--tak", mesh_url,
                              "--tak-cert", str(certs.client_p12), "--tak-ca", str(certs.ca),
                              "--tak-interface", "127.0.0.1", "--sim-drain", "1:8",
                              env={"GCS_TAK_CERT_PASSWORD": certs.p12_password})
            out, _ = await asyncio.wait_for(proc.communicate(), 240)
            ended = time.monotonic()
            # FreeTAKServer relays big events (routes, shapes) through its slower path, and on a loaded
            # machine its relay lags the flight by tens of seconds: let everything through
            await tcp.wait_for(lambda: not _missing(tcp.events), RELAY_WAIT_S)
            await tls.wait_for(lambda: not _missing(tls.events, tracks_only=True), 5)
            await asyncio.sleep(1.0)
        return proc.returncode, out.decode(), ended, tcp.events, tls.events, mesh.events

    code, out, ended, tcp, tls, mesh = asyncio.run(scenario())
    assert code == 0, out[-3000:]
    for events, name in ((tcp, "tcp"), (tls, "tls"), (mesh, "mesh")):
        missing = _missing(events, tracks_only=name == "tls")
        assert not missing, f"{name} client: no {', '.join(missing)} after {RELAY_WAIT_S:g} s"
    assert "2/2 landed" in out
    folder = tmp_path / "square"
    plan = load_plan_dir(folder)
    said = [line.split("] ", 1)[-1] for line in out.splitlines() if "TAK " in line]
    assert sorted(said[:3]) == sorted([f"TAK {tcp_url}: connected", f"TAK {tls_url}: connected",
                                       f"TAK {mesh_url}: sending to the multicast group"])
    assert all(line.endswith("CoT events sent") for line in said[3:]) and len(said) == 6

    detections = json.loads((folder / "detections.geojson").read_text())["features"]
    assert detections, "the simulated sensor reported nothing: nothing to look for on the map"
    for events, name in ((tcp, "tcp"), (mesh, "mesh")):
        # every vehicle, updated live
        for uav in (1, 2):
            tracks = _tracks(events, uav)
            assert tracks[0].type == "a-f-A-M-H-Q" and tracks[0].callsign == f"square UAV{uav}", name
            live = [t for t in tracks if "stage search" in t.remarks and t.at < ended]
            assert len({t.point for t in live}) >= 3, f"{name}: UAV {uav} was not followed live ({len(live)} tracks)"
            assert len(tracks) >= 6
            for track in tracks:
                assert track.time("stale") - track.time() == timedelta(seconds=STALE_S)
            # stale after landing: its last track says so, and nothing comes after it
            assert "stage landed" in tracks[-1].remarks, (name, uav, tracks[-1].remarks)
            assert "stage landed" not in tracks[-2].remarks
            landed = [e for e in events if e.uid == f"gcs.square.uav.{uav}.landed"]
            assert landed and landed[0].point == tracks[-1].point
            # its path
            path = [e for e in events if e.uid == f"gcs.square.uav.{uav}.path"][0]
            links = path.element.findall("detail/link")
            assert len(links) == len(plan.uavs[uav].waypoints) + 2
            airport = plan.uavs[uav].airport_lat_lon
            assert tuple(map(float, links[0].get("point").split(","))) == (round(airport[0], 7), round(airport[1], 7))
        # UAV 1 was sent home by the return trigger (its battery drains 8x): where it turned, and its leg home
        turned = [e for e in events if e.uid == "gcs.square.uav.1.return"]
        assert turned and turned[0].type == "b-m-p-s-m" and "going home: battery" in turned[0].remarks, name
        leg = [e for e in events if e.uid == "gcs.square.uav.1.return-leg"]
        assert leg and leg[0].type == "b-m-r" and len(leg[0].element.findall("detail/link")) >= 2
        assert not [e for e in events if e.uid == "gcs.square.uav.2.return"]  # UAV 2 flew its plan home
        # the area and the no-fly box
        area = [e for e in events if e.uid == "gcs.square.area.1"][0]
        ring = next(r for inclusion, r in plan.uavs[1].fence if inclusion)
        assert len(area.element.findall("detail/link")) == len(ring) + 1
        assert [e for e in events if e.uid == "gcs.square.keep-out.1"]
        # every positive reading, where and by whom it was seen
        markers = {e.uid: e for e in events if ".reading." in e.uid}
        wanted = {f"gcs.square.uav.{d['properties']['uav']}.reading.{d['properties']['index']}": d for d in detections}
        assert set(markers) == set(wanted), name
        for uid, d in wanted.items():
            lon, lat = d["geometry"]["coordinates"]
            assert markers[uid].point == (round(lat, 7), round(lon, 7))
            x, y = d["properties"]["cell"]
            assert f"positive reading: cell ({x}, {y})" in markers[uid].remarks
    for uav in (1, 2):  # the TLS client too
        tracks = _tracks(tls, uav)
        assert len(tracks) >= 4 and "stage landed" in tracks[-1].remarks


@SHARED_TAK_SERVER
def test_a_tak_server_killed_mid_flight_costs_one_line_and_every_vehicle_lands(make_tak_server, tak_server, tak_pki,
                                                                               tmp_path):
    """The plain server dies for good mid-flight; a TLS server refuses the certificate from the
    start: the flight lands both vehicles and says each once."""
    certs, _ = tak_pki
    doomed = make_tak_server()
    tcp_url, tls_url = f"tcp://127.0.0.1:{doomed.cot_port}", f"tls://127.0.0.1:{tak_server.ssl_port}"

    async def scenario():
        async with TakClient(doomed.cot_port, "team") as client:
            await asyncio.sleep(1.0)
            proc = await _fly(tmp_path / "square", "--tak", tcp_url, "--tak", tls_url, "--tak-cert",
                              str(certs.rogue_cert), "--tak-key", str(certs.rogue_key), "--tak-ca", str(certs.ca),
                              env={"PYTHONUNBUFFERED": "1"})  # its lines as they come
            assert proc.stdout is not None
            before: list[str] = []

            async def read_lines() -> None:
                while line := await proc.stdout.readline():
                    before.append(line.decode())

            reading = asyncio.create_task(read_lines())
            # killed once the flight searches and the server relays it
            assert await client.wait_for(lambda: any("search - mission started" in line for line in before)
                                         and client.of("gcs.square.uav"), 90), "".join(before)
            assert proc.returncode is None, "the server must die mid-flight"
            doomed.kill()
            try:
                await asyncio.wait_for(reading, 240)
            except TimeoutError:
                proc.kill()
                raise AssertionError(f"the flight did not end: {''.join(before)[-3000:]}") from None
            await proc.wait()
        return proc.returncode, "".join(before)

    code, out = asyncio.run(scenario())
    assert code == 0, out[-3000:]
    assert "2/2 landed" in out
    said = [line.split("] ", 1)[-1] for line in out.splitlines() if "TAK " in line]
    lost = [line for line in said if line.startswith(f"TAK {tcp_url}: lost the server")]
    assert len(lost) == 1, said  # the kill reaches us as a close, or as a reset when it had unread data from us
    assert lost[0] in [f"TAK {tcp_url}: lost the server: {how}; trying again in the background, the flight goes on"
                       for how in ("closed by the server", "connection reset by peer")]
    assert not [line for line in said if "connected again" in line]
    assert [line for line in said if line.startswith(f"TAK {tls_url}:") and "events sent" not in line] == [
        f"TAK {tls_url}: cannot connect: the server refused our client certificate (TLSV1_ALERT_UNKNOWN_CA); trying "
        "again in the background, the flight goes on"]
    assert f"TAK {tcp_url}: " in said[-2] + said[-1] and any(line.endswith("the server was away at the end")
                                                            for line in said[-2:])
