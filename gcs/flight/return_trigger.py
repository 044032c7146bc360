"""The fuel-based return trigger: DTSCS's range check (eq. 23-24) on a vehicle's live charge.

Pure functions, no I/O. `fuel_decision` is the planner's own range check
(`planner.range_check.check_return`, eq. 23 at step k+1, Algorithm 3) in mAh: keep searching while
the charge left pays for the next step (a few: the station sees a vehicle every tick, not every
step), the planned way home from there (the exact table's path under the OC) priced in the wind
the vehicle meets, the landing (and a plane's landing circuit), and still leaves the reserve;
otherwise return now. What a metre costs is the fuel gauge's (`gcs.flight.fuel.FuelGauge`):
learned in level flight from the vehicle's profile, never from its launch; the landing costs the
profile's figure, scaled up as far as cruise turned out dearer than the profile says
(`gcs.flight.vehicle_energy.VehicleEnergy.landing_mah`).

A return the wind estimate alone asks for, while it is young (`gcs.telemetry.wind.WindEstimate.young`)
and a wind two of its standard deviations weaker would let the vehicle search on, is put off
(`FuelDecision.deferred`): the check is taken again as the vehicle flies and its estimate firms
up, or shows the return is needed in any wind it allows. A first reading from a copter leaning out
of its first turn once cost a fleet two-thirds of its search in an 8 m/s wind (issue 38).

`confirmed` is when a "return" is acted on: once the check has said so for `confirm_s` seconds of
the vehicle's own time (ArduPilot waits BATT_LOW_TIMER, 10 s, before its own battery failsafe, so
that a reading that sags for a moment does not end a flight), at once when the charge falls short
by more than SEVERE_SHARE of the pack, and at once when an operator's range binds. The caller
latches it: once sent home a vehicle stays on its way home (PX4 latches its decision too)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gcs.flight.fuel import FuelGauge, LegCost
from planner.range_check import ReturnCheck, check_return

__all__ = ["FuelDecision", "HOME_MARGIN", "SEVERE_SHARE", "THIRSTY_SHARE", "check_return", "confirmed", "fuel_decision"]

#: A return is acted on at once when the charge falls short by more than this share of the pack.
SEVERE_SHARE = 0.02

#: Once a vehicle's cruise has cost more than THIRSTY_SHARE of its profile's, its way home and
#: landing are priced HOME_MARGIN dearer than estimated: its profile is known wrong, and what the
#: gauge has learned by then lags (ArduCopter SITL drawing 1.3x its profile on 30 m cells: its way
#: home cost 21 % more than priced, and it touched down at 23 % of a 30 % reserve). A vehicle flying
#: as profiled is priced as planned, so it flies its plan to its planned return.
HOME_MARGIN = 0.1
THIRSTY_SHARE = 1.05

Legs = list[tuple[float, float]]


@dataclass(frozen=True, slots=True)
class FuelDecision:
    """One evaluation: the range check in mAh (`fuel`) and, when an operator set a range, the same
    check in metres against it (`ordered`); for people, what the charge above the reserve and the
    landing still buys (`range_left_m`, metres of cruise) and what is left of the binding range
    once the way home is paid (`margin_m`); the way home (with a plane's landing circuit) in
    metres and in mAh with the landing (`home_m`, `home_mah`)."""

    fuel: ReturnCheck
    ordered: ReturnCheck | None
    home_m: float
    home_mah: float
    range_left_m: float
    margin_m: float
    deferred: bool = False  # the charge would not pay in the wind estimated, but would in one two sigmas kinder

    @property
    def must_return(self) -> bool:
        return (self.fuel.must_return and not self.deferred) or (self.ordered is not None and self.ordered.must_return)

    @property
    def by_order(self) -> bool:
        """The operator's range, not the charge, sends the vehicle home."""
        return self.ordered is not None and self.ordered.must_return and not self.fuel.must_return


def fuel_decision(gauge: FuelGauge, *, reserve_pct: float, landing_mah: float, steps_ahead: list[Legs],
                  home_legs: list[Legs], circuit_legs: Legs, ordered_left_m: float | None = None
                  ) -> FuelDecision | None:
    """The range check for each look-ahead j: the legs to the j-th pose ahead (`steps_ahead[j]`)
    and the planned way home from it (`home_legs[j]`), then the landing circuit and the landing;
    the worst of them decides. `ordered_left_m`: metres an operator's range still allows from
    here, checked the same way. None while the charge is unknown."""
    remaining = gauge.remaining_mah
    if remaining is None or not steps_ahead:
        return None
    reserve = gauge.reserve_mah(reserve_pct)
    costs = gauge.way_costs([circuit_legs, *steps_ahead, *home_legs])
    circuit, ahead_costs, home_costs = costs[0], costs[1:1 + len(steps_ahead)], costs[1 + len(steps_ahead):]
    margin = HOME_MARGIN if gauge.still_air_mah_per_m > THIRSTY_SHARE * gauge.profile.cruise_mah_per_m else 0.0
    landing_mah *= 1.0 + margin
    left_m = gauge.cruise_m_for(remaining - reserve - landing_mah)
    worst: FuelDecision | None = None
    for step, way in zip(ahead_costs, home_costs):
        way = LegCost(way.metres, way.mah * (1.0 + margin))
        check = check_return(remaining, way.mah + circuit.mah, landing_mah, reserve, step.mah)
        ordered = None if ordered_left_m is None else check_return(ordered_left_m, way.metres, step=step.metres)
        margin_m = math.copysign(gauge.cruise_m_for(abs(check.margin)), check.margin)
        if ordered is not None:
            margin_m = min(margin_m, ordered.margin)
        decision = FuelDecision(check, ordered, way.metres + circuit.metres, way.mah + circuit.mah + landing_mah,
                                left_m, margin_m)
        if worst is None or decision.margin_m < worst.margin_m:
            worst = decision
    return worst


def confirmed(decision: FuelDecision | None, since_s: float | None, now_s: float, *, confirm_s: float,
              capacity_mah: float) -> tuple[bool, float | None]:
    """Whether `decision` sends the vehicle home now, and since when it has said so (None when it
    does not): held for `confirm_s` (vehicle seconds), or at once when short by more than
    SEVERE_SHARE of `capacity_mah`, or at once when an operator's range binds."""
    if decision is None or not decision.must_return:
        return False, None
    if decision.ordered is not None and decision.ordered.must_return:
        return True, now_s if since_s is None else since_s
    since_s = now_s if since_s is None else since_s
    severe = decision.fuel.margin < -SEVERE_SHARE * capacity_mah
    return severe or now_s - since_s >= confirm_s, since_s
