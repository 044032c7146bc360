"""The stretches ArduCopter SITL flew at 10 m/s to measure its corners (`benchmarks/sim_corners.py`;
docs/energy.md, "The simulator"), each from a stop to a stop, as polylines from the origin, and
SITL's seconds on each: what `planner.path_time.ARDUCOPTER_CORNERING` is fitted to
(`benchmarks/path_time_fit.py`) and checked against (`test_path_time.py`)."""

from __future__ import annotations

import math

import numpy as np

SPEED_M_S = 10.0
SITL_S = {"zig90": 68.4, "zig45": 60.2, "straight": 46.8}


def stretches() -> dict[str, np.ndarray]:
    """Eight 50 m legs turning 90 degrees (N, E, N, E ...), eight turning 45 (N, NE, N, NE ...),
    and 400 m straight."""
    z90 = [(0.0, 0.0)] + [(50.0 * ((i + 1) // 2), 50.0 * ((i + 2) // 2)) for i in range(8)]
    here, z45 = (0.0, 0.0), [(0.0, 0.0)]
    for i in range(8):
        here = (here[0], here[1] + 50.0) if i % 2 == 0 else (here[0] + 50 / math.sqrt(2), here[1] + 50 / math.sqrt(2))
        z45.append(here)
    return {"zig90": np.array(z90), "zig45": np.array(z45), "straight": np.array([(0.0, 0.0), (0.0, 400.0)])}
