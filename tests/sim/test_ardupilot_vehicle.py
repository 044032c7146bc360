"""The `ardupilot` profile's vehicle, stepped by hand (no sockets), against what ArduCopter and
ArduPlane 4.7 SITL did (research `ardupilot_flight`, sections named in each test): start-up,
streams, arming refusals, the copter's and the plane's launch, landing and auto-disarm, re-plans,
DO_REPOSITION, the battery."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim import BatteryConfig, HomePose, Mode, VehicleConfig, WireItem, new_vehicle
from sim.autopilot.ardupilot import BOOT_TIMES
from tests.sim.helpers import SteppedVehicle, distance_m, offset

HOME = HomePose(47.2771883, 11.4039709, 584.0, 90.0)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
COPTER = {"GUIDED": 4, "AUTO": 3, "LOITER": 5, "RTL": 6}
PLANE = {"MANUAL": 0, "AUTO": 10, "RTL": 11, "GUIDED": 15}
ACCEPTED, FAILED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED, mavlink.MAV_RESULT_DENIED


class Sim(SteppedVehicle):
    """An ardupilot-profile vehicle stepped by hand."""

    def command_int(self, command: int, p: tuple, lat: float, lon: float, alt: float) -> int:
        out = self.handle(mavlink.MAVLink_command_int_message(1, 1, REL, command, 0, 0, *p, round(lat * 1e7),
                                                              round(lon * 1e7), alt))
        return next(m.result for m in out if m.get_type() == "COMMAND_ACK")

    def mode(self, number: int) -> int:
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number)

    def arm(self) -> int:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def param(self, name: str, value: float) -> None:
        self.handle(mavlink.MAVLink_param_set_message(1, 1, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32))

    def stream(self, msg_id: int, hz: float) -> None:
        assert self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz) == ACCEPTED

    def upload(self, items: list[WireItem]) -> None:
        """The mission protocol as a station runs it: COUNT, then each MISSION_REQUEST answered."""
        out = self.handle(mavlink.MAVLink_mission_count_message(1, 1, len(items), 0))
        while True:
            request = next(m for m in out if m.get_type() in ("MISSION_REQUEST", "MISSION_ACK"))
            if request.get_type() == "MISSION_ACK":
                assert request.type == mavlink.MAV_MISSION_ACCEPTED
                return
            out = self.handle(items[request.seq].to_msg((1, 1)))


def sim(vehicle_type: str = "copter", **config) -> Sim:
    return Sim(new_vehicle(1, HOME, VehicleConfig(vehicle_type=vehicle_type, **config)))


def ready(vehicle_type: str = "copter", **config) -> Sim:
    """A vehicle past its start-up (measured times)."""
    s = sim(vehicle_type, **config)
    s.run(BOOT_TIMES[vehicle_type].ekf_position_s + 3.0)
    return s


def launched() -> Sim:
    """A ready copter started the ArduPilot way: mission, GUIDED, arm, MISSION_START (0, 0)."""
    s = ready()
    s.upload(copter_mission())
    s.mode(COPTER["GUIDED"])
    assert s.arm() == ACCEPTED
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == ACCEPTED
    return s


def hovering() -> Sim:
    """A ready copter at 30 m in GUIDED (NAV_TAKEOFF)."""
    s = ready()
    s.mode(COPTER["GUIDED"])
    s.arm()
    s.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 30)
    s.run(30.0, until=lambda v: v.airframe.kin.alt_m > 29.0)
    return s


def item(seq: int, command: int, east: float = 0.0, north: float = 0.0, alt: float = 30.0, **params) -> WireItem:
    lat, lon = offset(HOME, east, north)
    return WireItem(seq=seq, frame=REL, command=command, x=round(lat * 1e7), y=round(lon * 1e7), z=alt, **params)


def copter_mission() -> list[WireItem]:
    """flight §2: take-off to 30 m, four waypoints, land at home."""
    wp = mavlink.MAV_CMD_NAV_WAYPOINT
    return [item(0, wp, alt=0.0), item(1, mavlink.MAV_CMD_NAV_TAKEOFF), item(2, wp, 0, 150), item(3, wp, 150, 150),
            item(4, wp, 200, 0), item(5, wp, 100, -100), item(6, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]


def plane_mission() -> list[WireItem]:
    """flight §3: take-off to 40 m, a square, DO_LAND_START, an approach 600 m west, land at home."""
    wp = mavlink.MAV_CMD_NAV_WAYPOINT
    return [item(0, wp, alt=0.0), item(1, mavlink.MAV_CMD_NAV_TAKEOFF, alt=40.0, param1=15.0),
            item(2, wp, 500, 0, 50.0), item(3, wp, 500, 400, 50.0), item(4, wp, 0, 400, 50.0),
            item(5, wp, -600, 400, 50.0), item(6, mavlink.MAV_CMD_DO_LAND_START, alt=0.0),
            item(7, wp, -600, 0, 40.0), item(8, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]


# ---- start-up (flight §1) --------------------------------------------------------------------


@pytest.mark.parametrize("vehicle_type", ["copter", "plane"])
def test_readiness_milestones_come_at_the_measured_vehicle_times(vehicle_type):
    s = sim(vehicle_type)
    for msg_id in (mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                   mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT):
        s.stream(msg_id, 20.0)
    s.run(50.0)
    b = BOOT_TIMES[vehicle_type]
    assert s.first("GPS_RAW_INT", lambda m: m.fix_type >= 3) == pytest.approx(b.gps_fix_s, abs=0.06)
    assert s.first("GLOBAL_POSITION_INT", lambda m: m.lat != 0) == pytest.approx(b.gps_fix_s, abs=0.06)
    assert all((m.lat, m.lon) == (0, 0) for t, m in s.of("GLOBAL_POSITION_INT") if t < b.gps_fix_s - 0.01)
    fixed = s.of("GPS_RAW_INT", b.gps_fix_s + 0.1)[0][1]
    assert (fixed.fix_type, fixed.satellites_visible) == (6, 10)
    assert s.first("HOME_POSITION") == pytest.approx(b.home_s, abs=0.06)
    assert s.first("GPS_GLOBAL_ORIGIN") == pytest.approx(b.origin_s, abs=0.06)
    ok = s.first("EKF_STATUS_REPORT", lambda m: m.flags & mavlink.EKF_POS_HORIZ_ABS
                 and not m.flags & mavlink.EKF_CONST_POS_MODE)
    assert ok == pytest.approx(b.ekf_position_s, abs=0.06)
    assert {m.flags for t, m in s.of("EKF_STATUS_REPORT") if t < b.attitude_s} <= {0x400}


def test_copter_arming_is_refused_with_ardupilots_words_until_the_ekf_has_a_position():
    s = sim()
    assert s.mode(COPTER["GUIDED"]) == ACCEPTED  # GUIDED is accepted at once, disarmed
    said = {}
    for t in (5.0, 14.5, 20.5, 25.0, 30.5):
        s.run(t - s.v.time_s)
        result, said[t] = s.said(s.arm)
        assert result == FAILED
    assert said[5.0] == ["Arm: Need Alt Estimate", "Arm: Accels inconsistent", "Arm: EKF attitude is bad",
                         "Arm: AHRS: waiting for home"]
    assert said[14.5] == ["Arm: Gyros inconsistent", "Arm: AHRS: waiting for home"]
    assert said[20.5] == ["Arm: Gyros inconsistent", "Arm: Need Position Estimate"]
    assert said[25.0] == ["Arm: Need Position Estimate"]
    mark = s.mark()
    s.run(0.1)  # 30.6 s
    assert s.texts(mark) == []
    assert [text for t, m in s.sent if m.get_type() == "STATUSTEXT" and 29.9 <= t < 30.2
            for text in [m.text]] == ["PreArm: Need Position Estimate"]  # unprompted every 30 s
    s.run(42.1 - s.v.time_s)
    assert s.said(s.arm) == (ACCEPTED, ["Arming motors"])
    assert s.of("HOME_POSITION", 42.0)  # home moves to where it arms


def test_plane_arming_refusals_and_its_throttle_armed():
    s = sim("plane")
    said = {}
    for t in (4.0, 11.0, 14.0, 24.0):
        s.run(t - s.v.time_s)
        said[t] = s.said(s.arm)
    assert said[4.0] == (FAILED, ["Arm: Accels inconsistent", "Arm: AHRS: waiting for home"])
    assert said[11.0] == (FAILED, ["Arm: Accels inconsistent"])
    assert said[14.0] == (FAILED, ["Arm: Gyros inconsistent"])
    assert said[24.0] == (ACCEPTED, ["Throttle armed"])


def test_the_pre_arm_bit_depends_on_the_mode():
    s = sim()
    s.stream(mavlink.MAVLINK_MSG_ID_SYS_STATUS, 2.0)
    s.run(45.0)
    prearm = mavlink.MAV_SYS_STATUS_PREARM_CHECK
    stabilize = s.first("SYS_STATUS", lambda m: m.onboard_control_sensors_health & prearm)
    assert stabilize == pytest.approx(24.0, abs=0.6)  # STABILIZE needs no position (peer README: 23.6 s)
    g = sim()
    g.stream(mavlink.MAVLINK_MSG_ID_SYS_STATUS, 2.0)
    g.mode(COPTER["GUIDED"])
    g.run(45.0)
    assert g.first("SYS_STATUS", lambda m: m.onboard_control_sensors_health & prearm) == pytest.approx(42.0, abs=0.6)


def test_boot_scale_brings_every_milestone_forward():
    s = sim(boot_scale=0.1)
    s.mode(COPTER["GUIDED"])
    s.run(4.25)
    assert s.first("HOME_POSITION") == pytest.approx(1.98, abs=0.06)
    assert s.arm() == ACCEPTED  # 4.2 s instead of 42 s
    instant = sim(boot_scale=0.0)
    instant.mode(COPTER["GUIDED"])
    instant.run(0.05)
    assert instant.arm() == ACCEPTED
    with pytest.raises(ValueError):
        VehicleConfig(boot_scale=-1.0)


# ---- streams (flight §1, protocol Q6) ---------------------------------------------------------


def test_a_copter_sends_nothing_but_heartbeats_and_events_until_asked():
    s = sim()
    s.run(30.0)
    kinds = {m.get_type() for _, m in s.sent}
    assert "HEARTBEAT" in kinds and kinds <= {"HEARTBEAT", "STATUSTEXT", "HOME_POSITION", "GPS_GLOBAL_ORIGIN"}
    assert len(s.of("HOME_POSITION")) == 1 and len(s.of("GPS_GLOBAL_ORIGIN")) == 1  # once, when set
    s.stream(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 4.0)
    s.handle(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTRA3, 2, 1))
    s.run(10.0)
    assert len(s.of("GLOBAL_POSITION_INT", 30.0)) == pytest.approx(40, abs=1)  # per vehicle second
    assert len(s.of("BATTERY_STATUS", 30.0)) == pytest.approx(20, abs=1)
    assert len(s.of("EKF_STATUS_REPORT", 30.0)) == pytest.approx(20, abs=1)  # same group, EXTRA3
    assert s.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, -1) == ACCEPTED
    s.run(5.0)
    assert not s.of("GLOBAL_POSITION_INT", 40.2)


def test_a_plane_streams_every_group_at_1_hz_unasked():
    s = sim("plane")
    s.run(30.0)
    for kind in ("GLOBAL_POSITION_INT", "SYS_STATUS", "BATTERY_STATUS", "MISSION_CURRENT", "GPS_RAW_INT",
                 "EKF_STATUS_REPORT", "ATTITUDE", "VFR_HUD", "EXTENDED_SYS_STATE"):
        assert len(s.of(kind, 10.0)) == pytest.approx(20, abs=1), kind


def test_status_messages_say_what_ardupilot_says():
    s = ready()
    for msg_id in (mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
                   mavlink.MAVLINK_MSG_ID_SYS_STATUS):
        s.stream(msg_id, 1.0)
    s.run(1.0)
    battery = s.of("BATTERY_STATUS")[-1][1]
    assert (battery.time_remaining, battery.voltages[0], battery.voltages[1], battery.current_battery,
            battery.current_consumed, battery.battery_remaining) == (0, 12600, 65535, 0, 0, 100)
    assert s.of("SYS_STATUS")[-1][1].voltage_battery == 12600
    current = s.of("MISSION_CURRENT")[-1][1]
    assert (current.seq, current.total, current.mission_state) == (0, 0, mavlink.MISSION_STATE_NO_MISSION)
    s.upload(copter_mission())
    s.run(1.0)
    current = s.of("MISSION_CURRENT")[-1][1]
    assert (current.seq, current.total, current.mission_state) == (0, 6, mavlink.MISSION_STATE_NOT_STARTED)


# ---- the copter's launch and landing (flight §2) ----------------------------------------------


def test_copter_takes_off_with_guided_arm_mission_start_0_0():
    s = ready()
    s.upload(copter_mission())
    assert s.mode(COPTER["AUTO"]) == ACCEPTED
    assert s.said(s.arm) == (FAILED, ["Arm: AUTO mode not armable"])
    assert s.mode(COPTER["GUIDED"]) == ACCEPTED
    assert s.arm() == ACCEPTED
    assert s.command(mavlink.MAV_CMD_MISSION_START, 1, 0) == DENIED  # only (0, 0)
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 6) == DENIED
    started = s.v.time_s
    assert s.said(s.command, mavlink.MAV_CMD_MISSION_START, 0, 0) == (ACCEPTED, ["Mission: 1 Takeoff"])
    assert s.v.mode is Mode.AUTO and s.v.mission_seq == 1
    s.stream(mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 4.0)
    s.run(10.0, until=lambda v: not v.landed)
    assert s.v.time_s - started == pytest.approx(3.25, abs=0.15)  # the motors spool up first
    s.run(10.0, until=lambda v: v.airframe.kin.alt_m > 1.0)
    assert s.v.time_s - started < 4.25 + 0.1  # 1 m above home at +4.25 s
    s.run(30.0, until=lambda v: 1 in v.reached)
    s.run(0.5)
    states = [m.landed_state for _, m in s.of("EXTENDED_SYS_STATE")]
    changes = [x for i, x in enumerate(states) if i == 0 or x != states[i - 1]]
    assert changes[-2:] == [mavlink.MAV_LANDED_STATE_TAKEOFF, mavlink.MAV_LANDED_STATE_IN_AIR]  # 3, then 2


def test_auto_without_a_mission_is_taken_but_arming_needs_one():
    s = ready()
    assert s.mode(COPTER["AUTO"]) == ACCEPTED  # disarmed: any mode
    assert s.said(s.arm) == (FAILED, ["Arm: Mode requires mission"])


def test_auto_after_arming_does_not_take_off_and_the_copter_disarms_10_s_after_arming():
    s = ready()
    s.upload(copter_mission())
    s.mode(COPTER["GUIDED"])
    armed, mark = s.v.time_s, s.mark()
    assert s.arm() == ACCEPTED
    assert s.mode(COPTER["AUTO"]) == ACCEPTED and "Mission: 1 Takeoff" in s.texts(mark)
    s.run(20.0, until=lambda v: not v.armed)
    assert s.v.airframe.kin.alt_m == 0.0
    assert s.v.time_s - armed == pytest.approx(10.0, abs=0.1) and "Disarming motors" in s.texts(mark)


def test_a_disarm_delay_of_0_keeps_the_copter_armed_on_the_ground():
    s = ready()
    s.param("DISARM_DELAY", 0.0)  # ArduPilot: 0 disables the auto-disarm
    s.mode(COPTER["GUIDED"])
    assert s.arm() == ACCEPTED
    s.run(30.0)
    assert s.v.armed and s.v.airframe.kin.alt_m == 0.0


def test_mission_start_while_disarmed_switches_to_auto_and_nothing_moves():
    s = ready()
    s.upload(copter_mission())
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == ACCEPTED and s.v.mode is Mode.AUTO
    s.run(3.0)
    assert s.v.landed and not s.v.armed
    s.mode(COPTER["GUIDED"])
    s.arm()
    s.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    s.run(10.0, until=lambda v: v.airframe.kin.alt_m > 1.0)


def test_copter_flies_its_mission_lands_and_disarms_2_s_after_touching_down():
    s = launched()
    s.run(400.0, until=lambda v: v.landed and v.mission_seq == 6)
    landed = s.v.time_s
    assert s.v.armed
    assert s.v.landing  # EXTENDED_SYS_STATE says LANDING until it disarms
    mark = s.mark()
    s.run(5.0, until=lambda v: not v.armed)
    assert s.v.time_s - landed == pytest.approx(2.0, abs=0.1)
    reached = [m.seq for _, m in s.of("MISSION_ITEM_REACHED")]
    assert reached == [1, 2, 3, 4, 5]  # none for NAV_LAND
    # the mission is reset: MISSION_CURRENT 0, then item 1 again, which waits for a new start
    assert [m.seq for _, m in s.sent[mark:] if m.get_type() == "MISSION_CURRENT"] == [0, 1]
    assert s.texts(mark) == ["Disarming motors", "Mission: 1 Takeoff"]
    state = s.v.state
    assert distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) < 1.0


def test_mission_start_resumes_after_a_re_upload_so_the_first_item_must_be_set():
    """flight §4: re-plan while item 3 is flown; MISSION_START alone resumes at item 3 of the new
    mission, NAV_LAND (the log: it flew to the land point at home and landed, never near A)."""
    new = [item(0, mavlink.MAV_CMD_NAV_WAYPOINT, alt=0.0), item(1, mavlink.MAV_CMD_NAV_WAYPOINT, -150, 100),
           item(2, mavlink.MAV_CMD_NAV_WAYPOINT, -150, -100), item(3, mavlink.MAV_CMD_NAV_LAND, alt=0.0)]
    a = offset(HOME, -150, 100)
    for set_current in (False, True):
        s = launched()
        s.run(200.0, until=lambda v: v.mission_seq == 3)
        s.run(3.0)
        assert s.mode(COPTER["GUIDED"]) == ACCEPTED
        assert "Flight plan received" in s.said(s.upload, new)[1]
        if set_current:
            assert s.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == ACCEPTED
            assert s.of("MISSION_CURRENT")[-1][1].seq == 1
        started = s.mark()
        assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == ACCEPTED
        closest_a = math.inf
        while not s.v.landed:
            s.run(0.5)
            closest_a = min(closest_a, distance_m(*s.v.airframe.lat_lon_deg, *a))
        state = s.v.state
        assert distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) < 0.1  # the land point
        assert s.texts(started)[0] == ("Mission: 1 WP" if set_current else "Mission: 3 Land")
        assert (closest_a < 2.0) is set_current


def test_uploading_into_a_copter_flying_auto_restarts_its_command_item_by_item():
    s = launched()
    s.run(200.0, until=lambda v: v.mission_seq == 3)
    _, said = s.said(s.upload, copter_mission())
    assert said.count("Auto mission changed, restarted command") == 4  # items 0..3 of 7


def test_loiter_without_rc_sinks_to_the_ground():
    s = hovering()
    assert s.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0) == FAILED  # flying, not forced: no text
    s.mode(COPTER["LOITER"])
    s.run(40.0, until=lambda v: v.landed)
    s.run(5.0, until=lambda v: not v.armed)


def test_do_reposition_only_as_command_int_and_it_takes_a_copter_out_of_rtl():
    s = hovering()
    lat, lon = offset(HOME, 0, 50)
    assert s.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat, lon, 30) == mavlink.MAV_RESULT_UNSUPPORTED
    s.mode(COPTER["RTL"])
    assert s.command_int(mavlink.MAV_CMD_DO_REPOSITION, (-1, 1, 0, math.nan), lat, lon, 30) == ACCEPTED
    assert s.v.mode is Mode.GUIDED
    s.run(20.0, until=lambda v: distance_m(*v.airframe.lat_lon_deg, lat, lon) < 1.0)


# ---- the plane (flight §3, §7) ----------------------------------------------------------------


def test_plane_refuses_to_arm_with_a_landing_sequence_and_rtl_autoland_0():
    s = ready("plane")
    s.upload(plane_mission())
    assert s.mode(PLANE["AUTO"]) == ACCEPTED
    assert s.said(s.arm) == (FAILED, ["Arm: DO_LAND_START set and RTL_AUTOLAND disabled"])
    _, said = s.said(s.run, 31.0)
    assert "PreArm: DO_LAND_START set and RTL_AUTOLAND disable" in said  # 50 characters, cut as measured
    s.param("RTL_AUTOLAND", 2)
    assert s.arm() == ACCEPTED


def _plane_flying(**config) -> Sim:
    s = ready("plane", **config)
    s.upload(plane_mission())
    s.param("RTL_AUTOLAND", 2)
    s.mode(PLANE["AUTO"])
    armed = s.v.time_s
    assert s.arm() == ACCEPTED  # AUTO, then arm: it takes off by itself
    s.run(10.0, until=lambda v: v.airframe.kin.alt_m > 2.0)
    assert s.v.time_s - armed == pytest.approx(3.9, abs=1.5)  # measured: 2 m at +3.9 s
    return s


def test_plane_flies_its_landing_sequence_and_disarms_20_s_after_touching_down():
    s = _plane_flying()
    s.run(600.0, until=lambda v: v.landed)
    landed, mark = s.v.time_s, s.mark()
    lat, lon = s.v.airframe.lat_lon_deg
    east = (lon - HOME.lon_deg) * 111_319.49 * math.cos(math.radians(HOME.lat_deg))
    north = (lat - HOME.lat_deg) * 111_319.49
    assert -15.0 < east <= 0.0 and abs(north) < 0.5  # on the runway axis, just short of the LAND point
    reached = [m.seq for _, m in s.of("MISSION_ITEM_REACHED")]
    assert reached == [1, 2, 3, 4, 6, 7]  # the waypoint before DO_LAND_START is reported as 6
    assert "Mission: 6 LandStart" in s.texts() or "Mission: 7 WP" in s.texts()
    s.run(30.0, until=lambda v: not v.armed)
    assert s.v.time_s - landed == pytest.approx(20.0, abs=0.1) and "Auto disarmed" in s.texts(mark)


def test_plane_rtl_with_rtl_autoland_2_goes_straight_to_the_approach():
    s = _plane_flying()
    s.run(200.0, until=lambda v: 3 in v.reached)
    result, said = s.said(s.mode, PLANE["RTL"])
    assert result == ACCEPTED and said[0] == "Landing sequence start"
    assert s.v.mode is Mode.AUTO and s.v.mission_seq == 7
    s.run(600.0, until=lambda v: v.landed)


def test_plane_rtl_with_rtl_autoland_0_circles_home_until_told_to_land():
    s = _plane_flying()
    s.run(200.0, until=lambda v: 3 in v.reached)
    s.param("RTL_AUTOLAND", 0)  # set in flight (arming needs it non-zero)
    s.mode(PLANE["RTL"])
    s.run(150.0)
    assert s.v.mode is Mode.RTL and not s.v.landed
    assert s.v.airframe.kin.alt_m == pytest.approx(100.0, abs=1.0)  # RTL_ALTITUDE
    assert distance_m(*s.v.airframe.lat_lon_deg, HOME.lat_deg, HOME.lon_deg) < 150.0
    assert s.command(mavlink.MAV_CMD_DO_LAND_START) == ACCEPTED
    assert s.v.mode is Mode.AUTO and s.v.mission_seq == 7
    s.run(600.0, until=lambda v: v.landed)


def test_plane_arm_then_mission_start_launches_too():
    s = ready("plane")
    s.upload(plane_mission())
    s.param("RTL_AUTOLAND", 2)
    assert s.arm() == ACCEPTED  # in MANUAL
    assert s.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == ACCEPTED
    s.run(10.0, until=lambda v: v.airframe.kin.alt_m > 2.0)


def test_plane_ignores_position_targets_and_circles_a_reposition():
    s = _plane_flying()
    s.run(100.0, until=lambda v: 2 in v.reached)
    s.mode(PLANE["GUIDED"])
    lat, lon = offset(HOME, 1000, 1000)
    s.handle(mavlink.MAVLink_set_position_target_global_int_message(
        0, 1, 1, REL, 0x0DF8, round(lat * 1e7), round(lon * 1e7), 60, 0, 0, 0, 0, 0, 0, 0, 0))
    s.run(60.0)
    assert distance_m(*s.v.airframe.lat_lon_deg, lat, lon) > 800.0  # ignored
    assert s.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat, lon, 60) == mavlink.MAV_RESULT_UNSUPPORTED
    assert s.command_int(mavlink.MAV_CMD_DO_REPOSITION, (-1, 1, 0, math.nan), lat, lon, 60) == ACCEPTED
    s.run(200.0, until=lambda v: distance_m(*v.airframe.lat_lon_deg, lat, lon) < 100.0)
    s.run(60.0)
    assert distance_m(*s.v.airframe.lat_lon_deg, lat, lon) < 150.0  # it circles the point


# ---- the battery (flight §5, §6) --------------------------------------------------------------


def test_batt_capacity_changes_the_remaining_charge_at_once_and_consumption_counts_in_mah():
    s = ready(battery=BatteryConfig(endurance_s=1200.0))
    assert s.v.params["BATT_CAPACITY"] == pytest.approx(30.3 * 1200 / 3.6, abs=1)  # at 10 m/s cruise
    s.run(5.0)
    assert s.v.airframe.battery.consumed_mah == 0.0  # no current while disarmed
    s.mode(COPTER["GUIDED"])
    s.arm()
    s.run(2.0)
    assert s.v.airframe.battery.consumed_mah == 0.0  # nor armed on the ground (ArduCopter SITL)
    s.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 30)
    s.run(10.0, until=lambda v: not v.landed)
    on_ground = s.v.airframe.battery.consumed_mah  # spooling up: the climb's current
    assert on_ground == pytest.approx(3.25 * 30.525 / 3.6, rel=0.05)
    s.run(60.0)
    used = s.v.airframe.battery.consumed_mah
    assert used - on_ground == pytest.approx((12.0 * 30.525 + 48.0 * 28.1) / 3.6, rel=0.01)  # climb, hover
    assert s.v.airframe.battery.energy_j == pytest.approx(used * 3.6 * 12.6, rel=1e-6)
    before = s.v.airframe.battery.remaining_pct
    s.param("BATT_CAPACITY", 1000.0)
    assert s.v.airframe.battery.remaining_pct == pytest.approx(100.0 * (1000.0 - used) / 1000.0, abs=0.01)
    assert s.v.airframe.battery.remaining_pct < before


def test_arming_voltage_and_capacity_refusals():
    s = ready()
    s.mode(COPTER["GUIDED"])
    s.param("BATT_ARM_VOLT", 13.0)  # the sim battery is 12.6 V
    assert s.said(s.arm) == (FAILED, ["Arm: Battery 1 below minimum arming voltage"])
    s.param("BATT_ARM_VOLT", 0.0)
    s.param("BATT_ARM_MAH", 1e6)
    assert s.said(s.arm) == (FAILED, ["Arm: Battery 1 below minimum arming capacity"])
    s.param("BATT_ARM_MAH", 0.0)
    s.param("BATT_LOW_VOLT", 13.0)
    assert s.said(s.arm) == (FAILED, ["Arm: Battery 1 low voltage failsafe"])
    s.param("BATT_LOW_VOLT", 10.5)
    assert s.arm() == ACCEPTED


def test_battery_failsafe_acts_only_while_armed_with_ardupilots_texts():
    s = ready(battery=BatteryConfig(low_pct=50.0))
    s.v.set_drain_multiplier(20.0)
    s.run(60.0)
    assert s.v.airframe.battery.remaining_pct == 100.0  # disarmed: no current, no failsafe
    s.mode(COPTER["GUIDED"])
    s.arm()
    s.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 30)
    s.run(100.0, until=lambda v: v.mode is Mode.RTL)
    low = [t for t in s.texts() if t.startswith("Battery 1 is low")]
    assert low and low[0].startswith("Battery 1 is low 12.60V used ") and "Battery Failsafe" in s.texts()


@pytest.mark.parametrize("speedup", [1.0, 60.0])
def test_an_armed_copter_gives_a_station_10_real_seconds_to_start_its_mission_at_any_speed_up(speedup):
    """DISARM_DELAY times the station's MISSION_START after its arming: sped up 60 times, the
    copter armed on the ground disarms after 10 real seconds, 600 of its own."""
    s = ready()
    s.v.started_at_speedup(speedup)
    s.mode(COPTER["GUIDED"])
    armed = s.v.time_s
    assert s.arm() == ACCEPTED
    s.run(9.5 * speedup, dt=0.5)
    assert s.v.armed
    s.run(1.0 * speedup, dt=0.5)
    assert not s.v.armed and s.v.time_s - armed > 10.0 * speedup - 0.6


@pytest.mark.parametrize("speedup", [1.0, 60.0])
def test_the_mission_protocol_gives_a_station_8_real_seconds_at_any_speed_up(speedup):
    """ArduPilot gives up an upload 8 s after the last item; a station's round trips do not speed
    up with the simulation, so sped up 60 times the vehicle waits 8 real seconds, 480 of its own."""
    s = ready()
    s.v.started_at_speedup(speedup)
    s.handle(mavlink.MAVLink_mission_count_message(1, 1, 3, 0))
    since = s.mark()
    s.run(7.5 * speedup, dt=0.5)
    assert "Mission upload timeout" not in s.texts(since)
    s.run(1.0 * speedup, dt=0.5)
    assert "Mission upload timeout" in s.texts(since)
