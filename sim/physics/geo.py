"""Local metric frame: flat-earth (equirectangular) conversion around one origin.

A fleet searches an area a few kilometres across. Degrees are scaled by the WGS84 radii of
curvature at the origin (longitude at the mid latitude of origin and point). Against pymap3d's
geodetic2enu this is within 0.1 m at 1 km and about 2 m at 7 km (the gap grows with the
square of the distance: ENU is a tangent plane, this is a map), below GPS noise and the sensor
cell. What matters more: the simulator converts both ways with the same function, so waypoints,
flown track and reported lat/lon agree exactly, at the cost of one cosine per conversion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

WGS84_A_M = 6_378_137.0
WGS84_E2 = 6.694379990141317e-3


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
        """Meridian radius of curvature M of the WGS84 ellipsoid at the origin."""
        s2 = math.sin(math.radians(self.lat0_deg)) ** 2
        return math.radians(1.0) * WGS84_A_M * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5

    @property
    def _n_m(self) -> float:
        """Prime vertical radius of curvature N of the WGS84 ellipsoid at the origin."""
        return WGS84_A_M / math.sqrt(1 - WGS84_E2 * math.sin(math.radians(self.lat0_deg)) ** 2)

    def _m_per_deg_lon(self, lat_deg: float) -> float:
        """Longitude scale at the mid latitude between the origin and the point."""
        return math.radians(1.0) * self._n_m * math.cos(math.radians(0.5 * (lat_deg + self.lat0_deg)))

    def geodetic2en(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """(lat, lon) in degrees to (east, north) in metres."""
        return (
            (lon_deg - self.lon0_deg) * self._m_per_deg_lon(lat_deg),
            (lat_deg - self.lat0_deg) * self._m_per_deg_lat,
        )

    def en2geodetic(self, east_m: float, north_m: float) -> tuple[float, float]:
        """(east, north) in metres to (lat, lon) in degrees."""
        lat_deg = self.lat0_deg + north_m / self._m_per_deg_lat
        return (lat_deg, self.lon0_deg + east_m / self._m_per_deg_lon(lat_deg))
