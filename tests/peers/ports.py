"""Loopback ports for a server a test starts in another process (a station's `udpin`, a broker, a
SITL's output, a simulated fleet's base port).

A port the kernel hands out for `bind(0)` and the test then closes is a port from its ephemeral
range, and any socket that connects in the meantime (a SITL's `udpclient`, a simulated vehicle, a
browser) may be given it before the server binds it: the server then fails with "address already
in use" (a CI run lost a whole three-copter flight this way). These ports come from below the
ephemeral range instead, and each is handed out once per cycle through that range
(a counter under the user's lock folder, shared by every pytest worker and checkout), so neither the kernel nor another
test picks it while its server starts."""

from __future__ import annotations

from pathlib import Path

from tests.peers.process import LOCKS, exclusive, port_free

FIRST = 20000
COUNTER = LOCKS / "next-port"


def _ephemeral_low() -> int:
    try:
        return int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def _end() -> int:
    """Where the handed-out range ends: the ephemeral range's start, or (a host whose ephemeral range
    starts below ours) the last port: still never handed out twice, though no longer out of its way."""
    low = _ephemeral_low()
    return low if low > FIRST + 1000 else 65536


def free_ports(count: int = 1, *, udp: bool = True) -> int:
    """The first of `count` consecutive loopback ports, free for UDP (or TCP) now and handed to no
    other caller of this user on this machine until the range has been gone through."""
    end = _end()
    with exclusive("ports"):
        try:
            port = int(COUNTER.read_text())
        except (OSError, ValueError):
            port = FIRST
        for _ in range(end - FIRST):
            if port + count > end:
                port = FIRST
            block = range(port, port + count)
            port += count
            if all(port_free(p, udp=udp) for p in block):
                COUNTER.write_text(str(port))
                return block.start
    raise RuntimeError(f"no {count} free consecutive loopback ports in {FIRST}..{end - 1}")


def free_port(*, udp: bool = False) -> int:
    """One loopback port (TCP unless `udp`), as `free_ports`."""
    return free_ports(1, udp=udp)


def free_udp_port() -> int:
    return free_ports(1, udp=True)
