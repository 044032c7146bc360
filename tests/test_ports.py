"""The test suite's server ports (`tests.peers.ports`): below the kernel's ephemeral range, so no
connecting socket is given one while its server starts, and never handed out twice at once, even to
two pytest workers asking together."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

from tests.peers.ports import _end, free_ports
from tests.peers.process import port_free, tcp_listening, udp_bound

ROOT = Path(__file__).resolve().parents[1]


def test_blocks_are_free_below_the_ephemeral_range_and_never_overlap():
    blocks = [range(b, b + 3) for b in (free_ports(3) for _ in range(20))]
    assert all(block.stop <= _end() for block in blocks)
    assert all(port_free(p, udp=True) for block in blocks for p in block)
    ports = [p for block in blocks for p in block]
    assert len(set(ports)) == len(ports)


def test_processes_asking_together_get_different_ports():
    ask = "from tests.peers.ports import free_ports; print(*(free_ports(2) for _ in range(30)))"
    procs = [subprocess.Popen([sys.executable, "-c", ask], cwd=ROOT, stdout=subprocess.PIPE, text=True)
             for _ in range(3)]
    bases = [int(b) for p in procs for b in p.communicate(timeout=60)[0].split()]
    ports = [b + k for b in bases for k in (0, 1)]
    assert len(bases) == 90 and len(set(ports)) == len(ports)


def test_a_port_listens_only_once_its_socket_listens():
    with socket.socket() as s:
        s.bind(("127.0.0.1", free_ports(1)))
        port = s.getsockname()[1]
        assert not tcp_listening(port)
        s.listen()
        assert tcp_listening(port)
    assert not tcp_listening(port)


def test_a_udp_port_is_seen_bound_without_binding_it():
    port = free_ports(1)
    assert not udp_bound(port)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", port))
        assert udp_bound(port)
        assert not port_free(port, udp=True)
    assert not udp_bound(port)
