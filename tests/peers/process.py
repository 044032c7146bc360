"""What every SITL peer shares: a process started in a working folder of its own, on an instance
number (its port block) claimed for it alone, stopped (its folder deleted, its number given
back) when the `with` block ends.

Tests run in several processes at once (pytest-xdist workers, and other checkouts' test runs on
the same machine), so an instance number is claimed with a lock file held while the instance
runs: two processes never pick the same port block, even when they look at the same moment."""

from __future__ import annotations

import fcntl
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Self

import pytest

LOCKS = Path(tempfile.gettempdir()) / f"gcs-sitl-locks-{os.getuid()}"

#: The real-autopilot tests run in one pytest-xdist worker, one after the other (`--dist
#: loadgroup`, tests/conftest.py). Two groups side by side (PX4, ArduPilot) lost an ArduPlane
#: fleet's and a fast-draining copter's flights to the load (8 on the 2-core CI machine) and were no
#: faster: docs/tests.md.
SITL_WORKER = pytest.mark.xdist_group("sitl")

#: The simulated flights whose outcome is a battery a slow station spends by the clock (its hold
#: while it sends a way home, the lock step's hover while it decides): one after the other, never
#: two beside each other. pytest-xdist hands out the largest group first (`--loadscope-reorder`,
#: its default), so with two workers one starts with the real autopilots' group, the other with
#: this one, and each takes other tests only when its group is nearly done.
CLOCK_WORKER = pytest.mark.xdist_group("clock")


def port_free(port: int, *, udp: bool = False) -> bool:
    """Whether a loopback TCP (or UDP) port can be bound now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM if udp else socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def tcp_listening(port: int) -> bool:
    """Whether a TCP socket listens on `port` now, read from /proc/net/tcp: a probe that binds
    could take the port for a moment from the process about to listen on it, and one that
    connects would be its first client."""
    wanted = f":{port:04X}"
    with open("/proc/net/tcp") as table:
        next(table)
        return any(fields[1].endswith(wanted) and fields[3] == "0A" for fields in map(str.split, table))


def udp_bound(port: int) -> bool:
    """Whether a UDP socket is bound to `port` now, read from /proc/net/udp: a probe that binds
    takes the port for a moment, and a PX4 whose MAVLink module binds it then never opens it."""
    wanted = f":{port:04X}"
    with open("/proc/net/udp") as table:
        next(table)
        return any(fields[1].endswith(wanted) for fields in map(str.split, table))


def stop_process(process: subprocess.Popen) -> None:
    """Terminate, and kill what does not end within 10 s."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(5)


def lock_file(name: str) -> IO[str]:
    """The lock file `name` under `LOCKS`, opened (not locked)."""
    LOCKS.mkdir(exist_ok=True)
    return open(LOCKS / f"{name}.lock", "a")


@dataclass
class InstanceClaim:
    """An instance number held by this process until `release()`."""

    number: int
    _file: IO[str]

    def release(self) -> None:
        self._file.close()  # closing the file drops its lock


def claim(kind: str, ports_free: Callable[[int], bool], count: int, first: int = 0) -> InstanceClaim:
    """The lowest instance number of `kind` from `first` that no other process holds and whose
    ports are free (against programs that do not take these locks)."""
    for number in range(first, first + count):
        file = lock_file(f"{kind}-{number}")
        try:
            fcntl.flock(file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            file.close()
            continue
        if ports_free(number):
            return InstanceClaim(number, file)
        file.close()
    raise RuntimeError(f"no free {kind} instance number in {first}..{first + count - 1}")


@contextmanager
def exclusive(name: str) -> Iterator[None]:
    """Held by one process at a time, machine-wide (a lock file under `LOCKS`)."""
    with lock_file(name) as file:
        fcntl.flock(file, fcntl.LOCK_EX)
        yield


def hold(name: str, *, alone: bool) -> IO[str]:
    """Machine-wide lock `name`, held `alone` (exclusively) or shared with other shared holders
    until the returned file is closed. Waiting `alone` holders go first (they hold the turnstile
    that new shared holders pass), so a stream of shared ones cannot starve them."""
    with exclusive(f"{name}-turnstile"):
        file = lock_file(name)
        fcntl.flock(file, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
    return file


@contextmanager
def cpu_share(*, heavy: bool) -> Iterator[None]:
    """A `heavy` holder runs alone, the others side by side (`hold`). A fleet of two PX4 SITLs at
    speed-up 5 and an ArduCopter takes about 1.5 of the CI machine's two cores, and a simulated
    fleet flown beside it (the vehicles on a thread of the test's own process) lost its uploads:
    the vehicles asked for items the station had sent, again and again (ci28, ci29, reproduced
    here). Such fleets take it `heavy`; the simulated flights of the other worker take it shared,
    so they wait (a fleet is some 3 minutes) instead of failing."""
    with hold("cpu-share", alone=heavy):
        yield


class SitlProcess:
    """Mixin for a dataclass with `process`, `workdir` and `claim` fields and a `start()`
    returning self."""

    process: subprocess.Popen | None
    workdir: Path | None
    claim: InstanceClaim | None

    def start(self) -> Self:
        raise NotImplementedError

    def stop(self) -> None:
        if self.process is not None:
            stop_process(self.process)
        self.process = None
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None
        if self.claim is not None:
            self.claim.release()
            self.claim = None

    def __enter__(self) -> Self:
        try:
            return self.start()
        except BaseException:
            self.stop()  # a start that failed half-way leaves no process and no claim behind
            raise

    def __exit__(self, *exc: object) -> None:
        self.stop()
