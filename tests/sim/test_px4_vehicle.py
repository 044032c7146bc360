"""The `px4` profile's vehicle, stepped by hand (no sockets), against what PX4 v1.15.3 SITL did
(research `px4`, sections named in each test): start-up, arming, MISSION_START, take-off and
reposition altitudes, landing and auto-disarm, RTL, re-plans, the battery and its failsafes,
link loss, OFFBOARD, the geofence, parameters and texts."""

from __future__ import annotations

import math
import struct
from dataclasses import replace

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import renumber
from sim import HomePose, MissionType, Mode, VehicleConfig, WireItem, new_vehicle
from sim.autopilot.px4 import BOOT_TIMES
from tests.sim.helpers import SteppedVehicle, distance_m, offset

HOME = HomePose(47.2771883, 11.4039709, 584.0, 90.0)
REL, ABS = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL
REL_INT, ABS_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_INT
MODES = {"MANUAL": (1, 0), "POSCTL": (3, 0), "OFFBOARD": (6, 0), "TAKEOFF": (4, 2), "HOLD": (4, 3),
         "MISSION": (4, 4), "RTL": (4, 5), "LAND": (4, 6)}
ACCEPTED, REJECTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED, UNSUPPORTED = mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_UNSUPPORTED
READY_S = BOOT_TIMES["copter"].prearm_s


class Sim(SteppedVehicle):
    """A px4-profile vehicle stepped by hand, hearing its station's HEARTBEAT; texts with PX4's
    trailing tab removed and its chunks joined."""

    def run(self, seconds: float, until=None, dt: float = 0.05, station: bool = True) -> None:
        super().run(seconds, until, dt, station)

    def command_int(self, command: int, frame: int, p: tuple, lat: float, lon: float, z: float) -> int:
        out = self.handle(mavlink.MAVLink_command_int_message(1, 1, frame, command, 0, 0, *p, round(lat * 1e7),
                                                              round(lon * 1e7), z))
        return next(m.result for m in out if m.get_type() == "COMMAND_ACK")

    def mode(self, name: str) -> int:
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, *MODES[name])

    def arm(self, arm: bool = True) -> int:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1 if arm else 0)

    def param(self, name: str, value: float, int32: bool = False) -> mavlink.MAVLink_message:
        raw = struct.unpack("<f", struct.pack("<i", int(value)))[0] if int32 else value
        kind = mavlink.MAV_PARAM_TYPE_INT32 if int32 else mavlink.MAV_PARAM_TYPE_REAL32
        out = self.handle(mavlink.MAVLink_param_set_message(1, 1, name.encode(), raw, kind))
        return next(m for m in out if m.get_type() == "PARAM_VALUE")

    def texts(self, since: int = 0) -> list[str]:
        out, chunks = [], {}
        for _, m in self.sent[since:]:
            if m.get_type() != "STATUSTEXT":
                continue
            chunks[m.id] = chunks.get(m.id, "") + m.text
            if len(m.text) < 50:
                out.append(chunks.pop(m.id).rstrip("\t"))
        return out

    def upload(self, items: list[WireItem], mission_type: int = 0) -> int:
        """COUNT, each request answered with MISSION_ITEM_INT; the ACK's result."""
        out = self.handle(mavlink.MAVLink_mission_count_message(1, 1, len(items), mission_type))
        while True:
            answer = next(m for m in out if m.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"))
            if answer.get_type() == "MISSION_ACK":
                return answer.type
            out = self.handle(items[answer.seq].to_msg((1, 1)))

    @property
    def here(self) -> tuple[float, float]:
        return self.v.airframe.lat_lon_deg

    @property
    def custom_mode(self) -> tuple[int, int]:
        return (self.v.custom_mode >> 16) & 0xFF, self.v.custom_mode >> 24


def sim(**config) -> Sim:
    return Sim(new_vehicle(1, HOME, VehicleConfig(profile="px4", **config)))


def ready(**config) -> Sim:
    """A copter past its start-up (measured times)."""
    s = sim(**config)
    s.run(READY_S + 1.0)
    return s


def item(seq: int, command: int, east: float = 0.0, north: float = 0.0, alt: float = 30.0,
         frame: int = REL, **params) -> WireItem:
    lat, lon = offset(HOME, east, north)
    return WireItem(seq=seq, frame=frame, command=command, x=round(lat * 1e7), y=round(lon * 1e7), z=alt, **params)


def mission(*legs: tuple[float, float], alt: float = 30.0) -> list[WireItem]:
    """§4: take-off at home, waypoints (east, north), land at home."""
    wp = mavlink.MAV_CMD_NAV_WAYPOINT
    items = [item(0, mavlink.MAV_CMD_NAV_TAKEOFF, alt=alt)]
    items += [item(i + 1, wp, e, n, alt) for i, (e, n) in enumerate(legs)]
    return items + [item(len(items), mavlink.MAV_CMD_NAV_LAND, alt=0.0)]


def hovering(alt: float = 20.0) -> Sim:
    """A ready copter holding at `alt` after NAV_TAKEOFF (param7 above sea level)."""
    s = ready()
    assert s.arm() == ACCEPTED
    assert s.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, HOME.alt_m + alt) == ACCEPTED
    s.run(40.0, until=lambda v: v.mode == Mode.LOITER and not v.landed)
    return s


