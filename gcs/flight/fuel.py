"""A vehicle's fuel as the return trigger reads it: charge used and left, and what a metre of
cruise costs it now, from its battery reports (`FuelGauge`). Pure: fed values, no MAVLink.

Charge is counted in mAh. Where the autopilot reports the charge it has consumed (ArduPilot's
BATTERY_STATUS.current_consumed, integrated from its current sensor), that is the reading; where
it reports only a percentage (PX4 SITL, whose percentage comes from the voltage), the used charge
is the capacity times the percentage gone. The capacity is the autopilot's own (BATT_CAPACITY,
BAT1_CAPACITY), read before the flight, else the profile's, so percentages and charges convert
the way the autopilot converts them.

What a metre costs is learned in level flight only. PX4 met this fault (its PR 22401: a long
fixed-wing climb at full throttle, averaged as cruise, cut the remaining-time estimate and sent
the plane home) and ArduPilot's plane-wind-fs example samples only after 30 s of flight: the
launch and climb, the landing, and the first `settle_s` seconds after levelling off (where a
voltage-based percentage is still recovering from the climb's sag) are never averaged as cruise.
The estimate starts from the vehicle's profile and moves towards what level flight shows as
evidence accrues: the profile counts as `prior_weight_m` metres already flown at its figure,

    rate = (profile rate * prior_weight_m + charge used in cruise) / (prior_weight_m + cruise metres)

with each cruise metre weighted by what the wind made it cost (`planner.energy.wind_factor`), so
the rate is a still-air figure and a leg home into the wind is priced at its own cost. A first
noisy reading cannot move it far, and a battery that drains faster than its profile says shows
within a few hundred metres of cruise."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

from planner.energy import EnergyProfile, wind_factor

__all__ = ["FlightPhase", "FuelGauge", "PRIOR_WEIGHT_M", "SETTLE_S"]

#: Metres of cruise the profile's figure counts for against what the flight shows.
PRIOR_WEIGHT_M = 300.0

#: Seconds of level flight after the climb before cruise is sampled.
SETTLE_S = 10.0


class FlightPhase(str, Enum):
    """Where a vehicle is in its flight, as far as its battery is concerned."""

    GROUND = "ground"
    LAUNCH = "launch"     # take-off and climb to the mission altitude
    CRUISE = "cruise"     # level flight along the plan (search or return)
    LANDING = "landing"   # descent at the airport


@dataclass(frozen=True, slots=True)
class LegCost:
    """A priced way: its ground metres and its charge (mAh) in the wind."""

    metres: float
    mah: float


class FuelGauge:
    """One vehicle's charge and cruise cost (see the module docstring)."""

    def __init__(self, profile: EnergyProfile, *, prior_weight_m: float = PRIOR_WEIGHT_M,
                 settle_s: float = SETTLE_S) -> None:
        self.profile = profile
        self.capacity_mah = profile.capacity_mah
        self.prior_weight_m = prior_weight_m
        self.settle_s = settle_s
        self.wind_m_s: tuple[float, float] = (0.0, 0.0)
        self.used_mah: float | None = None
        self.remaining_pct: float | None = None
        self.reports_consumed = False
        self.cruise_mah = 0.0
        self.cruise_m = 0.0          # ground metres of sampled cruise
        self.cruise_still_m = 0.0    # the same weighted by their wind factors
        self.phase_mah: dict[FlightPhase, float] = dict.fromkeys(FlightPhase, 0.0)
        self.phase_m: dict[FlightPhase, float] = dict.fromkeys(FlightPhase, 0.0)
        self.used_at_launch: float | None = None
        self._level_since: float | None = None
        self._last_time: float | None = None
        self._last_used: float | None = None
        self._last_phase: FlightPhase | None = None
        self._pure = True            # one phase (and settled cruise) since the last battery report
        self._pending_m = 0.0
        self._pending_still_m = 0.0

    # ---- inputs ---------------------------------------------------------------------------

    def set_capacity(self, capacity_mah: float) -> None:
        """The autopilot's battery capacity (its parameter), when it gives a positive one."""
        if math.isfinite(capacity_mah) and capacity_mah > 0:
            self.capacity_mah = float(capacity_mah)

    def set_wind(self, east_m_s: float, north_m_s: float) -> None:
        """The wind the autopilot estimates: the air moving towards (east, north)."""
        if math.isfinite(east_m_s) and math.isfinite(north_m_s):
            self.wind_m_s = (float(east_m_s), float(north_m_s))

    def moved(self, time_s: float, east_m: float, north_m: float, phase: FlightPhase) -> None:
        """A step of `(east_m, north_m)` over the ground, flown in `phase`, ending at `time_s`."""
        if phase is FlightPhase.CRUISE:
            if self._level_since is None:
                self._level_since = time_s
        else:
            self._level_since = None
        metres = math.hypot(east_m, north_m)
        self.phase_m[phase] += metres
        if phase is not self._last_phase and self._last_phase is not None:
            self._pure = False
        self._last_phase = phase
        if not self._settled(time_s):
            self._pure = False
            return
        self._pending_m += metres
        self._pending_still_m += metres * wind_factor(self.profile, *self.wind_m_s, east_m, north_m)

    def battery(self, time_s: float, phase: FlightPhase, consumed_mah: float | None,
                remaining_pct: float | None) -> None:
        """A battery report: the charge the autopilot has consumed (None when it does not count
        it) and its remaining percentage (None when unknown)."""
        if consumed_mah is not None and consumed_mah >= 0:
            self.reports_consumed = True
            used = float(consumed_mah)
        elif remaining_pct is not None and not self.reports_consumed:
            used = self.capacity_mah * (100.0 - remaining_pct) / 100.0
        else:
            return
        if remaining_pct is not None:
            self.remaining_pct = float(remaining_pct)
        elif self.reports_consumed:
            self.remaining_pct = 100.0 * (1.0 - used / self.capacity_mah)
        if phase is not FlightPhase.GROUND and self.used_at_launch is None:
            self.used_at_launch = self.used_mah if self.used_mah is not None else used
        if self._last_used is not None:
            spent = used - self._last_used
            self.phase_mah[phase] += spent
            if self._pure and phase is FlightPhase.CRUISE and self._settled(time_s) and self._pending_m > 0:
                self.cruise_mah += spent
                self.cruise_m += self._pending_m
                self.cruise_still_m += self._pending_still_m
        self.used_mah = used
        self._last_used = used
        self._last_time = time_s
        self._pure = True
        self._pending_m = 0.0
        self._pending_still_m = 0.0

    def _settled(self, time_s: float) -> bool:
        return self._level_since is not None and time_s - self._level_since >= self.settle_s

    # ---- estimates ------------------------------------------------------------------------

    @property
    def rate_mah_per_m(self) -> float:
        """Charge per still-air metre of cruise: the profile's, moved by the cruise sampled."""
        w = self.prior_weight_m
        return (self.profile.cruise_mah_per_m * w + self.cruise_mah) / (w + self.cruise_still_m)

    @property
    def remaining_mah(self) -> float | None:
        if self.used_mah is None:
            return None
        return self.capacity_mah - self.used_mah

    def reserve_mah(self, reserve_pct: float) -> float:
        return self.capacity_mah * reserve_pct / 100.0

    def way_cost(self, legs_m: list[tuple[float, float]]) -> LegCost:
        """The charge of flying `legs_m` ((east, north) metres each) at the current rate in the
        current wind."""
        metres = mah = 0.0
        rate = self.rate_mah_per_m
        for east, north in legs_m:
            length = math.hypot(east, north)
            metres += length
            mah += rate * length * wind_factor(self.profile, *self.wind_m_s, east, north)
        return LegCost(metres, mah)

    def cruise_m_for(self, mah: float) -> float:
        """Still-air metres of cruise `mah` pays for at the current rate."""
        return max(0.0, mah) / self.rate_mah_per_m
