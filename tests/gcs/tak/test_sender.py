"""Sending to TAK over real sockets: the mesh's multicast group read back on loopback (XML and TAK
protocol 1), FreeTAKServer's TLS input with a client certificate, and a server that is not there,
answers nonsense or drops: each said in one line, once, while the sending goes on."""

from __future__ import annotations

import asyncio
import contextlib
import json
import ssl
import time
from datetime import timedelta

import pytest

from gcs.plans.plan_folder import load_plan_dir
from gcs.tak.cot import TrackSample
from gcs.tak.destination import TakProtocol, TakTls, check_tls, parse_tak_url
from gcs.tak.publisher import TakPublisher
from gcs.tak.sender import close_senders, open_senders
from gcs.tak.settings import TakSettings
from tests.gcs.tak.helpers import SHARED_TAK_SERVER, MulticastReader, TakClient
from tests.peers.ports import free_port, free_udp_port


def _sample(uav: int, step: int = 0, stage: str = "search") -> TrackSample:
    return TrackSample(uav, 47.0 + step * 1e-4, 8.0, 50.0, stage, course_deg=90.0, speed_m_s=10.0, battery_pct=80.0)


@pytest.mark.parametrize("protocol", [TakProtocol.XML, TakProtocol.PROTOBUF])
def test_the_mesh_gets_the_plan_the_tracks_and_the_markers(square_plan_dir, protocol):
    plan = load_plan_dir(square_plan_dir)
    port = free_udp_port()
    mesh = parse_tak_url(f"udp://239.2.3.1:{port}", interface="127.0.0.1", protocol=protocol)
    lines: list[str] = []

    async def scenario():
        async with MulticastReader(port) as reader:
            senders = open_senders([mesh], TakSettings("mesh"), lines.append)
            publisher = TakPublisher(senders, TakSettings("mesh"))
            await asyncio.sleep(0.3)
            publisher.plan(plan)
            publisher.track(_sample(1))
            publisher.reading(1, 7, 47.0, 8.0, (3, 4))
            publisher.stage(2, "landed", 47.0, 8.0, "landed, battery 70%")
            await asyncio.sleep(0.5)
            await close_senders(senders, lines.append)
        return reader

    reader = asyncio.run(scenario())
    if protocol is TakProtocol.PROTOBUF:
        assert reader.datagrams and all(d[:3] == b"\xbf\x01\xbf" for d in reader.datagrams)
    else:
        assert all(d.startswith(b"<?xml") for d in reader.datagrams)
    kinds = {e.uid: e.type for e in reader.events}
    segments = {uid: kind for uid, kind in kinds.items() if uid.startswith("gcs.mesh.segment.")}
    assert len(segments) == len(json.loads((plan.folder / "segments.geojson").read_text())["features"]) > 1
    assert set(segments.values()) == {"u-d-f"}
    kinds = {uid: kind for uid, kind in kinds.items() if uid not in segments}
    assert kinds == {"gcs.mesh.area.1": "u-d-f", "gcs.mesh.keep-out.1": "u-d-f", "gcs.mesh.uav.1.path": "b-m-r",
                     "gcs.mesh.uav.2.path": "b-m-r", "gcs.mesh.uav.1": "a-f-A-M-F-Q",
                     "gcs.mesh.uav.1.reading.7": "b-m-p-s-m", "gcs.mesh.uav.2.landed": "b-m-p-s-m"}
    path = reader.of("gcs.mesh.uav.2.path")[0]
    assert len(path.element.findall("detail/link")) == len(plan.uavs[2].waypoints) + 2  # from the airport and back
    assert "positive reading: cell (3, 4)" in reader.of("gcs.mesh.uav.1.reading")[0].remarks
    assert lines == [f"TAK {mesh}: sending to the multicast group", f"TAK {mesh}: {7 + len(segments)} CoT events sent"]


