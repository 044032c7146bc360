"""`gcs replay`: open a Rerun recording (.rrd) of a run in the Rerun viewer, or serve the web
viewer on a loopback port for a machine without a screen (`gcs.recording.replay`)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from gcs.errors import UserError
from gcs.recording.replay import LOOPBACK, check_recording, viewer_command, web_viewer


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("rrd", help="the recording, e.g. runs/plan.rrd")
    p.add_argument("--web", action="store_true",
                   help=f"serve the web viewer on {LOOPBACK} and print its URL; runs until Ctrl-C")
    p.add_argument("--port", type=int, default=0, help="web viewer HTTP port with --web (0: a free port)")
    p.add_argument("--grpc-port", type=int, default=0, help="gRPC port the web viewer reads from (0: a free port)")
    p.set_defaults(func=run)


def serve_web(path: Path, web_port: int, grpc_port: int) -> int:
    try:
        with web_viewer(path, web_port, grpc_port) as (url, proc):
            print(f"serving {path} at {url}  (Ctrl-C to stop)", flush=True)
            return proc.wait()
    except KeyboardInterrupt:
        return 0


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
