"""Pure pieces: unicycle kinematics, the airframe, batteries and failsafe decisions, sensor,
modes, the local frame."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

import sim
from planner.georef import LocalFrame
from planner.sensor_noise import reading_draw
from sim.autopilot.failsafe import FailsafeLevel, failsafe_level, failsafe_to_trigger
from sim.autopilot.modes import Mode, custom_mode_of, mode_from_custom
from sim.physics.airframe import Airframe, Goal, HomePose
from sim.physics.battery import Battery, BatteryConfig, CopterDraw, Load, PlaneDraw, SihBattery
from sim.physics.kinematics import (
    COPTER_ACCEL_M_S2,
    KinematicLimits,
    KinematicState,
    corner_fraction,
    step_toward,
    wrap_pi,
)
from sim.physics.sensor import DownwardSensor, SensorConfig

PLANE = KinematicLimits(cruise_speed_m_s=20, turn_rate_rad_s=math.radians(20), climb_rate_m_s=5,
                        descent_rate_m_s=3, can_hover=False)
COPTER = KinematicLimits(cruise_speed_m_s=10, turn_rate_rad_s=math.radians(90), climb_rate_m_s=2.5,
                         descent_rate_m_s=1.5, can_hover=True)


@settings(max_examples=200, deadline=None)
@given(
    heading=st.floats(-math.pi, math.pi),
    tx=st.floats(-2000, 2000), ty=st.floats(-2000, 2000), talt=st.floats(0, 200),
    dt=st.floats(0.01, 0.1),
)
def test_plane_keeps_speed_and_respects_turn_and_climb_limits(heading, tx, ty, talt, dt):
    s = KinematicState(0.0, 0.0, 50.0, heading)
    before = (s.east_m, s.north_m, s.alt_m, s.heading_rad)
    step_toward(s, PLANE, dt, target_en=(tx, ty), target_alt_m=talt)
    moved = math.hypot(s.east_m - before[0], s.north_m - before[1])
    assert moved == pytest.approx(PLANE.cruise_speed_m_s * dt, rel=1e-9)
    assert abs(wrap_pi(s.heading_rad - before[3])) <= PLANE.turn_rate_rad_s * dt + 1e-12
    assert -PLANE.descent_rate_m_s * dt - 1e-9 <= s.alt_m - before[2] <= PLANE.climb_rate_m_s * dt + 1e-9


def test_copter_reaches_and_stops_on_a_point_inside_its_turn_circle():
    s = KinematicState(0.0, 0.0, 10.0, 0.0)
    for _ in range(200):
        step_toward(s, COPTER, 0.05, target_en=(3.0, 0.0), target_alt_m=10.0)
    assert math.hypot(s.east_m - 3.0, s.north_m) < 0.05
    assert s.speed_m_s < 0.1


ARDUCOPTER = KinematicLimits(cruise_speed_m_s=10, turn_rate_rad_s=math.radians(360), climb_rate_m_s=2.5,
                             descent_rate_m_s=1.5, can_hover=True, accel_m_s2=COPTER_ACCEL_M_S2)


def _speed_at(s: KinematicState, target: tuple[float, float], pass_fraction: float, within_m: float) -> float:
    """Steps toward `target` (0.01 s each); its speed once within `within_m` of it."""
    for _ in range(12000):
        step_toward(s, ARDUCOPTER, 0.01, target_en=target, target_alt_m=s.alt_m, pass_fraction=pass_fraction)
        if math.hypot(s.east_m - target[0], s.north_m - target[1]) <= within_m:
            return s.speed_m_s
    raise AssertionError("never got there")


def test_an_accelerating_copter_speeds_up_and_brakes_at_its_limit_from_a_stop_to_a_stop():
    """400 m at 10 m/s from a stop to a stop: 40 s, and v/a more (ArduCopter SITL: 47.2 s)."""
    s = KinematicState(0.0, 0.0, 30.0, 0.0)
    speeds = []
    t = 0.0
    while math.hypot(s.east_m, s.north_m - 400.0) > 1e-6:
        step_toward(s, ARDUCOPTER, 0.01, target_en=(0.0, 400.0), target_alt_m=30.0)
        speeds.append(s.speed_m_s)
        t += 0.01
    assert t == pytest.approx(400.0 / 10.0 + 10.0 / COPTER_ACCEL_M_S2, abs=0.2)
    assert max(b - a for a, b in zip(speeds, speeds[1:])) <= COPTER_ACCEL_M_S2 * 0.01 + 1e-9
    assert max(speeds) == pytest.approx(10.0)


def test_an_accelerating_copter_passes_a_corner_at_the_speed_its_turn_allows():
    """It arrives at a waypoint with a 90-degree turn after it at 42 % of its speed, one with 45
    at 45 %, and keeps its speed through a straight one."""
    assert corner_fraction(0.0) == 1.0 and corner_fraction(math.pi) == 0.0
    assert corner_fraction(math.radians(90)) == pytest.approx(0.42)
    assert corner_fraction(math.radians(-45)) == pytest.approx(0.45)
    for fraction in (0.42, 0.45, 1.0):
        s = KinematicState(0.0, 0.0, 30.0, 0.0)
        assert _speed_at(s, (0.0, 200.0), fraction, within_m=0.1) == pytest.approx(10.0 * fraction, abs=0.1)


def test_plane_holding_circles_at_its_turn_radius():
    s = KinematicState(0.0, 0.0, 50.0, 0.0)
    points = []
    for _ in range(int(2 * math.pi / PLANE.turn_rate_rad_s / 0.05)):
        step_toward(s, PLANE, 0.05, target_en=None, target_alt_m=50.0)
        points.append((s.east_m, s.north_m))
    cx = sum(x for x, _ in points) / len(points)
    cy = sum(y for _, y in points) / len(points)
    assert math.hypot(cx - PLANE.turn_radius_m, cy) < 1.0  # turning right from heading north
    radii = [math.hypot(x - cx, y - cy) for x, y in points]
    assert max(radii) - min(radii) < 0.5
    assert sum(radii) / len(radii) == pytest.approx(PLANE.turn_radius_m, rel=0.02)


@pytest.mark.parametrize(
    ("pct", "level"),
    [(100, FailsafeLevel.NONE), (20.01, FailsafeLevel.NONE), (20, FailsafeLevel.LOW),
     (5.01, FailsafeLevel.LOW), (5, FailsafeLevel.CRITICAL), (0, FailsafeLevel.CRITICAL)],
)
def test_failsafe_level_thresholds(pct, level):
    assert failsafe_level(pct, BatteryConfig(low_pct=20, critical_pct=5)) == level


def test_failsafe_triggers_only_on_escalation():
    N, L, C = FailsafeLevel.NONE, FailsafeLevel.LOW, FailsafeLevel.CRITICAL
    table = {(N, N): None, (N, L): L, (N, C): C, (L, L): None, (L, C): C, (L, N): None, (C, L): None, (C, C): None}
    for (current, reached), expected in table.items():
        assert failsafe_to_trigger(current, reached) == expected


def test_battery_integrates_the_draws_current_into_charge_and_energy_and_fails_on_demand():
    b = Battery(BatteryConfig(endurance_s=1000), CopterDraw(), cruise_current_a=36.0)
    assert b.capacity_mah == pytest.approx(10_000.0)  # the endurance at the cruise current
    b.step(100, Load(armed=False), 12.6)
    b.step(100, Load(armed=True), 12.6)
    assert b.consumed_mah == 0.0 and b.current_a == 0.0  # ArduCopter draws nothing on the ground
    b.step(100, Load(armed=True, flying=True), 12.6)  # hovering: 28.1 A
    assert b.current_a == pytest.approx(28.1)
    assert b.consumed_mah == pytest.approx(28.1 * 100 / 3.6)
    assert b.energy_j == pytest.approx(28.1 * 12.6 * 100)
    assert b.remaining_pct == pytest.approx(100.0 - 100.0 * 28.1 * 100 / 3.6 / 10_000.0)
    b.drain_multiplier = 10
    b.step(1, Load(armed=True, flying=True), 12.6)
    assert b.current_a == pytest.approx(281.0)
    b.fail()
    assert b.remaining_pct == 0
    assert Battery(BatteryConfig(capacity_mah=3300, endurance_s=5), CopterDraw(), 30.0).capacity_mah == 3300


def test_arducopter_draw_rises_with_air_speed_and_climb_as_measured_on_sitl():
    """docs/energy.md: hover 28.1 A, 5 m/s 28.3 A, 10 m/s 30.3 A, climbing 2.5 m/s 30.5 A,
    descending 1.5 m/s 26.9 A and 0.5 m/s 27.7 A; spooling up for take-off the climb's current."""
    d = CopterDraw()
    flying = dict(armed=True, flying=True)
    assert d.current_a(Load(**flying)) == pytest.approx(28.1)
    assert d.current_a(Load(**flying, airspeed_m_s=5.0)) == pytest.approx(28.3)
    assert d.current_a(Load(**flying, airspeed_m_s=7.5)) == pytest.approx(29.3)
    assert d.current_a(Load(**flying, airspeed_m_s=10.0)) == pytest.approx(30.3)
    assert d.current_a(Load(**flying, airspeed_m_s=30.0)) == pytest.approx(31.8)  # the table's end
    assert d.current_a(Load(**flying, climb_m_s=2.5)) == pytest.approx(30.5, abs=0.05)
    assert d.current_a(Load(**flying, climb_m_s=-1.5)) == pytest.approx(26.9)
    assert d.current_a(Load(**flying, climb_m_s=-0.5)) == pytest.approx(27.7)
    assert d.current_a(Load(armed=True, launching=True)) == pytest.approx(30.5, abs=0.05)
    assert d.throttle(Load(**flying)) == pytest.approx(0.36, abs=0.005)
    assert d.sag_v(Load(**flying, climb_m_s=2.5)) == 0.0


