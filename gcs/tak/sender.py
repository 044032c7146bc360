"""Sending CoT to one destination without ever holding a flight up: `TakSender` opens the
destination with pytak (`protocol_factory`, `TXWorker`), opens each connection with the
station's hello, reconnects with a growing pause when a server refuses, drops or is not there,
and reports each change as one line (`say`), once: a server that stays away is said to be away
once, not at every attempt.

What is sent while the server is away: nothing of the positions (they would be stale by the
time it is back); the items sent with `keep` (shapes, paths, markers, the last word on each
vehicle) are kept by uid and sent again on every new connection, so a restarted server, or one
that was not there at take-off, still gets them. A server that answers with something that is
not CoT is said so once and otherwise ignored; whatever it sends is read and dropped."""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import ssl
import time
import uuid
import warnings
from collections.abc import Callable, Sequence
from datetime import timedelta

from gcs.tak import cot
from gcs.tak.destination import TakDestination
from gcs.tak.pytak_module import pytak
from gcs.tak.settings import TakSettings

__all__ = ["TakSender", "close_senders", "describe_failure", "open_senders"]

FLUSH_S = 2.0  # what is queued at the end is sent for at most this long

CONNECT_TIMEOUT_S = 5.0
RETRY_FIRST_S = 1.0
RETRY_MAX_S = 30.0
SETTLE_S = 1.0  # a connection that holds this long is announced; one dropped sooner is a failed attempt
HELLO_WAIT_S = 1.0  # after the hello, the server's first word is waited for this long before anything else is sent
TLS_VERDICT_S = 0.3  # on TLS, nothing is sent this long: a server that refuses our certificate says so in this time
QUEUE_SIZE = 1000
_COT_STARTS = (b"<", b"\xbf")  # CoT XML, or a TAK protocol 1 header


def describe_failure(exc: BaseException) -> str:
    """What went wrong with a connection, in words: the TLS reasons a user can act on first."""
    cause: BaseException = exc
    while cause.__cause__ is not None and isinstance(cause, (SyntaxError, ValueError)):
        cause = cause.__cause__  # pytak wraps a certificate failure in SyntaxError
    if isinstance(cause, ssl.SSLCertVerificationError):
        return f"the server's certificate is not trusted: {cause.verify_message or cause.reason}"
    if isinstance(cause, ssl.SSLError):
        reason = str(cause.reason or cause)
        if "ALERT" in reason and ("CERTIFICATE" in reason or "UNKNOWN_CA" in reason):
            return f"the server refused our client certificate ({reason})"
        return f"TLS failed ({reason})"
    if isinstance(cause, ConnectionRefusedError):
        return "connection refused"
    if isinstance(cause, (TimeoutError, asyncio.TimeoutError)):
        return f"no answer within {CONNECT_TIMEOUT_S:g} s"
    if isinstance(cause, EOFError):
        return "closed by the server"
    if isinstance(cause, OSError) and cause.strerror:
        return cause.strerror.lower() if cause.strerror[:1].isupper() else cause.strerror
    return str(cause) or type(cause).__name__


