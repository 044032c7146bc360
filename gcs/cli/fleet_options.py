"""Command-line options of the commands that send a plan folder to a fleet (`fly`, `upload`):
the plan, the links or the simulated fleet, and the checks made before anything is sent."""

from __future__ import annotations

import argparse

from gcs.cli.link_options import add_link_arguments
from gcs.cli.sim_options import add_sim_arguments
from gcs.flight.controller import FlyOptions


def add_fleet_arguments(p: argparse.ArgumentParser, verb: str) -> None:
    """`--plan`, the links (`--connect`, signing), `--sim` and its settings, `--no-fence`,
    `--ready-timeout` and `--allow-home-offset`; `verb` ("fly", "upload") words the last help."""
    p.add_argument("--plan", metavar="DIR", help="a gcs plan --area output folder")
    add_link_arguments(p)
    add_sim_arguments(p)
    p.add_argument("--no-fence", action="store_true", help="do not upload geofence and rally points")
    p.add_argument("--ready-timeout", type=float, default=FlyOptions.ready_timeout_s,
                   help="seconds to wait for each vehicle's GPS fix, position estimate and home")
    p.add_argument("--allow-home-offset", action="store_true",
                   help=f"{verb} even when a vehicle's home is more than a cell from its UAV's airport")
