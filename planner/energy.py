"""What a flight costs a vehicle's battery, and the range a charge buys.

A vehicle's `EnergyProfile` prices each part of a flight in charge (mAh of its battery: the unit
autopilots count as current consumed; a percentage converts through the capacity): the launch
(arming and take-off, and each metre climbed to the mission altitude), level flight at the
cruise speed per metre flown over the ground in still air, loitering or hovering per second, and
the landing (each metre of descent, and the touch-down). Over a real area the planner spends a
range in metres (`planner.motion.MoveCosts`); `range_m` is the range a charge pays for once the
launch, the landing and the reserve are kept back, so a plan's range comes from the battery.

Wind changes what a metre over the ground costs (`wind_factor`). A plane holds its airspeed: a
leg into the wind takes longer at the same power, and charge per ground metre grows as airspeed
over ground speed. A multicopter holds its ground speed: against the wind it flies faster
through the air, and its power grows with the square of the extra airspeed (drag), scaled by
`drag_share`, the part of its cruise power that goes into drag at its cruise speed in still air.
Both read wind as the vector the air moves towards (east, north), as ArduPilot's WIND and PX4's
WIND_COV give it turned around (they give where it blows from, or its velocity)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

__all__ = ["Airframe", "EnergyProfile", "wind_factor"]


class Airframe(str, Enum):
    COPTER = "copter"
    PLANE = "plane"


@dataclass(frozen=True, kw_only=True)
class EnergyProfile:
    """One vehicle's energy model (charges in mAh, lengths in metres, times in seconds).

    `capacity_mah`: the pack's capacity as the autopilot counts it (BATT_CAPACITY, BAT1_CAPACITY);
    `cruise_speed_m_s`: the speed its missions fly at; `cruise_mah_per_m`: level flight at that
    speed, per ground metre in still air, turns included as a search path makes them;
    `loiter_mah_per_s`: hover (copter) or loiter circle (plane); `launch_mah` + `climb_mah_per_m`
    per metre of climb: from arming to the mission altitude; `landing_mah` + `descent_mah_per_m`
    per metre of descent: from the mission altitude to disarmed on the ground; `drag_share`: see
    the module docstring (copters)."""

    airframe: Airframe
    capacity_mah: float
    cruise_speed_m_s: float
    cruise_mah_per_m: float
    loiter_mah_per_s: float
    launch_mah: float
    climb_mah_per_m: float
    landing_mah: float
    descent_mah_per_m: float
    drag_share: float = 0.3

    def __post_init__(self) -> None:
        positive = ("capacity_mah", "cruise_speed_m_s", "cruise_mah_per_m")
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        for name in ("loiter_mah_per_s", "launch_mah", "climb_mah_per_m", "landing_mah", "descent_mah_per_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a number >= 0, got {value}")
        if not 0 <= self.drag_share <= 1:
            raise ValueError(f"drag_share must be in [0, 1], got {self.drag_share}")

    def launch_cost_mah(self, altitude_m: float) -> float:
        """Arming, take-off and the climb to `altitude_m` above the airport."""
        return self.launch_mah + self.climb_mah_per_m * max(0.0, altitude_m)

    def landing_cost_mah(self, altitude_m: float) -> float:
        """The descent from `altitude_m` and the touch-down."""
        return self.landing_mah + self.descent_mah_per_m * max(0.0, altitude_m)

    def cruise_cost_mah(self, metres: float, factor: float = 1.0) -> float:
        """`metres` over the ground at the cruise speed, each `factor` times its still-air cost."""
        return self.cruise_mah_per_m * max(0.0, metres) * factor

    def flight_cost_mah(self, cruise_m: float, altitude_m: float, loiter_s: float = 0.0) -> float:
        """A whole flight: launch, `cruise_m` of level flight, `loiter_s` of loiter, landing."""
        return (self.launch_cost_mah(altitude_m) + self.cruise_cost_mah(cruise_m)
                + self.loiter_mah_per_s * max(0.0, loiter_s) + self.landing_cost_mah(altitude_m))

    def reserve_mah(self, reserve_pct: float) -> float:
        return self.capacity_mah * reserve_pct / 100.0

    def range_m(self, altitude_m: float, reserve_pct: float, charge_pct: float = 100.0) -> float:
        """Metres of level flight at the cruise speed that `charge_pct` of the pack pays for once
        the launch, the landing and `reserve_pct` are kept back (0 when it pays for none)."""
        left = (self.capacity_mah * (charge_pct - reserve_pct) / 100.0 - self.launch_cost_mah(altitude_m)
                - self.landing_cost_mah(altitude_m))
        return max(0.0, left / self.cruise_mah_per_m)

    def with_capacity(self, capacity_mah: float) -> EnergyProfile:
        """The same airframe with another pack."""
        return replace(self, capacity_mah=capacity_mah)


def wind_factor(profile: EnergyProfile, wind_east_m_s: float, wind_north_m_s: float, leg_east: float,
                leg_north: float) -> float:
    """What one ground metre along the direction (leg_east, leg_north) costs in the wind (the air
    moving towards east, north), over its still-air cost (see the module docstring). A plane that
    cannot make way against the wind gets an infinite factor."""
    length = math.hypot(leg_east, leg_north)
    wind = math.hypot(wind_east_m_s, wind_north_m_s)
    if length == 0 or wind == 0:
        return 1.0
    ue, un = leg_east / length, leg_north / length
    along = wind_east_m_s * ue + wind_north_m_s * un  # tailwind > 0
    v = profile.cruise_speed_m_s
    if profile.airframe is Airframe.PLANE:
        cross2 = wind * wind - along * along
        if v * v <= cross2:
            return math.inf
        ground = along + math.sqrt(v * v - cross2)
        return math.inf if ground <= 0 else v / ground
    air2 = (v * ue - wind_east_m_s) ** 2 + (v * un - wind_north_m_s) ** 2
    return 1.0 + profile.drag_share * (air2 / (v * v) - 1.0)
