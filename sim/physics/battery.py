"""Batteries and what the airframe draws from them: ArduPilot SITL's simulated pack (`Battery`,
the current by flight phase of `CopterDraw` or `PlaneDraw`) and PX4 SIH's (`SihBattery`, linear
in armed time). The figures are ArduCopter's and ArduPlane's SITL as measured by
`benchmarks/measure_energy.py` (docs/energy.md). What an autopilot does about a low battery is
`sim.autopilot.failsafe`."""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass

DEFAULT_ENDURANCE_S = 1200.0


@dataclass(frozen=True, slots=True)
class Load:
    """What the airframe asks of its battery this step: `armed` (ArduPilot draws nothing
    disarmed), `flying`, `launching` (on the ground, motors spooling or the plane rolling for
    take-off), its air speed and its climb rate (m/s, negative descending)."""

    armed: bool
    flying: bool = False
    launching: bool = False
    airspeed_m_s: float = 0.0
    climb_m_s: float = 0.0


def _interp(x: float, table: tuple[tuple[float, float], ...]) -> float:
    xs = [p[0] for p in table]
    i = bisect_right(xs, x)
    if i == 0:
        return table[0][1]
    if i == len(table):
        return table[-1][1]
    (x0, y0), (x1, y1) = table[i - 1], table[i]
    return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


@dataclass(frozen=True, slots=True, kw_only=True)
class CopterDraw:
    """ArduCopter SITL's quad (copter.parm): no current armed on the ground; in the air the hover
    current rising with air speed (`by_airspeed`: m/s, A), plus `climb_a_per_m_s` per m/s climbed
    and less `descent_a_per_m_s` per m/s descended; spooling up for take-off it draws the climb's
    current. The voltage does not sag (SIM_BATT_VOLTAGE throughout); VFR_HUD's throttle is the
    current over `amps_per_throttle_pct`."""

    by_airspeed: tuple[tuple[float, float], ...] = ((0.0, 28.1), (5.0, 28.3), (10.0, 30.3), (10.3, 30.6), (11.3, 31.8))
    climb_a_per_m_s: float = 0.97
    descent_a_per_m_s: float = 0.8
    climb_m_s: float = 2.5
    amps_per_throttle_pct: float = 0.78

    def current_a(self, load: Load) -> float:
        if not load.armed:
            return 0.0
        if load.launching:
            return _interp(0.0, self.by_airspeed) + self.climb_a_per_m_s * self.climb_m_s
        if not load.flying:
            return 0.0
        rate = self.climb_a_per_m_s if load.climb_m_s > 0 else self.descent_a_per_m_s
        return _interp(load.airspeed_m_s, self.by_airspeed) + rate * load.climb_m_s

    def throttle(self, load: Load) -> float:
        """0..1, as VFR_HUD reports it."""
        return min(1.0, self.current_a(load) / self.amps_per_throttle_pct / 100.0)

    def sag_v(self, load: Load) -> float:
        return 0.0

    def cruise_current_a(self, airspeed_m_s: float) -> float:
        return _interp(airspeed_m_s, self.by_airspeed)


@dataclass(frozen=True, slots=True, kw_only=True)
class PlaneDraw:
    """ArduPlane SITL (plane.parm): throttle by phase (full for the take-off roll and any climb
    faster than `climbing_m_s`, `cruise_throttle` level at AIRSPEED_CRUISE, `glide_throttle`
    descending, none on the ground or gliding steeper than `idle_below_m_s`), the current
    `full_throttle_a` times the throttle squared, and the voltage `sag_v_at_full` times the
    throttle under SIM_BATT_VOLTAGE."""

    full_throttle_a: float = 47.2
    cruise_throttle: float = 0.49
    glide_throttle: float = 0.23
    climbing_m_s: float = 1.0
    idle_below_m_s: float = -2.5
    sag_v_at_full: float = 0.7

    def throttle(self, load: Load) -> float:
        if not load.armed:
            return 0.0
        if load.launching:
            return 1.0
        if not load.flying:
            return 0.0
        if load.climb_m_s > self.climbing_m_s:
            return 1.0
        if load.climb_m_s < self.idle_below_m_s:
            return 0.0
        if load.climb_m_s < -0.3:
            return self.glide_throttle
        return self.cruise_throttle

    def current_a(self, load: Load) -> float:
        return self.full_throttle_a * self.throttle(load) ** 2

    def sag_v(self, load: Load) -> float:
        return self.sag_v_at_full * self.throttle(load)

    def cruise_current_a(self, airspeed_m_s: float) -> float:
        return self.full_throttle_a * self.cruise_throttle ** 2


