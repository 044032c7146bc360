"""A real FreeTAKServer on free loopback ports (installed in .venv-tak when missing), certificates
from a throw-away CA, and a TAK client that reads back what the server relays, as ATAK would:
it connects, announces itself, and parses every event it is sent."""

from __future__ import annotations

import asyncio
import datetime
import ipaddress
import os
import signal
import socket
import ssl
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from gcs.tak.pytak_module import pytak
from tests.peers.ports import free_port

ROOT = Path(__file__).resolve().parents[3]
HERE = Path(__file__).resolve().parent
VENV = ROOT / ".venv-tak"
PYTHON = VENV / "bin" / "python"
#: The tests that read from the shared FreeTAKServer (the `tak_server` fixture): one xdist group,
#: so one worker runs them one after the other and starts the server once, and stops it after them.
SHARED_TAK_SERVER = pytest.mark.xdist_group("tak")
START_TIMEOUT_S = 180.0  # it takes 13-30 s here: slack for a machine loaded by other work


def ensure_freetakserver() -> Path:
    """The interpreter of the FreeTAKServer virtual environment, made (pinned) when missing."""
    if PYTHON.exists() and subprocess.run([str(PYTHON), "-c", "import FreeTAKServer"],
                                          capture_output=True).returncode == 0:
        return PYTHON
    subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    subprocess.run([str(PYTHON), "-m", "pip", "install", "--quiet", "-r", str(HERE / "freetakserver-requirements.txt")],
                   check=True, timeout=1200)
    return PYTHON


# ---- certificates -----------------------------------------------------------------------------


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _pem_key(key) -> bytes:
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


@dataclass
class Authority:
    """A CA that signs server and client certificates."""

    name: str
    key: ec.EllipticCurvePrivateKey = field(default_factory=lambda: ec.generate_private_key(ec.SECP256R1()))
    cert: x509.Certificate | None = None

    def __post_init__(self) -> None:
        now = datetime.datetime.now(datetime.UTC)
        self.cert = (x509.CertificateBuilder().subject_name(_name(self.name)).issuer_name(_name(self.name))
                     .public_key(self.key.public_key()).serial_number(x509.random_serial_number())
                     .not_valid_before(now - datetime.timedelta(hours=1))
                     .not_valid_after(now + datetime.timedelta(days=2))
                     .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
                     .sign(self.key, hashes.SHA256()))

    def issue(self, common_name: str, server: bool) -> tuple[bytes, bytes]:
        """(certificate PEM, key PEM): a server's names 127.0.0.1."""
        assert self.cert is not None
        key = ec.generate_private_key(ec.SECP256R1())
        now = datetime.datetime.now(datetime.UTC)
        builder = (x509.CertificateBuilder().subject_name(_name(common_name)).issuer_name(self.cert.subject)
                   .public_key(key.public_key()).serial_number(x509.random_serial_number())
                   .not_valid_before(now - datetime.timedelta(hours=1))
                   .not_valid_after(now + datetime.timedelta(days=2)))
        if server:
            builder = builder.add_extension(
                x509.SubjectAlternativeName([x509.IPAddress(ipaddress.IPv4Address("127.0.0.1"))]), critical=False)
        cert = builder.sign(self.key, hashes.SHA256())
        return cert.public_bytes(serialization.Encoding.PEM), _pem_key(key)

    def empty_crl(self) -> bytes:
        assert self.cert is not None
        now = datetime.datetime.now(datetime.UTC)
        crl = (x509.CertificateRevocationListBuilder().issuer_name(self.cert.subject).last_update(now)
               .next_update(now + datetime.timedelta(days=2)).sign(self.key, hashes.SHA256()))
        return crl.public_bytes(serialization.Encoding.PEM)

    @property
    def pem(self) -> bytes:
        assert self.cert is not None
        return self.cert.public_bytes(serialization.Encoding.PEM)


@dataclass
class Certificates:
    """Files made by `make_certificates`: the CA, a client it signed (PEM and .p12) and one
    signed by another CA."""

    ca: Path
    client_cert: Path
    client_key: Path
    client_p12: Path
    p12_password: str
    rogue_cert: Path
    rogue_key: Path


