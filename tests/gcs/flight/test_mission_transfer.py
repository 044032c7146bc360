"""The GCS-side mission protocol state machines, message by message, and against the
simulator's vehicle-side state machine over a seeded lossy, duplicating, reordering channel
(both pure: no sockets, time passed in)."""

from __future__ import annotations

import random

import pytest

from gcs.autopilots import Autopilot, compare_items
from gcs.autopilots.mission_transfer import Download, MissionType, Upload, WireItem
from gcs.links import mavlink
from sim.autopilot.mission_protocol import MissionProtocol, ProtocolConfig

GCS = (255, 190)
VEHICLE = (1, 1)


def _msg(m, src=VEHICLE):
    """Give a constructed message a source, as decoding does."""
    m._header = mavlink.MAVLink_header(m.id, srcSystem=src[0], srcComponent=src[1])
    return m


def _items(n: int) -> list[WireItem]:
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
    return [WireItem.at(i, rel, mavlink.MAV_CMD_NAV_WAYPOINT, -35.0 + i * 1e-4, 149.0, 50.0 + i) for i in range(n)]


def _req(seq, legacy=False, mtype=0):
    cls = mavlink.MAVLink_mission_request_message if legacy else mavlink.MAVLink_mission_request_int_message
    return _msg(cls(*GCS, seq, mtype))


def _ack(result, mtype=0):
    return _msg(mavlink.MAVLink_mission_ack_message(*GCS, result, mtype))


def test_upload_happy_path_and_legacy_request_answered_with_item_int():
    up = Upload(VEHICLE, _items(3), timeout_s=1.0)
    [count] = up.start(0.0)
    assert count.get_type() == "MISSION_COUNT" and count.count == 3
    [item] = up.handle(_req(0), 0.1)
    assert item.get_type() == "MISSION_ITEM_INT" and item.seq == 0
    [item] = up.handle(_req(1, legacy=True), 0.2)  # ArduPilot asks only this way: no float32 rounding
    assert item.get_type() == "MISSION_ITEM_INT" and item.x == round((-35.0 + 1e-4) * 1e7)
    assert up.legacy_requests == 1
    up.handle(_req(2), 0.3)
    assert not up.done
    assert up.handle(_ack(mavlink.MAV_MISSION_ACCEPTED), 0.4) == [] and up.done and up.error is None


def test_upload_duplicate_and_out_of_order_requests_are_answered():
    up = Upload(VEHICLE, _items(3))
    up.start(0.0)
    assert up.handle(_req(1), 0.1)[0].seq == 1  # out of order: send what is asked
    assert up.handle(_req(1), 0.2) == []  # a re-request crossing the item just sent (0.5 s / 4)
    assert up.handle(_req(1), 0.3)[0].seq == 1  # later: it was lost, send it again
    assert up.handle(_req(7), 0.3) == []  # beyond the list: stale
    assert up.handle(_req(0, mtype=MissionType.FENCE), 0.1) == []  # another list's request


def test_upload_stale_accept_and_invalid_sequence_are_not_final():
    up = Upload(VEHICLE, _items(2))
    up.start(0.0)
    up.handle(_req(0), 0.1)
    up.handle(_ack(mavlink.MAV_MISSION_ACCEPTED), 0.1)  # an old transfer's ACK: the last item was not asked yet
    assert not up.done
    up.handle(_ack(mavlink.MAV_MISSION_INVALID_SEQUENCE), 0.2)
    assert not up.finished
    up.handle(_req(1), 0.3)
    up.handle(_ack(mavlink.MAV_MISSION_ACCEPTED), 0.4)
    assert up.done


def test_upload_error_ack_fails_with_its_result():
    up = Upload(VEHICLE, _items(2))
    up.start(0.0)
    up.handle(_ack(mavlink.MAV_MISSION_NO_SPACE), 0.1)
    assert up.error is not None and up.error.result == mavlink.MAV_MISSION_NO_SPACE
    assert "NO_SPACE" in str(up.error)


def test_upload_timeouts_resend_then_give_up():
    up = Upload(VEHICLE, _items(2), timeout_s=0.5, max_retries=2)
    up.start(0.0)
    assert up.poll(0.4) == []
    assert up.poll(0.5)[0].get_type() == "MISSION_COUNT"
    up.handle(_req(0), 0.6)
    assert up.poll(1.2)[0].get_type() == "MISSION_ITEM_INT"  # the retry count restarts on progress
    assert up.poll(1.8)[0].get_type() == "MISSION_ITEM_INT"
    cancel = up.poll(2.4)  # gives up, and tells the vehicle so
    assert [(m.get_type(), m.type) for m in cancel] == [("MISSION_ACK", mavlink.MAV_MISSION_OPERATION_CANCELLED)]
    assert up.error is not None and up.error.result is None
    assert up.poll(3.0) == [] and up.resends == 3


