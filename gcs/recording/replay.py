"""Replaying a Rerun recording (`gcs replay`): the recording checked, the `rerun` viewer program
found, and the web viewer served on a loopback port for a machine without a screen."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from urllib.parse import quote

from gcs.errors import UserError

RRD_MAGIC = b"RRF"  # the .rrd stream header ("RRF2" in Rerun 0.41)
LOOPBACK = "127.0.0.1"


def check_recording(path: Path) -> None:
    """A readable .rrd file, or one clear UserError."""
    if not path.exists():
        raise UserError(f"no such recording: {path}")
    if not path.is_file():
        raise UserError(f"not a file: {path}")
    if path.suffix != ".rrd":
        raise UserError(f"not a Rerun recording (expected a .rrd file): {path}")
    with path.open("rb") as fh:
        head = fh.read(4)
    if not head.startswith(RRD_MAGIC):
        raise UserError(f"not a Rerun recording (bad header): {path}")


def viewer_command() -> list[str]:
    """The `rerun` program that rerun-sdk installs: its binary (found the way the `rerun` wrapper
    script finds it), else the wrapper beside this Python or on PATH, else `python -m rerun`."""
    if os.environ.get("RERUN_CLI_PATH"):
        return [os.environ["RERUN_CLI_PATH"]]
    try:
        import rerun_cli

        binary = Path(rerun_cli.__file__).parent / ("rerun.exe" if os.name == "nt" else "rerun")
        if binary.is_file() and os.access(binary, os.X_OK):
            return [str(binary)]
    except ImportError:
        pass
    beside = Path(sys.executable).parent / ("rerun.exe" if os.name == "nt" else "rerun")
    if beside.is_file() and os.access(beside, os.X_OK):
        return [str(beside)]
    found = shutil.which("rerun")
    if found:
        return [found]
    return [sys.executable, "-m", "rerun"]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((LOOPBACK, 0))
        return s.getsockname()[1]


def web_url(web_port: int, grpc_port: int) -> str:
    return f"http://{LOOPBACK}:{web_port}/?url={quote(f'rerun+http://{LOOPBACK}:{grpc_port}/proxy', safe='')}"


def wait_for_port(port: int, proc: subprocess.Popen, timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise UserError(f"the Rerun viewer server stopped (exit {proc.returncode}): see its messages above")
        try:
            with socket.create_connection((LOOPBACK, port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.1)
    raise UserError(f"the Rerun web viewer did not start listening on port {port} within {timeout_s:.0f} s")


def stop_server(proc: subprocess.Popen) -> None:
    """Stop the server and anything it started (it runs in its own process group)."""
    for sig, wait_s in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(timeout=wait_s)
            return
        except subprocess.TimeoutExpired:
            continue


@contextmanager
def web_viewer(path: Path, web_port: int = 0, grpc_port: int = 0) -> Iterator[tuple[str, subprocess.Popen]]:
    """The web viewer serving `path` on loopback (0: a free port), its URL and process, for the
    block; stopped, with anything it started, when the block ends."""
    web_port = web_port or free_port()
    grpc_port = grpc_port or free_port()
    cmd = viewer_command() + ["--serve-web", "--bind", LOOPBACK, "--web-viewer-port", str(web_port),
                              "--port", str(grpc_port), str(path)]
    env = dict(os.environ, RUST_LOG=os.environ.get("RUST_LOG", "warn"))
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, env=env, start_new_session=True)
    try:
        wait_for_port(web_port, proc)
        yield web_url(web_port, grpc_port), proc
    finally:
        stop_server(proc)