def make_certificates(folder: Path) -> tuple[Certificates, Authority]:
    folder.mkdir(parents=True, exist_ok=True)
    ca, rogue = Authority("gcs test TAK CA"), Authority("someone else's CA")
    (folder / "ca.pem").write_bytes(ca.pem)
    client_pem, client_key = ca.issue("gcs test client", server=False)
    (folder / "client.pem").write_bytes(client_pem)
    (folder / "client.key").write_bytes(client_key)
    password = "p12 secret"
    from cryptography.hazmat.primitives.serialization import pkcs12

    p12 = pkcs12.serialize_key_and_certificates(
        b"client", serialization.load_pem_private_key(client_key, None), x509.load_pem_x509_certificate(client_pem),
        [ca.cert], serialization.BestAvailableEncryption(password.encode()))
    (folder / "client.p12").write_bytes(p12)
    rogue_pem, rogue_key = rogue.issue("not a client of this server", server=False)
    (folder / "rogue.pem").write_bytes(rogue_pem)
    (folder / "rogue.key").write_bytes(rogue_key)
    return Certificates(folder / "ca.pem", folder / "client.pem", folder / "client.key", folder / "client.p12",
                        password, folder / "rogue.pem", folder / "rogue.key"), ca


# ---- the server ---------------------------------------------------------------------------------


