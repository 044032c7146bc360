"""Batteries that drain with flight time: ArduPilot SITL's simulated pack (`Battery`) and PX4
SIH's (`SihBattery`). What an autopilot does about a low battery is `sim.autopilot.failsafe`."""

from __future__ import annotations

from dataclasses import dataclass

DEFAULT_ENDURANCE_S = 1200.0


@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryConfig:
    """Capacity as flight endurance at `flight_current_a` (None: 1200 s); on the ground
    (powered) the current is `ground_drain_fraction` of that. The px4 profile's battery is
    SIH's: an endurance given is its SIM_BAT_DRAIN (None: PX4's 60 s), and `low_pct`,
    `critical_pct`, `ground_drain_fraction`, `flight_current_a` do not apply (PX4's BAT_*_THR)."""

    endurance_s: float | None = None
    ground_drain_fraction: float = 0.05
    cells: int = 4
    flight_current_a: float = 20.0
    low_pct: float = 20.0
    critical_pct: float = 5.0

    @property
    def flight_endurance_s(self) -> float:
        return DEFAULT_ENDURANCE_S if self.endurance_s is None else self.endurance_s

    @property
    def capacity_mah(self) -> float:
        return self.flight_current_a * self.flight_endurance_s / 3.6


class Battery:
    """Charge state: consumed charge is integrated from the current, so a capacity changed
    mid-flight (ArduPilot's BATT_CAPACITY) changes the remaining charge at once.
    `drain_multiplier` scales the current and `fail()` empties the battery."""

    def __init__(self, config: BatteryConfig) -> None:
        self.config = config
        self.capacity_mah = config.capacity_mah
        self.drain_multiplier = 1.0
        self.current_a = 0.0
        self.consumed_mah = 0.0
        self.energy_j = 0.0

    def step(self, dt_s: float, *, flying: bool, powered: bool = True, voltage_v: float | None = None) -> None:
        """`powered` False: no current at all (ArduPilot draws none while disarmed)."""
        cfg = self.config
        if not powered:
            self.current_a = 0.0
            return
        rate = 1.0 if flying else cfg.ground_drain_fraction
        self.current_a = cfg.flight_current_a * rate * self.drain_multiplier
        self.consumed_mah += self.current_a * dt_s / 3.6
        self.energy_j += self.current_a * (self.voltage_v if voltage_v is None else voltage_v) * dt_s

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

    @property
    def voltage_v(self) -> float:
        """Open-circuit LiPo voltage, linear from 3.3 V (empty) to 4.2 V (full) per cell."""
        return self.config.cells * (3.3 + 0.9 * self.remaining_fraction)

    @property
    def time_remaining_s(self) -> float:
        return self.remaining_fraction * self.config.flight_endurance_s / max(self.drain_multiplier, 1e-9)


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