def test_a_vehicle_that_keeps_asking_for_an_item_it_was_sent_fails_the_upload_and_is_told():
    """Our items never reach it (a one-way link), or a loaded station's answers drown in its
    re-requests: it asks for item 1 every 8 ms (PX4's 0.25 s at 30 times real time). Each copy is
    not answered; after max_retries timeouts without a new item the upload ends (TIMEOUT, so
    `upload_verified` tries again) and the vehicle is told to leave the transfer."""
    up = Upload(VEHICLE, _items(3), timeout_s=0.5, max_retries=4)
    up.start(0.0)
    up.handle(_req(0), 0.01)
    sent = [m for k in range(1, 301) for m in up.handle(_req(1), 0.01 + 0.008 * k)]
    assert up.error is not None and up.error.result is None and "asked for item 1 again" in str(up.error)
    assert sum(m.get_type() == "MISSION_ITEM_INT" for m in sent) <= 2.4 / (0.5 / 4) + 1  # one per 125 ms, not 300
    assert sent[-1].get_type() == "MISSION_ACK" and sent[-1].type == mavlink.MAV_MISSION_OPERATION_CANCELLED


def test_upload_ignores_other_systems():
    up = Upload(VEHICLE, _items(1))
    up.start(0.0)
    assert up.handle(_msg(mavlink.MAVLink_mission_request_int_message(*GCS, 0, 0), src=(2, 1)), 0.1) == []


def test_download_sequence_duplicates_and_busy_vehicle():
    dl = Download(VEHICLE, timeout_s=0.5)
    [first] = dl.start(0.0)
    assert first.get_type() == "MISSION_REQUEST_LIST"
    assert dl.handle(_ack(mavlink.MAV_MISSION_DENIED), 0.1) == [] and not dl.finished  # busy: ask again later
    [req] = dl.handle(_msg(mavlink.MAVLink_mission_count_message(*GCS, 2, 0)), 0.2)
    assert req.get_type() == "MISSION_REQUEST_INT" and req.seq == 0
    items = _items(2)
    dl.handle(_msg(items[0].to_msg(GCS)), 0.3)
    assert dl.handle(_msg(items[0].to_msg(GCS)), 0.3) == []  # duplicate
    i = items[1]
    legacy = mavlink.MAVLink_mission_item_message(*GCS, i.seq, i.frame, i.command, 0, 1, 0, 0, 0, 0, i.x / 1e7,
                                                  i.y / 1e7, i.z, 0)  # an old vehicle answering in float degrees
    [ack] = dl.handle(_msg(legacy), 0.4)
    assert ack.get_type() == "MISSION_ACK" and dl.done
    assert abs(dl.items[1].x - i.x) <= 20 and dl.items[1].z == i.z


def test_a_download_that_must_not_wait_fails_at_once_on_a_busy_vehicle():
    """A restarted station asks a vehicle still receiving the killed station's upload: DENIED ends
    the read-back (no 10 re-sends while the vehicle holds in the air)."""
    dl = Download(VEHICLE, timeout_s=0.5, busy_is_final=True)
    dl.start(0.0)
    assert dl.handle(_ack(mavlink.MAV_MISSION_DENIED), 0.1) == []
    assert dl.error is not None and dl.error.result == mavlink.MAV_MISSION_DENIED
    assert "receiving an upload" in str(dl.error)


def _with(item: WireItem, **changes) -> WireItem:
    return WireItem(**{**{f: getattr(item, f) for f in WireItem.__slots__}, **changes})


