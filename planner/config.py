"""Compilation flags shared by every numba kernel (one place, never per kernel)."""

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba

CACHE = True  # compiled code kept on disk: a second process loads it instead of compiling
NOGIL = True

Kernel = TypeVar("Kernel", bound=Callable[..., Any])


def njit(func: Kernel) -> Kernel:
    """Compile `func` with the project's flags. Typed as `func`: called from Python the
    dispatcher takes and returns what `func` does (and is `func` under NUMBA_DISABLE_JIT)."""
    return cast(Kernel, numba.njit(cache=CACHE, nogil=NOGIL)(func))