class FreeTakServer:
    """One FreeTAKServer with everything it keeps in `workdir`, every service on 127.0.0.1 and
    free ports (`cot_port` plain, `ssl_port` TLS with a server certificate from `authority`)."""

    def __init__(self, workdir: Path, authority: Authority) -> None:
        self.python = ensure_freetakserver()
        self.workdir = workdir
        self.certs = workdir / "certs"
        self.certs.mkdir(parents=True, exist_ok=True)
        server_pem, server_key = authority.issue("127.0.0.1", server=True)
        crl = authority.empty_crl()
        (self.certs / "ca.pem").write_bytes(authority.pem + crl)  # FreeTAKServer checks the CRL of the client's CA
        assert authority.key is not None
        (self.certs / "ca.key").write_bytes(_pem_key(authority.key))
        (self.certs / "server.pem").write_bytes(server_pem)
        (self.certs / "server.key").write_bytes(server_key)
        (self.certs / "server.key.unencrypted").write_bytes(server_key)
        (self.certs / "FTS_CRL.json").write_bytes(crl)
        self.cot_port, self.ssl_port = free_port(), free_port()
        self.log = workdir / "fts.log"
        self.process: subprocess.Popen | None = None

    def _environment(self) -> dict[str, str]:
        w, c = self.workdir, self.certs
        for sub in ("logs", "datapackages", "excheck/template", "excheck/checklist", "clientpackages"):
            (w / sub).mkdir(parents=True, exist_ok=True)
        ports = {name: str(free_port()) for name in (
            "FTS_API_PORT", "FTS_FED_PORT", "FTS_ROUTING_PROXY_SUBSCRIBE_PORT", "FTS_ROUTING_PROXY_PUBLISHER_PORT",
            "FTS_ROUTING_PROXY_SERVER_PORT", "FTS_INTEGRATION_MANAGER_PULLER_PORT",
            "FTS_INTEGRATION_MANAGER_PUBLISHER_PORT")}
        return {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(w), "FTS_FIRST_START": "false",
                "FTS_CONFIG_PATH": str(w / "FTSConfig.yaml"), "FTS_PERSISTENCE_PATH": str(w),
                "FTS_DB_PATH": str(w / "FTSDataBase.db"), "FTS_LOGFILE_PATH": str(w / "logs"),
                "FTS_DATAPACKAGE_PATH": str(w / "datapackages"), "FTS_EXCHECK_PATH": str(w / "excheck"),
                "FTS_EXCHECK_TEMPLATE_PATH": str(w / "excheck" / "template"),
                "FTS_EXCHECK_CHECKLIST_PATH": str(w / "excheck" / "checklist"),
                "FTS_CLIENT_PACKAGES_PATH": str(w / "clientpackages"), "FTS_CERTS_PATH": str(c),
                "FTS_CADIR": str(c / "ca.pem"), "FTS_CAKEYDIR": str(c / "ca.key"),
                "FTS_SERVER_PEMDIR": str(c / "server.pem"), "FTS_SERVER_KEYDIR": str(c / "server.key"),
                "FTS_UNENCRYPTED_KEYDIR": str(c / "server.key.unencrypted"),
                "FTS_SERVER_P12DIR": str(c / "server.p12"), "FTS_TESTCLIENT_PEMDIR": str(c / "server.pem"),
                "FTS_TESTCLIENT_KEYDIR": str(c / "server.key"), "FTS_FEDERATION_CERTDIR": str(c / "server.pem"),
                "FTS_FEDERATION_KEYDIR": str(c / "server.key"), "FTS_CRLDIR": str(c / "FTS_CRL.json"),
                "FTS_API_ADDRESS": "127.0.0.1", "FTS_DP_ADDRESS": "127.0.0.1", "FTS_USER_ADDRESS": "127.0.0.1",
                "FTS_CONNECTION_MESSAGE": "gcs test server", **ports}

    def start(self) -> None:
        args = [str(self.python), str(HERE / "fts_launch.py"), "-CoTIP", "127.0.0.1", "-CoTPort", str(self.cot_port),
                "-SSLCoTIP", "127.0.0.1", "-SSLCoTPort", str(self.ssl_port), "-DataPackageIP", "127.0.0.1",
                "-DataPackagePort", str(free_port()), "-SSLDataPackageIP", "127.0.0.1",
                "-SSLDataPackagePort", str(free_port()), "-RestAPIIP", "127.0.0.1", "-RestAPIPort", str(free_port())]
        with open(self.log, "ab") as log:
            self.process = subprocess.Popen(args, cwd=self.workdir, env=self._environment(), stdin=subprocess.DEVNULL,
                                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        end = time.monotonic() + START_TIMEOUT_S
        while not (_listening(self.cot_port) and _listening(self.ssl_port)):
            if self.process.poll() is not None or time.monotonic() > end:
                self.stop()
                raise RuntimeError(f"FreeTAKServer did not start: {self.log.read_text(errors='replace')[-3000:]}")
            time.sleep(0.5)

    def kill(self) -> None:
        """Gone at once, as a crashed server is: every process of it, SIGKILL."""
        self._signal(signal.SIGKILL)

    def stop(self) -> None:
        if self.process is None:
            return
        self._signal(signal.SIGTERM)
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            self._signal(signal.SIGKILL)
            self.process.wait(10)
        self.process = None

    def _signal(self, sig: int) -> None:
        assert self.process is not None
        try:
            os.killpg(self.process.pid, sig)  # the server's own process group (start_new_session)
        except ProcessLookupError:
            pass


def _listening(port: int) -> bool:
    """Whether something listens on the loopback port, read from /proc (no connection that the
    server would take for a client)."""
    wanted = f"0100007F:{port:04X}"
    for table in ("/proc/net/tcp",):
        with open(table) as f:
            for line in f.readlines()[1:]:
                fields = line.split()
                if fields[1] == wanted and fields[3] == "0A":
                    return True
    return False


# ---- a TAK client -------------------------------------------------------------------------------


@dataclass
class Received:
    """One event as a TAK client parsed it."""

    element: ET.Element
    at: float

    @property
    def uid(self) -> str:
        return self.element.get("uid", "")

    @property
    def type(self) -> str:
        return self.element.get("type", "")

    def time(self, attribute: str = "time") -> datetime.datetime:
        return datetime.datetime.strptime(self.element.get(attribute, ""), pytak.W3C_XML_DATETIME).replace(
            tzinfo=datetime.UTC)

    @property
    def point(self) -> tuple[float, float]:
        point = self.element.find("point")
        assert point is not None
        return float(point.get("lat", "nan")), float(point.get("lon", "nan"))

    @property
    def remarks(self) -> str:
        """The remarks element; FreeTAKServer 2.2.1 relays it as an attribute of `detail` instead."""
        detail = self.element.find("detail")
        return self.element.findtext("detail/remarks") or ("" if detail is None else detail.get("remarks", ""))

    @property
    def callsign(self) -> str:
        contact = self.element.find("detail/contact")
        return "" if contact is None else contact.get("callsign", "")


class TakClient:
    """A client of the server, as ATAK is: connects (TLS with `ssl_context`), sends its own SA
    first, then collects every event the server relays to it, read with pytak's reader."""

    def __init__(self, port: int, callsign: str = "test client", ssl_context: ssl.SSLContext | None = None) -> None:
        self.port = port
        self.callsign = callsign
        self.ssl_context = ssl_context
        self.events: list[Received] = []
        self._task: asyncio.Task | None = None

    async def __aenter__(self) -> TakClient:
        reader, writer = await asyncio.open_connection("127.0.0.1", self.port, ssl=self.ssl_context)
        self._writer = writer
        own = pytak.cot_event(lat=47.0, lon=8.0, uid=f"test-{self.callsign}", cot_type="a-f-G-U-C", stale=600,
                              callsign=self.callsign)
        writer.write(pytak.serialize_cot(own))
        await writer.drain()
        self._task = asyncio.create_task(self._read(reader))
        return self

    async def _read(self, reader: asyncio.StreamReader) -> None:
        worker = pytak.RXWorker(asyncio.Queue(), None, reader)
        while True:
            data = await worker.readcot()
            if not data:
                return
            text = data.decode(errors="replace")
            text = text[text.index("<event"):] if "<event" in text else text
            try:
                self.events.append(Received(ET.fromstring(text), time.monotonic()))
            except ET.ParseError:
                continue

    async def __aexit__(self, *exc_info) -> None:
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)
        self._writer.close()

    def of(self, prefix: str) -> list[Received]:
        return [e for e in self.events if e.uid.startswith(prefix)]

    async def wait_for(self, predicate, timeout_s: float) -> bool:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if predicate():
                return True
            await asyncio.sleep(0.1)
        return predicate()