# ---- start-up and arming (§3, §8) -------------------------------------------------------------


def test_gps_and_home_come_at_once_but_arming_waits_for_the_prearm_bit_in_health_only():
    s = sim()
    s.run(3.0)
    assert s.v.home_set and s.v.gps_fixed
    assert s.of("HOME_POSITION") and s.of("GPS_GLOBAL_ORIGIN")
    result, texts = s.said(s.arm)
    assert result == REJECTED and texts == ["Arming denied: Resolve system health failures first"]
    s.run(READY_S + 1.05 - s.v.time_s)
    position = [m for t, m in s.of("GLOBAL_POSITION_INT") if t < BOOT_TIMES["copter"].position_s - 0.1]
    assert position and all((m.lat, m.lon) == (0, 0) for m in position)
    bit = mavlink.MAV_SYS_STATUS_PREARM_CHECK
    status = s.of("SYS_STATUS")
    assert all(not m.onboard_control_sensors_present & bit and not m.onboard_control_sensors_enabled & bit
               for _, m in status)
    ready_at = s.first("SYS_STATUS", lambda m: m.onboard_control_sensors_health & bit)
    assert READY_S - 1.0 < ready_at <= READY_S + 1.0
    assert s.said(s.arm) == (ACCEPTED, ["Armed by external command"])


def test_the_estimator_has_its_position_a_second_before_the_prearm_bit():
    position_ok = mavlink.ESTIMATOR_POS_HORIZ_ABS
    s = sim()
    for t, ok in ((35.5, False), (36.5, True)):
        s.run(t - s.v.time_s)
        out = s.handle(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                                            mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS, 0, 0, 0, 0, 0, 0))
        flags = next(m.flags for m in out if m.get_type() == "ESTIMATOR_STATUS")
        assert bool(flags & position_ok) == ok and bool(flags & mavlink.ESTIMATOR_CONST_POS_MODE) != ok
    assert not s.v.prearm_ok


def test_com_armable_0_clears_the_bit_and_refuses_arming_until_it_is_1_again():
    s = ready()
    value = s.param("COM_ARMABLE", 0, int32=True)
    assert value.param_type == mavlink.MAV_PARAM_TYPE_INT32 and value.param_value == 0.0
    assert "Preflight Fail: Vehicle is in safety configuration" in s.texts()
    s.run(1.1)
    assert not s.of("SYS_STATUS")[-1][1].onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_PREARM_CHECK
    assert s.said(s.arm) == (REJECTED, ["Arming denied: Resolve system health failures first"])
    one = s.param("COM_ARMABLE", 1, int32=True)
    assert struct.unpack("<i", struct.pack("<f", one.param_value))[0] == 1  # PX4 sends INT32 bytewise
    assert s.arm() == ACCEPTED


def test_armed_and_left_on_the_ground_it_disarms_after_11_s_and_refuses_to_disarm_in_flight():
    s = ready()
    s.arm()
    armed_at = s.v.time_s
    s.run(15.0, until=lambda v: not v.armed)
    assert 10.9 <= s.v.time_s - armed_at <= 11.1
    assert s.texts()[-1] == "Disarmed by auto preflight disarming"
    h = hovering()
    assert h.said(h.arm, False) == (REJECTED, ["Disarming denied: not landed"])
    assert h.v.armed


# ---- telemetry (§3) ---------------------------------------------------------------------------


