"""The knobs of a flight (`FlyOptions`), shared by the fleet controller and each vehicle's flight."""

from __future__ import annotations

from dataclasses import dataclass, field

from planner.energy import EnergyProfile

__all__ = ["LANDED_AWAY_M", "FlyOptions"]

#: Farther than this from its airport a vehicle has landed away, by airframe: a copter lands on its
#: spot, a plane rolls out along its runway.
LANDED_AWAY_M = {"copter": 25.0, "plane": 200.0}


@dataclass
class FlyOptions:
    """Knobs of a flight; times are real (wall-clock) seconds unless named otherwise.

    `profiles[uav]`: the energy profile of the vehicle flying as that UAV (`gcs fly --vehicles`);
    a UAV without one gets its autopilot's stock profile (`gcs.plans.vehicle_file.stock_profile`).
    `confirm_s`: vehicle seconds the return trigger must hold before it is acted on.
    `fit_charge`: a vehicle whose charge cannot pay for its plan flies it until its battery calls
    it home instead of being kept on the ground. `wind_m_s`: (east, north) m/s the air moves towards, as
    the crew measured it at launch: the check before arming and the trigger price the plan in it
    until the vehicle's own wind reading replaces it. `vehicles_file`: the vehicles.json the profiles this
    flight learns are merged into. `landed_away_m[airframe]`: farther than this from its airport a
    vehicle has landed away."""

    reserve_pct: float = 30.0
    profiles: dict[int, EnergyProfile] = field(default_factory=dict)
    confirm_s: float = 3.0
    fit_charge: bool = False
    wind_m_s: tuple[float, float] | None = None
    vehicles_file: str | None = None
    landed_away_m: dict[str, float] = field(default_factory=lambda: dict(LANDED_AWAY_M))
    link_timeout_s: float = 3.0
    lost_giveup_s: float = 20.0
    connect_timeout_s: float = 15.0
    gps_timeout_s: float = 120.0
    arm_timeout_s: float = 60.0
    transfer_timeout_s: float = 0.5
    command_timeout_s: float = 0.5
    tick_s: float = 0.05
    # the live table: drawn by `gcs.display.status_table.LiveTable`, never by the controller;
    # `fly_async` still honours these two for callers that give no `out` (see its docstring)
    fence: bool = True
    return_after_s: dict[int, float] = field(default_factory=dict)
    fly: bool = True
    lookahead_steps: int = 2
    check_home: bool = True
    ready_timeout_s: float = 180.0
