"""`gcs replay`: open a Rerun recording (.rrd) of a run in the Rerun viewer, or serve the web
viewer on a loopback port for a machine without a screen."""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import quote

from gcs.errors import UserError

RRD_MAGIC = b"RRF"  # the .rrd stream header ("RRF2" in Rerun 0.41)
LOOPBACK = "127.0.0.1"


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("rrd", help="the recording, e.g. runs/plan.rrd")
    p.add_argument("--web", action="store_true",
                   help=f"serve the web viewer on {LOOPBACK} and print its URL; runs until Ctrl-C")
    p.add_argument("--port", type=int, default=0, help="web viewer HTTP port with --web (0: a free port)")
    p.add_argument("--grpc-port", type=int, default=0, help="gRPC port the web viewer reads from (0: a free port)")
    p.set_defaults(func=run)


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


def serve_web(path: Path, web_port: int, grpc_port: int) -> int:
    web_port = web_port or free_port()
    grpc_port = grpc_port or free_port()
    cmd = viewer_command() + ["--serve-web", "--bind", LOOPBACK, "--web-viewer-port", str(web_port),
                              "--port", str(grpc_port), str(path)]
    env = dict(os.environ, RUST_LOG=os.environ.get("RUST_LOG", "warn"))
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, env=env, start_new_session=True)
    try:
        wait_for_port(web_port, proc)
        print(f"serving {path} at {web_url(web_port, grpc_port)}  (Ctrl-C to stop)", flush=True)
        return proc.wait()
    except KeyboardInterrupt:
        return 0
    finally:
        stop_server(proc)


def run(args: argparse.Namespace) -> int:
    path = Path(args.rrd)
    check_recording(path)
    if args.web:
        return serve_web(path, args.port, args.grpc_port)
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise UserError(f"no display to open the viewer on: use `gcs replay {path} --web` and open the printed URL")
    try:
        return subprocess.call(viewer_command() + [str(path)])
    except KeyboardInterrupt:
        return 0
