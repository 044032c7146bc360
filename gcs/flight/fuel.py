"""A vehicle's fuel as the return trigger reads it: charge used and left, and what a metre of
cruise costs it in each direction now, from its battery reports (`FuelGauge`). Pure: fed values,
no MAVLink.

Charge is counted in mAh. Where the autopilot measures its current and counts the charge consumed
(ArduPilot's BATTERY_STATUS.current_consumed), that is the reading; where it reports only a
percentage (PX4 SIH: current -1, consumed 0), the used charge is the capacity times the
percentage gone. The capacity is the autopilot's own (BATT_CAPACITY, BAT1_CAPACITY), read before
the flight, else the profile's, so percentages and charges convert as the autopilot converts them.

What a metre costs is learned in level flight only. PX4 met this fault (its PR 22401: a long
fixed-wing climb at full throttle, averaged as cruise, cut the remaining-time estimate and sent
the plane home; ArduPlane SITL's take-off draws four times its cruise current) and ArduPilot's
plane-wind-fs example samples only after 30 s of flight: the launch and climb, the landing, and
the first `settle_s` seconds after levelling off (where a voltage-based percentage is still
recovering from the climb) are never averaged as cruise.

Wind makes a metre dearer one way than the other, and a copter's autopilot may not even report
it (ArduCopter's EKF estimates no wind without drag fusion: WIND says 0 while an 8 m/s wind holds
the copter to 2.2 m/s over the ground, at 4.6 times its calm cost per metre; docs/energy.md).
So the cost of a metre is learned as a function of the direction flown, from the charge itself:

    charge of a stretch = f(direction) * (a * metres + b * metres east + c * metres north + ...)

(a is the still-air cost, b, c and the second harmonic's d, e how much dearer a metre is one way
than the average, negative where it is cheaper; f is what the wind known does to a metre flown
that way: what the vehicle has made good over the ground that way where it has flown it,
`gcs.flight.heading_speeds`, else `planner.energy.wind_factor` of the wind known, 1 in still
air). The wind is the autopilot's (ArduPlane's WIND, PX4's WIND_COV), else the crew's, else the
one a multicopter shows by leaning into it in steady flight (`gcs.flight.lean_wind`), with its
uncertainty (`gcs.telemetry.wind.WindEstimate`). The coefficients are fitted by least squares over the
settled cruise since take-off, each stretch weighted by the inverse of its length (charge
variance grows with distance), starting from a prior that counts as `prior_weight_m` metres
already flown: a at the profile's still-air figure, the harmonics at zero. A
first noisy reading cannot move it far; a battery that drains faster than its profile says, or a
wind the autopilot does not report, shows within a few hundred metres of search legs in a few
directions; a direction never flown is priced near the profile. Once SHOWN_AFTER_M metres are
sampled, no metre is priced under what level flight has cost on average (the prior never talks a
failing pack down), and no direction under MIN_SHARE of the average."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike

from gcs.flight.heading_speeds import HeadingSpeeds
from gcs.telemetry.wind import WindEstimate
from planner.energy import Airframe, EnergyProfile, wind_factor

__all__ = ["FlightPhase", "FuelGauge", "LegCost", "MIN_SHARE", "PRIOR_WEIGHT_M", "SETTLE_S"]

#: Metres of cruise the profile's figure counts for against what the flight shows.
PRIOR_WEIGHT_M = 300.0

#: Seconds of level flight after the climb before cruise is sampled.
SETTLE_S = 10.0

#: Metres of level flight sampled before their average cost is trusted over the profile's prior.
SHOWN_AFTER_M = 200.0

#: No direction is priced under this share of the cost averaged over directions.
MIN_SHARE = 0.4


#: a, and the first and second harmonics' cosine and sine
TERMS = 5

#: Cruise metres are counted towards so many directions (5 degrees apart)
DIRECTIONS = 72
_DIRECTION_UNITS = np.array([(math.sin(2 * math.pi * k / DIRECTIONS), math.cos(2 * math.pi * k / DIRECTIONS))
                             for k in range(DIRECTIONS)])

#: unit steps (east, north) in 36 directions, to average a direction's cost over
_COMPASS = np.array([(math.sin(math.radians(d)), math.cos(math.radians(d))) for d in range(0, 360, 10)])


def _unit_terms(east: np.ndarray, north: np.ndarray) -> np.ndarray:
    """(1, cos, sin, cos 2, sin 2) of each direction (east[i], north[i]) not zero, one row each."""
    length = np.hypot(east, north)
    cos, sin = east / length, north / length
    return np.stack([np.ones_like(cos), cos, sin, cos * cos - sin * sin, 2.0 * cos * sin], axis=-1)


def _terms(east: float, north: float) -> np.ndarray:
    """The regressors of a straight stretch: its length times `_unit_terms` of its direction."""
    m = math.hypot(east, north)
    if m == 0:
        return np.zeros(TERMS)
    return m * _unit_terms(np.array([east]), np.array([north]))[0]


class FlightPhase(str, Enum):
    """Where a vehicle is in its flight, as far as its battery is concerned."""

    GROUND = "ground"
    LAUNCH = "launch"     # take-off and climb to the mission altitude
    CRUISE = "cruise"     # level flight along the plan (search or return)
    LANDING = "landing"   # descent at the airport


@dataclass(frozen=True, slots=True)
class LegCost:
    """A priced way: its ground metres and its charge (mAh)."""

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
        self.wind: WindEstimate | None = None
        self.headings = HeadingSpeeds(profile.cruise_speed_m_s)
        self.max_air_speed_m_s: float | None = None  # a multicopter's at its tilt limit, where its lean shows it
        self._cruise_by_direction = np.zeros(DIRECTIONS)  # cruise metres flown towards each of DIRECTIONS
        self._air_m = self._air_s = 0.0  # a plane's metres through the air and seconds, in steady cruise
        self.used_mah: float | None = None
        self.remaining_pct: float | None = None
        self.measures_current = False
        self.cruise_mah = 0.0
        self.cruise_m = 0.0          # ground metres of sampled cruise
        self.phase_mah: dict[FlightPhase, float] = dict.fromkeys(FlightPhase, 0.0)
        self.phase_m: dict[FlightPhase, float] = dict.fromkeys(FlightPhase, 0.0)
        self.used_at_launch: float | None = None
        self._stretches: list[tuple[np.ndarray, float]] = []  # (`_terms` of a sampled stretch, its mAh)
        self._summed = 0             # stretches in the sums below, each weighed in the wind `_summed_in`
        self._summed_in: tuple[tuple[float, float] | None, int, float | None] | None = None
        self._normal = np.zeros((TERMS, TERMS))  # the least squares' normal matrix, prior left out
        self._rhs = np.zeros(TERMS)  # and its right-hand side
        self._flown = np.zeros(TERMS)  # the sum of the stretches' weighed terms
        self._fit: np.ndarray | None = None
        self._fit_lift = 0.0
        self._rate: float | None = None  # `rate_mah_per_m` of the current fit
        self._level_since: float | None = None
        self._last_used: float | None = None
        self._last_phase: FlightPhase | None = None
        self._pure = True            # one phase (and settled cruise) since the last battery report
        self._pending = np.zeros(TERMS)  # the terms of the stretch flown since the last battery report
        self.version = 0             # counts the changes to what the estimates read

    # ---- inputs ---------------------------------------------------------------------------

    def set_capacity(self, capacity_mah: float) -> None:
        """The autopilot's battery capacity (its parameter), when it gives a positive one."""
        if math.isfinite(capacity_mah) and capacity_mah > 0:
            self.capacity_mah = float(capacity_mah)
            self.version += 1

    def set_wind(self, east_m_s: float, north_m_s: float, sigma_m_s: float = 0.0, source: str = "its autopilot"
                 ) -> None:
        """The wind known: the air moving towards (east, north), one standard deviation of each
        component, where it came from. A wind of 0 is no report (ArduCopter sends 0 when it
        estimates none)."""
        if math.isfinite(east_m_s) and math.isfinite(north_m_s) and (east_m_s or north_m_s):
            before, self.wind = self.wind_m_s, WindEstimate(float(east_m_s), float(north_m_s), sigma_m_s, source)
            if before != self.wind.vector:
                self._refit()

    def clear_wind(self) -> None:
        """Still air after all (a vehicle's own reading replacing an earlier one)."""
        self.wind = None
        self._refit()

    @property
    def wind_m_s(self) -> tuple[float, float] | None:
        """(east, north) m/s the air moves towards, as known; None in still air."""
        return None if self.wind is None else self.wind.vector

    def set_max_air_speed(self, speed_m_s: float) -> None:
        """The most air speed a multicopter has been seen to make (at its tilt limit, the most
        its lean shows): what the wind leaves it on a way it has not flown."""
        if math.isfinite(speed_m_s) and speed_m_s > (self.max_air_speed_m_s or 0.0) + 0.2:
            self.max_air_speed_m_s = speed_m_s
            if self.wind_m_s is not None:
                self._refit()

    def in_wind(self, wind_m_s: tuple[float, float]) -> FuelGauge:
        """This gauge as it would price a way in another wind (a copy: this one is unchanged)."""
        other = copy.copy(self)
        other.wind = replace(self.wind, east_m_s=wind_m_s[0], north_m_s=wind_m_s[1]) \
            if self.wind is not None and any(wind_m_s) else None
        other._fit = other._rate = None
        return other

    def steady(self, time_s: float, velocity_m_s: tuple[float, float], seconds: float, phase: FlightPhase) -> None:
        """`seconds` of steady flight at `velocity_m_s` (east, north) over the ground, ending at
        `time_s`: cruise teaches what the vehicle makes good in its direction."""
        if phase is FlightPhase.CRUISE and self._settled(time_s) and 0 < seconds < 5.0:
            version = self.headings.version
            if self.profile.airframe is Airframe.PLANE:
                self._true_air_speed(velocity_m_s, seconds)
            self.headings.add(*velocity_m_s, seconds)
            if self.headings.version != version:
                self._refit()

    def _true_air_speed(self, velocity_m_s: tuple[float, float], seconds: float) -> None:
        """A plane holds its air speed: its ground velocity less the wind known, averaged over its
        steady cruise, is the speed a still-air metre of its profile was flown at (ArduPlane SITL:
        23.4 m/s true at 22 indicated), against which each way's ground speed prices a metre."""
        wind = self.wind_m_s or (0.0, 0.0)
        self._air_m += math.hypot(velocity_m_s[0] - wind[0], velocity_m_s[1] - wind[1]) * seconds
        self._air_s += seconds
        self.headings.cruise_speed_m_s = self.max_air_speed_m_s = self._air_m / self._air_s

    def factor(self, east: ArrayLike, north: ArrayLike) -> float | np.ndarray:
        """What a metre flown in the direction (east, north), or in each of several, costs against
        a still-air one: what the vehicle made good that way where it flew it, else what the wind
        known does to it."""
        model = 1.0 if self.wind_m_s is None else wind_factor(self.profile, east, north, self.wind_m_s,
                                                               self.max_air_speed_m_s)
        return self.headings.factors(east, north, model) if self.headings.flown else model

    def moved(self, time_s: float, east_m: float, north_m: float, phase: FlightPhase) -> None:
        """A step of `(east_m, north_m)` over the ground, flown in `phase`, ending at `time_s`."""
        if phase is FlightPhase.CRUISE:
            if self._level_since is None:
                self._level_since = time_s
        else:
            self._level_since = None
        metres = math.hypot(east_m, north_m)
        self.phase_m[phase] += metres
        if phase is FlightPhase.CRUISE and metres > 0:
            direction = math.degrees(math.atan2(east_m, north_m)) % 360.0
            self._cruise_by_direction[round(direction / (360.0 / DIRECTIONS)) % DIRECTIONS] += metres
        if phase is not self._last_phase and self._last_phase is not None:
            self._pure = False
        self._last_phase = phase
        if not self._settled(time_s):
            self._pure = False
            return
        self._pending += _terms(east_m, north_m)

    def battery(self, time_s: float, phase: FlightPhase, consumed_mah: float | None,
                remaining_pct: float | None) -> None:
        """A battery report: the charge the autopilot counts as consumed (None when it measures
        no current) and its remaining percentage (None when unknown)."""
        if consumed_mah is not None and consumed_mah >= 0:
            self.measures_current = True
            used = float(consumed_mah)
        elif remaining_pct is not None and not self.measures_current:
            used = self.capacity_mah * (100.0 - remaining_pct) / 100.0
        else:
            return
        if remaining_pct is not None:
            self.remaining_pct = float(remaining_pct)
        elif self.measures_current:
            self.remaining_pct = 100.0 * (1.0 - used / self.capacity_mah)
        if phase is not FlightPhase.GROUND and self.used_at_launch is None:
            self.used_at_launch = self.used_mah if self.used_mah is not None else used
        if self._last_used is not None:
            spent = used - self._last_used
            self.phase_mah[phase] += spent
            metres = self._pending[0]
            if self._pure and phase is FlightPhase.CRUISE and self._settled(time_s) and metres > 0:
                self.cruise_mah += spent
                self.cruise_m += metres
                self._stretches.append((self._pending, spent))
                self._refit()
        self.used_mah = used
        self._last_used = used
        self._pure = True
        self._pending = np.zeros(TERMS)
        self.version += 1

    @property
    def cruise_priced_m(self) -> float:
        """The cruise metres flown, each weighed by what a metre that way costs as now known (the
        ground speed made good that way, else the wind known)."""
        flown = self._cruise_by_direction
        if not flown.any():
            return 0.0
        factors = np.broadcast_to(self.factor(_DIRECTION_UNITS[:, 0], _DIRECTION_UNITS[:, 1]), flown.shape)
        return float(flown @ factors)

    def _settled(self, time_s: float) -> bool:
        return self._level_since is not None and time_s - self._level_since >= self.settle_s

    # ---- estimates ------------------------------------------------------------------------

    def _refit(self) -> None:
        self._fit = self._rate = None
        self.version += 1

    def _sum_stretches(self) -> None:
        """Add the stretches sampled since the last fit to the normal equations, or sum them all
        again when the wind known has changed (it weighs every stretch): a fit costs the same
        late in a long flight as early."""
        weighed_in = (self.wind_m_s, self.headings.version, self.max_air_speed_m_s)
        if self._summed_in != weighed_in:
            self._summed, self._summed_in = 0, weighed_in
            self._normal, self._rhs, self._flown = np.zeros((TERMS, TERMS)), np.zeros(TERMS), np.zeros(TERMS)
        new = self._stretches[self._summed:]
        if not new:
            return
        terms = np.array([t for t, _ in new]).reshape(-1, TERMS)
        mah = np.array([m for _, m in new])
        xs = terms * np.reshape(self.factor(terms[:, 1], terms[:, 2]), (-1, 1))
        weighed = xs / terms[:, :1]
        self._normal += weighed.T @ xs
        self._rhs += weighed.T @ mah
        self._flown += xs.sum(axis=0)
        self._summed = len(self._stretches)

    @property
    def fit(self) -> np.ndarray:
        """(a, b, c, d, e) of the module docstring, in mAh per metre."""
        if self._fit is None:
            weight = np.diag([self.prior_weight_m] + [2.0 * self.prior_weight_m] * (TERMS - 1))
            prior = np.array([self.profile.cruise_mah_per_m, 0.0, 0.0, 0.0, 0.0])
            self._sum_stretches()
            self._fit = np.linalg.solve(self._normal + weight, self._rhs + weight @ prior)
            shown = self.shown_mah_per_m
            self._fit_lift = 0.0
            if shown is not None:
                self._fit_lift = max(0.0, shown - float(self._flown @ self._fit) / self.cruise_m)
        return self._fit

    @property
    def shown_mah_per_m(self) -> float | None:
        """What level flight has cost per metre on average, once SHOWN_AFTER_M have been sampled."""
        return self.cruise_mah / self.cruise_m if self.cruise_m >= SHOWN_AFTER_M else None

    @property
    def _lift(self) -> float:
        """How far the fit, over the stretches sampled, lies under what they cost (0 when it
        does not, or before SHOWN_AFTER_M are sampled): the prior's pull, taken back."""
        return self._fit_lift if self.fit is not None else 0.0

    @property
    def still_air_mah_per_m(self) -> float:
        """Charge per metre of level cruise in still air: the fit's a, lifted as `rate_mah_per_m` is."""
        return max(float(self.fit[0]) + self._lift, 1e-9)

    @property
    def rate_mah_per_m(self) -> float:
        """Charge per metre of cruise in the wind known, averaged over directions: the fit's, never
        under what level flight has shown (a pack draining faster than its profile says is priced
        as it drains, not pulled back towards the profile)."""
        if self.wind_m_s is None and not self.headings.flown:
            return self.still_air_mah_per_m
        if self._rate is None:
            self._rate = max(float(np.mean(self._rates_along(_COMPASS[:, 0], _COMPASS[:, 1]))), 1e-9)
        return self._rate

    def _rates_along(self, east: np.ndarray, north: np.ndarray) -> np.ndarray:
        """The fit's charge per metre in each direction (none zero) in the wind known, lifted."""
        return self.factor(east, north) * (_unit_terms(east, north) @ self.fit) + self._lift

    def rate_along(self, east: float, north: float) -> float:
        """Charge per metre of cruise in the direction (east, north), lifted as the average is."""
        return self.way_cost([(east, north)]).mah / math.hypot(east, north) if (east or north) \
            else self.rate_mah_per_m

    @property
    def remaining_mah(self) -> float | None:
        if self.used_mah is None:
            return None
        return self.capacity_mah - self.used_mah

    def reserve_mah(self, reserve_pct: float) -> float:
        return self.capacity_mah * reserve_pct / 100.0

    def way_cost(self, legs_m: list[tuple[float, float]]) -> LegCost:
        """The charge of flying `legs_m` ((east, north) metres each) at the rates learned, no
        direction under MIN_SHARE of the average."""
        return self.way_costs([legs_m])[0]

    def way_costs(self, ways: list[list[tuple[float, float]]]) -> list[LegCost]:
        """`way_cost` of each of `ways`, priced together."""
        counts = [len(way) for way in ways]
        legs = np.asarray([leg for way in ways for leg in way], dtype=float).reshape(-1, 2)
        length = np.hypot(legs[:, 0], legs[:, 1])
        moving = length > 0
        rates = np.zeros(len(legs))
        if moving.any():
            rates[moving] = np.maximum(MIN_SHARE * self.rate_mah_per_m,
                                       self._rates_along(legs[moving, 0], legs[moving, 1]))
        ends = np.cumsum(counts)[:-1]
        return [LegCost(float(m.sum()), float(c.sum()))
                for m, c in zip(np.split(length, ends), np.split(length * rates, ends))]

    def cruise_m_for(self, mah: float) -> float:
        """Metres of cruise `mah` pays for at the rate averaged over directions."""
        return max(0.0, mah) / self.rate_mah_per_m
