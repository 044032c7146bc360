"""A battery that drains with flight time, and the autopilot's low-battery failsafe decision."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryConfig:
    """Capacity as flight endurance; drain on the ground is a fraction of that in flight."""

    endurance_s: float = 1200.0
    ground_drain_fraction: float = 0.05
    cells: int = 4
    flight_current_a: float = 20.0
    ground_current_a: float = 1.0
    low_pct: float = 20.0
    critical_pct: float = 5.0

    @property
    def capacity_mah(self) -> float:
        return self.flight_current_a * self.endurance_s / 3.6


class FailsafeLevel(Enum):
    NONE = 0
    LOW = 1  # return to launch
    CRITICAL = 2  # land now


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
    """Charge state; `drain_multiplier` speeds draining and `fail()` empties it at once."""

    def __init__(self, config: BatteryConfig) -> None:
        self.config = config
        self.remaining_fraction = 1.0
        self.drain_multiplier = 1.0
        self.current_a = 0.0
        self.consumed_mah = 0.0

    def step(self, dt_s: float, *, flying: bool) -> None:
        cfg = self.config
        rate = 1.0 if flying else cfg.ground_drain_fraction
        used = self.drain_multiplier * rate * dt_s / cfg.endurance_s
        self.remaining_fraction = max(0.0, self.remaining_fraction - used)
        self.current_a = (cfg.flight_current_a if flying else cfg.ground_current_a) * self.drain_multiplier
        self.consumed_mah = (1.0 - self.remaining_fraction) * cfg.capacity_mah

    def fail(self) -> None:
        """Immediate battery failure: no charge left."""
        self.remaining_fraction = 0.0
        self.consumed_mah = self.config.capacity_mah

    @property
    def remaining_pct(self) -> float:
        return 100.0 * self.remaining_fraction

    @property
    def voltage_v(self) -> float:
        """Open-circuit LiPo voltage, linear from 3.3 V (empty) to 4.2 V (full) per cell."""
        return self.config.cells * (3.3 + 0.9 * self.remaining_fraction)

    @property
    def time_remaining_s(self) -> float:
        return self.remaining_fraction * self.config.endurance_s / max(self.drain_multiplier, 1e-9)
