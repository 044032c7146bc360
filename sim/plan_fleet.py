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


def fleet_for_plan(plan: FleetPlan, *, speedup: float, profile: str = "ardupilot", seed: int = 0, pc: float = 0.9,
              pf: float = 0.1, drain: dict[int, float] | None = None, loss: float = 0.0,
              endurance_s: float = 1200.0, signing: SigningKey | None = None, boot_scale: float = 1.0):
    """The built-in simulated fleet on free loopback ports: vehicle i (system id i) at UAV i's
    airport with its start heading (a UAV the plan left on the ground waits at its airport), the
    plan's targets, a sensor on the plan's grid; `drain` multiplies chosen vehicles' battery
    drain; `boot_scale` scales the autopilots' start-up (`VehicleConfig.boot_scale`). ValueError
    for UAV ids other than 1..N."""
    homes_by_id = {uid: HomePose(*u.airport_lat_lon, 0.0, u.start_heading * 45.0) for uid, u in plan.uavs.items()}
    for uav in plan.raw.get("grounded", []):
        homes_by_id[int(uav["id"])] = HomePose(*uav["airport_lat_lon"], 0.0, 0.0)
    ids = sorted(homes_by_id)
    if ids != list(range(1, len(ids) + 1)):
        raise ValueError(f"the simulated fleet needs UAV ids 1..N, the plan has {ids}")
    homes = [homes_by_id[i] for i in ids]
    world = World.of_plan(plan)  # the world `gcs detector` gives real vehicles
    vehicle = next(iter(plan.uavs.values())).vehicle.value
    config = VehicleConfig(vehicle_type=vehicle, profile=profile, sensor=world.sensor_config(pc, pf),
                           battery=BatteryConfig(endurance_s=endurance_s), boot_scale=boot_scale)
    fleet = SimFleet(homes, config, FleetOptions(base_port=0, speedup=speedup, targets=world.targets, seed=seed,
                                                 faults=LinkFaults(loss=loss, seed=seed),
                                                 signing_key=signing.secret if signing else None,
                                                 grid_origin=world.grid_origin))
    for uid, k in (drain or {}).items():
        fleet.vehicle(uid).set_drain_multiplier(k)
    return fleet
