"""The `ardupilot` profile's mission protocol, message by message with the vehicle's clock,
against what ArduCopter and ArduPlane 4.7 SITL did (research `ardupilot_protocol`, Q1-Q4)."""

from __future__ import annotations

import math
from functools import partial

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.ardupilot_storage import stored_item
from gcs.autopilots.wire_item import MissionType, WireItem
from sim.autopilot.ardupilot import CAPACITY, f32, fence_problems, from_legacy_item, item_result, to_legacy_item
from sim.autopilot.ardupilot_mission import ArduPilotMissionProtocol
from sim.autopilot.mission_protocol import ProtocolConfig

GCS = (255, 190)
OTHER = (254, 190)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
LAT, LON = 472771883, 114039709
FENCE, RALLY = MissionType.FENCE, MissionType.RALLY
VERTEX = mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
CIRCLE = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION


def protocol(vehicle_type: str = "copter") -> ArduPilotMissionProtocol:
    p = ArduPilotMissionProtocol(ProtocolConfig(
        home_item=True, store=partial(stored_item, fixed_wing=vehicle_type == "plane"),
        capacity=dict(CAPACITY[vehicle_type])))
    p.set_home(47.2771883, 11.4039709, 584.09)
    return p


def _from(msg, sender=GCS):
    msg._header = mavlink.MAVLink_header(msg.id, srcSystem=sender[0], srcComponent=sender[1])
    return msg


def count(n, mtype=0, sender=GCS):
    return _from(mavlink.MAVLink_mission_count_message(1, 1, n, mtype), sender)


def wp(seq, z=None, mtype=0, **fields) -> WireItem:
    base = dict(seq=seq, frame=REL, command=mavlink.MAV_CMD_NAV_WAYPOINT, x=LAT + seq, y=LON, z=z if z is not None
                else 100.0 + seq, mission_type=mtype)
    return WireItem(**(base | fields))


def vertex(seq, n=4, **fields) -> WireItem:
    return WireItem(**(dict(seq=seq, frame=mavlink.MAV_FRAME_GLOBAL, command=VERTEX, param1=n, x=LAT + 100 * seq,
                            y=LON + 100 * (seq % 2), mission_type=FENCE) | fields))


def rally(seq, z=60.0, **fields) -> WireItem:
    return WireItem(**(dict(seq=seq, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                            command=mavlink.MAV_CMD_NAV_RALLY_POINT, x=LAT, y=LON + seq, z=z,
                            mission_type=RALLY) | fields))


def send(p, item: WireItem, now=0.0, sender=GCS):
    return p.handle(_from(item.to_msg((1, 1)), sender), now)


def only(out, kind):
    assert [m.get_type() for m in out][:1] == [kind], out
    return out[0]


def texts(out) -> list[str]:
    return [m.text for m in out if m.get_type() == "STATUSTEXT"]


def upload(p, items: list[WireItem], now=0.0) -> list:
    """COUNT, then each item as the vehicle asks for it; the vehicle's last answer."""
    out = p.handle(count(len(items), items[0].mission_type if items else 0), now)
    for it in items:
        if out[0].get_type() != "MISSION_REQUEST":
            return out
        assert out[0].seq == it.seq
        out = send(p, it, now)
    return out


def zs(p, mtype=0) -> list[float]:
    return [it.z for it in p.items(mtype)[1 if mtype == 0 else 0:]]


def test_items_are_asked_for_with_mission_request_only_and_int_items_answer():
    p = protocol()
    out = p.handle(count(3), 0.0)
    assert only(out, "MISSION_REQUEST").seq == 0  # id 40, never MISSION_REQUEST_INT
    out = send(p, wp(0))
    assert only(out, "MISSION_REQUEST").seq == 1
    send(p, wp(1))
    out = send(p, wp(2))
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert texts(out) == ["Flight plan received"]


def test_uploaded_item_0_is_ignored_and_reads_back_as_the_current_home():
    p = protocol()
    upload(p, [wp(0, z=999.0, x=LAT + 55_000_00, param1=9), wp(1)])
    home = p.items()[0]
    assert (home.frame, home.command, home.x, home.y, home.z, home.param1) == (0, 16, LAT, LON, 584.09, 0.0)
    p.set_home(47.0, 11.0, 600.0)  # home moves (ArduPilot sets it again at arming)
    assert (p.items()[0].x, p.items()[0].z) == (470000000, 600.0)