def test_streams_at_px4_rates_and_set_message_interval_fails_for_mission_current_and_ekf():
    s = ready()
    start = s.v.time_s
    s.run(10.0)
    counts = {kind: len(s.of(kind, start)) for kind in ("GLOBAL_POSITION_INT", "GPS_RAW_INT", "VFR_HUD",
                                                        "SYS_STATUS", "BATTERY_STATUS", "HOME_POSITION")}
    expected = {"GLOBAL_POSITION_INT": 200, "GPS_RAW_INT": 50, "VFR_HUD": 40, "SYS_STATUS": 10, "BATTERY_STATUS": 5,
                "HOME_POSITION": 5}  # 50 Hz: one per 0.05 s step at most
    assert all(abs(counts[k] - n) <= 1 for k, n in expected.items()), counts
    interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
    assert s.command(interval, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, 1e6) == mavlink.MAV_RESULT_FAILED
    assert s.command(interval, mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 1e6) == mavlink.MAV_RESULT_FAILED
    assert s.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT) == DENIED
    assert s.command(interval, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 250_000) == ACCEPTED
    assert s.command(interval, mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS, 1e6) == ACCEPTED
    start = s.v.time_s
    s.run(10.0)
    assert abs(len(s.of("GLOBAL_POSITION_INT", start)) - 40) <= 1
    assert len(s.of("MISSION_CURRENT", start)) >= 10  # sent at 1 Hz all the same
    gps = s.of("GPS_RAW_INT")[-1][1]
    assert (gps.fix_type, gps.satellites_visible) == (mavlink.GPS_FIX_TYPE_3D_FIX, 10)


def test_battery_status_reads_as_sih_reports_it():
    s = ready()
    s.run(2.1)
    b = s.of("BATTERY_STATUS")[-1][1]
    assert (b.voltages[0], b.voltages[1], b.current_battery, b.current_consumed, b.energy_consumed) == \
        (16200, 65535, -100, 0, -1)
    assert (b.battery_remaining, b.time_remaining, b.charge_state, b.temperature) == \
        (100, 0, mavlink.MAV_BATTERY_CHARGE_STATE_OK, 32767)
    status = s.of("SYS_STATUS")[-1][1]
    assert (status.voltage_battery, status.current_battery, status.battery_remaining) == (16200, -100, 100)


# ---- launch and mission flight (§4) -----------------------------------------------------------


def test_mission_start_from_hold_on_the_ground_arms_takes_off_flies_and_lands_disarmed_in_mission():
    s = ready()
    assert s.custom_mode == MODES["HOLD"]
    assert s.upload(mission((0, 60))) == mavlink.MAV_MISSION_ACCEPTED
    start = s.v.time_s
    result, texts = s.said(s.command, mavlink.MAV_CMD_MISSION_START, 0, 0)
    assert result == ACCEPTED
    assert texts == ["Armed by mission start", "Executing Mission", "Climb to 30.0 meters above home"]
    assert s.v.armed and s.custom_mode == MODES["MISSION"]
    s.run(300.0, until=lambda v: not v.armed)
    s.run(1.5)
    landed = [m.landed_state for _, m in s.of("EXTENDED_SYS_STATE", start)]
    states = [st for i, st in enumerate(landed) if i == 0 or st != landed[i - 1]]
    assert states == [mavlink.MAV_LANDED_STATE_ON_GROUND, mavlink.MAV_LANDED_STATE_TAKEOFF,
                      mavlink.MAV_LANDED_STATE_IN_AIR, mavlink.MAV_LANDED_STATE_LANDING,
                      mavlink.MAV_LANDED_STATE_ON_GROUND]
    reached = [m.seq for _, m in s.of("MISSION_ITEM_REACHED")]
    assert reached == [0, 1, 2]  # the NAV_LAND item over its point, before the descent
    above_one_m = s.first("GLOBAL_POSITION_INT", lambda m: m.relative_alt > 1000)
    assert 4.5 < above_one_m - start < 6.0  # §4: 5.3 s
    took_off = s.first("MISSION_ITEM_REACHED", lambda m: m.seq == 0)
    assert 18.0 < took_off - start < 22.0  # §4: 19.9 s
    assert s.texts()[-3:] == ["Landing detected", "Mission finished, landed", "Disarmed by landing"]
    assert s.custom_mode == MODES["MISSION"]  # the mode still reads MISSION after the landing
    assert distance_m(*s.here, HOME.lat_deg, HOME.lon_deg) < 1.0
    currents = [m.seq for _, m in s.of("MISSION_CURRENT", start)]
    assert sorted(set(currents)) == [0, 1, 2]


