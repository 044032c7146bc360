"""Local metric frame: flat-earth (equirectangular) conversion around one origin.

A fleet searches an area a few kilometres across. Over 10 km the flat-earth approximation
differs from pymap3d's geodetic2enu by well under a metre horizontally (the error grows with
the square of the distance, about 1e-8 relative at 1 km), far below GPS noise and the sensor
cell size, while costing two multiplications per conversion in the telemetry hot loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

EARTH_RADIUS_M = 6_378_137.0


@dataclass(frozen=True, slots=True)
class HomePose:
    """Where a vehicle starts: geodetic position, ground altitude (AMSL) and heading."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    heading_deg: float = 0.0


@dataclass(frozen=True, slots=True)
class LocalFrame:
    """East-north frame tangent at an origin, in metres."""

    lat0_deg: float
    lon0_deg: float

    @property
    def _m_per_deg_lat(self) -> float:
        return math.radians(1.0) * EARTH_RADIUS_M

    @property
    def _m_per_deg_lon(self) -> float:
        return math.radians(1.0) * EARTH_RADIUS_M * math.cos(math.radians(self.lat0_deg))

    def geodetic2en(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """(lat, lon) in degrees to (east, north) in metres."""
        return (
            (lon_deg - self.lon0_deg) * self._m_per_deg_lon,
            (lat_deg - self.lat0_deg) * self._m_per_deg_lat,
        )

    def en2geodetic(self, east_m: float, north_m: float) -> tuple[float, float]:
        """(east, north) in metres to (lat, lon) in degrees."""
        return (
            self.lat0_deg + north_m / self._m_per_deg_lat,
            self.lon0_deg + east_m / self._m_per_deg_lon,
        )
