"""A vehicle's wind as the station knows it (`WindEstimate`): where the air moves, how sure the
estimate is, and where it came from. Pure: fed values, no I/O.

Three sources, best first: the autopilot's own estimate (ArduPlane's WIND, within 0.5 m/s and
5 degrees of SITL's set wind; PX4's WIND_COV with its variance), the crew's measurement at launch
(`gcs fly --wind`), and a multicopter's lean in steady flight (`gcs.flight.lean_wind`), for the
autopilots that estimate none (ArduCopter's EKF without drag fusion reports 0)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gcs.links import mavlink

__all__ = ["AUTOPILOT_SIGMA_M_S", "CALM_M_S", "CREW_SIGMA_M_S", "YOUNG_SIGMA_M_S", "WindEstimate", "wind_from_message"]

#: One standard deviation of a component of ArduPlane's WIND: within 0.5 m/s of SITL's set wind,
#: yet 1.1-1.4 m/s in SITL's still air (docs/energy.md); two of these is still air
AUTOPILOT_SIGMA_M_S = 0.75
#: A crew's hand-held reading at the launch site, taken for the mission altitude
CREW_SIGMA_M_S = 1.0
#: An estimate slower than this, or than two of its standard deviations, is still air
CALM_M_S = 1.0
#: An estimate less sure than this (m/s, one standard deviation) is young: it does not commit a
#: return on its own (`gcs.flight.vehicle_energy.VehicleEnergy.evaluate`)
YOUNG_SIGMA_M_S = 1.0


@dataclass(frozen=True, slots=True)
class WindEstimate:
    """The air moving towards (east, north) m/s, one standard deviation of each component, and
    its source ("its lean", "its autopilot", "the crew")."""

    east_m_s: float
    north_m_s: float
    sigma_m_s: float
    source: str

    @property
    def vector(self) -> tuple[float, float]:
        return self.east_m_s, self.north_m_s

    @property
    def speed_m_s(self) -> float:
        return math.hypot(self.east_m_s, self.north_m_s)

    @property
    def from_deg(self) -> float:
        """Where it blows from, degrees from north."""
        return math.degrees(math.atan2(-self.east_m_s, -self.north_m_s)) % 360.0

    @property
    def calm(self) -> bool:
        """Whether it cannot be told from still air."""
        return self.speed_m_s < max(CALM_M_S, 2.0 * self.sigma_m_s)

    @property
    def young(self) -> bool:
        return self.sigma_m_s > YOUNG_SIGMA_M_S

    def weakened(self, sigmas: float = 2.0) -> tuple[float, float]:
        """The wind `sigmas` standard deviations weaker (never reversed): the kindest the estimate allows."""
        speed = self.speed_m_s
        if speed == 0:
            return 0.0, 0.0
        scale = max(0.0, speed - sigmas * self.sigma_m_s) / speed
        return self.east_m_s * scale, self.north_m_s * scale

    def text(self) -> str:
        """'7.3 ± 0.6 m/s from 252 deg (its lean)'."""
        return f"{self.speed_m_s:.1f} ± {self.sigma_m_s:.1f} m/s from {self.from_deg:03.0f} deg ({self.source})"


def wind_from_message(msg: mavlink.MAVLink_message) -> WindEstimate | None:
    """The autopilot's wind: ArduPilot's WIND (the direction it comes from, degrees), PX4's
    WIND_COV (its velocity, NED, with its horizontal variance); None for other messages, unknown
    values, or a wind of exactly 0 (ArduCopter sends 0 when it estimates none)."""
    kind = msg.get_type()
    if kind == "WIND":
        rad = math.radians(msg.direction)
        east, north, sigma = -msg.speed * math.sin(rad), -msg.speed * math.cos(rad), AUTOPILOT_SIGMA_M_S
    elif kind == "WIND_COV" and math.isfinite(msg.wind_x) and math.isfinite(msg.wind_y):
        east, north = float(msg.wind_y), float(msg.wind_x)
        variance = msg.var_horiz
        sigma = math.sqrt(variance) if math.isfinite(variance) and variance > 0 else AUTOPILOT_SIGMA_M_S
    else:
        return None
    if not (math.isfinite(east) and math.isfinite(north)) or (east == 0 and north == 0):
        return None
    return WindEstimate(float(east), float(north), sigma, "its autopilot")
