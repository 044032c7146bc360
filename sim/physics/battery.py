"""A battery that drains with flight time, and the autopilot's low-battery failsafe decision."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

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


class FailsafeLevel(Enum):
    NONE = 0
    LOW = 1  # return to launch
    CRITICAL = 2  # land now
    EMERGENCY = 3  # PX4's last level (BAT_EMERGEN_THR)


def failsafe_level(remaining_pct: float, config: BatteryConfig) -> FailsafeLevel:
    """Which failsafe the remaining charge calls for (ArduPilot's BATT_LOW / BATT_CRT)."""
    if remaining_pct <= config.critical_pct:
        return FailsafeLevel.CRITICAL
    if remaining_pct <= config.low_pct:
        return FailsafeLevel.LOW
    return FailsafeLevel.NONE


def failsafe_to_trigger(current: FailsafeLevel, reached: FailsafeLevel) -> FailsafeLevel | None:
    """The failsafe to act on now: only escalations trigger, never a repeat or a recovery."""
    return reached if reached.value > current.value else None


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