Draw = CopterDraw | PlaneDraw


def draw_for(vehicle_type: str) -> Draw:
    """The measured draw of ArduPilot SITL's `copter` or `plane`."""
    return PlaneDraw() if vehicle_type == "plane" else CopterDraw()


@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryConfig:
    """A pack's capacity: `capacity_mah` (ArduPilot SITL's BATT_CAPACITY is 3300), else flight
    endurance (None: 1200 s) at the vehicle's cruise current (`Battery` is told it);
    `low_pct`, `critical_pct`: the ardupilot profile's failsafe levels. The px4 profile's
    battery is SIH's: an endurance given is its SIM_BAT_DRAIN, with SIM_BAT_MIN_PCT 0 (None:
    PX4's 60 s, down to 50 %), and the rest does not apply (PX4's BAT_*_THR)."""

    endurance_s: float | None = None
    capacity_mah: float | None = None
    low_pct: float = 20.0
    critical_pct: float = 5.0

    @property
    def flight_endurance_s(self) -> float:
        return DEFAULT_ENDURANCE_S if self.endurance_s is None else self.endurance_s

    def capacity_for(self, cruise_current_a: float) -> float:
        """mAh: `capacity_mah`, or the endurance at that current."""
        if self.capacity_mah is not None:
            return self.capacity_mah
        return cruise_current_a * self.flight_endurance_s / 3.6


class Battery:
    """Charge state: consumed charge and energy integrated from the current the `draw` gives for
    each step's `Load`, so a capacity changed mid-flight (ArduPilot's BATT_CAPACITY) changes the
    remaining charge at once. `drain_multiplier` scales the current and `fail()` empties the
    battery. `cruise_current_a` sets the capacity an endurance stands for."""

    def __init__(self, config: BatteryConfig, draw: Draw, cruise_current_a: float) -> None:
        self.config = config
        self.draw = draw
        self.capacity_mah = config.capacity_for(cruise_current_a)
        self.cruise_current_a = cruise_current_a
        self.drain_multiplier = 1.0
        self.current_a = 0.0
        self.consumed_mah = 0.0
        self.energy_j = 0.0

    def step(self, dt_s: float, load: Load, voltage_v: float) -> None:
        self.current_a = self.draw.current_a(load) * self.drain_multiplier
        self.consumed_mah += self.current_a * dt_s / 3.6
        self.energy_j += self.current_a * voltage_v * dt_s

    def fail(self) -> None:
        """Immediate battery failure: no charge left."""
        self.consumed_mah = max(self.consumed_mah, self.capacity_mah)

    @property
    def remaining_fraction(self) -> float:
        if self.capacity_mah <= 0:
            return 0.0
        return min(1.0, max(0.0, 1.0 - self.consumed_mah / self.capacity_mah))

    @property
    def remaining_mah(self) -> float:
        return max(0.0, self.capacity_mah - self.consumed_mah)

    @property
    def remaining_pct(self) -> float:
        return 100.0 * self.remaining_fraction


class SihBattery:
    """PX4 SIH's battery (px4 profile): a state of charge `charge` (1 full) that falls linearly,
    emptying in `drain_s` seconds (SIM_BAT_DRAIN) times `drain_multiplier`, down to a floor
    (SIM_BAT_MIN_PCT), and is full again when refilled. `fail()` empties it for good. The voltage
    and remaining charge PX4 reports from it are the autopilot's (`sim.autopilot.px4`)."""

    def __init__(self) -> None:
        self.charge = 1.0
        self.failed = False
        self.drain_multiplier = 1.0

    def step(self, dt_s: float, *, drain_s: float, floor_fraction: float) -> None:
        floor = 0.0 if self.failed else floor_fraction
        rate = self.drain_multiplier / max(drain_s, 1e-3)
        self.charge = max(self.charge - rate * dt_s, floor)

    def fail(self) -> None:
        self.failed = True
        self.charge = 0.0

    def refill(self) -> None:
        """Full again (SIH refills its battery when the vehicle disarms), unless it failed."""
        if not self.failed:
            self.charge = 1.0
