"""The `gcs` command line: one sub-command per module in `gcs.cli.commands`."""

from __future__ import annotations

import argparse
import atexit
import gc
import importlib
import os
import sys
import threading
from collections.abc import Sequence
from typing import Any, NoReturn

from gcs.cli.commands import COMMANDS, command_module
from gcs.errors import UserError


def _noting(base: type[argparse.Action]) -> type[argparse.Action]:
    """`base`, also noting in the parsed namespace's `given` that its option was given on the
    command line: `given` maps the destination to the option's first spelling (`np_steps` ->
    `--np`), so a command can tell given options from defaults without parsing again."""
    class Noting(base):  # type: ignore[valid-type, misc]
        def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                     values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
            super().__call__(parser, namespace, values, option_string)
            if self.option_strings:
                namespace.given = {**getattr(namespace, "given", {}), self.dest: self.option_strings[0]}

    Noting.__name__ = Noting.__qualname__ = base.__name__
    return Noting


_NOTED = ("store", "store_const", "store_true", "store_false", "append", "append_const", "count", "extend")
_NOTING: dict[type[argparse.Action], type[argparse.Action]] = {}

#: `argparse.BooleanOptionalAction` (`--x` / `--no-x`), noting its option as given.
BooleanOption = _noting(argparse.BooleanOptionalAction)


def given_options(args: argparse.Namespace) -> dict[str, str]:
    """The options given on the command line (not left at their defaults): destination ->
    the option's first spelling."""
    return dict(getattr(args, "given", {}))


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        for name in (None, *_NOTED):
            base = self._registry_get("action", name)
            self.register("action", name, _NOTING.setdefault(base, _noting(base)))

    def error(self, message: str) -> None:  # type: ignore[override]  # one clear line, exit 2, no usage dump
        raise UserError(f"{self.prog}: {message}")


class _Commands(argparse._SubParsersAction):
    """Sub-commands listed by name and summary; a command's own parser (and with it its module's
    imports) is built only when the command is chosen."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
        name = values[0] if isinstance(values, list) and values else None
        if name in COMMANDS:
            self._name_parser_map[name] = command_parser(name, self._prog_prefix)
        super().__call__(parser, namespace, values, option_string)


def command_parser(name: str, prog: str = "gcs") -> argparse.ArgumentParser:
    """The parser of command `name`, as its module registers it."""
    sub = _Parser(prog=prog).add_subparsers(parser_class=_Parser)
    collecting = gc.isenabled()
    gc.disable()  # imports allocate a lot and free little: collection passes would only slow them
    try:
        module = importlib.import_module(command_module(name))
    finally:
        if collecting:
            gc.enable()
    module.register(sub)
    return sub.choices[name]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="gcs", description=__doc__)
    parser.register("action", "parsers", _Commands)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, summary in COMMANDS.items():
        sub.add_parser(name, help=summary)
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        args = build_parser().parse_args(argv)
        args.argv = argv  # the words given, for commands that must tell given options from defaults
        return int(args.func(args) or 0)
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def entry_point() -> NoReturn:
    """The `gcs` program: `main()`, then exit without tearing the interpreter down (with numba,
    matplotlib and rerun loaded that takes longer than `gcs --help` itself). Exit handlers run
    and output is flushed first; while another thread still runs, or under a profiler or
    tracer, Python exits as usual."""
    code = main()
    others = [t for t in threading.enumerate() if t is not threading.main_thread() and not t.daemon]
    if others or sys.getprofile() is not None or sys.gettrace() is not None:
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`gcs ... | head`) or stream
            pass
    os._exit(code)


