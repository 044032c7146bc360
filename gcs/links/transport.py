"""The byte carriers under a MAVLink link: UDP (listening or sending first), TCP (client or
server) and serial ports, on asyncio's own UDP/TCP transports and pyserial-asyncio-fast.

A transport delivers what arrives as `(bytes, peer)` to its receiver and sends bytes to one
peer or to every peer; a peer is whatever tells the far ends apart (a UDP address, one TCP
client). A TCP connection or serial port that drops is reopened in the background, with
back-off, and every change is reported as a `LinkStatus` so the operator sees it; the link
above keeps its state meanwhile."""

from __future__ import annotations

import asyncio
import errno
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from enum import Enum

from gcs.links.connection import Connection, LinkKind

__all__ = ["LinkState", "LinkStatus", "Transport", "TransportError", "open_transport"]

Peer = Hashable
Receiver = Callable[[bytes, Peer], None]
RECONNECT_FIRST_S = 0.2
RECONNECT_MAX_S = 5.0


class TransportError(Exception):
    """A link that cannot be opened; the message says why in the user's terms."""


class LinkState(str, Enum):
    CONNECTED = "connected"
    LOST = "lost"
    RECONNECTED = "reconnected"
    PEER_JOINED = "peer joined"
    PEER_LEFT = "peer left"
    SIGNATURE_REFUSED = "signature refused"


@dataclass(frozen=True, slots=True)
class LinkStatus:
    """Something the operator should know about a link (`link` is its connection string)."""

    link: str
    state: LinkState
    detail: str = ""

    def __str__(self) -> str:
        return f"link {self.link}: {self.state.value}{' (' + self.detail + ')' if self.detail else ''}"


StatusSink = Callable[[LinkStatus], None]


class Transport:
    """Base: `peers` that can be sent to, `send`, `close`."""

    def __init__(self, connection: Connection, receiver: Receiver, status: StatusSink) -> None:
        self.connection = connection
        self._receiver = receiver
        self._status = status
        self.closed = False

    @property
    def name(self) -> str:
        return str(self.connection)

    @property
    def peers(self) -> list[Peer]:
        raise NotImplementedError

    async def open(self) -> None:
        raise NotImplementedError

    def send(self, data: bytes, peer: Peer | None = None) -> bool:
        """Send to `peer`, or to every peer when None; False when nobody could be sent to."""
        raise NotImplementedError

    def close(self) -> None:
        self.closed = True

    def report(self, state: LinkState, detail: str = "") -> None:
        self._status(LinkStatus(self.name, state, detail))


# ---- UDP ----------------------------------------------------------------------------------


class _Datagrams(asyncio.DatagramProtocol):
    def __init__(self, owner: UdpTransport) -> None:
        self.owner = owner

    def datagram_received(self, data: bytes, addr: tuple) -> None:
        self.owner.received(data, addr)

    def error_received(self, exc: Exception) -> None:  # ICMP port unreachable: the peer is not up yet
        self.owner.errors += 1


class UdpTransport(Transport):
    """`udpout`: one fixed peer we speak to first. `udpin`: every address that sent us a
    datagram is a peer (several SITL instances pushing to one port come from one port each)."""

    def __init__(self, connection: Connection, receiver: Receiver, status: StatusSink) -> None:
        super().__init__(connection, receiver, status)
        self._socket: asyncio.DatagramTransport | None = None
        self._peers: dict[tuple, None] = {}
        self.errors = 0

    @property
    def peers(self) -> list[Peer]:
        return list(self._peers)

    @property
    def local_address(self) -> tuple:
        assert self._socket is not None
        return self._socket.get_extra_info("sockname")

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        c = self.connection
        try:
            if c.kind is LinkKind.UDP_OUT:
                local = ("0.0.0.0", c.source_port) if c.source_port else None
                sock, _ = await loop.create_datagram_endpoint(lambda: _Datagrams(self), remote_addr=(c.host, c.port),
                                                              local_addr=local)
                self._peers[(c.host, c.port)] = None
            else:
                sock, _ = await loop.create_datagram_endpoint(lambda: _Datagrams(self), local_addr=(c.host, c.port))
        except OSError as exc:
            raise TransportError(f"cannot open the UDP port: {_os_reason(exc)}") from None
        self._socket = sock  # type: ignore[assignment]

    def received(self, data: bytes, addr: tuple) -> None:
        if self.connection.kind is LinkKind.UDP_IN and addr not in self._peers:
            self._peers[addr] = None
            self.report(LinkState.PEER_JOINED, f"{addr[0]}:{addr[1]}")
        self._receiver(data, addr)

    def send(self, data: bytes, peer: Peer | None = None) -> bool:
        if self._socket is None or self._socket.is_closing():
            return False
        if self.connection.kind is LinkKind.UDP_OUT:
            self._socket.sendto(data)
            return True
        targets = [peer] if peer is not None and peer in self._peers else list(self._peers)
        for addr in targets:
            self._socket.sendto(data, addr)
        return bool(targets)

    def close(self) -> None:
        super().close()
        if self._socket is not None:
            self._socket.close()
            self._socket = None


