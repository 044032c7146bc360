"""What a flight costs a vehicle's battery, and the range a charge buys.

A vehicle's `EnergyProfile` prices each part of a flight in charge (mAh of its battery: the unit
autopilots count as current consumed; a percentage converts through the capacity): the launch
(arming and take-off, and each metre climbed to the mission altitude), level flight at the
cruise speed per metre flown over the ground in still air, loitering or hovering per second, and
the landing (each metre of descent, and the touch-down). Over a real area the planner spends a
range in metres (`planner.motion.MoveCosts`); `range_m` is the range a charge pays for once the
launch, the landing and the reserve are kept back, so a plan's range comes from the battery.

Wind changes what a metre over the ground costs, one way more than the other: `wind_factor` is
what a wind does to a vehicle that draws its cruise current wherever it flies, at its cruise
speed through the air (a plane) or over the ground as far as its air speed allows (a
multicopter: upwind it makes only what its air speed leaves). A profile holds still-air figures,
and, for a multicopter, how far it leans into the air it moves through, from which a station
reads a wind its autopilot does not report."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike

from planner.path_time import Cornering, path_length_m, path_time_s

__all__ = ["Airframe", "EnergyProfile", "MAX_WIND_FACTOR", "wind_factor"]

#: A direction the vehicle can barely make headway in costs at most this many times its still-air metre.
MAX_WIND_FACTOR = 10.0


class Airframe(str, Enum):
    COPTER = "copter"
    PLANE = "plane"


@dataclass(frozen=True, kw_only=True)
class EnergyProfile:
    """One vehicle's energy model (charges in mAh, lengths in metres, times in seconds).

    `capacity_mah`: the pack's capacity as the autopilot counts it (BATT_CAPACITY, BAT1_CAPACITY);
    `cruise_speed_m_s`: the speed its missions fly at; `cruise_mah_per_m`: level flight at that
    speed, per ground metre in still air, turns included as the search path it was measured on
    made them (what a path not yet planned is priced at);
    `loiter_mah_per_s`: hover (copter) or loiter circle (plane); `launch_mah` + `climb_mah_per_m`
    per metre of climb: from arming to the mission altitude; `landing_mah` + `descent_mah_per_m`
    per metre of descent: from the mission altitude to disarmed on the ground;
    `lean_tan_at_10_m_s` (multicopters): the tangent of the tilt it holds against 10 m/s of air
    speed, its drag against its weight (None: unknown, its wind is not read from its lean);
    `cornering` and `moving_mah_per_s` (multicopters whose current hardly changes with their
    speed): how it speeds up and brakes into corners, and what a second of flying a path costs,
    so that a known path is priced by its time (`path_mah_per_m`): a search path on small cells
    turns more often per metre than the one `cruise_mah_per_m` was measured on, and costs more."""

    airframe: Airframe
    capacity_mah: float
    cruise_speed_m_s: float
    cruise_mah_per_m: float
    loiter_mah_per_s: float
    launch_mah: float
    climb_mah_per_m: float
    landing_mah: float
    descent_mah_per_m: float
    lean_tan_at_10_m_s: float | None = None
    cornering: Cornering | None = None
    moving_mah_per_s: float | None = None

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
        lean = self.lean_tan_at_10_m_s
        if lean is not None and not (math.isfinite(lean) and lean > 0):
            raise ValueError(f"lean_tan_at_10_m_s must be a positive number or None, got {lean}")
        moving = self.moving_mah_per_s
        if (self.cornering is None) != (moving is None):
            raise ValueError("cornering and moving_mah_per_s come together (or neither)")
        if moving is not None and not (math.isfinite(moving) and moving > 0):
            raise ValueError(f"moving_mah_per_s must be a positive number or None, got {moving}")

    def launch_cost_mah(self, altitude_m: float) -> float:
        """Arming, take-off and the climb to `altitude_m` above the airport."""
        return self.launch_mah + self.climb_mah_per_m * max(0.0, altitude_m)

    def landing_cost_mah(self, altitude_m: float) -> float:
        """The descent from `altitude_m` and the touch-down."""
        return self.landing_mah + self.descent_mah_per_m * max(0.0, altitude_m)

    def cruise_cost_mah(self, metres: float) -> float:
        """`metres` over the ground at the cruise speed in still air."""
        return self.cruise_mah_per_m * max(0.0, metres)

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

    def path_mah_per_m(self, points_en: ArrayLike) -> float:
        """What a still-air metre of the path `points_en` ((east, north) metres, from a stop to a
        stop) costs on average: with `cornering`, `moving_mah_per_s` times its seconds
        (`planner.path_time.path_time_s`) over its metres; else `cruise_mah_per_m`."""
        if self.cornering is None or self.moving_mah_per_s is None:
            return self.cruise_mah_per_m
        length = path_length_m(points_en)
        if length <= 0:
            return self.cruise_mah_per_m
        return self.moving_mah_per_s * path_time_s(points_en, self.cruise_speed_m_s, self.cornering) / length

    def along(self, points_en: ArrayLike) -> EnergyProfile:
        """This profile for one path: a cruise metre at that path's average (`path_mah_per_m`)."""
        return replace(self, cruise_mah_per_m=self.path_mah_per_m(points_en))

    def with_capacity(self, capacity_mah: float) -> EnergyProfile:
        """The same airframe with another pack."""
        return replace(self, capacity_mah=capacity_mah)


def wind_factor(profile: EnergyProfile, east: ArrayLike, north: ArrayLike, wind_m_s: tuple[float, float],
                air_speed_m_s: float | None = None) -> float | np.ndarray:
    """What a metre flown in the direction (east, north) costs in the wind `wind_m_s` (east, north
    m/s the air moves towards), against a still-air metre: the cruise speed over the ground in
    still air over the ground speed made good in that direction, its air speed the cruise speed
    (a multicopter's ground speed never above it: its autopilot holds that speed over the ground),
    at most MAX_WIND_FACTOR; 1 for no direction (a zero step). Directions may come as arrays:
    one factor each. `air_speed_m_s`: the most air speed a multicopter makes when its cruise
    speed over the ground cannot be held (its tilt limit's), a plane's true air speed (its
    ground speed in still air, which a metre of its profile is priced at); the cruise speed by
    default."""
    east, north = np.asarray(east, dtype=float), np.asarray(north, dtype=float)
    length = np.hypot(east, north)
    copter = profile.airframe is Airframe.COPTER
    air = profile.cruise_speed_m_s if air_speed_m_s is None else air_speed_m_s
    speed = profile.cruise_speed_m_s if copter else air
    air = max(speed, air) if copter else air
    along = (east * wind_m_s[0] + north * wind_m_s[1]) / np.where(length > 0, length, 1.0)
    across2 = wind_m_s[0] ** 2 + wind_m_s[1] ** 2 - along * along
    ground = along + np.sqrt(np.maximum(air * air - across2, 0.0))
    if copter:
        ground = np.minimum(ground, speed)
    blocked = (across2 >= air * air) | (ground * MAX_WIND_FACTOR <= speed)
    factor = np.where(length == 0, 1.0, np.where(blocked, MAX_WIND_FACTOR, speed / np.where(blocked, 1.0, ground)))
    return float(factor) if factor.ndim == 0 else factor
