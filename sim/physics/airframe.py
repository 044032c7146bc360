"""One simulated vehicle's body: where it stands, how it moves, its battery and downward sensor.

The autopilot (`sim.autopilot.vehicle.SimVehicle`) decides where to go; the airframe goes there
within its limits. Each step the autopilot hands it a `Goal` (a horizontal target or none, an
altitude, whether it is landing) and the airframe moves by the unicycle of
`sim.physics.kinematics`. The battery drains with the current the autopilot's state calls for,
and the sensor reads the ground under the airframe. Nothing here knows MAVLink, modes or
missions: positions are metres east and north in the fleet's local frame
(`planner.georef.LocalFrame`), altitudes metres above home.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.georef import LocalFrame
from sim.physics.battery import Battery, SihBattery
from sim.physics.kinematics import KinematicLimits, KinematicState, step_toward
from sim.physics.sensor import DownwardSensor, Observation


@dataclass(frozen=True, slots=True)
class HomePose:
    """Where a vehicle starts: geodetic position, ground altitude (AMSL) and heading."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    heading_deg: float = 0.0


@dataclass(slots=True)
class Goal:
    """Where the airframe is flown this step: toward `target_en` (None: hold where it is; a
    plane circles) at `alt_m` above home; `landing`: descending to touch down; `climb_rate_m_s`:
    a climb rate other than the limits' (ArduPlane's take-off climbs twice as fast);
    `pass_fraction`: of its speed, what an accelerating copter keeps as it passes the target (a
    waypoint with a turn after it, `sim.physics.kinematics.corner_fraction`; 0: it stops there)."""

    target_en: tuple[float, float] | None
    alt_m: float
    landing: bool = False
    climb_rate_m_s: float | None = None
    pass_fraction: float = 0.0


class Airframe:
    """The body in the local frame: its motion state (`kin`), limits, battery and sensor."""

    def __init__(
        self,
        home: HomePose,
        frame: LocalFrame,
        limits: KinematicLimits,
        battery: Battery | SihBattery,
        sensor: DownwardSensor,
    ) -> None:
        self.frame = frame
        self.limits = limits
        east, north = frame.geodetic2en(home.lat_deg, home.lon_deg)
        self.kin = KinematicState(east, north, 0.0, math.radians(home.heading_deg))
        self.battery = battery
        self.sensor = sensor

    @property
    def position_en(self) -> tuple[float, float]:
        return (self.kin.east_m, self.kin.north_m)

    @property
    def lat_lon_deg(self) -> tuple[float, float]:
        return self.frame.en2geodetic(self.kin.east_m, self.kin.north_m)

    @property
    def heading_deg(self) -> float:
        return math.degrees(self.kin.heading_rad) % 360.0

    def step(self, dt_s: float, goal: Goal, speed_m_s: float | None = None) -> None:
        """Move for dt toward the goal: turn-rate limited, at cruise speed (or `speed_m_s`),
        climbing or descending at the limits' rates."""
        step_toward(self.kin, self.limits, dt_s, target_en=goal.target_en, target_alt_m=goal.alt_m,
                    speed_m_s=speed_m_s, climb_rate_m_s=goal.climb_rate_m_s, pass_fraction=goal.pass_fraction)

    def stop(self) -> None:
        """Standing still (on the ground, or disarmed)."""
        self.kin.speed_m_s = self.kin.climb_m_s = self.kin.turn_rate_rad_s = 0.0

    def touch_down(self) -> float:
        """On the ground, standing still; the vertical speed it hit the ground with (m/s, down)."""
        descent = -self.kin.climb_m_s
        self.kin.alt_m = 0.0
        self.stop()
        return descent

    def sense(self, time_s: float) -> Observation | None:
        """The downward sensor's reading at the airframe's position now, if it has one."""
        return self.sensor.update(self.kin.east_m, self.kin.north_m, self.kin.alt_m, time_s)
