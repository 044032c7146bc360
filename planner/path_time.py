"""How long a multicopter takes along a path of waypoints.

ArduCopter's waypoint navigation speeds up and brakes at an acceleration (WPNAV_ACCEL) and
passes each waypoint at the speed its turn onto the next leg allows, stopping at the path's ends;
its current hardly changes with its speed (ArduCopter SITL: 8.1 mAh/s in 90-degree zig-zags of
50 m legs, 8.3 on a 400 m straight, 7.8 hovering; docs/energy.md), so what a path costs it is
its time, and a search path's corners are most of the difference between its metres and its
seconds. `path_time_s` is that time: the speed profile of a point moving along the polyline,
capped at the cruise speed and at each corner's speed, whose speed changes at most at the
acceleration (a forward and a backward pass over the waypoints, then each leg accelerating,
cruising and braking). Planes keep their speed through a turn: they have no `Cornering`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["ARDUCOPTER_CORNERING", "Cornering", "path_length_m", "path_time_s", "turn_angles_deg"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Cornering:
    """`accel_m_s2`: the most the speed changes per second, either way; `corner_fractions`:
    (turn in degrees, share of the cruise speed kept through it), increasing turns from 0."""

    accel_m_s2: float
    corner_fractions: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.accel_m_s2) and self.accel_m_s2 > 0):
            raise ValueError(f"accel_m_s2 must be a positive number, got {self.accel_m_s2}")
        turns = [t for t, _ in self.corner_fractions]
        if not turns or turns[0] != 0.0 or turns != sorted(set(turns)) or turns[-1] > 180.0:
            raise ValueError(f"corner_fractions must start at 0 degrees and increase to 180 at most, got {turns}")
        if any(not 0.0 <= f <= 1.0 for _, f in self.corner_fractions):
            raise ValueError("corner_fractions' shares must lie in [0, 1]")

    def fraction(self, turn_deg: ArrayLike) -> np.ndarray:
        """The share of the cruise speed kept through each turn (degrees, any sign)."""
        turns, shares = zip(*self.corner_fractions, strict=True)
        shares_kept: np.ndarray = np.interp(np.abs(np.asarray(turn_deg, dtype=float)), turns, shares, right=shares[-1])
        return shares_kept


#: Fitted to ArduCopter SITL at WPNAV_SPEED 10 m/s, WPNAV_ACCEL stock (`benchmarks/path_time_fit.py`:
#: its 90- and 45-degree zig-zags of 50 m legs and a 400 m straight, each from a stop to a stop,
#: within 0.3 % of SITL's seconds)
ARDUCOPTER_CORNERING = Cornering(accel_m_s2=1.5, corner_fractions=((0.0, 1.0), (45.0, 0.46), (90.0, 0.31),
                                                                   (180.0, 0.0)))


def turn_angles_deg(points_en: ArrayLike) -> np.ndarray:
    """The turn at each inner waypoint of a polyline (degrees, 0 straight on, 180 back), its
    repeated points dropped first."""
    legs = _legs(points_en)
    if len(legs) < 2:
        return np.zeros(0)
    heading = np.arctan2(legs[:, 0], legs[:, 1])
    turn = (np.diff(heading) + math.pi) % (2.0 * math.pi) - math.pi
    degrees: np.ndarray = np.degrees(np.abs(turn))
    return degrees


def _legs(points_en: ArrayLike) -> np.ndarray:
    points = np.asarray(points_en, dtype=float).reshape(-1, 2)
    legs = np.diff(points, axis=0)
    return legs[np.hypot(legs[:, 0], legs[:, 1]) > 1e-9]


def path_length_m(points_en: ArrayLike) -> float:
    """The length of the polyline `points_en` ((east, north) metres)."""
    legs = _legs(points_en)
    return float(np.hypot(legs[:, 0], legs[:, 1]).sum())


def path_time_s(points_en: ArrayLike, cruise_speed_m_s: float, cornering: Cornering | None = None) -> float:
    """Seconds to fly the polyline `points_en` ((east, north) metres), from a stop to a stop at
    `cornering`'s acceleration and corner speeds; without `cornering`, its length at the cruise
    speed."""
    legs = _legs(points_en)
    lengths = np.hypot(legs[:, 0], legs[:, 1])
    if cornering is None or len(lengths) == 0:
        return float(lengths.sum()) / cruise_speed_m_s
    a, v = cornering.accel_m_s2, cruise_speed_m_s
    caps = np.concatenate([[0.0], v * cornering.fraction(turn_angles_deg(points_en)), [0.0]])
    speeds = caps.copy()
    for i in range(1, len(speeds)):
        speeds[i] = min(speeds[i], math.sqrt(speeds[i - 1] ** 2 + 2.0 * a * lengths[i - 1]))
    for i in range(len(speeds) - 2, -1, -1):
        speeds[i] = min(speeds[i], math.sqrt(speeds[i + 1] ** 2 + 2.0 * a * lengths[i]))
    u, w = speeds[:-1], speeds[1:]
    peak = np.minimum(v, np.sqrt((2.0 * a * lengths + u * u + w * w) / 2.0))
    ramps_m = (2.0 * peak * peak - u * u - w * w) / (2.0 * a)
    cruise_s = np.where(peak > 0, np.maximum(lengths - ramps_m, 0.0) / np.where(peak > 0, peak, 1.0), 0.0)
    return float(((2.0 * peak - u - w) / a + cruise_s).sum())
