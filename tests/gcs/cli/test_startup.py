"""Start-up of the command line: `gcs --help` loads no heavy module, each command loads only its
own, the parent of `gcs plan` never loads matplotlib or rerun, and the quick exit keeps what an
ordinary exit promises (exit handlers, output, threads still running)."""

import pkgutil
import subprocess
import sys
import textwrap

import pytest

import gcs.cli.commands
from gcs.cli import build_parser, command_parser, main
from gcs.cli.commands import COMMANDS

HEAVY = {"matplotlib", "rerun", "numba", "llvmlite", "numpy", "pymavlink", "shapely", "pyproj", "aiomqtt", "mavsdk",
         "pyarrow", "jsonschema"}


def imported(*args: str) -> tuple[set[str], subprocess.CompletedProcess]:
    """Top-level packages a `gcs` process imported (from `python -X importtime`), and the run."""
    run = subprocess.run([sys.executable, "-X", "importtime", "-m", "gcs.cli", *args], capture_output=True, text=True)
    names = {line.split("|")[-1].strip().split(".")[0] for line in run.stderr.splitlines()
             if line.startswith("import time:")}
    return names, run


def test_help_lists_every_command_and_imports_nothing_heavy():
    names, run = imported("--help")
    assert run.returncode == 0, run.stderr
    assert "gcs" in names and "argparse" in names  # the import log was read
    assert names & HEAVY == set()
    for name, summary in COMMANDS.items():
        assert name in run.stdout and summary.split()[0] in run.stdout


@pytest.mark.parametrize("command", ["replay", "signing"])
def test_a_command_imports_its_own_modules_only(command):
    names, run = imported(command, "--help")
    assert run.returncode == 0, run.stderr
    assert f"usage: gcs {command}" in run.stdout
    assert "matplotlib" not in names and "numba" not in names


def test_plan_parses_without_loading_the_planner():
    """`gcs plan` builds its parser from names alone: its help loads no heavy module (and a run
    can start its pictures helper before it loads the planner)."""
    names, run = imported("plan", "--help")
    assert run.returncode == 0, run.stderr
    assert "usage: gcs plan" in run.stdout and "cpio" in run.stdout and "paper" in run.stdout
    assert names & HEAVY == set()


def test_every_command_module_is_listed_and_registers_its_name():
    modules = {m.name for m in pkgutil.iter_modules(gcs.cli.commands.__path__) if not m.name.startswith("_")}
    assert modules == set(COMMANDS)
    for name in COMMANDS:
        parser = command_parser(name)
        assert parser.prog == f"gcs {name}"
        assert callable(parser.get_default("func"))


def test_the_chosen_command_parses_with_its_own_options_and_defaults():
    args = build_parser().parse_args(["plan", "--seed", "4"])
    assert (args.command, args.seed, args.np_steps, args.strategy) == ("plan", 4, 5, "cpio")


def test_unknown_or_missing_command_is_one_error_line(capsys):
    assert main(["fly-away"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: gcs: argument command: invalid choice: 'fly-away'") and "'plan'" in err
    assert main([]) == 2
    assert "required: command" in capsys.readouterr().err
    assert main(["plan", "--no-such-option"]) == 2
    assert "unrecognized arguments: --no-such-option" in capsys.readouterr().err


def test_the_plan_process_itself_never_imports_matplotlib_or_rerun(tmp_path):
    """The picture and the recording are made by the background helper: the planning process
    loads neither library, and both files are written all the same."""
    out = tmp_path / "plan.json"
    script = textwrap.dedent(f"""
        import sys
        from gcs.cli import main
        code = main(["plan", "--range", "40", "--np", "2", "--out", {str(out)!r}, "--quiet"])
        print(code, sorted(m for m in ("matplotlib", "rerun") if m in sys.modules))
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["0", "[]"]
    assert out.with_suffix(".png").stat().st_size > 10_000
    assert out.with_suffix(".rrd").stat().st_size > 10_000


def run_entry_point(tmp_path, argv: list[str], setup: str = "") -> subprocess.CompletedProcess:
    script = textwrap.dedent(f"""
        import atexit, pathlib, sys, threading, time
        atexit.register(lambda: pathlib.Path({str(tmp_path / "atexit")!r}).write_text("ran"))
        {setup}
        sys.argv = ["gcs", *{argv!r}]
        from gcs.cli import entry_point
        entry_point()
    """)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)


def test_the_quick_exit_runs_exit_handlers_flushes_output_and_keeps_the_exit_code(tmp_path):
    run = run_entry_point(tmp_path, ["plan", "--scenario", "moon"], "print('buffered', end='')")
    assert run.returncode == 2
    assert run.stdout == "buffered"
    assert run.stderr.strip() == "error: unknown scenario 'moon' (choose from paper)"
    assert (tmp_path / "atexit").read_text() == "ran"


def test_the_quick_exit_waits_for_a_thread_still_running(tmp_path):
    done = tmp_path / "thread-done"
    setup = (f"threading.Thread(target=lambda: (time.sleep(0.5), pathlib.Path({str(done)!r}).write_text('x'))).start()")
    run = run_entry_point(tmp_path, ["plan", "--scenario", "moon"], setup)
    assert run.returncode == 2
    assert done.read_text() == "x"
