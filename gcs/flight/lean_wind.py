"""The wind a multicopter shows by leaning into it. Pure: fed values, no MAVLink.

ArduCopter's EKF estimates no wind without drag fusion (its WIND says 0 while 8 m/s hold it to
2.2 m/s upwind; docs/energy.md), yet a multicopter holding its place in a wind tilts its thrust
into it until the thrust's level part balances the drag: tan(tilt) = L (|air speed| / 10 m/s)^p,
L the airframe's `EnergyProfile.lean_tan_at_10_m_s`. ArduCopter SITL's quad hovering at 40 m
leans 0.0023 in still air, 0.114 in 4 m/s and 0.288 in 8 m/s (`benchmarks/lean_wind.py`): p 4/3
(a drag between linear and quadratic at these speeds), L 0.387. Its lean gives its air velocity;
its ground velocity less that is the wind, in a hover, a climb or level flight alike, averaged
over the last half minute so gusts and turns even out."""

from __future__ import annotations

import math
from collections import deque

__all__ = ["CALM_M_S", "LEAN_EXPONENT", "LeanWind", "MAX_ACCELERATION_M_S2", "MIN_SAMPLES", "WINDOW", "thrust_lean"]

#: p of the module docstring
LEAN_EXPONENT = 4.0 / 3.0

#: Samples (ATTITUDE at 2 Hz: 3 s) before the wind is said, and the last ones it is the mean of (30 s)
MIN_SAMPLES = 6
WINDOW = 60

#: A wind read as slower than this is taken for still air: in level flight the lean law, measured
#: hovering, reads ArduCopter SITL's still air as up to 1.9 m/s (the drag of a quad flying nose
#: first is not quite the drag of a quad holding in a wind)
CALM_M_S = 2.5

#: Samples accelerating harder than this are left out (the acceleration is read from velocities
#: a quarter of a second apart: a turn's or a stop's is too coarse to take out of the lean)
MAX_ACCELERATION_M_S2 = 2.0

GRAVITY_M_S2 = 9.80665


def thrust_lean(roll: float, pitch: float, yaw: float) -> tuple[float, float]:
    """(east, north) of the thrust's level part over its vertical one (tan of the tilt, towards
    where the thrust leans), from ATTITUDE's angles (radians)."""
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), \
        math.sin(yaw)
    north = -(cy * sp * cr + sy * sr)
    east = -(sy * sp * cr - cy * sr)
    up = cp * cr
    return east / up, north / up


class LeanWind:
    """The wind of a multicopter's lean (see the module docstring), over its last WINDOW samples."""

    def __init__(self, lean_tan_at_10_m_s: float) -> None:
        self.lean_at_10 = lean_tan_at_10_m_s
        self.samples = 0
        self._winds: deque[tuple[float, float]] = deque(maxlen=WINDOW)

    def air_velocity(self, lean: tuple[float, float]) -> tuple[float, float]:
        """(east, north) m/s of the air speed a drag lean of `lean` holds against."""
        tan = math.hypot(*lean)
        if tan == 0:
            return 0.0, 0.0
        speed = 10.0 * (tan / self.lean_at_10) ** (1.0 / LEAN_EXPONENT)
        return speed * lean[0] / tan, speed * lean[1] / tan

    def sample(self, lean: tuple[float, float], velocity_m_s: tuple[float, float],
               acceleration_m_s2: tuple[float, float]) -> None:
        """One attitude's lean (`thrust_lean`) in the air, with the vehicle's velocity and
        acceleration over the ground then (east, north): its thrust pushes the drag of its air
        speed aside and accelerates it, so the drag's share is the lean less acceleration / g, and
        the wind is the ground velocity less the air velocity. A sample accelerating harder than
        MAX_ACCELERATION_M_S2 (a turn, a stop) is left out."""
        values = (*lean, *velocity_m_s, *acceleration_m_s2)
        if not all(math.isfinite(v) for v in values) or math.hypot(*acceleration_m_s2) > MAX_ACCELERATION_M_S2:
            return
        drag = (lean[0] - acceleration_m_s2[0] / GRAVITY_M_S2, lean[1] - acceleration_m_s2[1] / GRAVITY_M_S2)
        air = self.air_velocity(drag)
        self.samples += 1
        self._winds.append((velocity_m_s[0] - air[0], velocity_m_s[1] - air[1]))

    @property
    def wind_m_s(self) -> tuple[float, float] | None:
        """(east, north) m/s the air moves towards, the mean of the last samples, (0, 0) under
        CALM_M_S; None before MIN_SAMPLES."""
        if self.samples < MIN_SAMPLES:
            return None
        n = len(self._winds)
        east, north = sum(w[0] for w in self._winds) / n, sum(w[1] for w in self._winds) / n
        return (east, north) if math.hypot(east, north) >= CALM_M_S else (0.0, 0.0)