def test_landing_takes_about_30_s_from_30_m():
    s = ready()
    s.upload(mission())
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(60.0, until=lambda v: 1 in v.reached)  # over the landing point
    over = s.v.time_s
    s.run(60.0, until=lambda v: v.landed)
    assert 26.0 < s.v.time_s - over < 32.0  # §4: 30 s (MPC_LAND_SPEED 0.7 m/s below 10 m)


def test_mission_start_checks_the_mission_and_its_first_item():
    s = ready()
    result, texts = s.said(s.command, mavlink.MAV_CMD_MISSION_START, 0, 0)
    assert (result, texts) == (DENIED, ["Mission start denied! No valid mission"])
    s.upload(mission((0, 50), (50, 50), (50, 0), (0, 0)))
    for first in (6, 7, -2, math.nan):
        assert s.said(s.command, mavlink.MAV_CMD_MISSION_START, first, 0) == (DENIED, [])
    s.upload([item(0, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1000), item(1, mavlink.MAV_CMD_NAV_LAND, alt=0.0)])
    assert [p.split(":")[0] for p in s.v.mission_problems()] == ["First waypoint too far away"]
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == DENIED
    s.upload([item(0, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 50), item(1, mavlink.MAV_CMD_NAV_TAKEOFF)])
    assert s.v.mission_problems() == ["Mission rejected: takeoff not first waypoint item"]
    s.upload([item(0, mavlink.MAV_CMD_NAV_LAND, 0, 50, alt=0.0)])
    assert s.v.mission_problems() == ["Mission rejected: starts with landing"]
    s.upload(mission((0, 50)))
    assert s.command(mavlink.MAV_CMD_MISSION_START, 2, 0) == ACCEPTED  # param1: the first item
    assert s.v.mission_seq == 2


def test_a_mission_start_refused_for_arming_leaves_mission_intended_and_the_next_arm_starts_it():
    s = ready()
    s.upload(mission((0, 50)))
    s.param("COM_ARMABLE", 0, int32=True)
    result, texts = s.said(s.command, mavlink.MAV_CMD_MISSION_START, 0, 0)
    assert result == REJECTED
    assert texts == ["Arming denied: Resolve system health failures first",
                     "Switching to Mission is currently not available"]
    assert not s.v.armed and s.custom_mode == MODES["HOLD"]
    s.param("COM_ARMABLE", 1, int32=True)
    result, texts = s.said(s.arm)
    assert result == ACCEPTED and texts[:2] == ["Armed by external command", "Executing Mission"]
    assert s.custom_mode == MODES["MISSION"]


@pytest.mark.parametrize("arm_first", [True, False])
def test_arm_then_mode_mission_or_mode_mission_then_arm_both_fly(arm_first):
    s = ready()
    s.upload(mission((0, 50)))
    steps = [s.arm, lambda: s.mode("MISSION")]
    assert [step() for step in (steps if arm_first else steps[::-1])] == [ACCEPTED, ACCEPTED]
    s.run(30.0, until=lambda v: 0 in v.reached)
    assert s.v.airframe.kin.alt_m > 29.0


# ---- re-plans (§5) ----------------------------------------------------------------------------


def _flying_leg_two() -> Sim:
    s = ready()
    s.upload(mission((0, 150), (150, 150), (150, 0)))
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(200.0, until=lambda v: v.mission_seq == 2)
    s.run(5.0)
    return s