class TakSender:
    """One destination: `start()` in a running loop, `send()` from anywhere in it (never waits),
    `close()` flushes what is queued (for at most `flush_s`) and stops."""

    def __init__(self, destination: TakDestination, say: Callable[[str], None],
                 hello: Callable[[], bytes] | None = None) -> None:
        self.destination = destination
        self.say = say
        self.hello = hello
        self.connected = False
        self.sent = 0
        self.dropped = 0
        self._state: str | None = None  # what was said last: "up", "away" or nothing yet
        self._been_up = False
        self._said_bad_answer = False
        self._away_since = 0.0
        self._kept: dict[str, bytes] = {}
        self._queue: asyncio.Queue[bytes] = asyncio.Queue(QUEUE_SIZE)
        self._ended_up = False
        self._task: asyncio.Task | None = None

    def send(self, uid: str, data: bytes, keep: bool = False) -> None:
        if keep:
            self._kept[uid] = data
        if not self.connected:
            self.dropped += not keep
            return
        if self._queue.full():
            self._take()
            self.dropped += 1
        self._queue.put_nowait(data)

    def _take(self) -> None:
        self._queue.get_nowait()
        self._queue.task_done()

    def start(self) -> None:
        self._task = asyncio.create_task(self._run(), name=f"tak {self.destination}")

    async def close(self, flush_s: float = 2.0) -> None:
        if self.connected:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(flush_s):
                    await self._queue.join()
        self._ended_up = self._state == "up" and self.connected
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    def summary(self) -> str:
        away = "" if self._ended_up else \
            ("; the server was away at the end" if self.destination.stream else "; the last sends failed")
        return f"TAK {self.destination}: {self.sent} CoT events sent{away}"

    # ---- the connection ------------------------------------------------------------------

    def _line(self, text: str) -> None:
        self.say(f"TAK {self.destination}: {text}")

    def _away(self, reason: str) -> None:
        """One line when the destination goes away or cannot be reached; silence while it stays away."""
        if self._state == "away":
            return
        what = "lost the server" if self._state == "up" else "cannot connect"
        if not self.destination.stream:
            what = "cannot send"
        self._line(f"{what}: {reason}; trying again in the background, the flight goes on")
        self._state, self._away_since = "away", time.monotonic()

    def _up(self) -> None:
        if self._state == "up":
            return
        if not self.destination.stream:
            self._line(f"sending to {'the multicast group' if _multicast(self.destination.host) else 'it'}")
        elif self._been_up:
            self._line(f"connected again after {time.monotonic() - self._away_since:.0f} s "
                       "(shapes, paths and markers sent again)")
        else:
            self._line("connected")
        self._state, self._been_up = "up", True

    async def _run(self) -> None:
        pause = RETRY_FIRST_S
        config = self.destination.pytak_config()
        while True:
            try:
                with warnings.catch_warnings():  # pytak warns when the host name check is off
                    warnings.simplefilter("ignore")
                    async with asyncio.timeout(CONNECT_TIMEOUT_S):
                        reader, writer = await pytak.protocol_factory(config)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                self._away(describe_failure(exc))
                await asyncio.sleep(pause)
                pause = min(pause * 2, RETRY_MAX_S)
                continue
            started = time.monotonic()
            try:
                await self._connection(config, reader, writer)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                reason = describe_failure(exc)
                if self.destination.scheme == "tls" and time.monotonic() - started < SETTLE_S \
                        and isinstance(exc, (ConnectionError, EOFError)):
                    reason = f"{reason} right after the TLS handshake (did it refuse our client certificate?)"
                self._away(reason)
            finally:
                self.connected = False
                await _close(writer)
            if time.monotonic() - started > SETTLE_S:
                pause = RETRY_FIRST_S
            await asyncio.sleep(pause)
            pause = min(pause * 2, RETRY_MAX_S)

    async def _connection(self, config, reader, writer) -> None:
        """Send until the connection fails (it raises) or the sender is cancelled."""
        worker = pytak.TXWorker(asyncio.Queue(), config, writer)
        while not self._queue.empty():  # positions queued before a drop are stale now
            self._take()
        self.connected = True
        # a stream is announced once it has held; a datagram socket once a send went out (in `_write`)
        settled = asyncio.get_running_loop().call_later(SETTLE_S, self._up) if self.destination.stream else None
        heard = asyncio.Event()
        tasks = [asyncio.create_task(self._write(worker, heard), name="tak-write")]
        if reader is not None:
            tasks.append(asyncio.create_task(self._read(reader, heard), name="tak-read"))
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            for task in done:
                task.result()
        finally:
            if settled is not None:
                settled.cancel()
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

    async def _write(self, worker: pytak.TXWorker, heard: asyncio.Event) -> None:
        """The hello alone first: FreeTAKServer reads a connection's first event with one read and
        drops the connection when more than that event came in it; it answers with a welcome."""
        if self.destination.scheme == "tls":  # a refusal then comes as its alert, not as a reset of unread data
            await asyncio.sleep(TLS_VERDICT_S)
        if self.hello is not None:
            await worker.send_data(self.hello())
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(HELLO_WAIT_S):
                    await heard.wait()
        for data in list(self._kept.values()):
            await self._send_one(worker, data)
        while True:
            data = await self._queue.get()
            try:
                await self._send_one(worker, data)
            finally:
                self._queue.task_done()

    async def _send_one(self, worker: pytak.TXWorker, data: bytes) -> None:
        await worker.send_data(data)
        self.sent += 1
        if not self.destination.stream:
            self._up()

    async def _read(self, reader: asyncio.StreamReader, heard: asyncio.Event) -> None:
        """Read and drop what the server sends; EOFError when it closes the connection."""
        first = True
        while True:
            chunk = await reader.read(65536)
            if not chunk:
                raise EOFError
            heard.set()
            text = chunk.lstrip()
            if first and text and not text.startswith(_COT_STARTS) and not self._said_bad_answer:
                self._said_bad_answer = True
                self._line(f"the server answers with something that is not Cursor-on-Target ({text[:60]!r}); "
                           "ignored")
            first = first and not text


def open_senders(destinations: Sequence[TakDestination], settings: TakSettings,
                 say: Callable[[str], None]) -> list[TakSender]:
    """A started sender per destination; a stream (TCP, TLS) opens with the station's hello."""
    naming = cot.Naming(settings.name)

    def hello() -> bytes:
        when = cot.utc_now()
        return cot.encode(cot.station_hello(naming, uuid.uuid4().hex[:12], when,
                                            when + timedelta(seconds=settings.stale_s)))

    senders = [TakSender(d, say, hello if d.stream else None) for d in destinations]
    for sender in senders:
        sender.start()
    return senders


async def close_senders(senders: Sequence[TakSender], say: Callable[[str], None]) -> None:
    """Send what is queued (for at most `FLUSH_S`), stop, and say what each destination got."""
    await asyncio.gather(*(sender.close(FLUSH_S) for sender in senders))
    for sender in senders:
        say(sender.summary())


def _multicast(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_multicast
    except ValueError:
        return False


async def _close(writer) -> None:
    if writer is None:
        return
    with contextlib.suppress(Exception):
        writer.close()
        if hasattr(writer, "wait_closed"):
            async with asyncio.timeout(1.0):
                await writer.wait_closed()
