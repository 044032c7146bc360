"""The `px4` profile over real MAVLink on loopback UDP, driven by pymavlink as a station drives
PX4 v1.15.3 (research `px4`): readiness from SYS_STATUS health, the first upload's requests,
MISSION_START from HOLD, DO_SET_MISSION_CURRENT refused, the battery's parameters, and the
link's first partner kept for good."""

from __future__ import annotations

import struct
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim import VehicleConfig, WireItem
from sim.autopilot.px4 import BOOT_TIMES
from tests.sim.helpers import HOME, distance_m, fast, offset, waypoint
from tests.sim.mission_client import MissionClient

PREARM = mavlink.MAV_SYS_STATUS_PREARM_CHECK
MISSION_MODE = (4, 4)


def _mode(msg) -> tuple[int, int]:
    return (msg.custom_mode >> 16) & 0xFF, msg.custom_mode >> 24


def _mission(alt: float = 10.0) -> list[WireItem]:
    lat, lon = offset(HOME, 0, 40)
    take_off = WireItem(seq=0, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, command=mavlink.MAV_CMD_NAV_TAKEOFF,
                        x=round(HOME.lat_deg * 1e7), y=round(HOME.lon_deg * 1e7), z=alt)
    land = WireItem(seq=2, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, command=mavlink.MAV_CMD_NAV_LAND,
                    x=round(HOME.lat_deg * 1e7), y=round(HOME.lon_deg * 1e7))
    return [take_off, waypoint(1, lat, lon, alt), land]


def test_ready_when_the_health_prearm_bit_comes_at_37_s_of_vehicle_time(make_fleet, make_gcs):
    fleet = make_fleet(config=VehicleConfig(profile="px4"), speedup=50.0)
    gcs = make_gcs(fleet)
    gcs.hello()
    home = gcs.wait("HOME_POSITION", timeout_s=5.0)
    fix = gcs.wait("GPS_RAW_INT", lambda m: m.fix_type >= 3, timeout_s=5.0)
    assert home is not None and fix.satellites_visible == 10
    assert fleet.vehicle(1).time_s < 10.0  # both long before the vehicle can arm
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    status = gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & PREARM, timeout_s=10.0)
    assert not status.onboard_control_sensors_present & PREARM and not status.onboard_control_sensors_enabled & PREARM
    clock = gcs.wait("ATTITUDE").time_boot_ms / 1000.0
    assert BOOT_TIMES["copter"].prearm_s - 0.5 < clock < BOOT_TIMES["copter"].prearm_s + 2.5
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED


def test_message_intervals_as_px4_answers_them(make_fleet, make_gcs):
    fleet = make_fleet(config=fast(profile="px4"))
    gcs = make_gcs(fleet)
    gcs.hello()
    answers = {msg_id: gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6)
               for msg_id in (33, 1, 147, 245, 24, 242, 230, 42, 193)}
    failed = mavlink.MAV_RESULT_FAILED
    assert answers == {33: 0, 1: 0, 147: 0, 245: 0, 24: 0, 242: 0, 230: 0, 42: failed, 193: failed}
    assert gcs.wait("MISSION_CURRENT", timeout_s=2.0) is not None  # at 1 Hz all the same


def test_first_upload_asks_item_0_with_mission_request_then_flies_from_hold_on_mission_start(make_fleet, make_gcs):
    fleet = make_fleet(config=fast(profile="px4"), speedup=40.0)
    gcs = make_gcs(fleet)
    gcs.hello()
    gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & PREARM, timeout_s=10.0)
    items = _mission()
    gcs.mav.mission_count_send(*gcs.target, len(items), 0)
    kinds = []
    while True:
        msg = gcs.wait(["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"])
        if msg.get_type() == "MISSION_ACK":
            assert msg.type == mavlink.MAV_MISSION_ACCEPTED
            break
        if not kinds or kinds[-1] != (msg.get_type(), msg.seq):
            kinds.append((msg.get_type(), msg.seq))
        gcs.mav.send(items[msg.seq].to_msg(gcs.target))
    assert kinds == [("MISSION_REQUEST", 0), ("MISSION_REQUEST_INT", 1), ("MISSION_REQUEST_INT", 2)]
    assert _mode(gcs.wait("HEARTBEAT")) == (4, 3)  # Hold
    assert gcs.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == mavlink.MAV_RESULT_UNSUPPORTED
    assert gcs.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == mavlink.MAV_RESULT_ACCEPTED
    beat = gcs.wait("HEARTBEAT", lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    assert _mode(beat) == MISSION_MODE
    gcs.wait("MISSION_ITEM_REACHED", lambda m: m.seq == 2, timeout_s=20.0)
    gcs.wait("HEARTBEAT", lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=20.0)
    state = fleet.vehicle(1).state
    assert state.landed and distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) < 1.0
    back = MissionClient(gcs.conn, 1).download()
    assert [(it.frame, it.current) for it in back] == [(6, 0), (6, 0), (6, 1)]  # frame 3 reads 6; current: the land


def test_sim_bat_drain_and_sim_bat_min_pct_set_the_drain_while_armed(make_fleet, make_gcs):
    fleet = make_fleet(config=fast(profile="px4"), speedup=20.0)
    gcs = make_gcs(fleet)
    gcs.hello()
    gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & PREARM, timeout_s=10.0)
    for name, value in (("SIM_BAT_DRAIN", 5.0), ("SIM_BAT_MIN_PCT", 20.0)):
        gcs.mav.param_set_send(*gcs.target, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32)
        echo = gcs.wait("PARAM_VALUE", lambda m, n=name: m.param_id == n)
        assert echo.param_value == value
    time.sleep(0.5)
    assert gcs.wait("BATTERY_STATUS").battery_remaining == 100  # disarmed: full
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED
    first = gcs.wait("BATTERY_STATUS")
    # 20 % of the charge left, the floor, through PX4's voltage filter (1 s)
    low = gcs.wait("BATTERY_STATUS", lambda m: m.voltages[0] <= round(14400 + 1800 * 0.2) + 2, timeout_s=5.0)
    assert first.voltages[0] > low.voltages[0] >= 14760
    assert low.battery_remaining == 20  # on the ground: no load on the estimate
    gcs.wait("HEARTBEAT", lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=5.0)
    gcs.wait("BATTERY_STATUS", lambda m: m.voltages[0] == 16200, timeout_s=2.0)  # full again once disarmed


def test_the_vehicle_keeps_answering_its_first_station_only(make_fleet, make_gcs):
    fleet = make_fleet(config=fast(profile="px4"))
    first = make_gcs(fleet)
    first.hello()
    second = make_gcs(fleet)
    second.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    second.mav.param_set_send(1, 1, b"COM_ARMABLE", struct.unpack("<f", struct.pack("<i", 0))[0],
                              mavlink.MAV_PARAM_TYPE_INT32)
    assert second.wait("HEARTBEAT", timeout_s=1.0, check=False) is None
    echo = first.wait("PARAM_VALUE", lambda m: m.param_id == "COM_ARMABLE")  # executed, answered to the first
    assert echo.param_value == 0.0
