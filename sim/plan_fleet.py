"""The simulated fleet that stands in for a plan's aircraft (`gcs fly --sim`, `gcs upload --sim`):
one vehicle per UAV at its airport, in the world of the plan (`sim.detector.World`: targets and
the sensor on the plan's grid)."""

from __future__ import annotations

from gcs.links import SigningKey
from gcs.plans.plan_folder import FleetPlan
from sim.autopilot.vehicle import VehicleConfig
from sim.detector import World
from sim.fleet import FleetOptions, SimFleet
from sim.physics.airframe import HomePose
from sim.physics.battery import BatteryConfig
from sim.vehicle_link import LinkFaults


def plan_homes(plan: FleetPlan, alt_m: float = 0.0) -> list[HomePose]:
    """Vehicle i's home (system id i): UAV i's airport and start heading (a UAV the plan left on
    the ground waits at its airport, facing north), `alt_m` above mean sea level. ValueError for
    UAV ids other than 1..N."""
    homes_by_id = {uid: HomePose(*u.airport_lat_lon, alt_m, u.start_heading * 45.0) for uid, u in plan.uavs.items()}
    for uav in plan.raw.get("grounded", []):
        homes_by_id[int(uav["id"])] = HomePose(*uav["airport_lat_lon"], alt_m, 0.0)
    ids = sorted(homes_by_id)
    if ids != list(range(1, len(ids) + 1)):
        raise ValueError(f"the simulated fleet needs UAV ids 1..N, the plan has {ids}")
    return [homes_by_id[i] for i in ids]


def fleet_for_plan(plan: FleetPlan, *, speedup: float, profile: str = "ardupilot", seed: int = 0,
                   pc: float | None = None, pf: float | None = None, drain: dict[int, float] | None = None,
                   loss: float = 0.0, endurance_s: float = 1200.0, signing: SigningKey | None = None,
                   boot_scale: float = 1.0):
    """The built-in simulated fleet on free loopback ports: vehicle i (system id i) at UAV i's
    airport with its start heading (`plan_homes`), the plan's targets, a sensor on the plan's
    grid reading at `pc` and `pf` (default: the plan's, its camera's Pc when it was made with one:
    `FleetPlan.pc`); `drain` multiplies chosen vehicles' battery drain; `boot_scale` scales the
    autopilots' start-up (`VehicleConfig.boot_scale`). ValueError for UAV ids other than 1..N."""
    homes = plan_homes(plan)
    world = World.of_plan(plan)  # the world `gcs detector` gives real vehicles
    vehicle = next(iter(plan.uavs.values())).vehicle.value
    sensor = world.sensor_config(plan.pc if pc is None else pc, plan.pf if pf is None else pf)
    config = VehicleConfig(vehicle_type=vehicle, profile=profile, sensor=sensor,
                           battery=BatteryConfig(endurance_s=endurance_s), boot_scale=boot_scale)
    fleet = SimFleet(homes, config, FleetOptions(base_port=0, speedup=speedup, targets=world.targets, seed=seed,
                                                 faults=LinkFaults(loss=loss, seed=seed),
                                                 signing_key=signing.secret if signing else None,
                                                 grid_origin=world.grid_origin))
    for uid, k in (drain or {}).items():
        fleet.vehicle(uid).set_drain_multiplier(k)
    return fleet
