"""The simulated ArduCopter against ArduCopter SITL where a search path spends its charge: 8 x 50 m
legs turning 90 degrees, 8 x 50 m turning 45 degrees and 400 m straight, each from a stop to a
stop, at 10 m/s and 30 m. SITL at speed-up 20 and the simulator at 30 fly side by side; prints
each stretch's seconds, metres, mAh and mAh per metre (the figures `sim.physics.kinematics`'s
acceleration and corner fractions were fitted to; docs/energy.md).

    .venv/bin/python benchmarks/sim_corners.py
"""

from __future__ import annotations

import math
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from pymavlink import mavutil

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sim import BatteryConfig, FleetOptions, HomePose, SimFleet, VehicleConfig  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl  # noqa: E402
from tests.peers.energy import Course, Record, Station, Step, fly, phase  # noqa: E402
from tests.peers.site import CENTRE, GROUND_AMSL_M  # noqa: E402

STRETCHES = ("zig90", "zig45", "straight")


def course() -> Course:
    steps = [Step("takeoff", "take-off", value=30.0), Step("hover", "hover", value=5.0), Step("speed", value=10.0),
             Step("stop", "stop", (0.0, 0.0), value=3.0)]
    z90 = [(50.0 * ((i + 1) // 2), 50.0 * ((i + 2) // 2)) for i in range(8)]  # N, E, N, E ...
    steps += [Step("zigzag", "zig90", e) for e in z90] + [Step("stop", "stop", z90[-1], value=3.0)]
    here, z45 = z90[-1], []
    for i in range(8):  # N, NE, N, NE ...
        here = (here[0], here[1] + 50.0) if i % 2 == 0 else (here[0] + 50 / math.sqrt(2), here[1] + 50 / math.sqrt(2))
        z45.append(here)
    steps += [Step("leg", "zig45", e) for e in z45] + [Step("stop", "stop", z45[-1], value=3.0)]
    straight = (here[0], here[1] + 400.0)
    steps += [Step("straight", "straight", straight, here), Step("stop", "stop", straight, value=3.0),
              Step("leg", "home", (0.0, 0.0), straight), Step("land", "landing", (0.0, 0.0))]
    return Course(tuple(steps), 30.0)


def stretches(record: Record) -> dict[str, tuple[float, float, float, float]]:
    out = {}
    for label in STRETCHES:
        seqs = {i + record.seq_offset for i, st in enumerate(record.steps) if st.label == label}
        p = phase(label, label, [x for x in record.samples if x.seq in seqs and x.t_s >= record.start_t_s])
        assert p is not None, f"no samples on {label}"
        out[label] = (round(p.seconds, 1), round(p.metres), round(p.mah), round(p.mah / p.metres, 3))
    return out


def flown(connection: str, speedup: float) -> dict[str, tuple[float, float, float, float]]:
    link = mavutil.mavlink_connection(connection, source_system=255, source_component=190, dialect="ardupilotmega")
    try:
        return stretches(fly(Station(link, 1, False, speedup), course(), vehicle="copter", idle_s=6.0))
    finally:
        link.close()


def sitl() -> dict[str, tuple[float, float, float, float]]:
    with ArduPilotSitl("copter", home=(*CENTRE, GROUND_AMSL_M, 0.0), speedup=20.0) as vehicle:
        return flown(vehicle.udp_connection, 20.0)


def simulated() -> dict[str, tuple[float, float, float, float]]:
    config = VehicleConfig(battery=BatteryConfig(capacity_mah=3300.0), boot_scale=0.05)
    fleet = SimFleet([HomePose(*CENTRE, GROUND_AMSL_M, 0.0)], config, FleetOptions(base_port=0, speedup=30.0))
    with fleet.running():
        return flown(fleet.connection_strings()[0], 30.0)


def main() -> None:
    with ThreadPoolExecutor(1) as pool:
        sim = pool.submit(simulated)
        real = sitl()
        ours = sim.result()
    print("stretch    (seconds, metres, mAh, mAh/m)")
    for name in STRETCHES:
        print(f"{name:9s}  SITL {real[name]}  simulator {ours[name]}")


if __name__ == "__main__":
    main()