def test_hold_upload_mission_start_flies_the_new_list_from_its_first_item():
    s = _flying_leg_two()
    assert s.mode("HOLD") == ACCEPTED
    assert s.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 0) == UNSUPPORTED
    new = [item(0, mavlink.MAV_CMD_NAV_WAYPOINT, -100, -100), item(1, mavlink.MAV_CMD_NAV_WAYPOINT, 0, -150),
           item(2, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]
    assert s.upload(new) == mavlink.MAV_MISSION_ACCEPTED
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == ACCEPTED
    s.run(300.0, until=lambda v: not v.armed)
    after = [m.seq for t, m in s.of("MISSION_ITEM_REACHED")][-3:]
    assert after == [0, 1, 2]
    assert distance_m(*s.here, HOME.lat_deg, HOME.lon_deg) < 1.0


def test_hold_upload_mode_mission_resumes_at_the_old_index_and_skips_the_new_waypoints():
    s = _flying_leg_two()
    s.mode("HOLD")
    new = [item(0, mavlink.MAV_CMD_NAV_WAYPOINT, -100, -100), item(1, mavlink.MAV_CMD_NAV_WAYPOINT, 0, -150),
           item(2, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]
    s.upload(new)
    mark = s.mark()
    assert s.mode("MISSION") == ACCEPTED
    s.run(300.0, until=lambda v: not v.armed)
    assert [m.seq for _, m in s.sent[mark:] if m.get_type() == "MISSION_ITEM_REACHED"] == [2]


def test_mission_set_current_message_points_the_mission_at_an_item():
    s = _flying_leg_two()
    s.mode("HOLD")
    s.handle(mavlink.MAVLink_mission_set_current_message(1, 1, 0))
    assert s.v.mission_seq == 0 and s.of("MISSION_CURRENT")[-1][1].seq == 0
    assert s.said(s.handle, mavlink.MAVLink_mission_set_current_message(1, 1, 9))[1] == \
        ["WPM: WP CURR CMD: Not in list"]


# ---- commands without a mission (§9) ----------------------------------------------------------


def test_nav_takeoff_takes_param7_above_sea_level():
    s = hovering(20.0)
    assert 19.4 < s.v.airframe.kin.alt_m < 20.6 and s.custom_mode == MODES["HOLD"]
    low = ready()
    low.arm()
    result, texts = low.said(low.command, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, 30)
    assert (result, texts) == (ACCEPTED, ["Already higher than takeoff altitude"])
    low.run(12.0, until=lambda v: not v.armed)
    assert low.v.airframe.kin.alt_m == 0.0 and low.texts()[-1] == "Disarmed by auto preflight disarming"
    default = ready()
    default.arm()
    result, texts = default.said(default.command, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan,
                                 math.nan)
    assert texts == ["Using default takeoff altitude: 2.5 m"]
    default.run(20.0, until=lambda v: v.mode == Mode.LOITER and not v.landed)
    assert 2.0 < default.v.airframe.kin.alt_m < 3.0


def test_do_reposition_altitude_is_above_sea_level_and_a_relative_frame_6_height_lands_it():
    s = hovering(20.0)
    lat, lon = offset(HOME, 0, 50)
    assert s.command(mavlink.MAV_CMD_DO_REPOSITION, -1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, math.nan,
                     lat, lon, HOME.alt_m + 20) == ACCEPTED
    s.run(30.0, until=lambda v: distance_m(*v.airframe.lat_lon_deg, lat, lon) < 1.0)
    assert s.custom_mode == MODES["HOLD"] and 19.0 < s.v.airframe.kin.alt_m < 21.0
    for frame in (ABS_INT, mavlink.MAV_FRAME_GLOBAL):
        assert s.command_int(mavlink.MAV_CMD_DO_REPOSITION, frame, (-1, 1, 0, math.nan), *offset(HOME, 0, 0),
                             HOME.alt_m + 25) == ACCEPTED
    s.run(30.0, until=lambda v: distance_m(*v.airframe.lat_lon_deg, HOME.lat_deg, HOME.lon_deg) < 1.0)
    assert 24.0 < s.v.airframe.kin.alt_m < 26.0
    start = s.here
    result = s.command_int(mavlink.MAV_CMD_DO_REPOSITION, REL_INT, (-1, 0, 0, math.nan), *offset(HOME, 0, 50), 20)
    assert result == UNSUPPORTED  # without CHANGE_MODE ... and flown all the same
    s.run(120.0, until=lambda v: not v.armed)
    assert distance_m(*s.here, *start) < 2.0 and s.v.landed


def test_nav_land_lands_where_it_is_and_disarms_3_5_s_after_touchdown():
    s = hovering(20.0)
    far = offset(HOME, 0, 50)
    result, texts = s.said(s.command, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, math.nan, *far, 0)
    assert (result, texts) == (ACCEPTED, ["Landing at current position"])
    s.run(60.0, until=lambda v: v.landed)
    touchdown = s.v.time_s
    assert distance_m(*s.here, HOME.lat_deg, HOME.lon_deg) < 1.0
    s.run(10.0, until=lambda v: not v.armed)
    assert 3.4 < s.v.time_s - touchdown < 3.6
    assert s.texts()[-2:] == ["Landing detected", "Disarmed by landing"]


# ---- RTL (§6) ---------------------------------------------------------------------------------


def _away(north_m: float = 200.0) -> Sim:
    s = ready()
    s.upload([item(0, mavlink.MAV_CMD_NAV_TAKEOFF, alt=20.0),
              item(1, mavlink.MAV_CMD_NAV_WAYPOINT, 0, north_m, 20.0, param1=3600.0)])
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(200.0, until=lambda v: 1 in v.reached)
    return s


def test_rtl_climbs_to_30_m_in_place_flies_home_at_30_m_and_lands_there():
    s = _away()
    start, where = s.v.time_s, s.here
    result, texts = s.said(s.command, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    assert result == ACCEPTED
    assert texts == ["Returning to launch", "RTL: start return at 614 m (30 m above destination)"]
    s.run(30.0, until=lambda v: v.airframe.kin.alt_m > 29.5)
    assert distance_m(*s.here, *where) < 1.0  # straight up first
    s.run(100.0, until=lambda v: distance_m(*v.airframe.lat_lon_deg, HOME.lat_deg, HOME.lon_deg) < 2.0)
    assert s.v.airframe.kin.alt_m > 29.0
    mark = s.mark()
    s.run(120.0, until=lambda v: not v.armed)
    assert s.texts(mark) == ["RTL: land at destination", "Landing detected", "Disarmed by landing"]
    assert distance_m(*s.here, HOME.lat_deg, HOME.lon_deg) < 1.0
    assert 70.0 < s.v.time_s - start < 95.0  # §6: 83.7 s
    assert s.custom_mode == MODES["MISSION"]  # back to the mission it flew


@pytest.mark.parametrize("frame", [REL, ABS])
def test_rtl_lands_at_a_nearer_rally_point_uploaded_in_frame_3_or_0(frame):
    s = _away()
    lat, lon = offset(HOME, -60, 120)
    z = 15.0 if frame == REL else HOME.alt_m + 15.0
    assert s.upload([WireItem(seq=0, frame=frame, command=mavlink.MAV_CMD_NAV_RALLY_POINT, x=round(lat * 1e7),
                              y=round(lon * 1e7), z=z, mission_type=2)], 2) == mavlink.MAV_MISSION_ACCEPTED
    assert s.said(s.mode, "RTL")[1][1] == "RTL: start return at 629 m (30 m above destination)"
    s.run(200.0, until=lambda v: not v.armed)
    assert distance_m(*s.here, lat, lon) < 1.0


def test_a_rally_point_in_frame_6_breaks_rtl_it_climbs_without_end():
    s = _away()
    lat, lon = offset(HOME, -60, 120)
    s.upload([WireItem(seq=0, frame=REL_INT, command=mavlink.MAV_CMD_NAV_RALLY_POINT, x=round(lat * 1e7),
                       y=round(lon * 1e7), z=15.0, mission_type=2)], 2)
    s.run(3.0)
    assert "RTL: unsupported MAV_FRAME" in s.texts()  # said while armed, before any RTL
    where = s.here
    assert "RTL: start return at -2147483648 m (0 m above destination)" in s.said(s.mode, "RTL")[1]
    s.run(100.0)
    assert s.v.airframe.kin.alt_m > 150.0 and distance_m(*s.here, *where) < 1.0


# ---- battery (§7) -----------------------------------------------------------------------------


def test_the_battery_drains_only_while_armed_at_100_per_sim_bat_drain_down_to_sim_bat_min_pct():
    s = ready()
    s.run(30.0)
    assert s.v.battery_pct == 100.0  # disarmed: no drain
    s.upload([item(0, mavlink.MAV_CMD_NAV_TAKEOFF, alt=15.0),
              item(1, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 0, 15.0, param1=3600.0)])
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(10.0)
    sih = s.v.airframe.battery  # SIH's state of charge
    a, t_a = sih.charge, s.v.time_s
    s.run(10.0)
    assert (a - sih.charge) / (s.v.time_s - t_a) == pytest.approx(1 / 60.0)  # SIM_BAT_DRAIN 60 s
    s.run(60.0)
    assert sih.charge == pytest.approx(0.5) and round(s.v.battery_pct) == 61  # the floor, read under load
    assert s.of("BATTERY_STATUS")[-1][1].voltages[0] == 15300
    s.param("SIM_BAT_DRAIN", 150.0)
    s.param("SIM_BAT_MIN_PCT", 0.0)
    a, t_a = sih.charge, s.v.time_s
    s.run(10.0)
    assert (a - sih.charge) / (s.v.time_s - t_a) == pytest.approx(1 / 150.0)
    s.run(300.0)
    assert round(s.v.battery_pct) == 11 and s.v.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    assert "Low battery level" in s.texts() and "Failsafe activated" in s.texts()
    s.handle(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 21196,
                                                  0, 0, 0, 0, 0))
    assert not s.v.armed and s.v.battery_pct < 1.0  # PX4 filters the voltage it reads (1 s)
    s.run(0.4)
    assert 20.0 < s.v.battery_pct < 50.0  # a third of the way back (SITL: 15.3 V to 15.6 V in 0.4 s)
    s.run(4.6)
    assert s.v.battery_pct > 98.0  # full again once disarmed, within 5 s from empty


@pytest.mark.parametrize(("action", "then"), [(2, Mode.LAND), (3, Mode.RTL)])
def test_com_low_bat_act_holds_5_s_at_critical_then_lands_or_returns(action, then):
    s = _away()
    for name, value in (("BAT_LOW_THR", 0.5), ("BAT_CRIT_THR", 0.3), ("BAT_EMERGEN_THR", 0.2),
                        ("SIM_BAT_DRAIN", 150.0), ("SIM_BAT_MIN_PCT", 0.0)):
        s.param(name, value)
    s.param("COM_LOW_BAT_ACT", action, int32=True)
    s.run(200.0, until=lambda v: v.mode == Mode.LOITER and v.time_s > 0)
    assert s.texts()[-1] == "Failsafe activated: entering Hold for 5 seconds"
    held = s.v.time_s
    s.run(10.0, until=lambda v: v.mode == then)
    assert 4.9 < s.v.time_s - held < 5.2
    if action == 3:  # still flying home when the emergency level comes: it lands where it is
        s.run(400.0, until=lambda v: v.failsafe.name == "EMERGENCY")
        assert s.texts()[-2:] == ["System does not support shutdown", "Failsafe activated"]  # no "Landing at ..."
        assert s.v.mode == Mode.LAND


# ---- link loss, OFFBOARD, geofence (§8, §9, §13) ----------------------------------------------


def test_nav_dll_act_2_holds_then_returns_when_the_station_goes_quiet_and_the_mission_goes_on_with_0():
    s = _away()
    s.run(60.0, station=False)  # nothing heard for 60 s: NAV_DLL_ACT 0 ignores it
    assert s.v.mode == Mode.AUTO
    assert s.said(s.handle, mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))[1] == ["GCS connection regained"]
    s.param("NAV_DLL_ACT", 2, int32=True)
    quiet = s.v.time_s
    s.run(20.0, until=lambda v: v.mode == Mode.LOITER, station=False)
    assert s.v.time_s - quiet == pytest.approx(10.0, abs=0.1)  # COM_DL_LOSS_T, no text
    s.run(10.0, until=lambda v: v.mode == Mode.RTL, station=False)
    assert s.v.time_s - quiet == pytest.approx(15.0, abs=0.1)


def test_position_setpoints_fly_only_in_offboard_and_their_loss_falls_back_to_a_sinking_posctl():
    s = hovering(20.0)
    lat, lon = offset(HOME, 0, 50)

    def setpoint():
        s.handle(mavlink.MAVLink_set_position_target_global_int_message(
            0, 1, 1, REL_INT, 0b110111111000, round(lat * 1e7), round(lon * 1e7), 20.0, 0, 0, 0, 0, 0, 0, 0, 0))

    assert s.said(s.mode, "OFFBOARD") == (REJECTED, ["Switching to Offboard is currently not available"])
    for _ in range(20):
        setpoint()
        s.run(0.1)
    assert distance_m(*s.here, HOME.lat_deg, HOME.lon_deg) < 0.5  # ignored in HOLD
    assert s.mode("OFFBOARD") == ACCEPTED
    for _ in range(100):
        setpoint()
        s.run(0.1)
    assert distance_m(*s.here, lat, lon) < 1.0
    s.run(10.0, until=lambda v: v.mode == Mode.POSCTL)
    assert s.texts()[-1] == "Failsafe activated"
    alt = s.v.airframe.kin.alt_m
    s.run(16.0)
    assert alt - s.v.airframe.kin.alt_m == pytest.approx(12.0, abs=0.5)  # §9: 19 to 7 m in 16 s


def _square(half: float, inclusion: bool = True, centre=(0.0, 0.0)) -> list[WireItem]:
    cmd = (mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION if inclusion
           else mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
    corners = [(-half, -half), (-half, half), (half, half), (half, -half)]
    return [item(k, cmd, centre[0] + e, centre[1] + n, 0.0, frame=ABS, param1=4.0, mission_type=1)
            for k, (e, n) in enumerate(corners)]


def test_a_fence_without_home_is_ignored_and_a_waypoint_outside_a_good_one_makes_the_mission_invalid():
    s = ready()
    inside = mission((0, 100), (100, 100))
    assert s.upload(_square(200, centre=(300, 300)), 1) == mavlink.MAV_MISSION_ACCEPTED
    s.upload(inside)
    s.run(1.0)
    assert "Geofence invalid, doesn't contain Home position" in s.texts() and s.v.mission_problems() == []
    s.upload(_square(200, centre=(50, 50)), 1)
    outside = mission((0, 100), (100, 400))
    mark = s.mark()
    s.upload(outside)
    s.run(1.0)
    assert s.texts(mark) == ["Geofence violation for waypoint 3"]
    result, texts = s.said(s.command, mavlink.MAV_CMD_MISSION_START, 0, 0)
    assert (result, texts) == (DENIED, ["Mission start denied! No valid mission"])
    s.upload(_square(200, centre=(50, 50)) + [
        replace(v, seq=v.seq + 4) for v in _square(15, False, (100, 100))], 1)
    s.upload(inside)
    assert s.v.mission_problems() == ["Geofence violation for waypoint 3"]


# ---- texts ------------------------------------------------------------------------------------


def test_texts_end_with_a_tab_and_longer_ones_come_in_chunks_of_50():
    s = ready()
    s.upload([item(0, mavlink.MAV_CMD_NAV_TAKEOFF, alt=20.0),
              item(1, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 200, 20.0, param1=3600.0)])
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(200.0, until=lambda v: 1 in v.reached)
    mark = s.mark()
    s.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    raw = [m for _, m in s.sent[mark:] if m.get_type() == "STATUSTEXT"]
    long = "RTL: start return at 614 m (30 m above destination)\t"
    assert [(m.text, m.chunk_seq) for m in raw] == [("Returning to launch\t", 0), (long[:50], 0), (long[50:], 1)]
    assert raw[0].id + 1 == raw[1].id == raw[2].id  # every text has the next id, its chunks share it


def test_a_plane_mission_needs_a_landing_and_a_glide_slope_no_steeper_than_fw_lnd_ang():
    plane = Sim(new_vehicle(1, HOME, VehicleConfig(profile="px4", vehicle_type="plane")))
    wp, land_start = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_DO_LAND_START

    def landing(approach_m: float, approach_alt: float = 30.0, starts: int = 1) -> list[WireItem]:
        items = [item(0, mavlink.MAV_CMD_NAV_TAKEOFF), item(1, wp, 0, 800)]
        items += [WireItem(seq=0, frame=mavlink.MAV_FRAME_MISSION, command=land_start)] * starts
        items += [item(0, wp, 0, -approach_m, approach_alt), item(0, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]
        return renumber(items, MissionType.MISSION)

    cases = [
        (landing(500)[:2], ["Mission rejected: Landing waypoint/pattern required."]),
        (landing(500), []),
        (landing(340), []),
        (landing(250), ["Mission rejected: the landing glide slope is steeper than the vehicle setting of "
                        "5.0 degrees."]),
        (landing(500, starts=2), ["Mission rejected: more than one land start."]),
        (landing(500, approach_alt=-5.0), ["Mission rejected: the approach waypoint must be above the landing "
                                           "point."]),
    ]
    for items, problems in cases:
        plane.v.load_mission(items)
        assert plane.v.mission_problems() == problems
