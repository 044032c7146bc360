"""The simulator's batteries against real SITL's: the same short flight (`tests/peers/energy.py`:
armed on the ground, take-off, hover or loiter, straight legs, a copter's zig-zag, landing) on
ArduCopter, ArduPlane and PX4 SIH SITL with stock parameters and on the simulator's matching
profile, and the battery figures of each phase compared within the tolerances below.

What a fuel trigger reads is compared: ArduPilot's consumed charge per phase (mAh, per second,
per metre), its energy and voltage, and remaining % against the charge used; PX4's voltage and
remaining % (its simulated battery drains in time, SIM_BAT_DRAIN 60 s to SIM_BAT_MIN_PCT 50 %,
and its estimate rises with the thrust), and how it comes back on disarm."""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import pytest
from pymavlink import mavutil

from sim import BatteryConfig, FleetOptions, HomePose, SimFleet, VehicleConfig
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.energy import Course, Phase, Station, analyse, copter_course, fly, plane_course
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import PX4_SPEEDUP, Px4Sitl
from tests.peers.site import CENTRE, GROUND_AMSL_M

pytestmark = [pytest.mark.autopilot, SITL_WORKER]  # tests/peers/process.py

SPEEDUP = 20.0  # ArduPilot as its flight tests (docs/tests.md)
#: the simulator's course flies as the simulated fleets do (docs/tests.md)
SIM_SPEEDUP = 30.0
#: the copter's course with a 90-degree zig-zag of 50 m legs and a straight from a stop to a stop, on a
#: 5000 mAh pack (it does not fit SITL's default 3300): where a search path spends its charge
COPTER = copter_course(alt_m=30.0, leg_m=200.0, speeds=(5, 10), hover_s=10.0, turns=True)
COPTER_PACK = {"BATT_CAPACITY": 5000.0}
PLANE = plane_course(leg_m=1000.0, loiter_s=30.0, turns=False)
PX4 = copter_course(alt_m=30.0, leg_m=300.0, speeds=(None, 10), hover_s=10.0, turns=False, default_speed_m_s=5.0)
AUTOLAND = {"RTL_AUTOLAND": 2.0}  # ArduPlane arms with a DO_LAND_START only with it


def _phases(record) -> dict[str, Phase]:
    return {p.name: p for p in analyse(record)}


def _fly(connection: str, course: Course, *, vehicle: str, px4: bool, speedup: float,
         setup: dict[str, float] | None = None) -> dict[str, Phase]:
    conn = mavutil.mavlink_connection(connection, source_system=255, source_component=190, dialect="ardupilotmega")
    # PX4 disarms 11 s after arming unless it has taken off; the simulated one leaves the ground
    # 4.5 s after MISSION_START (SITL armed: 3.5 s)
    idle_s = 4.0 if px4 else 6.0
    try:
        return _phases(fly(Station(conn, 1, px4, speedup), course, vehicle=vehicle, setup=setup, idle_s=idle_s))
    finally:
        conn.close()


def _sim(config: VehicleConfig, course: Course, *, setup: dict[str, float] | None = None) -> dict[str, Phase]:
    heading = 90.0 if config.vehicle_type == "plane" else 0.0
    fleet = SimFleet([HomePose(*CENTRE, GROUND_AMSL_M, heading)], config,
                     FleetOptions(base_port=0, speedup=SIM_SPEEDUP))
    with fleet.running():
        phases = _fly(fleet.connection_strings()[0], course, vehicle=config.vehicle_type, px4=config.profile == "px4",
                      speedup=SIM_SPEEDUP, setup=setup)
    assert not fleet.errors
    return phases


Phases = dict[str, Phase]


def _side_by_side(sim: Callable[[], Phases], real: Callable[[], Phases]) -> tuple[Phases, Phases]:
    """(simulator, SITL): the simulator's course flown on a thread while SITL flies its own (the
    figures are per second and metre of each vehicle's own time, so neither waits for the other)."""
    with ThreadPoolExecutor(1, thread_name_prefix="sim-course") as pool:
        simulated = pool.submit(sim)
        flown = real()
        return simulated.result(), flown


