"""Fit `planner.path_time`'s ArduCopter cornering (acceleration, corner speed shares at 45 and 90
degrees) to ArduCopter SITL's seconds on the stretches of `benchmarks/sim_corners.py`, each from a
stop to a stop at 10 m/s: a zig-zag of eight 50 m legs turning 90 degrees, one turning 45, and a
400 m straight (`tests/planner/corner_stretches.py`: 68.4, 60.2 and 46.8 s). A grid search; prints the
best fit and each stretch's modelled seconds against SITL's.

    .venv/bin/python benchmarks/path_time_fit.py
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planner.path_time import ARDUCOPTER_CORNERING, Cornering, path_time_s
from tests.planner.corner_stretches import SITL_S, SPEED_M_S, stretches


def cornering(accel: float, f45: float, f90: float) -> Cornering:
    return Cornering(accel_m_s2=accel, corner_fractions=((0.0, 1.0), (45.0, f45), (90.0, f90), (180.0, 0.0)))


def modelled(c: Cornering) -> dict[str, float]:
    return {name: path_time_s(points, SPEED_M_S, c) for name, points in stretches().items()}


def main() -> None:
    best = None
    for accel, f45, f90 in itertools.product(np.arange(0.9, 2.01, 0.05), np.arange(0.2, 0.91, 0.01),
                                             np.arange(0.1, 0.81, 0.01)):
        if f90 > f45:
            continue
        got = modelled(cornering(accel, f45, f90))
        err = sum((got[k] / SITL_S[k] - 1.0) ** 2 for k in SITL_S)
        if best is None or err < best[0]:
            best = (err, accel, f45, f90)
    _, accel, f45, f90 = best
    print(f"best fit: accel {accel:.2f} m/s2, 45 degrees {f45:.2f}, 90 degrees {f90:.2f}")
    for label, c in (("fit", cornering(accel, f45, f90)), ("ARDUCOPTER_CORNERING", ARDUCOPTER_CORNERING)):
        got = modelled(c)
        print(label + ": " + ", ".join(f"{k} {got[k]:.1f} s (SITL {SITL_S[k]}, {got[k] / SITL_S[k] - 1:+.1%})"
                                       for k in SITL_S))


if __name__ == "__main__":
    main()
