"""The planning options on the command line: defined once for `gcs plan` and `gcs fly`, with the
typed options' defaults; a Namespace becomes typed options in one place; the options given are
told from defaults without parsing again."""

import pathlib
import re

import pytest

from gcs.cli import build_parser, command_parser, given_options, plan_options
from gcs.cli.plan_options import output_options_from, plan_options_from
from gcs.missions.items import Vehicle
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions

ROOT = pathlib.Path(__file__).resolve().parents[3]


def _planning_actions(command: str) -> dict[str, object]:
    """dest -> (option strings, default, type, choices, action class) of `command`'s options."""
    parser = command_parser(command)
    return {a.dest: (tuple(a.option_strings), a.default, a.type, a.choices, type(a).__name__)
            for a in parser._actions if a.option_strings}


def test_plan_and_fly_share_every_planning_option_with_one_default():
    plan, fly = _planning_actions("plan"), _planning_actions("fly")
    planning = {*SearchOptions.__dataclass_fields__, *AreaOptions.__dataclass_fields__, "area", "quiet", "rrd",
                "no_rrd", "rerun_connect"}
    for dest in planning:
        assert plan[dest] == fly[dest], dest
    assert plan["strategy"][1] == fly["strategy"][1] == "cpio"  # the paper's algorithm, in both


def test_with_no_options_both_commands_plan_with_the_typed_defaults():
    for words in (["plan"], ["fly", "--area", "x.geojson"]):
        args = build_parser().parse_args(words)
        assert plan_options_from(args) == (AreaOptions(), SearchOptions()), words
        assert output_options_from(args) == OutputOptions()


def test_given_options_become_typed_options():
    args = build_parser().parse_args(["fly", "--area", "a.geojson", "--np", "3", "--oc", "8", "--strategy", "pio",
                                      "--no-horizon-value", "--no-improve", "--pc", "0.8", "--vehicle", "plane",
                                      "--margin", "5", "--cell-size", "20", "--terrain-follow", "--quiet", "--no-rrd"])
    area, search = plan_options_from(args)
    assert search == SearchOptions(np_steps=3, oc="8", strategy="pio", horizon_value=False, improve=False, pc=0.8)
    assert area == AreaOptions(vehicle=Vehicle.PLANE, margin_m=5.0, cell_size_m=20.0, terrain_follow=True)
    assert output_options_from(args) == OutputOptions(record=False, progress=False)


def test_the_options_given_are_told_from_defaults():
    args = build_parser().parse_args(["plan", "--np", "5", "--strat", "pio", "--no-horizon-value", "--out", "x"])
    assert given_options(args) == {"np_steps": "--np", "strategy": "--strategy", "horizon_value": "--horizon-value",
                                   "out": "--out"}
    assert args.np_steps == 5 and args.strategy == "pio"  # given with its default value: given all the same
    assert given_options(build_parser().parse_args(["plan"])) == {}


@pytest.mark.parametrize("path", ["gcs", "sim", "planner"])
def test_no_namespace_travels_below_the_command_line(path):
    """argparse is the command line's: the library takes typed options."""
    allowed = {"gcs/cli"}
    offenders = []
    for file in sorted((ROOT / path).rglob("*.py")):
        rel = file.relative_to(ROOT).as_posix()
        if any(rel == a or rel.startswith(a + "/") for a in allowed):
            continue
        if re.search(r"^\s*(import argparse|from argparse import)", file.read_text(encoding="utf-8"), re.M):
            offenders.append(rel)
    assert offenders == []


def test_the_names_the_parsers_list_are_the_planners():
    """The parsers spell the planner's names and its largest grid out (so that they load without
    the planner): they are the planner's own."""
    from planner.area_grid import MAX_CELLS
    from planner.dtscs import RETURN_PLANNERS
    from planner.scenario import SCENARIOS
    from planner.search import STRATEGIES

    assert plan_options.STRATEGIES == tuple(sorted(STRATEGIES))
    assert plan_options.RETURN_PLANNERS == RETURN_PLANNERS
    assert plan_options.SCENARIOS == tuple(SCENARIOS)
    assert AreaOptions().max_cells == MAX_CELLS
