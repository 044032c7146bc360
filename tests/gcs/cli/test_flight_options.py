"""One default per flight option: the flags of `gcs fly` and `gcs upload` default to
`FlyOptions`, so a flight started from Python flies as one started from the command line."""

from __future__ import annotations

from dataclasses import fields

import pytest

from gcs.cli import command_parser
from gcs.cli.commands.fly import options_from
from gcs.flight.controller import FlyOptions
from gcs.plans.plan_folder import FleetPlan

FLY_FLAGS = {"reserve_pct": "reserve_pct", "fit_charge": "fit_charge",
             "arm_timeout": "arm_timeout_s", "ready_timeout": "ready_timeout_s", "link_timeout": "link_timeout_s",
             "lost_giveup": "lost_giveup_s"}
UPLOAD_FLAGS = {"timeout": "transfer_timeout_s", "connect_timeout": "connect_timeout_s",
                "ready_timeout": "ready_timeout_s"}


@pytest.mark.parametrize(("command", "flags"), [("fly", FLY_FLAGS), ("upload", UPLOAD_FLAGS)])
def test_flight_flags_default_to_fly_options(command, flags):
    args = command_parser(command).parse_args(["--plan", "somewhere"])
    defaults = FlyOptions()
    for dest, field in flags.items():
        assert getattr(args, dest) == getattr(defaults, field), (command, dest)


def test_fly_without_flags_flies_with_the_default_options():
    args = command_parser("fly").parse_args(["--plan", "somewhere"])
    plan = FleetPlan.__new__(FleetPlan)
    plan.uavs, plan.raw = {1: None}, {}  # a plan made without --vehicles
    built, defaults = options_from(args, plan), FlyOptions()
    assert {f.name: getattr(built, f.name) for f in fields(FlyOptions)} == \
        {f.name: getattr(defaults, f.name) for f in fields(FlyOptions)}


def test_every_knob_the_journal_keeps_has_its_flag_for_resume():
    """`gcs fly --resume` keeps the journal's value of a knob unless its flag is given again: the
    flags it knows are exactly the knobs the journal keeps."""
    from gcs.cli.commands.fly import RESUMED_OPTIONS
    from gcs.flight.journal import JOURNALED_OPTIONS

    assert sorted(RESUMED_OPTIONS.values()) == sorted(JOURNALED_OPTIONS)


def test_upload_refuses_resume_in_one_line(capsys):
    from gcs.cli import main

    assert main(["upload", "--plan", "somewhere", "--sim", "--resume", "somewhere"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unrecognized arguments: --resume" in err