def test_arduplane_draw_is_full_throttle_to_climb_and_sags_the_voltage():
    """docs/energy.md: 47.2 A and 0.7 V under SIM_BATT_VOLTAGE at full throttle (take-off roll
    and climb), 11.3 A and 0.34 V cruising (49 %), 2.5 A gliding down (23 %), nothing on the ground."""
    d = PlaneDraw()
    assert d.current_a(Load(armed=True, launching=True)) == pytest.approx(47.2)
    assert d.sag_v(Load(armed=True, launching=True)) == pytest.approx(0.7)
    assert d.current_a(Load(armed=True, flying=True, airspeed_m_s=22, climb_m_s=5.0)) == pytest.approx(47.2)
    assert d.current_a(Load(armed=True, flying=True, airspeed_m_s=22)) == pytest.approx(11.3, abs=0.05)
    assert d.sag_v(Load(armed=True, flying=True, airspeed_m_s=22)) == pytest.approx(0.343)
    assert d.current_a(Load(armed=True, flying=True, airspeed_m_s=17, climb_m_s=-0.75)) == pytest.approx(2.5, abs=0.05)
    assert d.current_a(Load(armed=True)) == 0.0 and d.current_a(Load(armed=False, flying=True)) == 0.0


def test_sih_battery_drains_linearly_to_its_floor_refills_and_fails_for_good():
    b = SihBattery()
    b.step(6.0, drain_s=60.0, floor_fraction=0.5)
    assert b.charge == pytest.approx(0.9)
    b.drain_multiplier = 2.0
    b.step(60.0, drain_s=60.0, floor_fraction=0.5)
    assert b.charge == 0.5  # SIM_BAT_MIN_PCT
    b.refill()
    assert b.charge == 1.0
    b.fail()
    b.step(1.0, drain_s=60.0, floor_fraction=0.5)
    b.refill()
    assert b.charge == 0.0 and b.failed