def test_compare_items_expects_what_the_autopilot_stores_and_catches_corruption():
    rel_int = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    sent = [WireItem.at(0, 0, 16, -35.0, 149.0, 0.0),
            WireItem.at(1, rel_int, mavlink.MAV_CMD_NAV_TAKEOFF, -35.0, 149.0, 30.0, (15.3, 0, 0, 0)),
            WireItem.at(2, rel_int, mavlink.MAV_CMD_NAV_WAYPOINT, -35.0001, 149.0001, 30.456),
            WireItem.at(3, rel_int, mavlink.MAV_CMD_NAV_LAND, -35.0, 149.0, 0.0)]
    # what ArduPilot 4.7 SITL returned for these: frames without _INT, altitude cut to cm, pitch as a
    # whole degree, LAND param4 as yaw direction +1, item 0 replaced by the vehicle's home
    stored = [WireItem.at(0, 0, 16, -35.1, 149.1, 584.09),
              _with(sent[1], frame=3, param1=15.0), _with(sent[2], frame=3, z=30.45),
              _with(sent[3], frame=3, param4=1.0)]
    assert compare_items(sent, stored, Autopilot.ARDUPILOT) == []
    assert compare_items(sent, stored, Autopilot.PX4)  # PX4 keeps frames and item 0 as sent
    moved = [*stored[:2], _with(stored[2], x=stored[2].x + 1), stored[3]]
    assert compare_items(sent, moved, Autopilot.ARDUPILOT) == \
        ["item 2: position -35.0000999,149.0001000, sent -35.0001000,149.0001000"]
    higher = [*stored[:2], _with(stored[2], z=30.47), stored[3]]
    assert compare_items(sent, higher, Autopilot.ARDUPILOT) == ["item 2: altitude 30.47, expected 30.45 (sent 30.456)"]
    retyped = [*stored[:3], _with(stored[3], command=mavlink.MAV_CMD_NAV_WAYPOINT)]
    assert compare_items(sent, retyped, Autopilot.ARDUPILOT)[0].startswith("item 3: command/frame 16/3")
    assert compare_items(sent, stored[:3], Autopilot.ARDUPILOT) == ["3 items read back, 4 sent"]


def test_plane_waypoints_keep_radii_as_whole_metres_and_drop_the_hold_time():
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
    wp = WireItem.at(1, rel, mavlink.MAV_CMD_NAV_WAYPOINT, 47.0, 11.0, 50.0, (7.5, 3.7, 300.0, 45.5))
    plane = Autopilot.ARDUPILOT.stored_item(wp, fixed_wing=True)
    copter = Autopilot.ARDUPILOT.stored_item(wp, fixed_wing=False)
    assert (plane.param1, plane.param2, plane.param3, plane.param4) == (0.0, 3.0, 255.0, 0.0)
    assert (copter.param1, copter.param2, copter.param3, copter.param4) == (7.0, 0.0, 0.0, 0.0)


def test_autopilot_conventions():
    assert Autopilot.from_heartbeat(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA) is Autopilot.ARDUPILOT
    assert Autopilot.from_heartbeat(mavlink.MAV_AUTOPILOT_PX4) is Autopilot.PX4
    assert Autopilot.ARDUPILOT.home_item(MissionType.MISSION) and not Autopilot.ARDUPILOT.home_item(MissionType.FENCE)
    assert not Autopilot.PX4.home_item(MissionType.MISSION)
    assert (Autopilot.ARDUPILOT.first_mission_seq(), Autopilot.PX4.first_mission_seq()) == (1, 0)


def _channel_run(machine, vehicle: MissionProtocol, seed: int, loss: float, dup: float) -> float:
    """Drive GCS and vehicle machines over a seeded lossy channel with delays; returns the end time."""
    rng = random.Random(seed)
    now = 0.0
    in_flight: list[tuple[float, str, object]] = []

    def post(direction, msgs):
        for m in msgs:
            src = GCS if direction == "up" else VEHICLE
            m = _msg(m, src)
            for _ in range(2 if rng.random() < dup else 1):
                if rng.random() >= loss:
                    in_flight.append((now + rng.uniform(0.001, 0.03), direction, m))

    post("up", machine.start(now))
    while not machine.finished and now < 600:
        in_flight.sort(key=lambda e: e[0])
        due = [e for e in in_flight if e[0] <= now]
        in_flight[:] = [e for e in in_flight if e[0] > now]
        for _, direction, m in due:
            if direction == "up":
                post("down", vehicle.handle(m, now))
            else:
                post("up", machine.handle(m, now))
        post("up", machine.poll(now))
        post("down", vehicle.poll(now))
        now += 0.005
    return now


@pytest.mark.parametrize("seed", range(6))
def test_upload_and_read_back_against_the_vehicle_state_machine_under_loss(seed):
    vehicle = MissionProtocol(ProtocolConfig(home_item=True, timeout_s=0.3))
    items = _items(40)
    up = Upload(VEHICLE, items, timeout_s=0.1, max_retries=50)
    _channel_run(up, vehicle, seed, loss=0.2, dup=0.1)
    assert up.done and up.error is None
    stored = vehicle.items()
    assert [(s.x, s.y) for s in stored[1:]] == [(i.x, i.y) for i in items[1:]]
    dl = Download(VEHICLE, timeout_s=0.1, max_retries=50)
    _channel_run(dl, vehicle, seed + 100, loss=0.2, dup=0.1)
    assert dl.done
    assert compare_items(items, dl.items, Autopilot.ARDUPILOT) == []
