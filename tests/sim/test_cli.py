"""`gcs sim` from the outside: bad input gives one line and a non-zero exit; a good run serves
MAVLink and exits 0 on Ctrl-C."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.peers.ports import free_ports
from tests.sim.helpers import Gcs

ROOT = Path(__file__).resolve().parents[2]


def gcs_sim(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gcs.cli", "sim", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=30, **kwargs)


@pytest.mark.parametrize(
    "args",
    [
        ["--vehicles", "0"],
        ["--vehicles", "two"],
        ["--home", "91,0"],
        ["--home", "1,2,3,4"],
        ["--home", "north,east"],
        ["--vehicles", "2", "--home", "1,2", "--home", "3,4", "--home", "5,6"],
        ["--speedup", "0"],
        ["--loss", "1.5"],
        ["--pc", "2"],
        ["--base-port", "65535", "--vehicles", "4"],
        ["--out", "tcp:127.0.0.1:14550"],
        ["--bind", "not-an-ip"],
        ["--silent", "9"],
        ["--vehicle-type", "blimp"],
        ["--signing-key", " "],
        ["--target", "1"],
    ],
)
def test_bad_arguments_give_one_error_line_and_exit_2(args, capsys):
    from gcs.cli import main

    assert main(["sim", *args]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), lines


@pytest.mark.parametrize("args", [["--vehicles", "0"], ["--home", "91,0"], ["--loss", "1.5"]])
def test_bad_arguments_in_a_real_process(args):
    result = gcs_sim(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), result.stderr


def test_port_in_use_is_a_user_error():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
        result = gcs_sim("--base-port", str(port), "--duration-s", "1")
    assert result.returncode == 2
    assert result.stderr.strip().startswith("error: cannot listen") and "Traceback" not in result.stderr


def test_two_vehicles_serve_mavlink_and_ctrl_c_exits_0():
    base = free_ports(2)
    proc = subprocess.Popen(
        [sys.executable, "-m", "gcs.cli", "sim", "--vehicles", "2", "--home=-35.36,149.16,90",
         "--base-port", str(base), "--speedup", "5"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        banner = [proc.stdout.readline() for _ in range(3)]
        assert f"udpout:127.0.0.1:{base + 1}" in banner[2]
        for sysid in (1, 2):
            gcs = Gcs(("127.0.0.1", base + sysid - 1), sysid)
            hb = gcs.hello()
            assert hb.get_srcSystem() == sysid
            gcs.close()
        time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "Traceback" not in proc.stderr.read()