def test_tracks_keep_to_their_rate_and_fade_on_time():
    port = free_udp_port()
    mesh = parse_tak_url(f"udp://239.2.3.1:{port}", interface="127.0.0.1")
    settings = TakSettings("rate", every_s=0.4, stale_s=1.5, refresh_s=0.5)

    async def scenario():
        async with MulticastReader(port) as reader:
            senders = open_senders([mesh], settings, lambda line: None)
            publisher = TakPublisher(senders, settings)
            refresh = asyncio.create_task(publisher.run())
            await asyncio.sleep(0.3)
            sent = [publisher.track(_sample(1, step)) for step in range(5)]  # within 0.4 s: one goes out
            publisher.stage(1, "return", 47.0, 8.0, "going home: range")
            await asyncio.sleep(0.45)
            sent.append(publisher.track(_sample(1, 5, "return")))
            sent.append(publisher.track(_sample(1, 6, "return"), now=True))
            await asyncio.sleep(0.2)
            publisher.link_lost(1)
            await asyncio.sleep(0.6)
            refresh.cancel()
            await close_senders(senders, lambda line: None)
        return sent, reader

    sent, reader = asyncio.run(scenario())
    assert sent == [True, False, False, False, False, True, True]
    tracks = reader.of("gcs.rate.uav.1")
    tracks = [t for t in tracks if t.uid == "gcs.rate.uav.1"]
    assert [t.point[0] for t in tracks] == pytest.approx([47.0, 47.0005, 47.0006, 47.0006])
    for track in tracks[:3]:
        assert track.time("stale") - track.time() == timedelta(seconds=1.5)
    lost = tracks[-1]
    assert lost.remarks.endswith("link lost")
    assert lost.time("stale") == tracks[-2].time("stale") and lost.time() > tracks[-2].time()  # no longer life
    markers = reader.of("gcs.rate.uav.1.return")
    assert len(markers) >= 2 and markers[0].time("stale") - markers[0].time() == timedelta(hours=12)
    assert {m.element.get("time") for m in markers} == {markers[0].element.get("time")}  # sent again as it was


def test_a_server_that_is_not_there_is_said_once():
    destination = parse_tak_url(f"tcp://127.0.0.1:{free_port()}")
    lines: list[str] = []

    async def scenario():
        senders = open_senders([destination], TakSettings("none"), lines.append)
        publisher = TakPublisher(senders, TakSettings("none"))
        for step in range(30):  # 3.5 s: the first attempt and two more
            publisher.track(_sample(1, step), now=True)
            await asyncio.sleep(0.12)
        await close_senders(senders, lines.append)
        return senders[0]

    sender = asyncio.run(scenario())
    assert lines == [f"TAK {destination}: cannot connect: connection refused; trying again in the background, "
                     "the flight goes on", f"TAK {destination}: 0 CoT events sent; the server was away at the end"]
    assert sender.dropped == 30


def test_a_mesh_that_cannot_be_sent_to_is_said_once():
    """An interface address this machine does not have: the socket cannot be bound (nothing is sent)."""
    mesh = parse_tak_url(f"udp://239.2.3.1:{free_udp_port()}", interface="203.0.113.7")
    lines: list[str] = []

    async def scenario():
        senders = open_senders([mesh], TakSettings("nomesh"), lines.append)
        publisher = TakPublisher(senders, TakSettings("nomesh"))
        for step in range(30):
            publisher.track(_sample(1, step), now=True)
            await asyncio.sleep(0.12)
        await close_senders(senders, lines.append)

    asyncio.run(scenario())
    assert lines == [f"TAK {mesh}: cannot send: cannot assign requested address; trying again in the background, "
                     "the flight goes on", f"TAK {mesh}: 0 CoT events sent; the last sends failed"]


class CotInput:
    """A plain TCP CoT input on loopback that keeps what it is sent (and says `greeting` to each
    client first); `drop()` closes it and every connection, as a server that goes down."""

    def __init__(self, port: int, greeting: bytes = b"") -> None:
        self.port, self.greeting = port, greeting
        self.received: list[bytes] = []
        self._writers: list[asyncio.StreamWriter] = []
        self._server: asyncio.Server | None = None

    async def start(self) -> CotInput:
        self._server = await asyncio.start_server(self._client, "127.0.0.1", self.port)
        return self

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._writers.append(writer)
        if self.greeting:
            writer.write(self.greeting)
            await writer.drain()
        with contextlib.suppress(ConnectionError):
            while data := await reader.read(65536):
                self.received.append(data)
        writer.close()

    async def drop(self) -> None:
        assert self._server is not None
        self._server.close()
        for writer in self._writers:
            writer.close()
        await self._server.wait_closed()

    @property
    def text(self) -> bytes:
        return b"".join(self.received)


