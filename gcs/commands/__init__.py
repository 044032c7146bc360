"""Sub-commands of `gcs`, one module each, found by name. Each module defines
`register(subparsers)`; the parser it adds sets `func`, called with the parsed arguments and
returning the exit code."""

import pkgutil


def command_modules() -> list[str]:
    return sorted(f"{__name__}.{m.name}" for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))
