"""Constant-speed unicycle with a turn-rate limit, plus rate-limited climb and descent.

Heading is the yaw from north, clockwise, so with theta = pi/2 - heading the model is
xdot = v cos(theta), ydot = v sin(theta), |thetadot| <= eps, exactly the unicycle.
A plane always flies at cruise speed; a copter may slow down (0 <= v <= cruise) so that it
can stop on a point that lies inside its turning circle, and within one step of a point it
moves onto it without turning (a multirotor translates in any direction). A copter with an
acceleration limit (ArduCopter's) speeds up no faster than that and brakes in time to pass its
target at the speed its next turn allows (`corner_fraction`), or to stop on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Fitted to ArduCopter SITL at WPNAV_SPEED 10 m/s (`benchmarks/sim_corners.py`: 400 m from a stop
#: to a stop in 47.2 s, 7.2 s more than at 10 m/s throughout; a 50 m zig-zag's corners 1.9 s more
#: each at 45 degrees and 3.0 s at 90): an acceleration of 1.15 m/s² each way and, turning the
#: direction it moves at 360 deg/s (a multirotor translates; its yaw is another matter), these
#: fractions of its speed kept through a corner put the simulator within 2 % of SITL's time and
#: charge on each stretch. Turn (degrees) -> the fraction kept.
COPTER_ACCEL_M_S2 = 1.15
CORNER_FRACTIONS = ((0.0, 1.0), (45.0, 0.45), (90.0, 0.42), (180.0, 0.0))


@dataclass(frozen=True, slots=True, kw_only=True)
class KinematicLimits:
    cruise_speed_m_s: float
    turn_rate_rad_s: float
    climb_rate_m_s: float
    descent_rate_m_s: float
    can_hover: bool
    accel_m_s2: float | None = None  # a copter's speed changes at most this fast (None: at once)

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


def corner_fraction(turn_rad: float) -> float:
    """The fraction of its speed an accelerating copter keeps through a turn of `turn_rad`
    (`CORNER_FRACTIONS`)."""
    deg, fractions = zip(*CORNER_FRACTIONS, strict=True)
    return float(np.interp(math.degrees(abs(wrap_pi(turn_rad))), deg, fractions))


def step_toward(
    s: KinematicState,
    limits: KinematicLimits,
    dt_s: float,
    *,
    target_en: tuple[float, float] | None,
    target_alt_m: float,
    speed_m_s: float | None = None,
    climb_rate_m_s: float | None = None,
    pass_fraction: float = 0.0,
) -> None:
    """Advance `s` by dt toward a horizontal target (None: hold) and a target altitude, at
    `speed_m_s` and climbing at `climb_rate_m_s` (None: the limits'). A copter with an
    acceleration limit passes its target at `pass_fraction` of that speed (0: stops on it).

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
        if limits.can_hover and limits.accel_m_s2 is not None:
            a = limits.accel_m_s2
            passing = cruise * min(1.0, max(0.0, pass_fraction))
            cruise = min(cruise, math.sqrt(passing * passing + 2.0 * a * dist), s.speed_m_s + a * dt_s)
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
