"""The wind a multicopter shows by leaning into it. Pure: fed values, no MAVLink.

ArduCopter's EKF estimates no wind without drag fusion (its WIND says 0 in any wind;
docs/energy.md), yet a multicopter tilts its thrust into the air it moves through until the
thrust's level part balances the drag: tan(tilt) = L (|air speed| / 10 m/s)^p, L the airframe's
`EnergyProfile.lean_tan_at_10_m_s`. Its lean gives its air velocity; its ground velocity less
that is the wind.

ArduCopter SITL's quad hovering at 40 m leans 0.0023 in still air, 0.114 with SIM_WIND_SPD 4 and
0.288 with 8 (`benchmarks/lean_wind.py`). SITL's wind grows with the square root of the height up
to SIM_WIND_T_ALT, 60 m (SIM_WIND_T 0, its default): at 40 m those are 3.27 and 6.53 m/s, so
p 4/3 and L 0.507 (0.506 and 0.509 from the two). The same law holds in flight: on a star of
legs at 10 m/s in SIM_WIND_SPD 8 (`tests/peers/wind_log.py`) every leg's lean is what its air
speed asks within 0.03, up to the tilt limit (ANGLE_MAX, tan 0.577: 11 m/s of air). Read
against the nominal SIM_WIND_SPD (L 0.387, until 2026-12-02) it took every lean in flight for
2-3 m/s more air than there was, and a copter's way home into a wind for twice its price.

A sample counts only in steady flight: its velocity over the ground changing by less than
MAX_ACCELERATION_M_S2 over the second before (a turn, a stop or a speed-up leans for the change,
not the air). The estimate is the mean of the last WINDOW samples, with its standard deviation:
the samples' scatter (gusts, correlated over a few samples) and the lean law's own error."""

from __future__ import annotations

import math
from collections import deque

from gcs.telemetry.wind import WindEstimate

__all__ = ["LEAN_EXPONENT", "LeanWind", "MAX_ACCELERATION_M_S2", "MIN_SAMPLES", "WINDOW", "thrust_lean"]

#: p of the module docstring
LEAN_EXPONENT = 4.0 / 3.0

#: Samples (ATTITUDE at 2 Hz: 3 s) before the wind is estimated, and the last ones it is the mean of (30 s)
MIN_SAMPLES = 6
WINDOW = 60

#: Samples whose ground velocity changed faster than this over the second before are left out
MAX_ACCELERATION_M_S2 = 0.6

#: The lean law's own error (m/s of air speed, one standard deviation): 0.3-0.7 on SITL's legs
LAW_SIGMA_M_S = 0.6
#: The law's error shrinks to LAW_SIGMA_M_S only over so many samples (20 s): a first reading
#: leans from the climb's end into a first leg, and its error there is not yet averaged over the
#: ways it flies (ArduCopter SITL: 8.3 m/s read in the first 10 s in 7.3 at 50 m)
FIRM_SAMPLES = 40

#: Successive samples (half a second apart) share a gust: so many (5 s) count as one
CORRELATED_SAMPLES = 10

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
        """One attitude's lean (`thrust_lean`) in the air, with the vehicle's velocity over the
        ground then and its change per second over the second before (east, north): its thrust
        pushes the drag of its air speed aside and accelerates it, so the drag's share is the lean
        less acceleration / g, and the wind is the ground velocity less the air velocity. A sample
        not in steady flight (MAX_ACCELERATION_M_S2) is left out."""
        values = (*lean, *velocity_m_s, *acceleration_m_s2)
        if not all(math.isfinite(v) for v in values) or math.hypot(*acceleration_m_s2) > MAX_ACCELERATION_M_S2:
            return
        drag = (lean[0] - acceleration_m_s2[0] / GRAVITY_M_S2, lean[1] - acceleration_m_s2[1] / GRAVITY_M_S2)
        air = self.air_velocity(drag)
        self.samples += 1
        self._winds.append((velocity_m_s[0] - air[0], velocity_m_s[1] - air[1]))

    @property
    def estimate(self) -> WindEstimate | None:
        """The mean of the last samples and its standard deviation; None before MIN_SAMPLES."""
        if self.samples < MIN_SAMPLES:
            return None
        n = len(self._winds)
        east, north = sum(w[0] for w in self._winds) / n, sum(w[1] for w in self._winds) / n
        scatter = sum((w[0] - east) ** 2 + (w[1] - north) ** 2 for w in self._winds) / (2 * max(1, n - 1))
        law = LAW_SIGMA_M_S ** 2 * max(1.0, FIRM_SAMPLES / self.samples)
        sigma = math.sqrt(scatter * CORRELATED_SAMPLES / n + law)
        return WindEstimate(east, north, sigma, "its lean")

    @property
    def wind_m_s(self) -> tuple[float, float] | None:
        """(east, north) m/s the air moves towards, (0, 0) for still air (`WindEstimate.calm`); None
        before MIN_SAMPLES."""
        estimate = self.estimate
        if estimate is None:
            return None
        return (0.0, 0.0) if estimate.calm else estimate.vector
