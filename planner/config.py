"""Compilation flags shared by every numba kernel (one place, never per kernel)."""

import numba

JIT = dict(cache=True, nogil=True)


def njit(func):
    """Compile `func` with the project's flags (cached on disk so a second process does not recompile)."""
    return numba.njit(**JIT)(func)
