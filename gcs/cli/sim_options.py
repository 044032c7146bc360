"""Command-line options of the commands that can work the built-in simulated fleet instead of
real vehicles (`fly`, `upload`): `--sim` and its settings, and the choice between it and
`--connect`; and the simulated sensor's Pc and Pf over a plan (`fly --sim`, `sim --plan`,
`detector --plan`)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from gcs.cli import given_options
from gcs.cli.link_options import connections_from
from gcs.errors import UserError

if TYPE_CHECKING:
    from gcs.plans.plan_folder import FleetPlan
    from sim.fleet import SimFleet


def add_sim_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sim", action="store_true", help="start the built-in simulated fleet at the plan's airports")
    p.add_argument("--speedup", type=float, default=10.0, help="simulated time / real time with --sim")
    p.add_argument("--sim-profile", choices=("ardupilot", "px4"), default="ardupilot",
                   help="autopilot the sim imitates")
    p.add_argument("--sim-loss", type=float, default=0.0, help="packet loss probability on every simulated link")


def connections_or_sim(args: argparse.Namespace) -> list[str]:
    """`--sim` or well-formed `--connect` strings, checked before any planning or upload."""
    if args.sim and args.connect:
        raise UserError("--sim starts its own vehicles: leave out --connect")
    if not args.sim and not args.connect:
        raise UserError("give --connect (e.g. udpin:127.0.0.1:14550, tcp:127.0.0.1:5760, /dev/ttyUSB0,57600) or --sim")
    return connections_from(args)


def simulated_fleet(plan: FleetPlan, **settings) -> SimFleet:
    """`sim.plan_fleet.fleet_for_plan`, its refusal as one error line; sim is imported only here."""
    from sim.plan_fleet import fleet_for_plan

    try:
        return fleet_for_plan(plan, **settings)
    except ValueError as exc:
        raise UserError(f"--sim: {exc}") from None


def sim_sensor(args: argparse.Namespace, plan: FleetPlan) -> tuple[float, float]:
    """The Pc and Pf the simulated sensor reads `plan`'s world at: `--pc` and `--pf` when given on
    the command line, else the plan's (`FleetPlan.pc`: its camera's Pc when it was made with
    one), so that the readings are drawn as the plan and the sortie record count them."""
    given = given_options(args)
    return (float(args.pc) if "pc" in given else plan.pc), (float(args.pf) if "pf" in given else plan.pf)
