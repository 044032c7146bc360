"""The vehicle-side mission state machine, driven message by message with a fake clock."""

from __future__ import annotations

import pytest
from hypothesis import given, settings, strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import MissionType, WireItem
from sim.autopilot.mission_protocol import MissionProtocol, ProtocolConfig

GCS = (255, 190)
OTHER = (254, 190)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def _from(msg, sender=GCS):
    msg._header = mavlink.MAVLink_header(msg.id, srcSystem=sender[0], srcComponent=sender[1])
    return msg


def count(n, mtype=0, sender=GCS):
    return _from(mavlink.MAVLink_mission_count_message(1, 1, n, mtype), sender)


def item(seq, mtype=0, frame=REL, sender=GCS, legacy=False):
    it = WireItem(seq=seq, frame=frame, command=16, x=-353632610 + seq, y=1491652300, z=10.0 + seq,
                  mission_type=mtype)
    return _from(it.to_msg((1, 1), legacy=legacy), sender)


def request_int(seq, mtype=0, sender=GCS):
    return _from(mavlink.MAVLink_mission_request_int_message(1, 1, seq, mtype), sender)


def request_list(mtype=0, sender=GCS):
    return _from(mavlink.MAVLink_mission_request_list_message(1, 1, mtype), sender)


def only(out, kind):
    assert len(out) == 1 and out[0].get_type() == kind, out
    return out[0]


def upload(p, n, mtype=0, now=0.0):
    out = p.handle(count(n, mtype), now)
    for seq in range(n):
        assert only(out, "MISSION_REQUEST_INT").seq == seq
        out = p.handle(item(seq, mtype), now)
    return only(out, "MISSION_ACK").type


def test_upload_then_download_round_trip_with_home_item():
    p = MissionProtocol()
    p.set_home(-35.0, 149.0, 584.0)
    assert upload(p, 5) == mavlink.MAV_MISSION_ACCEPTED
    assert only(p.handle(request_list(), 0), "MISSION_COUNT").count == 5
    home = only(p.handle(request_int(0), 0), "MISSION_ITEM_INT")
    assert (home.x, home.y, home.z) == (-350000000, 1490000000, 584.0)
    third = only(p.handle(request_int(3), 0), "MISSION_ITEM_INT")
    assert (third.seq, third.x, third.z, third.target_system) == (3, -353632610 + 3, 13.0, GCS[0])


def test_px4_profile_has_no_home_item():
    p = MissionProtocol(ProtocolConfig(home_item=False))
    assert only(p.handle(request_list(), 0), "MISSION_COUNT").count == 0
    upload(p, 3)
    assert only(p.handle(request_int(0), 0), "MISSION_ITEM_INT").x == -353632610
    assert [i.seq for i in p.items()] == [0, 1, 2]


def test_ardupilot_profile_reports_home_when_empty():
    p = MissionProtocol()
    assert only(p.handle(request_list(), 0), "MISSION_COUNT").count == 1


