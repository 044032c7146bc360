"""The autopilot's low-battery failsafe: which level the remaining charge calls for, and when
to act (only on an escalation)."""

from __future__ import annotations

from enum import Enum

from sim.physics.battery import BatteryConfig


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
