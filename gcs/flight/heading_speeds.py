"""What a vehicle makes good over the ground in each direction it has flown (`HeadingSpeeds`): the
truth a wind estimate only predicts. Pure: fed values, no MAVLink.

A multicopter holds its cruise speed over the ground until its tilt limit; into a wind it makes
what the limit leaves (ArduCopter SITL at 10 m/s in SIM_WIND_SPD 8 at 40 m: 3.9 m/s into it, 7.1
with it on the quarter, 10 across and down it; `tests/peers/wind_log.py`), and its current hardly
changes, so a metre costs the cruise speed over the ground speed made good times a still-air
metre. No wind model gets those speeds within 10 %: the air speed a tilt limit buys depends on how
the airframe meets the air (10.3 m/s nose into it, 11.2 crabbing 30 degrees). So each direction's
ground speed is measured on the legs flown that way, in steady flight (a turn's or a stop's metres
are the profile's cornering), in BINS directions; a direction's cost factor is the measured one
where it has been flown for CONFIDENT_S seconds or more, the wind model's where it has not, and a
blend between, interpolated between neighbouring bins."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from planner.energy import MAX_WIND_FACTOR

__all__ = ["BINS", "CONFIDENT_S", "HeadingSpeeds"]

#: Directions measured apart (22.5 degrees: the grid's eight directions are bin centres)
BINS = 16
#: Seconds of steady flight in a direction after which its measured speed weighs as much as the model
CONFIDENT_S = 6.0
#: Slower than this over the ground, a vehicle is holding, not flying a leg
MIN_SPEED_M_S = 1.0
#: A new version of the factors (a refit of the fuel gauge) every so many seconds of steady flight
VERSION_EVERY_S = 4.0


class HeadingSpeeds:
    """Ground speed made good per direction (see the module docstring); `cruise_speed_m_s` is the
    speed a still-air metre is priced at."""

    def __init__(self, cruise_speed_m_s: float) -> None:
        self.cruise_speed_m_s = cruise_speed_m_s
        self.seconds = np.zeros(BINS)
        self.metres = np.zeros(BINS)
        self.version = 0
        self._since_version_s = 0.0

    def add(self, east_m_s: float, north_m_s: float, seconds: float) -> None:
        """`seconds` of steady flight at this velocity over the ground."""
        speed = math.hypot(east_m_s, north_m_s)
        if speed < MIN_SPEED_M_S or not math.isfinite(speed):
            return
        b = round(math.degrees(math.atan2(east_m_s, north_m_s)) % 360.0 / (360.0 / BINS)) % BINS
        first = self.seconds[b] == 0
        self.seconds[b] += seconds
        self.metres[b] += speed * seconds
        self._since_version_s += seconds
        if first or self._since_version_s >= VERSION_EVERY_S:
            self.version += 1
            self._since_version_s = 0.0

    @property
    def flown(self) -> bool:
        return bool(self.seconds.any())

    def speeds(self) -> np.ndarray:
        """Mean ground speed made good per bin (NaN where never flown)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.seconds > 0, self.metres / self.seconds, np.nan)

    def factors(self, east: ArrayLike, north: ArrayLike, model: ArrayLike) -> float | np.ndarray:
        """The cost factor of a metre in each direction (east, north): measured where flown, the
        `model`'s factor (the same shape) where not (see the module docstring)."""
        east, north = np.asarray(east, dtype=float), np.asarray(north, dtype=float)
        model = np.broadcast_to(np.asarray(model, dtype=float), east.shape)
        position = np.degrees(np.arctan2(east, north)) % 360.0 / (360.0 / BINS)
        low = np.floor(position).astype(int) % BINS
        high = (low + 1) % BINS
        share = position - np.floor(position)
        confidence = self.seconds / (self.seconds + CONFIDENT_S)
        with np.errstate(invalid="ignore", divide="ignore"):
            measured = np.where(self.seconds > 0, np.minimum(self.cruise_speed_m_s * self.seconds
                                                             / np.maximum(self.metres, 1e-9), MAX_WIND_FACTOR), 1.0)

        def at(b: np.ndarray) -> np.ndarray:
            return confidence[b] * measured[b] + (1.0 - confidence[b]) * model

        factor = (1.0 - share) * at(low) + share * at(high)
        factor = np.where(np.hypot(east, north) > 0, factor, 1.0)
        return float(factor) if factor.ndim == 0 else factor

    def as_dict(self) -> dict:
        """For vehicles.json: per bin, its direction, the seconds flown and the speed made good."""
        speeds = self.speeds()
        return {"cruise_speed_m_s": self.cruise_speed_m_s,
                "bins": [{"towards_deg": round(b * 360.0 / BINS, 1), "seconds": round(float(self.seconds[b]), 1),
                          "ground_speed_m_s": round(float(speeds[b]), 2)}
                         for b in range(BINS) if self.seconds[b] > 0]}