@pytest.fixture(scope="module")
def arducopter() -> tuple[Phases, Phases]:
    """About 35 s of SITL at 20x, and beside it 20 s of the simulator at 30x."""
    def real() -> Phases:
        with ArduPilotSitl("copter", home=(*CENTRE, GROUND_AMSL_M, 0.0), speedup=SPEEDUP) as sitl:
            return _fly(sitl.udp_connection, COPTER, vehicle="copter", px4=False, speedup=SPEEDUP, setup=COPTER_PACK)
    pack = BatteryConfig(capacity_mah=COPTER_PACK["BATT_CAPACITY"])
    return _side_by_side(lambda: _sim(VehicleConfig(battery=pack, boot_scale=0.05), COPTER, setup=COPTER_PACK), real)


@pytest.fixture(scope="module")
def arduplane() -> tuple[Phases, Phases]:
    config = VehicleConfig(vehicle_type="plane", cruise_speed_m_s=22.0, battery=BatteryConfig(capacity_mah=3300.0),
                           boot_scale=0.05)

    def real() -> Phases:
        with ArduPilotSitl("plane", home=(*CENTRE, GROUND_AMSL_M, 90.0), speedup=SPEEDUP) as sitl:
            return _fly(sitl.udp_connection, PLANE, vehicle="plane", px4=False, speedup=SPEEDUP, setup=AUTOLAND)
    return _side_by_side(lambda: _sim(config, PLANE, setup=AUTOLAND), real)


@pytest.fixture(scope="module")
def px4_quad() -> tuple[Phases, Phases]:
    """About 35 s of SITL at PX4's speed-up, and beside it 10 s of the simulator at 30x. (One
    after the other from ci51 until 2026-11-29: beside PX4 SITL one local run in ten read the
    simulator at 96 % "3 s after the disarm"; that reading was PX4's 1 s voltage filter at 3 s,
    97.5 % by itself, and is now taken 5 s after, `tests.peers.energy.AFTER_DISARM_S`.)"""
    def real() -> Phases:
        with Px4Sitl(home=(*CENTRE, GROUND_AMSL_M), speedup=PX4_SPEEDUP) as sitl:
            return _fly(sitl.gcs_connection, PX4, vehicle="copter", px4=True, speedup=PX4_SPEEDUP)
    return _side_by_side(lambda: _sim(VehicleConfig(profile="px4", boot_scale=0.05), PX4), real)


def _close(sim: float, real: float, rel: float, what: str) -> str | None:
    if math.isnan(sim) or math.isnan(real) or abs(sim - real) > rel * abs(real):
        return f"{what}: sim {sim:.3f}, SITL {real:.3f} (tolerance {rel:.0%})"
    return None


def _ardupilot_problems(sim: dict[str, Phase], real: dict[str, Phase], rules: dict[str, tuple[str, float]],
                        capacity_mah: float) -> list[str]:
    problems = [f"{name}: missing ({'sim' if name not in sim else 'SITL'})" for name in rules
                if name not in sim or name not in real]
    for name, (figure, rel) in rules.items():
        if name in sim and name in real:
            got, want = getattr(sim[name], figure), getattr(real[name], figure)
            problems.append(_close(got, want, rel, f"{name} {figure}"))
    for side, phases in (("sim", sim), ("SITL", real)):
        idle = phases["armed idle on the ground"]
        if idle.mah != 0 or idle.mean_current_a != 0:
            problems.append(f"{side}: {idle.mah} mAh, {idle.mean_current_a} A armed on the ground (SITL draws none)")
        for p in phases.values():  # remaining % follows the consumed charge over BATT_CAPACITY
            if p.mah > 100 and abs((p.remaining_from - p.remaining_to) - 100 * p.mah / capacity_mah) > 2.0:
                problems.append(f"{side} {p.name}: remaining {p.remaining_from} -> {p.remaining_to} % for {p.mah} mAh")
            # energy in whole hJ and charge in whole mAh: 150 J of rounding
            if p.mah > 100 and abs(p.energy_j - p.mah * 3.6 * p.mean_voltage_v) > 150 + 0.01 * p.energy_j:
                problems.append(f"{side} {p.name}: {p.energy_j} J for {p.mah} mAh at {p.mean_voltage_v:.2f} V")
    return [p for p in problems if p]