def test_items_are_kept_as_arducopter_stores_them():
    p = protocol()
    upload(p, [wp(0), wp(1, z=12.349, param1=7.5, param2=3.0, param4=math.nan),
               WireItem(seq=2, frame=REL, command=mavlink.MAV_CMD_NAV_LAND, x=LAT, y=LON, z=0.0)])
    one, land = p.items()[1:]
    assert (one.frame, one.z, one.param1, one.param2, one.param4) == (3, f32(12.34), 7.0, 0.0, 0.0)
    assert (land.param4, land.autocontinue, land.current) == (1.0, 1, 0)  # NAV_LAND param4 0 reads back 1


def test_an_accepted_count_truncates_and_an_abandoned_upload_leaves_the_old_tail():
    p = protocol()
    upload(p, [wp(i) for i in range(8)])  # home + z 101..107
    p.handle(count(3), 1.0)  # accepted, then nothing arrives
    assert zs(p) == [101.0, 102.0]  # the COUNT alone destroyed the tail
    out = p.poll(5.0) + p.poll(9.5)
    assert [m.get_type() for m in out] == ["MISSION_REQUEST", "MISSION_ACK", "STATUSTEXT"]
    assert out[1].type == mavlink.MAV_MISSION_OPERATION_CANCELLED and texts(out) == ["Mission upload timeout"]
    assert zs(p) == [101.0, 102.0]


def test_a_refused_item_leaves_new_items_before_it_and_old_ones_after():
    p = protocol()
    upload(p, [wp(i) for i in range(8)])
    new = [wp(i, z=200.0 + i) for i in range(6)]
    new[3] = wp(3, z=203.0, frame=mavlink.MAV_FRAME_LOCAL_NED)
    out = upload(p, new)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    assert zs(p) == [201.0, 202.0, 103.0, 104.0, 105.0]  # count 6, as measured (Q4)
    assert not p.busy


def test_a_longer_upload_refused_late_holds_its_new_items_only():
    p = protocol()
    upload(p, [wp(i) for i in range(3)])
    new = [wp(i, z=200.0 + i) for i in range(8)]
    new[5] = wp(5, frame=mavlink.MAV_FRAME_LOCAL_NED)
    upload(p, new)
    assert zs(p) == [201.0, 202.0, 203.0, 204.0]  # count 5: max(min(3, 8), 5)


@pytest.mark.parametrize(("vehicle", "mtype", "capacity"), [
    ("copter", 0, 650), ("copter", 1, 70), ("copter", 2, 46), ("plane", 0, 655), ("plane", 1, 84), ("plane", 2, 50),
])
def test_capacity_is_refused_at_the_count_with_the_number_in_a_text(vehicle, mtype, capacity):
    p = protocol(vehicle)
    upload(p, [wp(i) for i in range(8)])
    out = p.handle(count(capacity + 1, mtype), 0.0)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_NO_SPACE
    assert texts(out) == [f"Only {capacity} items are supported"]
    assert len(p.items()) == 8  # a refused COUNT leaves every list alone
    assert only(p.handle(count(capacity, mtype), 0.0), "MISSION_REQUEST").seq == 0