class MulticastReader:
    """A mesh client: a UDP socket joined to `group` on the loopback interface, collecting every
    datagram as an event (CoT XML, or TAK protocol 1 read with takproto)."""

    def __init__(self, port: int, group: str = "239.2.3.1") -> None:
        self.port, self.group = port, group
        self.events: list[Received] = []
        self.datagrams: list[bytes] = []
        self._transport: asyncio.DatagramTransport | None = None

    def _socket(self) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((self.group, self.port))
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                        socket.inet_aton(self.group) + socket.inet_aton("127.0.0.1"))
        return sock

    def __enter__(self) -> MulticastReader:
        """The same in a thread of its own, beside a flight that runs its own event loop."""
        sock = self._socket()
        sock.settimeout(0.1)
        self._stop = threading.Event()

        def receive() -> None:
            while not self._stop.is_set():
                try:
                    self.received(sock.recv(65536))
                except TimeoutError:
                    continue
            sock.close()

        self._thread = threading.Thread(target=receive, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc_info) -> None:
        self._stop.set()
        self._thread.join(5)

    async def __aenter__(self) -> MulticastReader:
        sock = self._socket()
        reader = self

        class Protocol(asyncio.DatagramProtocol):
            def datagram_received(self, data: bytes, addr) -> None:
                reader.received(data)

        self._transport, _ = await asyncio.get_running_loop().create_datagram_endpoint(Protocol, sock=sock)
        return self

    def received(self, data: bytes) -> None:
        self.datagrams.append(data)
        if data[:1] == b"\xbf":
            import takproto

            message = takproto.parse_proto(data)
            if message == -1 or message is None:
                return
            element = xml_of_proto(message)
        else:
            text = data.decode(errors="replace")
            element = ET.fromstring(text[text.index("<event"):])
        self.events.append(Received(element, time.monotonic()))

    async def __aexit__(self, *exc_info) -> None:
        if self._transport is not None:
            self._transport.close()

    def of(self, prefix: str) -> list[Received]:
        return [e for e in self.events if e.uid.startswith(prefix)]


def xml_of_proto(message) -> ET.Element:
    """A TAK protocol 1 message as the CoT event it carries (the fields a map uses)."""
    event = message.cotEvent

    def stamp(ms: int) -> str:
        return datetime.datetime.fromtimestamp(ms / 1000, datetime.UTC).strftime(pytak.W3C_XML_DATETIME)

    element = ET.Element("event", {"uid": event.uid, "type": event.type, "how": event.how,
                                   "time": stamp(event.sendTime), "start": stamp(event.startTime),
                                   "stale": stamp(event.staleTime)})
    ET.SubElement(element, "point", {"lat": repr(event.lat), "lon": repr(event.lon)})
    detail = ET.fromstring(f"<detail>{event.detail.xmlDetail}</detail>")
    if event.detail.HasField("contact"):
        ET.SubElement(detail, "contact", {"callsign": event.detail.contact.callsign})
    if event.detail.HasField("track"):
        ET.SubElement(detail, "track", {"course": repr(event.detail.track.course),
                                        "speed": repr(event.detail.track.speed)})
    element.append(detail)
    return element