def test_the_simulated_arducopter_draws_what_sitl_draws_phase_by_phase(arducopter):
    """Hover and cruise within 5 % (per second, per metre), the zig-zag's and the straight's charge
    and time within 5 % (the braking and speeding up around each corner and stop), the take-off
    and landing within 20 % (SITL's motors spool up in 1 s, the simulator's in 3.25 s), the
    voltage steady at 12.6 V."""
    sim, real = arducopter
    rules = {"take-off to 30 m": ("mah", 0.2), "hover": ("mah_per_s", 0.05),
             "cruise 5 m/s hdg 000": ("mah_per_m", 0.05), "cruise 5 m/s hdg 180": ("mah_per_m", 0.05),
             "cruise 10 m/s hdg 000": ("mah_per_m", 0.05), "cruise 10 m/s hdg 180": ("mah_per_m", 0.05),
             "zig-zag 8 x 50 m": ("mah", 0.05), "straight 400 m": ("mah", 0.05),
             "landing from 30 m": ("mah", 0.2)}
    problems = _ardupilot_problems(sim, real, rules, COPTER_PACK["BATT_CAPACITY"])
    for name in ("zig-zag 8 x 50 m", "straight 400 m"):
        if name in sim and name in real:
            problems.append(_close(sim[name].seconds, real[name].seconds, 0.05, f"{name} seconds"))
    problems = [p for p in problems if p]
    for side, phases in (("sim", sim), ("SITL", real)):
        problems += [f"{side} {p.name}: {p.min_voltage_v} V" for p in phases.values() if p.min_voltage_v != 12.6]
    assert real["hover"].mah_per_s > 7.0  # SITL did fly: 28 A
    assert problems == []


def test_the_simulated_arduplane_draws_full_throttle_to_take_off_and_sags_as_sitl(arduplane):
    """Loiter and cruise within 5 % per second (per metre the ground speed decides: SITL flies
    23.4 m/s over the ground at AIRSPEED_CRUISE 22), the take-off within 25 %, the landing's glide
    within 50 % (a few tens of mAh); the voltage 0.7 V under 12.6 V at full throttle and 0.34 V
    cruising, within 0.05 V."""
    sim, real = arduplane
    rules = {"take-off to 30 m": ("mah", 0.25), "take-off to 60 m": ("mah", 0.25), "loiter": ("mah_per_s", 0.05),
             "cruise hdg 090": ("mah_per_s", 0.05), "cruise hdg 270": ("mah_per_s", 0.05),
             "landing from 60 m": ("mah", 0.5), "landing from 30 m": ("mah", 0.5)}
    problems = _ardupilot_problems(sim, real, rules, 3300.0)
    for name, figure in (("take-off to 30 m", "min_voltage_v"), ("cruise hdg 090", "mean_voltage_v"),
                         ("loiter", "mean_voltage_v")):
        got, want = getattr(sim[name], figure), getattr(real[name], figure)
        if abs(got - want) > 0.05:
            problems.append(f"{name} {figure}: sim {got:.2f} V, SITL {want:.2f} V")
    assert real["take-off to 30 m"].mean_current_a > 3 * real["cruise hdg 090"].mean_current_a  # full throttle
    assert problems == []


def test_the_simulated_px4_reports_sih_battery_as_px4_does(px4_quad):
    """SIH drains in armed time: the voltage falls from 16.2 V to the floor 15.3 V (50 %) within
    the take-off, PX4's remaining % reads higher with the thrust (hover about 61 %, 9.8 m/s about
    65 %) within 3 points, no current (-1 A), and it is back to 98 % or more 5 s after the disarm."""
    sim, real = px4_quad
    problems = []
    for name in ("hover", "cruise 5 m/s (default) hdg 000", "cruise 5 m/s (default) hdg 180",
                 "cruise 10 m/s hdg 000", "cruise 10 m/s hdg 180", "landing from 30 m"):
        for side, phases in (("sim", sim), ("SITL", real)):
            if name not in phases:
                problems.append(f"{side}: no {name}")
        if name in sim and name in real:
            s, r = sim[name], real[name]
            if abs(s.mean_voltage_v - r.mean_voltage_v) > 0.05:
                problems.append(f"{name}: voltage sim {s.mean_voltage_v:.2f}, SITL {r.mean_voltage_v:.2f}")
            if name != "landing from 30 m" and abs(s.remaining_to - r.remaining_to) > 3:
                problems.append(f"{name}: remaining sim {s.remaining_to}, SITL {r.remaining_to}")
    for side, phases in (("sim", sim), ("SITL", real)):
        if phases["armed idle on the ground"].mean_current_a != -1.0:
            problems.append(f"{side}: current {phases['armed idle on the ground'].mean_current_a} A, not -1")
        if phases["disarmed"].remaining_to < 97:
            after = phases["disarmed"]
            problems.append(f"{side}: {after.remaining_to} % {after.seconds:.1f} s after the disarm")
    assert real["cruise 10 m/s hdg 000"].remaining_to > real["hover"].remaining_to  # the thrust reads higher
    assert problems == []