def test_sensor_rates_match_pc_and_pf():
    frame = LocalFrame(-35.0, 149.0)
    cfg = SensorConfig(cell_size_m=10.0, pc=0.8, pf=0.1)
    sensor = DownwardSensor(cfg, frame, [frame.en2geodetic(5.0, 5.0)], seed=1, vehicle_id=1)
    hits_on_target = hits_elsewhere = 0
    for _ in range(2000):
        on, off = sensor.update(5.0, 5.0, 20.0, 0.0), sensor.update(15.0, 5.0, 20.0, 0.0)
        assert on.cell == (0, 0) and on.present and off.cell == (1, 0) and not off.present
        hits_on_target += on.reported
        hits_elsewhere += off.reported
    assert hits_on_target / 2000 == pytest.approx(0.8, abs=0.04)
    assert hits_elsewhere / 2000 == pytest.approx(0.1, abs=0.03)
    assert sensor.update(15.0, 5.0, 20.0, 0.0) is None  # same cell again: no new reading
    assert sensor.update(25.0, 5.0, 1.0, 0.0) is None  # below minimum altitude


def test_sensor_reads_a_cell_over_its_centre_and_not_a_clipped_corner():
    frame = LocalFrame(-35.0, 149.0)
    sensor = DownwardSensor(SensorConfig(cell_size_m=10.0), frame, [], seed=0, vehicle_id=1, origin_en=(-5.0, -5.0))
    cells = []
    for i in range(101):  # a diagonal from the centre of cell (0, 0) to the centre of cell (1, 1)
        obs = sensor.update(0.1 * i, 0.1 * i, 20.0, 0.0)
        if obs is not None:
            cells.append(obs.cell)
    assert cells == [(0, 0), (1, 1)]  # passing the corner shared with (1, 0) and (0, 1) reads neither
    assert sensor.update(9.0, 13.0, 20.0, 0.0) is None  # inside cell (1, 1) again
    assert sensor.update(14.0, 16.0, 20.0, 0.0) is None  # in cell (1, 2) but 5.7 m from its centre
    assert sensor.update(10.0, 19.0, 20.0, 0.0).cell == (1, 2)