# ---- streams: TCP client, serial port (reopened when lost), TCP server ----------------------


class _Stream(asyncio.Protocol):
    def __init__(self, on_data: Callable[[bytes], None], on_lost: Callable[[Exception | None], None]) -> None:
        self._on_data = on_data
        self._on_lost = on_lost

    def data_received(self, data: bytes) -> None:
        self._on_data(data)

    def connection_lost(self, exc: Exception | None) -> None:
        self._on_lost(exc)


class ReopeningStream(Transport):
    """One stream (TCP client or serial port) with one peer, reopened in the background after
    it drops (the far end closed, the cable was pulled): 0.2 s, then doubling up to 5 s."""

    PEER = "stream"

    def __init__(self, connection: Connection, receiver: Receiver, status: StatusSink) -> None:
        super().__init__(connection, receiver, status)
        self._stream: asyncio.Transport | None = None
        self._reopen: asyncio.Task | None = None
        self._generation = 0
        self.reconnects = 0

    @property
    def peers(self) -> list[Peer]:
        return [self.PEER] if self._stream is not None else []

    @property
    def connected(self) -> bool:
        return self._stream is not None

    async def open(self) -> None:
        await self._connect()

    async def _connect(self) -> None:
        self._generation += 1
        generation = self._generation
        protocol = _Stream(lambda data: self._receiver(data, self.PEER), lambda exc: self._lost(generation, exc))
        self._stream = await self._open_stream(protocol)

    async def _open_stream(self, protocol: asyncio.Protocol) -> asyncio.Transport:
        raise NotImplementedError

    def _lost(self, generation: int, exc: Exception | None) -> None:
        if generation != self._generation or self.closed:
            return
        self._stream = None
        self.report(LinkState.LOST, self._lost_reason(exc))
        self._reopen = asyncio.get_running_loop().create_task(self._reopen_loop(), name=f"reopen {self.name}")

    def _lost_reason(self, exc: Exception | None) -> str:
        return _os_reason(exc) if exc else "closed by the other end"

    async def _reopen_loop(self) -> None:
        delay = RECONNECT_FIRST_S
        lost_at = asyncio.get_running_loop().time()
        while not self.closed:
            await asyncio.sleep(delay)
            try:
                await self._connect()
            except (OSError, TransportError):
                delay = min(2 * delay, RECONNECT_MAX_S)
                continue
            self.reconnects += 1
            self.report(LinkState.RECONNECTED, f"after {asyncio.get_running_loop().time() - lost_at:.1f} s")
            return

    def send(self, data: bytes, peer: Peer | None = None) -> bool:
        if self._stream is None or self._stream.is_closing():
            return False
        self._stream.write(data)
        return True

    def close(self) -> None:
        super().close()
        if self._reopen is not None:
            self._reopen.cancel()
        if self._stream is not None:
            self._stream.close()
            self._stream = None


class TcpClient(ReopeningStream):
    async def _open_stream(self, protocol: asyncio.Protocol) -> asyncio.Transport:
        c = self.connection
        try:
            transport, _ = await asyncio.get_running_loop().create_connection(lambda: protocol, c.host, c.port)
        except OSError as exc:
            raise TransportError(f"cannot connect: {_os_reason(exc)}") from None
        return transport