def test_out_of_order_item_gets_invalid_sequence_and_transfer_continues():
    p = MissionProtocol()
    p.handle(count(3), 0)
    p.handle(item(0), 0)
    ack = only(p.handle(item(2), 0), "MISSION_ACK")
    assert ack.type == mavlink.MAV_MISSION_INVALID_SEQUENCE
    assert only(p.handle(item(1), 0), "MISSION_REQUEST_INT").seq == 2
    assert only(p.handle(item(2), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED


def test_duplicate_item_is_answered_with_the_request_we_need():
    p = MissionProtocol()
    p.handle(count(3), 0)
    p.handle(item(0), 0)
    p.handle(item(1), 0)
    assert only(p.handle(item(1), 0), "MISSION_REQUEST_INT").seq == 2


def test_too_many_items_is_no_space():
    p = MissionProtocol(ProtocolConfig(capacity={0: 10, 1: 5, 2: 5}))
    assert only(p.handle(count(11), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_NO_SPACE
    assert only(p.handle(count(6, 1), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_NO_SPACE


def test_local_frame_is_unsupported_and_the_old_mission_survives():
    p = MissionProtocol()
    upload(p, 3)
    p.handle(count(2), 0)
    p.handle(item(0), 0)
    ack = only(p.handle(item(1, frame=mavlink.MAV_FRAME_LOCAL_NED), 0), "MISSION_ACK")
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    assert len(p.items()) == 3
    assert not p.busy


def test_second_gcs_is_denied_while_an_upload_is_in_progress():
    p = MissionProtocol()
    p.handle(count(3), 0)
    assert only(p.handle(count(2, sender=OTHER), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    assert only(p.handle(request_list(sender=OTHER), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED
    clear = _from(mavlink.MAVLink_mission_clear_all_message(1, 1, 0), OTHER)
    assert only(p.handle(clear, 0), "MISSION_ACK").type == mavlink.MAV_MISSION_DENIED


def test_timeout_re_requests_then_gives_up():
    p = MissionProtocol(ProtocolConfig(timeout_s=1.0, max_retries=2))
    p.handle(count(2), 0.0)
    assert p.poll(0.5) == []
    assert only(p.poll(1.1), "MISSION_REQUEST_INT").seq == 0
    assert only(p.poll(2.2), "MISSION_REQUEST_INT").seq == 0
    assert only(p.poll(3.3), "MISSION_ACK").type == mavlink.MAV_MISSION_OPERATION_CANCELLED
    assert not p.busy


def test_lost_final_ack_is_resent_when_the_last_item_is_repeated():
    p = MissionProtocol()
    upload(p, 2)
    assert only(p.handle(item(1), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED


def test_legacy_mission_item_and_request_are_accepted():
    p = MissionProtocol()
    p.handle(count(2), 0)
    p.handle(item(0, legacy=True), 0)
    assert only(p.handle(item(1, legacy=True), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    legacy = only(p.handle(_from(mavlink.MAVLink_mission_request_message(1, 1, 1, 0)), 0), "MISSION_ITEM")
    assert legacy.x == pytest.approx(-35.3632609, abs=1e-6)
    assert p.items()[1].x == -353632609


def test_mission_types_are_separate_stores_and_clear_all_clears_each():
    p = MissionProtocol()
    upload(p, 4, MissionType.MISSION)
    upload(p, 3, MissionType.FENCE)
    upload(p, 2, MissionType.RALLY)
    assert [len(p.items(t)) for t in (0, 1, 2)] == [4, 3, 2]
    clear_fence = _from(mavlink.MAVLink_mission_clear_all_message(1, 1, MissionType.FENCE))
    assert only(p.handle(clear_fence, 0), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert [len(p.items(t)) for t in (0, 1, 2)] == [4, 0, 2]
    clear_all = _from(mavlink.MAVLink_mission_clear_all_message(1, 1, MissionType.ALL))
    p.handle(clear_all, 0)
    assert [len(p.items(t)) for t in (0, 1, 2)] == [1, 0, 0]  # home stays


def test_request_beyond_the_end_is_invalid_sequence():
    p = MissionProtocol()
    upload(p, 2)
    assert only(p.handle(request_int(2), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_INVALID_SEQUENCE


def test_zero_count_clears_and_a_gcs_cancel_aborts_the_upload():
    p = MissionProtocol()
    upload(p, 3)
    assert only(p.handle(count(0), 0), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert len(p.items()) == 1
    p.handle(count(3), 0)
    p.handle(_from(mavlink.MAVLink_mission_ack_message(1, 1, mavlink.MAV_MISSION_OPERATION_CANCELLED, 0)), 0)
    assert not p.busy


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 40), drops=st.lists(st.booleans(), min_size=400, max_size=400))
def test_upload_converges_on_any_loss_pattern(n, drops):
    """A retrying GCS and the vehicle's own re-requests always finish with the right items."""
    p = MissionProtocol(ProtocolConfig(timeout_s=1.0, max_retries=1000))
    lost = iter([d and i % 3 != 0 for i, d in enumerate(drops * 10)])  # every third one arrives
    now = 0.0
    pending = [count(n)]
    for _ in range(4000):
        now += 0.4
        to_vehicle = [m for m in pending if not next(lost)]
        replies = [r for m in to_vehicle for r in p.handle(m, now)] + p.poll(now)
        replies = [r for r in replies if not next(lost)]
        acks = [r for r in replies if r.get_type() == "MISSION_ACK"]
        if any(a.type == mavlink.MAV_MISSION_ACCEPTED for a in acks):
            break
        requests = [r for r in replies if r.get_type() == "MISSION_REQUEST_INT"]
        pending = [item(r.seq) for r in requests] or pending  # GCS resends its last message
    assert [it.z for it in p.items()[1:]] == [10.0 + s for s in range(1, n)]