def test_sensor_noise_is_fixed_by_seed_vehicle_cell_and_visit():
    """The same looks give the same readings whatever else the vehicle saw in between, and they
    are the planner's simulated readings on the same seed."""
    frame = LocalFrame(-35.0, 149.0)
    cfg = SensorConfig(cell_size_m=10.0, pc=0.5, pf=0.5)
    direct = DownwardSensor(cfg, frame, [], seed=7, vehicle_id=2)
    detour = DownwardSensor(cfg, frame, [], seed=7, vehicle_id=2)
    readings_direct, readings_detour = [], []
    for visit in range(40):
        readings_direct.append(direct.update(5.0, 5.0, 20.0, 0.0).reported)
        direct.update(5.0, 15.0, 20.0, 0.0)
        readings_detour.append(detour.update(5.0, 5.0, 20.0, 0.0).reported)
        for north in (15.0, 25.0, 35.0):
            detour.update(5.0, north, 20.0, 0.0)
        assert readings_direct[-1] == (reading_draw(7, 2, 0, 0, visit) < 0.5)
    assert readings_direct == readings_detour
    assert 5 < sum(readings_direct) < 35
    other = DownwardSensor(cfg, frame, [], seed=8, vehicle_id=2)
    assert [other.update(5.0, 5.0 + 10 * (i % 2), 20.0, 0.0).reported for i in range(80)][::2] != readings_direct


@pytest.mark.parametrize(
    ("profile", "vtype", "mode", "number"),
    [("ardupilot", "copter", Mode.GUIDED, 4), ("ardupilot", "copter", Mode.AUTO, 3),
     ("ardupilot", "copter", Mode.RTL, 6), ("ardupilot", "copter", Mode.LAND, 9),
     ("ardupilot", "plane", Mode.GUIDED, 15), ("ardupilot", "plane", Mode.AUTO, 10),
     ("ardupilot", "plane", Mode.RTL, 11), ("px4", "copter", Mode.AUTO, 4 << 16 | 4 << 24),
     ("px4", "copter", Mode.RTL, 4 << 16 | 5 << 24)],
)
def test_mode_numbers_round_trip(profile, vtype, mode, number):
    assert custom_mode_of(mode, profile, vtype) == number
    assert mode_from_custom(number, profile, vtype) == mode


