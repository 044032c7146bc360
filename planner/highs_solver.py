"""A HiGHS solver (`highspy`) made quietly, for the bound's LPs and MIPs: one thread, a fixed
random seed (the same model gives the same answer), no output."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["quiet_highs"]


@contextmanager
def _stdout_closed() -> Iterator[None]:
    """File descriptor 1 on /dev/null: HiGHS prints its banner there when its first solver is made."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def quiet_highs() -> Any:
    """A new `highspy.Highs`, silent, on one thread, seed 0."""
    import highspy

    with _stdout_closed():
        h = highspy.Highs()  # type: ignore[no-untyped-call]
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    h.setOptionValue("random_seed", 0)
    return h
