"""One vehicle's energy as the station follows it (`VehicleEnergy`): its fuel gauge and the
phase of flight its battery is read in, the fuel-based return trigger's state, what coming home
costs beyond the way, the charge its plan needs before launch (`PlanCharge`), and the account of
its energy when it is down (`EnergyAccount`). Each vehicle's flight
(`gcs.flight.vehicle_flight.VehicleFlight`) owns one.

The trigger itself is pure (`gcs.flight.return_trigger`); this object keeps what it needs
between ticks."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from gcs.flight.fuel import FlightPhase, FuelGauge
from gcs.flight.lean_wind import MAX_ACCELERATION_M_S2, LeanWind, thrust_lean
from gcs.flight.return_trigger import FuelDecision, confirmed, fuel_decision
from gcs.flight.vehicle_track import Legs, PlanTrack
from gcs.links import mavlink
from gcs.plans.plan_folder import UavTask
from gcs.telemetry.status import Stage, VehicleStatus, ground_distance_m
from gcs.telemetry.wind import CREW_SIGMA_M_S, WindEstimate, wind_from_message
from planner.energy import Airframe, EnergyProfile

__all__ = ["EnergyAccount", "PlanCharge", "VehicleEnergy"]

MAVMessage = mavlink.MAVLink_message

#: Vehicle seconds a return is expected to hold the vehicle while its way home is sent, until a
#: return of the flight has shown how long (`gcs.flight.controller`: the longest seen).
HOLD_S = 3.0
#: The return trigger evaluates again once the vehicle is this far from where it last did, or its
#: charge, fit, pose or orders changed: positions arrive every metre or so, each evaluation prices
#: every look-ahead pose's way home, and ten metres of a leg is well inside the reserve.
REEVALUATE_M = 10.0

#: A vehicle's launch is over once it is within this share of its mission altitude (the fuel gauge
#: waits a few seconds more before it samples cruise); on its way home, a vehicle descending faster
#: than LEVEL_CLIMB_M_S below that is landing.
LEVEL_SHARE = 0.9
LEVEL_CLIMB_M_S = 0.7

#: A wind estimate is said again when it moves this far (m/s, as a vector).
WIND_SAID_CHANGE_M_S = 2.0

#: A vehicle's acceleration is its velocity's change over at least this many seconds
STEADY_BASELINE_S = 1.0

#: A multicopter slower than this share of its cruise speed in steady flight is held back by the
#: wind only where its lean is at its limit: this share of the most it has leant (else it is on a
#: leg too short to reach its speed, and what it makes there is the profile's cornering; one
#: whose lean is not read counts only at its cruise speed)
CRUISE_SHARE = 0.9
TILT_LIMIT_SHARE = 0.9


@dataclass(frozen=True, slots=True)
class EnergyAccount:
    """A landed vehicle's energy: what its profile predicted at launch for the flight it flew
    (`predicted_mah`), what it used from launch to touch-down (`used_mah`), the cruise metres
    flown, and the battery it landed with."""

    predicted_mah: float
    used_mah: float
    cruise_m: float
    landed_pct: float | None

    @property
    def error(self) -> float:
        """(used - predicted) / used."""
        return (self.used_mah - self.predicted_mah) / self.used_mah if self.used_mah > 0 else 0.0

    def line(self) -> str:
        """The account, for the operator."""
        return (f"energy: used {self.used_mah:.0f} mAh from launch to touch-down; its profile predicted "
                f"{self.predicted_mah:.0f} mAh for the {self.cruise_m:.0f} m it cruised ({self.error:+.1%})")


@dataclass(frozen=True, slots=True)
class PlanCharge:
    """Before launch: the charge reported (`have_mah`) against what the plan needs (`need_mah`:
    the launch, the mission path, the landing and the reserve, at the profile's prices, a metre
    at `mah_per_m`), and the metres of the plan the charge above the reserve and those ends pays
    for (`covers_m`)."""

    have_mah: float
    need_mah: float
    covers_m: float
    mah_per_m: float  # a metre of the plan, in the wind known

    @property
    def enough(self) -> bool:
        return self.have_mah >= self.need_mah


def _step_m(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """(east, north) metres from lat/lon `a` to `b`, two telemetry samples apart (equirectangular:
    exact to millimetres over such a step, and a thousand times cheaper than a projection)."""
    k = math.pi / 180.0 * 6_371_008.8
    return (b[1] - a[1]) * k * math.cos(math.radians(0.5 * (a[0] + b[0]))), (b[0] - a[0]) * k


class VehicleEnergy:
    """One vehicle's energy (see the module docstring); `status` is its telemetry, read here."""

    def __init__(self, task: UavTask, status: VehicleStatus, profile: EnergyProfile, *, reserve_pct: float,
                 confirm_s: float = 3.0, wind_m_s: tuple[float, float] | None = None,
                 path_en: np.ndarray | None = None) -> None:
        self.task = task
        self.status = status
        self.profile = profile
        self.path_en = path_en  # the plan's path in metres: a profile with cornering predicts a metre of it
        self.crew_wind = wind_m_s  # the wind the crew measured at launch (`gcs fly --wind`)
        self.fuel = self._gauge(profile)
        self.reserve_pct = reserve_pct
        self.confirm_s = confirm_s
        self.phase = FlightPhase.GROUND
        self.levelled = False
        self.trigger_since: float | None = None
        self.decision: FuelDecision | None = None
        self._evaluated: tuple[tuple, float, float] | None = None  # what `decision` was made from, and where
        self._searching_ahead = False  # search poses lay ahead at that evaluation
        self._last_m: tuple[float, float] | None = None  # lat, lon of the last position
        self._last_s: float | None = None
        self.holding = False  # held in the air by the station (while its way home is uploaded)
        self.hover_s = 0.0    # vehicle seconds held so
        self.hold_s = HOLD_S  # vehicle seconds a return's hold is expected to take
        self.launch_profile: EnergyProfile | None = None
        self.autopilot = "generic"
        self.wind_reported = False  # the autopilot estimates a wind: its lean is not read
        self.lean_wind = LeanWind(profile.lean_tan_at_10_m_s) if profile.lean_tan_at_10_m_s else None
        self.notes: list[str] = []  # lines for the operator, taken by the vehicle's flight
        self._velocity: tuple[float, float] | None = None      # east, north m/s over the ground
        self._acceleration: tuple[float, float] | None = None  # its change per second, over STEADY_BASELINE_S
        self._velocities: deque[tuple[float, float, float]] = deque(maxlen=12)  # time, east, north
        self._lean = 0.0      # tan of the last tilt
        self._most_lean = 0.0  # and the most it has leant in steady flight
        self._climb_m_s = 0.0
        self._wind_said: tuple[float, float] | None = None  # the wind last said ((0, 0): still air)

    @property
    def uid(self) -> int:
        return self.task.uav_id

    def set_profile(self, profile: EnergyProfile) -> None:
        """Price the flight with `profile` (before launch: the gauge starts afresh, keeping the
        capacity already read from the autopilot)."""
        capacity = self.fuel.capacity_mah if self.fuel.capacity_mah != self.profile.capacity_mah else None
        self.profile = profile
        self.fuel = self._gauge(profile)
        self._evaluated = None
        self.lean_wind = LeanWind(profile.lean_tan_at_10_m_s) if profile.lean_tan_at_10_m_s else None
        if capacity is not None:
            self.fuel.set_capacity(capacity)

    def _gauge(self, profile: EnergyProfile) -> FuelGauge:
        gauge = FuelGauge(profile)
        if self.crew_wind is not None:
            gauge.set_wind(*self.crew_wind, sigma_m_s=CREW_SIGMA_M_S, source="the crew")
        return gauge

    # ---- telemetry ---------------------------------------------------------------------------

    def on_message(self, msg: MAVMessage) -> None:
        """After `status.update(msg)`: the fuel gauge's share of the message."""
        kind = msg.get_type()
        if kind == "GLOBAL_POSITION_INT":
            self._on_position(msg)
        elif kind == "BATTERY_STATUS" and getattr(msg, "id", 0) == 0:
            # PX4 SIH measures no current (-1) and reports 0 consumed: only its percentage counts
            measured = msg.current_battery >= 0 or msg.current_consumed > 0
            consumed = float(msg.current_consumed) if measured and msg.current_consumed >= 0 else None
            remaining = float(msg.battery_remaining) if msg.battery_remaining >= 0 else None
            if self.phase is not FlightPhase.GROUND and self.launch_profile is None:
                self.launch_profile = self.fuel.profile
            self.fuel.battery(self.status.time_boot_s, self.phase, consumed, remaining)
        elif kind == "ATTITUDE":
            self._on_attitude(msg)
        else:
            wind = wind_from_message(msg)
            if wind is not None:
                self.wind_reported = True
                self._use_wind(wind)

    def _on_attitude(self, msg: MAVMessage) -> None:
        """A multicopter's lean in steady level flight or a hover (not climbing or descending,
        where its autopilot lets it drift): the wind its autopilot may not report
        (`gcs.flight.lean_wind`)."""
        tilt = thrust_lean(msg.roll, msg.pitch, msg.yaw)
        self._lean = math.hypot(*tilt)
        lean, st, acceleration = self.lean_wind, self.status, self._acceleration
        if lean is None or self.wind_reported or not st.airborne or st.rel_alt_m < 3.0 or self._velocity is None \
                or acceleration is None or abs(self._climb_m_s) > LEVEL_CLIMB_M_S:
            return
        if math.hypot(*acceleration) <= MAX_ACCELERATION_M_S2 and self._lean > self._most_lean:
            self._most_lean = self._lean
            self.fuel.set_max_air_speed(math.hypot(*lean.air_velocity(tilt)))
        lean.sample(tilt, self._velocity, acceleration)
        estimate = lean.estimate
        if estimate is not None and not lean.samples % 2:
            self._use_wind(estimate)

    def _use_wind(self, estimate: WindEstimate) -> None:
        """A wind estimate given to the fuel gauge (still air where it cannot be told from it,
        unless the crew said otherwise) and to the status, and said when it first shows and when
        it changes."""
        st = self.status
        st.wind = estimate
        if estimate.calm:
            if self.fuel.wind_m_s is not None and self.crew_wind is None:
                self.fuel.clear_wind()
                if self._wind_said not in (None, (0.0, 0.0)):  # a wind said again only 2 m/s from none
                    self._wind_said = (0.0, 0.0)
                    self.notes.append(f"still air after all ({estimate.text()})")
            return
        self.fuel.set_wind(*estimate.vector, sigma_m_s=estimate.sigma_m_s, source=estimate.source)
        said = self._wind_said
        if said is None or math.dist(estimate.vector, said) > WIND_SAID_CHANGE_M_S:
            self._wind_said = estimate.vector
            self.notes.append(f"wind {estimate.text()}: a metre is priced by the ground speed it makes that way")

    def _on_position(self, msg: MAVMessage) -> None:
        st = self.status
        if not st.has_position:
            return
        velocity = (msg.vy / 100.0, msg.vx / 100.0)
        self._steady(st.time_boot_s, velocity)
        self._velocity = velocity
        self._climb_m_s = -msg.vz / 100.0
        self.phase = self._phase(-msg.vz / 100.0)
        here = (st.lat_deg, st.lon_deg)
        if self._last_m is not None and self.phase is not FlightPhase.GROUND:
            east, north = _step_m(self._last_m, here)
            self.fuel.moved(st.time_boot_s, east, north, self.phase)
            if self.holding and self._last_s is not None:
                self.hover_s += max(0.0, st.time_boot_s - self._last_s)
        self._last_s = st.time_boot_s
        self._last_m = here

    def _steady(self, now_s: float, velocity: tuple[float, float]) -> None:
        """The acceleration over the last STEADY_BASELINE_S or more; in steady flight at its
        cruise speed, or held back at its tilt limit (a multicopter), what the vehicle made good
        since the last position teaches the fuel gauge its ground speed that way."""
        history = self._velocities
        while history and now_s < history[-1][0]:  # the vehicle's clock restarted
            history.clear()
        then = next((h for h in reversed(history) if now_s - h[0] >= STEADY_BASELINE_S), None)
        self._acceleration = None if then is None else ((velocity[0] - then[1]) / (now_s - then[0]),
                                                        (velocity[1] - then[2]) / (now_s - then[0]))
        last_s = history[-1][0] if history else None
        history.append((now_s, *velocity))
        acceleration = self._acceleration
        if acceleration is None or last_s is None or math.hypot(*acceleration) > MAX_ACCELERATION_M_S2:
            return
        cruise = self.profile.cruise_speed_m_s
        at_tilt_limit = self.lean_wind is not None and self._most_lean > 0 \
            and self._lean >= TILT_LIMIT_SHARE * self._most_lean
        if self.profile.airframe is Airframe.COPTER and math.hypot(*velocity) < CRUISE_SHARE * cruise \
                and not at_tilt_limit:
            return
        self.fuel.steady(now_s, velocity, now_s - last_s, self.phase)

    def _phase(self, climb_m_s: float) -> FlightPhase:
        st = self.status
        if not st.airborne:
            return FlightPhase.GROUND if not self.levelled else FlightPhase.LANDING
        altitude = self.task.altitude_m
        if not self.levelled:
            if st.rel_alt_m >= LEVEL_SHARE * altitude:  # as the profile's launch is measured: up to its altitude
                self.levelled = True
            else:
                return FlightPhase.LAUNCH
        descending = climb_m_s < -LEVEL_CLIMB_M_S and st.rel_alt_m < LEVEL_SHARE * altitude
        if st.landed_state == mavlink.MAV_LANDED_STATE_LANDING or st.mode_name == "LAND" \
                or (st.stage in (Stage.RETURN, Stage.RTL) and descending):
            return FlightPhase.LANDING
        return FlightPhase.CRUISE

    # ---- the trigger ---------------------------------------------------------------------------

    def check_along(self, track: PlanTrack, lookahead_steps: int, ordered_left_m: float | None) -> bool:
        """The return trigger's check for the vehicle on `track`: the next `lookahead_steps` poses
        of its plan, the way home from each, the landing circuit (`evaluate`); True when it must
        turn home now (searching, airborne, and confirmed: `must_return`)."""
        st = self.status
        inputs = (self.fuel.version, st.track_index, lookahead_steps, ordered_left_m, self.hold_s, self.reserve_pct)
        if not self._still_valid(inputs):
            steps_ahead, home = track.look_ahead(st.track_index, st.lat_deg, st.lon_deg, lookahead_steps) \
                if st.has_position else ([], [])
            self._searching_ahead = bool(steps_ahead)
            if steps_ahead:
                self.evaluate(steps_ahead, home, track.circuit_legs(), ordered_left_m)
            else:
                self.decision = None
                st.margin = math.inf  # the plan's own return (or its end): already the lowest-cost way home
            self._evaluated = (inputs, st.lat_deg, st.lon_deg) if st.has_position else None
        if not self._searching_ahead:
            return False
        return st.airborne_seen and st.stage is Stage.SEARCH and self.must_return(st.time_boot_s)

    def _still_valid(self, inputs: tuple) -> bool:
        """Whether the last evaluation stands: made from the same charge, fit, pose and orders,
        within REEVALUATE_M of here."""
        if self._evaluated is None or self._evaluated[0] != inputs:
            return False
        st = self.status
        return ground_distance_m(self._evaluated[1], self._evaluated[2], st.lat_deg, st.lon_deg) < REEVALUATE_M

    def why_home(self, operator_range_m: float | None) -> str:
        """The last evaluation's reason to return, in the operator's terms."""
        st, decision, fuel = self.status, self.decision, self.fuel
        assert decision is not None
        if decision.by_order:
            ordered = decision.ordered
            assert ordered is not None and operator_range_m is not None
            return (f"the ordered range of {operator_range_m:.0f} m leaves {ordered.range_left:.0f} m, "
                    f"the way home needs {ordered.cost:.0f} m: returning")
        remaining = fuel.remaining_mah or 0.0
        pct = f"{st.battery_pct:.0f}%" if st.battery_pct is not None else f"{remaining:.0f} mAh"
        air = "in still air" if fuel.wind is None else f"in the wind {fuel.wind.text()}"
        return (f"battery {pct} ({remaining:.0f} mAh) pays for {decision.range_left_m:.0f} m above the "
                f"{self.reserve_pct:g}% reserve and the landing; the way home is {decision.home_m:.0f} m "
                f"({decision.home_mah:.0f} mAh with the landing, at {fuel.rate_mah_per_m:.2f} mAh/m {air}): "
                "returning")

    def evaluate(self, steps_ahead: list[Legs], home_legs: list[Legs], circuit_legs: Legs,
                 ordered_left_m: float | None = None) -> FuelDecision | None:
        """The return trigger's check now (`gcs.flight.return_trigger.fuel_decision`), kept as
        `decision`; the status shows its range left and margin in metres."""
        def decide(fuel: FuelGauge) -> FuelDecision | None:
            return fuel_decision(fuel, reserve_pct=self.reserve_pct, landing_mah=self.landing_mah(),
                                 steps_ahead=steps_ahead, home_legs=home_legs, circuit_legs=circuit_legs,
                                 ordered_left_m=ordered_left_m)

        self.decision = decide(self.fuel)
        wind = self.fuel.wind
        if self.decision is not None and self.decision.must_return and not self.decision.by_order \
                and wind is not None and wind.young:
            kinder = decide(self.fuel.in_wind(wind.weakened()))
            if kinder is not None and not kinder.must_return:
                self.decision = replace(self.decision, deferred=True)
        st = self.status
        st.range_left = math.inf if self.decision is None else self.decision.range_left_m
        st.margin = math.inf if self.decision is None else self.decision.margin_m
        return self.decision

    @property
    def landing_altitude_m(self) -> float:
        """Where the landing starts: a plane's approach altitude (it flies down to it along its
        way to the approach point), else the mission altitude."""
        approach = self.task.approach
        return min(approach.alt_m, self.task.altitude_m) if approach is not None else self.task.altitude_m

    def landing_mah(self) -> float:
        """What coming home costs beyond its way: the hold while the station sends the way home
        (`hold_s` of vehicle time) and the landing, at the profile's prices scaled up as far as
        cruise costs more than the profile says (a pack that drains faster in cruise drains
        faster in a hover and on the way down too), never down."""
        scale = max(1.0, self.fuel.still_air_mah_per_m / self.profile.cruise_mah_per_m)
        profile = self.profile
        return (profile.loiter_mah_per_s * self.hold_s + profile.landing_cost_mah(self.landing_altitude_m)) * scale

    def plan_charge(self, path_m: float, track: PlanTrack) -> PlanCharge | None:
        """What the charge reported now pays for against a plan of `path_m` metres along `track`,
        a metre priced along its legs in the wind known; None while no charge has been reported.
        A metre costs what the plan's range was sized with (the profile's `cruise_mah_per_m`, not
        the plan's own path with its corners): the check is whether the charge is what the plan
        was made for."""
        fuel, profile = self.fuel, self.profile
        have = fuel.remaining_mah
        if have is None:
            return None
        reserve = fuel.reserve_mah(self.reserve_pct)
        ends = profile.launch_cost_mah(self.task.altitude_m) + profile.landing_cost_mah(self.landing_altitude_m)
        along = fuel.way_cost(track.legs())
        per_m = along.mah / along.metres if along.metres > 0 else fuel.rate_mah_per_m  # the wind known included
        return PlanCharge(have, ends + per_m * path_m + reserve, max(0.0, have - reserve - ends) / per_m, per_m)

    def must_return(self, now_s: float) -> bool:
        """Whether the last evaluation, confirmed (`gcs.flight.return_trigger.confirmed`), sends
        the vehicle home now."""
        go, self.trigger_since = confirmed(self.decision, self.trigger_since, now_s, confirm_s=self.confirm_s,
                                           capacity_mah=self.fuel.capacity_mah)
        return go

    # ---- the end -------------------------------------------------------------------------------

    def energy_account(self) -> EnergyAccount | None:
        """Predicted (by the profile at launch) against used, for what was flown (the cruise metres,
        each priced in the wind known as it was flown, at a metre of the plan's path where the
        profile prices a path by its time, `EnergyProfile.along`; the seconds it held in the air,
        the launch to its altitude, the landing from where it starts); None when the vehicle never
        launched or its charge was never read."""
        fuel, profile = self.fuel, self.launch_profile
        if profile is None or fuel.used_mah is None or fuel.used_at_launch is None:
            return None
        altitude = self.task.altitude_m
        cruise = profile if self.path_en is None else profile.along(self.path_en)
        predicted = (profile.launch_cost_mah(altitude) + cruise.cruise_cost_mah(fuel.cruise_priced_m)
                     + profile.loiter_mah_per_s * self.hover_s + profile.landing_cost_mah(self.landing_altitude_m))
        return EnergyAccount(predicted, fuel.used_mah - fuel.used_at_launch, fuel.phase_m[FlightPhase.CRUISE],
                             self.status.battery_pct)
