"""Constant-speed unicycle with a turn-rate limit, plus rate-limited climb and descent.

Heading is the yaw from north, clockwise, so with theta = pi/2 - heading the model is
xdot = v cos(theta), ydot = v sin(theta), |thetadot| <= eps, exactly the unicycle.
A plane always flies at cruise speed; a copter may slow down (0 <= v <= cruise) so that it
can stop on a point that lies inside its turning circle, and within one step of a point it
moves onto it without turning (a multirotor translates in any direction).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True, kw_only=True)
class KinematicLimits:
    cruise_speed_m_s: float
    turn_rate_rad_s: float
    climb_rate_m_s: float
    descent_rate_m_s: float
    can_hover: bool

    @property
    def turn_radius_m(self) -> float:
        return self.cruise_speed_m_s / self.turn_rate_rad_s


@dataclass(slots=True)
class KinematicState:
    east_m: float
    north_m: float
    alt_m: float  # above home
    heading_rad: float
    speed_m_s: float = 0.0
    climb_m_s: float = 0.0
    turn_rate_rad_s: float = 0.0


def wrap_pi(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def step_toward(
    s: KinematicState,
    limits: KinematicLimits,
    dt_s: float,
    *,
    target_en: tuple[float, float] | None,
    target_alt_m: float,
    speed_m_s: float | None = None,
    climb_rate_m_s: float | None = None,
) -> None:
    """Advance `s` by dt toward a horizontal target (None: hold) and a target altitude, at
    `speed_m_s` and climbing at `climb_rate_m_s` (None: the limits').

    Holding: a copter stops; a plane circles at its minimum turn radius.
    """
    climb = limits.climb_rate_m_s if climb_rate_m_s is None else climb_rate_m_s
    cruise = speed_m_s if speed_m_s is not None else limits.cruise_speed_m_s
    max_turn = limits.turn_rate_rad_s * dt_s
    if target_en is None:
        if limits.can_hover:
            s.speed_m_s, s.turn_rate_rad_s = 0.0, 0.0
        else:
            s.heading_rad = wrap_pi(s.heading_rad + max_turn)
            s.speed_m_s, s.turn_rate_rad_s = cruise, limits.turn_rate_rad_s
    else:
        de, dn = target_en[0] - s.east_m, target_en[1] - s.north_m
        dist = math.hypot(de, dn)
        if limits.can_hover and dist <= cruise * dt_s:
            s.east_m, s.north_m = target_en
            s.speed_m_s, s.turn_rate_rad_s = dist / dt_s, 0.0
            _climb(s, climb, limits.descent_rate_m_s, dt_s, target_alt_m)
            return
        if dist > 1e-6:
            err = wrap_pi(math.atan2(de, dn) - s.heading_rad)
            turn = max(-max_turn, min(max_turn, err))
            s.heading_rad = wrap_pi(s.heading_rad + turn)
            s.turn_rate_rad_s = turn / dt_s
            err_after = abs(err - turn)
        else:
            s.turn_rate_rad_s, err_after = 0.0, 0.0
        if limits.can_hover:
            s.speed_m_s = min(cruise, dist / dt_s) * max(0.0, math.cos(err_after))
        else:
            s.speed_m_s = cruise
    s.east_m += s.speed_m_s * math.sin(s.heading_rad) * dt_s
    s.north_m += s.speed_m_s * math.cos(s.heading_rad) * dt_s
    _climb(s, climb, limits.descent_rate_m_s, dt_s, target_alt_m)


def _climb(s: KinematicState, climb_rate_m_s: float, descent_rate_m_s: float, dt_s: float,
           target_alt_m: float) -> None:
    dz = target_alt_m - s.alt_m
    dz = max(-descent_rate_m_s * dt_s, min(climb_rate_m_s * dt_s, dz))
    s.alt_m += dz
    s.climb_m_s = dz / dt_s