def test_a_server_that_answers_nonsense_is_said_so_once_and_still_gets_the_cot():
    port = free_port()
    destination = parse_tak_url(f"tcp://127.0.0.1:{port}")
    lines: list[str] = []

    async def scenario():
        server = await CotInput(port, b"HTTP/1.1 400 Bad Request\r\n\r\n").start()
        senders = open_senders([destination], TakSettings("odd"), lines.append)
        publisher = TakPublisher(senders, TakSettings("odd"))
        await asyncio.sleep(1.2)
        publisher.track(_sample(1))
        await close_senders(senders, lines.append)
        await server.drop()
        return server

    server = asyncio.run(scenario())
    assert lines == [f"TAK {destination}: the server answers with something that is not Cursor-on-Target "
                     "(b'HTTP/1.1 400 Bad Request\\r\\n\\r\\n'); ignored", f"TAK {destination}: connected",
                     f"TAK {destination}: 1 CoT events sent"]
    text = server.text.decode()
    assert 'type="t-x-d-d"' in text and 'uid="gcs.odd.uav.1"' in text


def test_a_dropped_server_is_said_once_and_gets_the_lasting_items_again():
    port = free_port()
    destination = parse_tak_url(f"tcp://127.0.0.1:{port}")
    lines: list[str] = []

    async def scenario():
        first = await CotInput(port).start()
        senders = open_senders([destination], TakSettings("drop"), lines.append)
        publisher = TakPublisher(senders, TakSettings("drop", every_s=0.1))
        publisher.stage(1, "return", 47.0, 8.0, "going home: range")
        await asyncio.sleep(1.5)
        await first.drop()
        for step in range(20):  # 2 s without the server: positions are dropped, not queued
            publisher.track(_sample(1, step))
            await asyncio.sleep(0.1)
        second = await CotInput(port).start()
        end = time.monotonic() + 8
        while b"gcs.drop.uav.1.return" not in second.text and time.monotonic() < end:
            publisher.track(_sample(1, 99))
            await asyncio.sleep(0.1)
        await asyncio.sleep(1.2)
        await close_senders(senders, lines.append)
        await second.drop()
        return first, second

    first, second = asyncio.run(scenario())
    assert lines[0] == f"TAK {destination}: connected"
    assert lines[1] == (f"TAK {destination}: lost the server: closed by the server; trying again in the background, "
                        "the flight goes on")
    assert lines[2].startswith(f"TAK {destination}: connected again after ")
    assert lines[2].endswith(" s (shapes, paths and markers sent again)") and len(lines) == 4
    assert b"gcs.drop.uav.1.return" in first.text
    assert b"gcs.drop.uav.1.return" in second.text and b'lat="47.0099"' in second.text
    assert b'lat="47.0019"' not in second.text  # positions from while it was away were not queued


@SHARED_TAK_SERVER
def test_tls_with_a_client_certificate_on_freetakserver(tak_server, tak_pki, monkeypatch):
    certs, _ = tak_pki
    good = parse_tak_url(f"tls://127.0.0.1:{tak_server.ssl_port}",
                         tls=TakTls(str(certs.client_p12), None, str(certs.ca), certs.p12_password))
    rogue = parse_tak_url(f"tls://127.0.0.1:{tak_server.ssl_port}",
                          tls=TakTls(str(certs.rogue_cert), str(certs.rogue_key), str(certs.ca)))
    untrusting = parse_tak_url(f"tls://127.0.0.1:{tak_server.ssl_port}",
                               tls=TakTls(str(certs.client_cert), str(certs.client_key), str(certs.client_cert)))
    for destination in (good, rogue, untrusting):
        check_tls(destination)  # each loads: what goes wrong is the server's answer
    lines: list[str] = []
    context = ssl.create_default_context(cafile=str(certs.ca))
    context.load_cert_chain(str(certs.client_cert), str(certs.client_key))

    async def scenario():
        async with TakClient(tak_server.ssl_port, "tls reader", context) as client:
            senders = open_senders([good, rogue, untrusting], TakSettings("tls"), lines.append)
            publisher = TakPublisher(senders, TakSettings("tls", every_s=0.2))
            end = time.monotonic() + 20
            step = 0
            while not client.of("gcs.tls.uav.1") and time.monotonic() < end:
                step += 1
                publisher.track(_sample(1, step))
                await asyncio.sleep(0.25)
            await asyncio.sleep(2.5)  # more attempts of the refused ones: still one line each
            await close_senders(senders, lines.append)
            return client.of("gcs.tls.uav.1")

    got = asyncio.run(scenario())
    assert got and got[0].callsign == "tls UAV1"
    said = sorted(line.removeprefix(f"TAK {good}: ") for line in lines if "events sent" not in line)
    assert len(said) == 3 and said[0] == "cannot connect: the server refused our client certificate " \
        "(TLSV1_ALERT_UNKNOWN_CA); trying again in the background, the flight goes on"
    assert said[1].startswith("cannot connect: the server's certificate is not trusted: ")
    assert said[1].endswith("; trying again in the background, the flight goes on") and said[2] == "connected"