class SerialPort(ReopeningStream):
    def _lost_reason(self, exc: Exception | None) -> str:
        return "device disconnected" if exc is None or "no data" in str(exc) else _serial_reason(exc)
    async def _open_stream(self, protocol: asyncio.Protocol) -> asyncio.Transport:
        import serial
        import serial_asyncio_fast

        c = self.connection
        try:
            transport, _ = await serial_asyncio_fast.create_serial_connection(
                asyncio.get_running_loop(), lambda: protocol, c.device, baudrate=c.baud, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TransportError(f"cannot open the serial device: {_serial_reason(exc)}") from None
        return transport  # type: ignore[return-value]


class _ServerClient(asyncio.Protocol):
    """One client of a `TcpServer`."""

    def __init__(self, server: TcpServer) -> None:
        self.server = server
        self.peer: tuple = ()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.peer = tuple(transport.get_extra_info("peername")[:2])
        self.server.joined(self.peer, transport)  # type: ignore[arg-type]

    def data_received(self, data: bytes) -> None:
        self.server.received(data, self.peer)

    def connection_lost(self, exc: Exception | None) -> None:
        self.server.left(self.peer)


class TcpServer(Transport):
    """`tcpin`: listens; every client that connects is a peer until it disconnects."""

    def __init__(self, connection: Connection, receiver: Receiver, status: StatusSink) -> None:
        super().__init__(connection, receiver, status)
        self._server: asyncio.Server | None = None
        self._clients: dict[tuple, asyncio.Transport] = {}

    @property
    def peers(self) -> list[Peer]:
        return list(self._clients)

    @property
    def local_address(self) -> tuple:
        assert self._server is not None
        return self._server.sockets[0].getsockname()

    async def open(self) -> None:
        c = self.connection
        try:
            self._server = await asyncio.get_running_loop().create_server(self._accept, c.host, c.port)
        except OSError as exc:
            raise TransportError(f"cannot listen: {_os_reason(exc)}") from None

    def _accept(self) -> asyncio.Protocol:
        return _ServerClient(self)

    def joined(self, peer: tuple, transport: asyncio.Transport) -> None:
        self._clients[peer] = transport
        self.report(LinkState.PEER_JOINED, f"{peer[0]}:{peer[1]}")

    def left(self, peer: tuple) -> None:
        if self._clients.pop(peer, None) is not None and not self.closed:
            self.report(LinkState.PEER_LEFT, f"{peer[0]}:{peer[1]}")

    def received(self, data: bytes, peer: tuple) -> None:
        self._receiver(data, peer)

    def send(self, data: bytes, peer: Peer | None = None) -> bool:
        targets = [peer] if peer is not None and peer in self._clients else list(self._clients)
        for p in targets:
            self._clients[p].write(data)
        return bool(targets)

    def drop_clients(self) -> int:
        """Close every client connection (the server keeps listening); how many were closed."""
        clients = list(self._clients.values())
        for client in clients:
            client.close()
        return len(clients)

    def close(self) -> None:
        super().close()
        for client in self._clients.values():
            client.close()
        self._clients.clear()
        if self._server is not None:
            self._server.close()
            self._server = None


_KINDS: dict[LinkKind, type[Transport]] = {
    LinkKind.UDP_IN: UdpTransport, LinkKind.UDP_OUT: UdpTransport, LinkKind.TCP_CLIENT: TcpClient,
    LinkKind.TCP_SERVER: TcpServer, LinkKind.SERIAL: SerialPort,
}


async def open_transport(connection: Connection, receiver: Receiver, status: StatusSink) -> Transport:
    """Open the transport a connection names; TransportError with the reason when it cannot."""
    transport = _KINDS[connection.kind](connection, receiver, status)
    await transport.open()
    return transport


def _os_reason(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.errno is not None:
        if exc.errno == errno.ECONNREFUSED:
            return "connection refused (nothing listens there)"
        if exc.errno == errno.EADDRINUSE:
            return "address already in use (another program listens there)"
        return exc.strerror or str(exc)
    return str(exc) or type(exc).__name__


def _serial_reason(exc: BaseException) -> str:
    text = str(exc)
    number = getattr(exc, "errno", None)
    if number == errno.ENOENT or "No such file" in text:
        return "no such device (is the radio plugged in?)"
    if number in (errno.EACCES, errno.EPERM) or "Permission denied" in text:
        return "permission denied (add your user to the dialout group)"
    if "lock" in text.lower() or number in (errno.EBUSY, errno.EAGAIN):
        return "busy (another program has it open)"
    return text

