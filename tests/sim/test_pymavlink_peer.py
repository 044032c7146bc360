"""The simulator as a MAVLink peer, driven over UDP by a pymavlink ground station, the way a
station must drive ArduPilot: ask for the telemetry, wait until it is ready, GUIDED, arm,
MISSION_START (0, 0)."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.ardupilot_storage import stored_item
from sim import BatteryConfig, LinkFaults, WireItem
from sim.vehicle_link import signing_key_from
from tests.sim.helpers import HOME, distance_m, fast, home_placeholder, offset, waypoint
from tests.sim.mission_client import MissionClient, MissionTransferError

COPTER_GUIDED, COPTER_AUTO, COPTER_RTL, COPTER_LAND = 4, 3, 6, 9


def kept(items: list[WireItem]) -> list[WireItem]:
    """What ArduPilot reads back for `items` as sent (the home item aside)."""
    return [stored_item(it, fixed_wing=False) for it in items]


def survey(n: int) -> list[WireItem]:
    """Home placeholder plus n waypoints on a lawnmower pattern."""
    items = [home_placeholder()]
    for i in range(n):
        lat, lon = offset(HOME, (i % 20) * 15.0, (i // 20) * 15.0)
        items.append(waypoint(i + 1, lat, lon, 20.0 + i % 7, param2=float(i % 3)))
    return items


def test_heartbeat_identifies_an_ardupilot_copter(make_fleet, make_gcs):
    gcs = make_gcs(make_fleet())
    hb = gcs.hello()
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA)
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.get_srcComponent() == mavlink.MAV_COMP_ID_AUTOPILOT1
    gcs.wait_ready()
    assert gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == 0
    version = gcs.wait("AUTOPILOT_VERSION")
    assert version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION) == 0
    home = gcs.wait("HOME_POSITION")
    assert (home.latitude, home.longitude) == (round(HOME.lat_deg * 1e7), round(HOME.lon_deg * 1e7))
    assert gcs.command(mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 1) == mavlink.MAV_RESULT_UNSUPPORTED


def test_message_interval_and_params(make_fleet, make_gcs):
    gcs = make_gcs(make_fleet(speedup=1.0))
    gcs.hello()
    assert gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, 50_000) == 0
    first = gcs.wait("BATTERY_STATUS")
    stamps = [first._timestamp] + [gcs.wait("BATTERY_STATUS")._timestamp for _ in range(10)]
    assert (stamps[-1] - stamps[0]) / 10 == pytest.approx(0.05, abs=0.02)  # 20 Hz, was 1 Hz
    gcs.mav.param_request_list_send(*gcs.target)
    first = gcs.wait("PARAM_VALUE")
    names = {first.param_id} | {gcs.wait("PARAM_VALUE").param_id for _ in range(first.param_count - 1)}
    assert "MAV_SYSID" in names and "SYSID_THISMAV" not in names  # ArduPilot 4.7 renamed it
    gcs.mav.param_request_read_send(*gcs.target, b"SYSID_THISMAV", -1)
    assert gcs.wait("PARAM_VALUE", timeout_s=0.5, check=False) is None  # an unknown name gets no answer


def test_200_item_mission_uploads_and_reads_back_as_ardupilot_keeps_it(make_fleet, make_gcs):
    gcs = make_gcs(make_fleet())
    gcs.hello()
    home = gcs.wait_ready()
    items = survey(200)
    client = MissionClient(gcs.conn, 1)
    client.upload(items)
    back = client.download()
    assert len(back) == 201
    assert back[1:] == kept(items)[1:]
    assert all(b.frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT for b in back[1:])  # 6 comes back as 3
    assert (back[0].frame, back[0].x, back[0].y, back[0].z) == (
        mavlink.MAV_FRAME_GLOBAL, home.latitude, home.longitude, home.altitude / 1000)


def test_fence_and_rally_are_kept_apart_from_the_mission(make_fleet, make_gcs):
    gcs = make_gcs(make_fleet())
    gcs.hello()
    client = MissionClient(gcs.conn, 1)
    fence = [WireItem(seq=i, frame=5, command=mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                      param1=4, x=round(HOME.lat_deg * 1e7) + i, y=round(HOME.lon_deg * 1e7), z=12.5,
                      mission_type=1) for i in range(4)]
    client.upload(survey(3))
    client.upload(fence, mission_type=1)
    back = client.download(mission_type=1)
    assert back == kept(fence)
    assert {(b.frame, b.z) for b in back} == {(mavlink.MAV_FRAME_GLOBAL, 0.0)}
    assert len(client.download()) == 4
    assert client.download(mission_type=2) == []


def test_mission_upload_completes_under_20_percent_loss(make_fleet, make_gcs):
    fleet = make_fleet(faults=LinkFaults(loss=0.2, duplicate=0.05, seed=7))
    gcs = make_gcs(fleet)
    gcs.hello(timeout_s=10)
    items = survey(200)
    client = MissionClient(gcs.conn, 1, timeout_s=0.02, deadline_s=40)
    client.upload(items)  # ArduPilot re-requests after 1 s of its time: 50 ms at speedup 20
    assert client.resends > 0
    assert fleet.call(lambda: fleet.vehicle(1).mission.items()[1:]) == kept(items)[1:]
    assert client.download()[1:] == kept(items)[1:]


def test_items_are_requested_with_mission_request_and_errors_are_acked(make_fleet, make_gcs):
    gcs = make_gcs(make_fleet())
    gcs.hello()
    gcs.mav.mission_count_send(*gcs.target, 3, 0)
    assert gcs.wait(["MISSION_REQUEST", "MISSION_REQUEST_INT"]).get_type() == "MISSION_REQUEST"  # id 40 only
    gcs.mav.send(survey(3)[2].to_msg(gcs.target))
    ack = gcs.wait("MISSION_ACK")
    assert ack.type == mavlink.MAV_MISSION_INVALID_SEQUENCE
    gcs.mav.mission_count_send(*gcs.target, 5000, 0)
    assert gcs.wait("MISSION_ACK").type == mavlink.MAV_MISSION_NO_SPACE
    assert gcs.wait("STATUSTEXT").text == "Only 650 items are supported"


def test_signing_refuses_unsigned_commands_and_uploads(make_fleet, make_gcs):
    key = signing_key_from("correct horse battery staple")
    fleet = make_fleet(signing_key=key)
    signed = make_gcs(fleet)
    signed.conn.setup_signing(key, sign_outgoing=True)
    signed.hello()
    unsigned = make_gcs(fleet)
    with pytest.raises(MissionTransferError):
        MissionClient(unsigned.conn, 1, timeout_s=0.1, deadline_s=1.5).upload(survey(3))
    assert fleet.link(1).rejected > 0
    assert len(fleet.vehicle(1).mission.items()) == 1
    unsigned.mav.command_long_send(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    signed.wait("HEARTBEAT")  # the unsigned sender did not take over the link
    assert not fleet.vehicle(1).armed
    MissionClient(signed.conn, 1).upload(survey(3))
    assert len(fleet.vehicle(1).mission.items()) == 4
    signed.wait_ready()
    assert signed.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED


def _fly_square(make_fleet, make_gcs, **fleet_options):
    fleet = make_fleet(speedup=20.0, **fleet_options)
    gcs = make_gcs(fleet)
    gcs.hello()
    corners = [(0, 60), (60, 60), (60, 0)]
    items = [home_placeholder(),
             WireItem(seq=1, frame=6, command=mavlink.MAV_CMD_NAV_TAKEOFF, z=15.0)]
    for i, (e, n) in enumerate(corners):
        items.append(waypoint(i + 2, *offset(HOME, e, n), 15.0, param1=2.0))
    items.append(WireItem(seq=5, frame=2, command=mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH))
    gcs.wait_ready()
    MissionClient(gcs.conn, 1).upload(items)
    assert gcs.set_mode(COPTER_GUIDED) == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.command(mavlink.MAV_CMD_MISSION_START, 0, 0) == mavlink.MAV_RESULT_ACCEPTED
    return fleet, gcs, items, corners


def test_mission_flight_reaches_each_waypoint_then_rtl_lands_at_home(make_fleet, make_gcs):
    fleet, gcs, items, corners = _fly_square(make_fleet, make_gcs)
    reached: list[int] = []
    positions = []
    while not reached or reached[-1] < 5:
        msg = gcs.wait(["MISSION_ITEM_REACHED", "GLOBAL_POSITION_INT"], timeout_s=20)
        if msg.get_type() == "GLOBAL_POSITION_INT":
            positions.append(msg)
            continue
        reached.append(msg.seq)
        if 2 <= msg.seq <= 4:
            pos = gcs.wait("GLOBAL_POSITION_INT")  # holding 2 s at the waypoint
            wp = items[msg.seq]
            assert distance_m(pos.lat / 1e7, pos.lon / 1e7, wp.x / 1e7, wp.y / 1e7) <= 2.0 + 0.5
            assert pos.relative_alt / 1000 == pytest.approx(15.0, abs=1.0)
    assert reached == [1, 2, 3, 4, 5]
    # the track stays on the square's legs: never further than 6 m from the planned polyline
    legs = [(0, 0)] + corners + [(0, 0)]
    for pos in positions:
        lat0, lon0 = HOME.lat_deg, HOME.lon_deg
        e = (pos.lon / 1e7 - lon0) * 111_319.49 * math.cos(math.radians(lat0))
        n = (pos.lat / 1e7 - lat0) * 111_319.49
        assert min(_seg_dist((e, n), a, b) for a, b in zip(legs, legs[1:])) < 6.0
    hb = gcs.wait("HEARTBEAT", lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout_s=20)
    assert hb.custom_mode == COPTER_AUTO
    state = fleet.vehicle(1).state
    assert state.landed and not state.armed
    assert distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) <= 2.0
    assert gcs.wait("EXTENDED_SYS_STATE").landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND


def test_rtl_command_returns_and_lands_at_home(make_fleet, make_gcs):
    fleet, gcs, items, _ = _fly_square(make_fleet, make_gcs)
    gcs.wait("MISSION_ITEM_REACHED", lambda m: m.seq == 3, timeout_s=20)
    assert gcs.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH) == mavlink.MAV_RESULT_ACCEPTED
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == COPTER_RTL)
    gcs.wait("STATUSTEXT", lambda m: m.text == "Disarming motors", timeout_s=20)
    state = fleet.vehicle(1).state
    assert state.landed and not state.armed and state.mode.value == "RTL"
    assert distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) <= 2.0


def test_low_battery_failsafe_triggers_rtl(make_fleet, make_gcs):
    fleet = make_fleet(speedup=20.0, config=fast(battery=BatteryConfig(low_pct=90.0)))
    gcs = make_gcs(fleet)
    gcs.hello()
    gcs.wait_ready()
    gcs.set_mode(COPTER_GUIDED)
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
    assert gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 20) == 0
    gcs.wait("GLOBAL_POSITION_INT", lambda m: m.relative_alt > 19_000, timeout_s=20)
    lat, lon = offset(HOME, 150, 0)
    assert gcs.command_int(mavlink.MAV_CMD_DO_REPOSITION, 6, (-1, 0, 0, math.nan),
                           round(lat * 1e7), round(lon * 1e7), 20.0) == 0
    gcs.wait("GLOBAL_POSITION_INT", lambda m: distance_m(m.lat / 1e7, m.lon / 1e7, HOME.lat_deg, HOME.lon_deg) > 60)
    gcs.mav.param_set_send(*gcs.target, b"SIM_DRAIN_MULT", 20.0, mavlink.MAV_PARAM_TYPE_REAL32)
    text = gcs.wait("STATUSTEXT", lambda m: m.text.startswith("Battery 1 is low"), timeout_s=20)
    assert text.severity == mavlink.MAV_SEVERITY_WARNING and text.text.endswith(" mAh")
    assert gcs.wait("STATUSTEXT").text == "Battery Failsafe"
    gcs.wait("HEARTBEAT", lambda m: m.custom_mode == COPTER_RTL)
    battery = gcs.wait("BATTERY_STATUS")
    assert battery.battery_remaining <= 90
    assert battery.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    gcs.wait("STATUSTEXT", lambda m: m.text == "Disarming motors", timeout_s=30)
    state = fleet.vehicle(1).state
    assert distance_m(state.lat_deg, state.lon_deg, HOME.lat_deg, HOME.lon_deg) <= 2.0


def test_arm_is_denied_with_a_reason_when_the_battery_failed(make_fleet, make_gcs):
    fleet = make_fleet()
    fleet.call(fleet.vehicle(1).fail_battery)
    gcs = make_gcs(fleet)
    gcs.hello()
    gcs.wait_ready()
    assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_FAILED
    assert gcs.wait("STATUSTEXT").text == "Arm: Battery 1 critical capacity failsafe"
    assert gcs.wait("BATTERY_STATUS").charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_FAILED


def test_detections_are_reported_as_geotagged_captures(make_fleet, make_gcs):
    target = offset(HOME, 0, 50)
    fleet = make_fleet(targets=(target,))
    gcs = make_gcs(fleet)
    gcs.hello()
    gcs.wait_ready()
    gcs.set_mode(COPTER_GUIDED)
    gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)
    gcs.wait("GLOBAL_POSITION_INT", lambda m: m.relative_alt > 9_000, timeout_s=20)
    lat, lon = offset(HOME, 0, 100)
    # ArduPilot takes DO_REPOSITION only as COMMAND_INT
    assert gcs.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, 10) \
        == mavlink.MAV_RESULT_UNSUPPORTED
    assert gcs.command_int(mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                           (-1, 0, 0, math.nan), round(lat * 1e7), round(lon * 1e7), 10) == mavlink.MAV_RESULT_ACCEPTED
    captures = []
    while not captures or distance_m(captures[-1].lat / 1e7, captures[-1].lon / 1e7, lat, lon) > 20:
        captures.append(gcs.wait("CAMERA_IMAGE_CAPTURED", timeout_s=20))
    indexes = [c.image_index for c in captures]
    assert indexes == list(range(indexes[0], indexes[0] + len(indexes)))
    truth = {o.index: o for o in fleet.vehicle(1).observations}
    on_target = [c for c in captures if truth[c.image_index].present]
    assert len(on_target) == 1
    assert distance_m(on_target[0].lat / 1e7, on_target[0].lon / 1e7, *target) < 20 * 0.75
    for c in captures:
        assert f"hit={int(truth[c.image_index].reported)}" in c.file_url
    assert gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED,
                       indexes[0]) == 0
    assert gcs.wait("CAMERA_IMAGE_CAPTURED").image_index == indexes[0]


def test_silent_vehicle_stops_answering(make_fleet, make_gcs):
    fleet = make_fleet()
    gcs = make_gcs(fleet)
    gcs.hello()
    fleet.call(fleet.stop_answering, 1)
    gcs.conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.3)  # drain in-flight traffic
    assert gcs.wait("HEARTBEAT", timeout_s=1.0, check=False) is None
    fleet.call(fleet.resume_answering, 1)
    assert gcs.wait("HEARTBEAT", timeout_s=3.0) is not None


def _seg_dist(p, a, b) -> float:
    ax, ay = a
    bx, by = b
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy or 1.0)))
    return math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)