@pytest.mark.parametrize(("item", "result"), [
    (wp(3, frame=mavlink.MAV_FRAME_LOCAL_NED), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(3, frame=mavlink.MAV_FRAME_LOCAL_ENU), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(3, frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(3, frame=mavlink.MAV_FRAME_BODY_NED), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(3, frame=21), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    (wp(3, frame=mavlink.MAV_FRAME_MISSION), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, command=60000), mavlink.MAV_MISSION_UNSUPPORTED),
    (wp(3, command=mavlink.MAV_CMD_NAV_RALLY_POINT), mavlink.MAV_MISSION_UNSUPPORTED),
    (wp(3, command=0), mavlink.MAV_MISSION_INVALID),
    (wp(3, param1=math.nan), mavlink.MAV_MISSION_INVALID_PARAM1),
    (wp(3, param2=math.nan), mavlink.MAV_MISSION_INVALID_PARAM2),
    (wp(3, param4=math.nan), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, param4=math.inf), mavlink.MAV_MISSION_INVALID_PARAM4),
    (wp(3, param1=-math.inf), mavlink.MAV_MISSION_INVALID_PARAM1),
    (wp(3, command=mavlink.MAV_CMD_NAV_LAND, param1=math.nan), mavlink.MAV_MISSION_INVALID_PARAM1),
    (wp(3, command=mavlink.MAV_CMD_NAV_LAND, param4=math.nan), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, command=mavlink.MAV_CMD_NAV_TAKEOFF, param4=math.nan), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, command=mavlink.MAV_CMD_DO_CHANGE_SPEED, param2=math.nan), mavlink.MAV_MISSION_INVALID_PARAM2),
    (wp(3, command=mavlink.MAV_CMD_DO_CHANGE_SPEED, param4=math.nan), mavlink.MAV_MISSION_INVALID_PARAM4),
    (wp(3, z=math.nan), mavlink.MAV_MISSION_INVALID_PARAM7),
    (wp(3, z=math.inf), mavlink.MAV_MISSION_INVALID_PARAM7),
    (wp(3, z=83000.0), mavlink.MAV_MISSION_INVALID_PARAM7),
    (wp(3, z=-83000.0), mavlink.MAV_MISSION_INVALID_PARAM7),
    (wp(3, z=82999.99), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, x=900000031), mavlink.MAV_MISSION_ACCEPTED),  # ArduPilot compares in float32
    (wp(3, x=-900000001), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, x=900000033), mavlink.MAV_MISSION_INVALID_PARAM5_X),
    (wp(3, x=-910000000), mavlink.MAV_MISSION_INVALID_PARAM5_X),
    (wp(3, y=1800000063), mavlink.MAV_MISSION_ACCEPTED),
    (wp(3, y=1800000065), mavlink.MAV_MISSION_INVALID_PARAM6_Y),
    (wp(3, x=0, y=0), mavlink.MAV_MISSION_ACCEPTED),
], ids=lambda v: str(v) if isinstance(v, int) else None)
def test_each_bad_item_is_refused_at_the_item_as_measured(item, result):
    assert item_result(item) == result
    p = protocol()
    upload(p, [wp(i) for i in range(8)])
    out = upload(p, [wp(0), wp(1), wp(2), item, wp(4), wp(5)])
    assert only(out, "MISSION_ACK").type == result


def test_float_mission_item_is_accepted_with_a_warning_and_float32_arithmetic():
    p = protocol()
    p.handle(count(2), 0.0)
    send(p, wp(0))
    legacy = mavlink.MAVLink_mission_item_message(1, 1, 1, 3, 16, 0, 1, 0, 0, 0, 0, 47.2771883, 11.4039709, 30.0, 0)
    out = p.handle(_from(legacy), 0.0)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert "got MISSION_ITEM; GCS should send MISSION_ITEM_INT" in texts(out)
    assert (p.items()[1].x, p.items()[1].y) == (LAT - 11, LON - 5)  # as measured (Q1)


@pytest.mark.parametrize(("lat", "lon", "error"), [
    (47.2771889, 11.4039701, (-17, -5)), (-33.8567891, 151.2153423, (19, 49)), (89.9999999, 179.9999999, (1, 1)),
])
def test_float_items_are_stored_off_by_what_was_measured(lat, lon, error):
    legacy = mavlink.MAVLink_mission_item_message(1, 1, 1, 3, 16, 0, 1, 0, 0, 0, 0, lat, lon, 30.0, 0)
    item, result = from_legacy_item(legacy)
    assert result == mavlink.MAV_MISSION_ACCEPTED
    assert (item.x - round(lat * 1e7), item.y - round(lon * 1e7)) == error


def test_legacy_download_answers_mission_item_in_float32_degrees_with_a_warning():
    p = protocol()
    upload(p, [wp(0), wp(1)])
    out = p.handle(_from(mavlink.MAVLink_mission_request_message(1, 1, 1, 0)), 0.0)
    item = only(out, "MISSION_ITEM")
    assert texts(out) == ["got MISSION_REQUEST; use MISSION_REQUEST_INT!"]
    assert item.x == f32(f32(LAT + 1) * f32(1e-7)) and abs(item.x * 1e7 - (LAT + 1)) < 40
    again = p.handle(_from(mavlink.MAVLink_mission_request_message(1, 1, 1, 0)), 1.0)
    assert texts(again) == []  # warned once
    assert to_legacy_item(p.items()[1], GCS).y == item.y