def test_plane_has_no_land_mode_like_arduplane():
    assert mode_from_custom(9, "ardupilot", "plane") is None


def test_the_simulator_uses_the_planners_local_frame():
    """One local frame: the fleet's homes, each vehicle's airframe and sensor convert with
    `planner.georef.LocalFrame`, so a plan's cells and the simulated world are laid out alike."""
    assert sim.LocalFrame is LocalFrame
    home = HomePose(-35.363261, 149.165230)
    homes = sim.homes_for(3, [home], spacing_m=5.0)
    frame = LocalFrame(home.lat_deg, home.lon_deg)
    for i, h in enumerate(homes):
        assert frame.geodetic2en(h.lat_deg, h.lon_deg) == pytest.approx((5.0 * i, 0.0), abs=1e-6)
    fleet = sim.SimFleet(homes, sim.VehicleConfig(), sim.FleetOptions(base_port=0))
    v = fleet.vehicles[2]
    assert type(v.frame) is LocalFrame and v.airframe.frame is v.frame and v.sensor.frame is v.frame
    assert v.airframe.position_en == pytest.approx((10.0, 0.0), abs=1e-6)
    assert v.airframe.lat_lon_deg == pytest.approx((homes[2].lat_deg, homes[2].lon_deg), abs=1e-12)


def test_airframe_flies_toward_its_goal_touches_down_and_senses():
    frame = LocalFrame(-35.0, 149.0)
    sensor = DownwardSensor(SensorConfig(cell_size_m=10.0), frame, [], seed=0, vehicle_id=1, origin_en=(-5.0, -5.0))
    battery = Battery(BatteryConfig(), CopterDraw(), 30.3)
    body = Airframe(HomePose(-35.0, 149.0, 100.0, 90.0), frame, COPTER, battery, sensor)
    assert body.position_en == pytest.approx((0.0, 0.0), abs=1e-9) and body.heading_deg == pytest.approx(90.0)
    assert body.sense(0.0) is None  # on the ground
    for _ in range(40):
        body.step(0.05, Goal(None, 10.0))  # a copter climbs on the spot
    assert body.kin.alt_m == pytest.approx(COPTER.climb_rate_m_s * 2.0)
    assert body.position_en == pytest.approx((0.0, 0.0), abs=1e-9)
    assert body.sense(2.0).cell == (0, 0)
    for _ in range(40):
        body.step(0.05, Goal((20.0, 0.0), 10.0))
    assert body.position_en == pytest.approx((20.0, 0.0), abs=1e-9)
    body.step(0.05, Goal(None, -1.0, landing=True))
    assert body.touch_down() == pytest.approx(COPTER.descent_rate_m_s)
    assert (body.kin.alt_m, body.kin.speed_m_s, body.kin.climb_m_s) == (0.0, 0.0, 0.0)


def test_physics_knows_no_mavlink_and_no_autopilot():
    """sim/physics is the world: it imports neither the autopilot behaviour nor MAVLink."""
    for path in (Path(__file__).resolve().parents[2] / "sim" / "physics").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            for name in names:
                assert not name.startswith(("pymavlink", "sim.autopilot", "sim.fleet", "sim.vehicle_link", "gcs")), \
                    f"{path.name} imports {name}"


def test_the_simulated_sensor_defaults_to_the_planners_sensor_and_grid():
    """One default per option: what `gcs sim` and the fleet sense unless told otherwise is what
    `gcs plan` plans with."""
    from gcs.plans.options import DEFAULT_CELL_SIZE_M, SearchOptions
    from planner.environment import Sensor

    sim = SensorConfig()
    assert (sim.pc, sim.pf) == (Sensor().pc, Sensor().pf) == (SearchOptions().pc, SearchOptions().pf)
    assert sim.cell_size_m == DEFAULT_CELL_SIZE_M