def test_a_station_cancel_is_ignored_and_lists_cannot_be_read_while_uploading():
    p = protocol()
    p.handle(count(3), 0.0)
    send(p, wp(0))
    p.handle(_from(mavlink.MAVLink_mission_ack_message(1, 1, mavlink.MAV_MISSION_OPERATION_CANCELLED, 0)), 0.1)
    assert p.busy
    listing = p.handle(_from(mavlink.MAVLink_mission_request_list_message(1, 1, 0)), 0.2)
    assert only(listing, "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    reading = p.handle(_from(mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0)), 0.2)
    assert only(reading, "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    clear = p.handle(_from(mavlink.MAVLink_mission_clear_all_message(1, 1, 0)), 0.2)
    assert only(clear, "MISSION_ACK").type == mavlink.MAV_MISSION_ERROR
    fence_list = p.handle(_from(mavlink.MAVLink_mission_request_list_message(1, 1, FENCE)), 0.2)
    assert only(fence_list, "MISSION_COUNT").count == 0  # another list is not busy


def test_re_requests_every_second_and_gives_up_8_s_after_the_last_item():
    p = protocol()
    p.handle(count(3), 0.0)
    send(p, wp(0), 0.5)
    assert p.poll(1.4) == []
    assert only(p.poll(1.6), "MISSION_REQUEST").seq == 1
    assert only(p.poll(2.7), "MISSION_REQUEST").seq == 1
    assert p.poll(8.4) != [] and p.busy
    out = p.poll(8.6)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_OPERATION_CANCELLED
    assert texts(out) == ["Mission upload timeout"] and not p.busy


def test_a_count_restarts_the_same_stations_upload_and_another_station_is_denied():
    p = protocol()
    p.handle(count(4), 0.0)
    send(p, wp(0))
    send(p, wp(1))
    assert only(p.handle(count(2, sender=OTHER), 0.0), "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    assert only(p.handle(count(3), 0.0), "MISSION_REQUEST").seq == 0  # from the start again
    assert only(send(p, wp(1, z=5.0)), "MISSION_ACK").type == mavlink.MAV_MISSION_INVALID_SEQUENCE
    assert only(send(p, wp(0)), "MISSION_REQUEST").seq == 1  # the upload went on after the stale item


def test_an_item_of_another_sender_is_denied_and_items_of_an_idle_list_are_an_error():
    p = protocol()
    p.handle(count(3), 0.0)
    assert only(send(p, wp(0), sender=OTHER), "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    assert only(send(p, rally(0)), "MISSION_ACK").type == mavlink.MAV_MISSION_ERROR
    assert only(send(p, wp(0)), "MISSION_REQUEST").seq == 1  # the mission upload is still on


def test_the_last_item_again_after_a_lost_ack_is_an_error():
    p = protocol()
    upload(p, [wp(0), wp(1)])
    assert only(send(p, wp(1)), "MISSION_ACK").type == mavlink.MAV_MISSION_ERROR  # no longer receiving


def test_the_fence_is_staged_validated_at_the_end_and_all_or_nothing():
    p = protocol()
    good = [vertex(i) for i in range(4)]
    out = upload(p, good)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED and texts(out) == ["Fence Indexed OK"]
    kept = p.items(FENCE)
    assert [(k.frame, k.z, k.param1) for k in kept] == [(0, 0.0, 4.0)] * 4
    bad_frame = [vertex(0), vertex(1), vertex(2, frame=mavlink.MAV_FRAME_MISSION), vertex(3)]
    assert only(upload(p, bad_frame), "MISSION_ACK").type == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    bad_count = [vertex(i, n=5) for i in range(4)]
    out = upload(p, bad_count)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ERROR
    assert texts(out) == ["Incorrect item count", "Fence validation failed"]
    assert p.items(FENCE) == kept  # the old fence survives every refused upload


@pytest.mark.parametrize(("items", "problem"), [
    ([vertex(0, n=2), vertex(1, n=2)], "Invalid vertex count (2)"),
    ([vertex(i, n=5) for i in range(4)] + [WireItem(seq=4, frame=0, command=CIRCLE, param1=50.0, x=LAT, y=LON,
                                                    mission_type=FENCE)],
     "Received incorrect type (want=98 got=92)"),
    ([WireItem(seq=0, frame=0, command=CIRCLE, param1=0.0, x=LAT, y=LON, mission_type=FENCE)],
     "Non-positive circle radius"),
    ([WireItem(seq=i, frame=0, command=mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, x=LAT, y=LON, mission_type=FENCE)
      for i in range(2)], "Multiple return points"),
    ([vertex(i, x=910000000) for i in range(4)], "Bad lat or lon"),
    ([vertex(i, n=70) for i in range(70)], "Fence exceeds storage size"),
])
def test_fence_validation_says_what_arducopter_says(items, problem):
    assert fence_problems(items, CAPACITY["copter"][FENCE]) == [problem, "Fence validation failed"]


def test_fence_storage_fits_69_vertices_on_a_copter_and_83_on_a_plane():
    assert fence_problems([vertex(i, n=69) for i in range(69)], 70) == []
    assert fence_problems([vertex(i, n=83) for i in range(83)], 84) == []
    assert fence_problems([vertex(i, n=84) for i in range(84)], 84) == ["Fence exceeds storage size",
                                                                         "Fence validation failed"]


def test_a_small_fence_replacing_a_polygon_is_wiped_unless_sent_twice_or_after_a_settled_clear():
    one_circle = [WireItem(seq=0, frame=0, command=CIRCLE, param1=150.0, x=LAT, y=LON, mission_type=FENCE)]
    p = protocol()
    upload(p, [vertex(i) for i in range(4)], 0.0)
    out = upload(p, one_circle, 1.0)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED and texts(out) == ["Fence Indexed OK"]
    assert p.items(FENCE) == []  # ArduPilot took FENCE_TOTAL -> 0 as a clear (Q2)
    upload(p, one_circle, 2.0)
    assert len(p.items(FENCE)) == 1  # the second time nothing is wiped
    for wait_s, left in ((0.0, 0), (2.5, 1)):
        p = protocol()
        upload(p, [vertex(i) for i in range(4)], 0.0)
        p.handle(_from(mavlink.MAVLink_mission_clear_all_message(1, 1, FENCE)), 1.0)
        upload(p, one_circle, 1.0 + wait_s)
        assert len(p.items(FENCE)) == left
    p = protocol()
    upload(p, [vertex(i) for i in range(4)], 0.0)
    upload(p, [vertex(i, n=3) for i in range(3)], 1.0)
    assert len(p.items(FENCE)) == 3  # 3 vertices count: nothing wiped


def test_rally_points_are_written_in_place_with_their_own_refusals():
    p = protocol()
    upload(p, [rally(i, z=11.0 + i) for i in range(4)])
    new = [rally(0, z=21.0), rally(1, z=22.0, frame=mavlink.MAV_FRAME_MISSION), rally(2, z=23.0)]
    assert only(upload(p, new), "MISSION_ACK").type == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    assert zs(p, RALLY) == [21.0, 12.0, 13.0]  # as measured: count 3, the first new
    assert only(upload(p, [rally(0, z=60.75)]), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert zs(p, RALLY) == [60.0]  # whole metres
    for z, result in ((32767.0, mavlink.MAV_MISSION_ACCEPTED), (32768.0, mavlink.MAV_MISSION_INVALID_PARAM7),
                      (-32769.0, mavlink.MAV_MISSION_INVALID_PARAM7)):
        assert item_result(rally(0, z=z)) == result
    assert item_result(rally(0, command=mavlink.MAV_CMD_NAV_WAYPOINT)) == mavlink.MAV_MISSION_UNSUPPORTED
    assert item_result(rally(0, x=910000000)) == mavlink.MAV_MISSION_INVALID_PARAM5_X
    assert item_result(vertex(0, command=mavlink.MAV_CMD_NAV_WAYPOINT)) == mavlink.MAV_MISSION_UNSUPPORTED
    assert item_result(vertex(0, frame=mavlink.MAV_FRAME_LOCAL_NED)) == mavlink.MAV_MISSION_UNSUPPORTED_FRAME


def test_count_zero_and_clear_all_leave_only_home():
    p = protocol()
    upload(p, [wp(i) for i in range(4)])
    out = p.handle(count(0), 0.0)
    assert only(out, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert len(p.items()) == 1
    upload(p, [wp(i) for i in range(4)])
    upload(p, [rally(0)])
    clear = p.handle(_from(mavlink.MAVLink_mission_clear_all_message(1, 1, MissionType.ALL)), 0.0)
    assert only(clear, "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert [len(p.items(t)) for t in (0, 1, 2)] == [1, 0, 0]
