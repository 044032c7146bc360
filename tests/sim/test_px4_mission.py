"""PX4's mission manager (`sim.autopilot.px4_mission`), messages in and out without sockets, against what
PX4 v1.15.3 SITL did (research `px4` §1, §2) and, where it was not measured, its source: the
requests, atomic replacement, refusals, capacities, re-requests and the timeout, read-backs and
their `current` flags, and the item checks against the station's own model of PX4."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots import px4_storage
from gcs.autopilots.wire_item import WireItem
from sim.autopilot.mission_protocol import ProtocolConfig
from sim.autopilot.px4 import CAPACITY, item_result, list_result
from sim.autopilot.px4_mission import Px4MissionProtocol

GCS, OTHER = (255, 190), (254, 190)
MISSION, FENCE, RALLY = 0, 1, 2
REL, REL_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def _from(msg, sender=GCS):
    msg._header = mavlink.MAVLink_header(msg.id, srcSystem=sender[0], srcComponent=sender[1])
    return msg


class Manager:
    def __init__(self, current: int = -1) -> None:
        self.current = current
        self.p = Px4MissionProtocol(ProtocolConfig(capacity=dict(CAPACITY)), lambda: self.current,
                                    itertools.count().__next__)
        self.now = 0.0

    def send(self, msg, sender=GCS) -> list:
        return self.p.handle(_from(msg, sender), self.now)

    def count(self, n: int, mission_type: int = MISSION, sender=GCS) -> list:
        return self.send(mavlink.MAVLink_mission_count_message(1, 1, n, mission_type), sender)

    def upload(self, items: list[WireItem], mission_type: int = MISSION) -> tuple[int, list[tuple[str, int]]]:
        requests = []
        out = self.count(len(items), mission_type)
        while True:
            msg = next(m for m in out if m.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"))
            if msg.get_type() == "MISSION_ACK":
                return msg.type, requests
            requests.append((msg.get_type(), msg.seq))
            out = self.send(replace(items[msg.seq], seq=msg.seq, mission_type=mission_type).to_msg((1, 1)))

    def download(self, mission_type: int = MISSION, legacy: bool = False) -> list:
        n = self.send(mavlink.MAVLink_mission_request_list_message(1, 1, mission_type))[0].count
        make = mavlink.MAVLink_mission_request_message if legacy else mavlink.MAVLink_mission_request_int_message
        back = [self.send(make(1, 1, seq, mission_type))[0] for seq in range(n)]
        self.send(mavlink.MAVLink_mission_ack_message(1, 1, 0, mission_type))
        return back

    def poll(self, seconds: float, step: float = 0.05) -> list:
        out = []
        for _ in range(round(seconds / step)):
            self.now += step
            out += [(round(self.now, 2), m) for m in self.p.poll(self.now)]
        return out


def wp(seq: int, north_m: float = 0.0, z: float = 20.0, **kw) -> WireItem:
    return WireItem(seq=seq, frame=REL, command=mavlink.MAV_CMD_NAV_WAYPOINT, x=472771883 + round(north_m * 9),
                    y=114039709, z=z, **kw)


def texts(out: list) -> list[str]:
    return [m.text for m in out if m.get_type() == "STATUSTEXT"]


def test_the_first_upload_asks_item_0_with_mission_request_and_later_ones_only_with_the_int():
    m = Manager()
    assert m.upload([wp(0), wp(1), wp(2)]) == (0, [("MISSION_REQUEST", 0), ("MISSION_REQUEST_INT", 1),
                                                   ("MISSION_REQUEST_INT", 2)])
    assert m.upload([wp(0), wp(1)])[1] == [("MISSION_REQUEST_INT", 0), ("MISSION_REQUEST_INT", 1)]
    m.download(legacy=True)  # a MISSION_REQUEST puts it back in float mode
    assert m.upload([wp(0), wp(1)])[1][0] == ("MISSION_REQUEST", 0)


def test_a_refused_item_ends_the_upload_and_leaves_the_old_list_whole():
    m = Manager()
    old = [wp(i, 10 * i) for i in range(4)]
    m.upload(old)
    before = m.download()
    bad = [wp(i, 100 + i) for i in range(6)]
    bad[3] = replace(bad[3], frame=mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)
    result, requests = m.upload(bad)
    assert result == mavlink.MAV_MISSION_UNSUPPORTED_FRAME and requests[-1][1] == 3
    assert [(i.x, i.z) for i in m.download()] == [(i.x, i.z) for i in before]
    fence_vertex = replace(bad[3], frame=REL, command=mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, param1=4)
    out = m.count(6)
    for it in bad[:3] + [fence_vertex]:
        out = m.send(replace(it, seq=out[0].seq).to_msg((1, 1)))
    assert [x.type for x in out if x.get_type() == "MISSION_ACK"] == [mavlink.MAV_MISSION_ERROR] and not texts(out)
    assert len(m.download()) == 4


def test_capacity_is_checked_at_the_count_without_a_text_and_the_old_list_stays():
    m = Manager()
    m.upload([wp(0)], RALLY)
    for mission_type, n in ((MISSION, 65535), (FENCE, 65), (RALLY, 33)):
        out = m.count(n, mission_type)
        assert [x.type for x in out] == [mavlink.MAV_MISSION_NO_SPACE]
    assert m.count(64, FENCE)[0].get_type() == "MISSION_REQUEST_INT"
    m.send(mavlink.MAVLink_mission_ack_message(1, 1, mavlink.MAV_MISSION_OPERATION_CANCELLED, FENCE))
    assert len(m.download(RALLY)) == 1
    assert m.count(0, RALLY)[0].type == mavlink.MAV_MISSION_ACCEPTED and m.download(RALLY) == []


def test_an_abandoned_upload_is_asked_again_every_quarter_second_for_5_s_then_operation_timeout():
    m = Manager()
    m.upload([wp(0), wp(1)])
    out = m.count(3)
    m.send(wp(0).to_msg((1, 1)))
    sent = m.poll(6.0)
    asked = [t for t, x in sent if x.get_type() == "MISSION_REQUEST_INT"]
    assert all(x.seq == 1 for _, x in sent if x.get_type() == "MISSION_REQUEST_INT")
    gaps = [b - a for a, b in zip(asked, asked[1:])]
    assert len(asked) >= 16 and all(0.25 <= g <= 0.31 for g in gaps) and asked[-1] < 5.0  # §2: every 0.26 s
    assert [(t, x.text) for t, x in sent if x.get_type() == "STATUSTEXT"] == [(5.05, "Operation timeout\t")]
    assert not any(x.get_type() == "MISSION_ACK" for _, x in sent)
    assert len(m.download()) == 2 and out


def test_upload_states_and_partners_as_px4_answers_them():
    m = Manager()
    m.upload([wp(0), wp(1)])
    m.download()
    assert [x.type for x in m.send(wp(1).to_msg((1, 1)))] == [0]  # the last item again: ACCEPTED
    assert texts(m.send(wp(0).to_msg((1, 1)))) == ["IGN MISSION_ITEM: No transfer\t"]
    m.count(3)
    assert m.count(3)[0].get_type() == "MISSION_REQUEST_INT"  # request 0 lost: asked again
    m.send(wp(0).to_msg((1, 1)))
    out = m.count(3)
    assert texts(out) == ["WPM: REJ. CMD: Busy\t"] and out[-1].type == mavlink.MAV_MISSION_ERROR
    assert m.count(3, sender=OTHER)[0].type == mavlink.MAV_MISSION_ERROR
    assert texts(m.send(mavlink.MAVLink_mission_request_list_message(1, 1, 0))) == \
        ["Mission download request ignored, already active\t"]
    assert texts(m.send(mavlink.MAVLink_mission_clear_all_message(1, 1, 0))) == ["WPM: IGN CLEAR CMD: Busy\t"]
    assert m.send(wp(2).to_msg((1, 1))) == []  # not the awaited item: ignored
    assert texts(m.send(wp(1).to_msg((1, 1)), sender=OTHER)) == ["REJ. MIS ITEM: partner id mismatch\t"]


def test_read_backs_mark_the_current_item_in_every_list_and_answer_legacy_requests_in_legacy_frames():
    m = Manager()
    m.upload([wp(0, z=12.345), wp(1, 30, current=1), wp(2, 60)])
    m.upload([wp(0, 10), wp(1, 20)], FENCE)
    assert m.p.uploaded_current[MISSION] == 1
    m.current = 1
    assert [x.current for x in m.download()] == [0, 1, 0]
    assert [x.current for x in m.download(FENCE)] == [0, 1]
    legacy = m.download(legacy=True)
    assert [(x.get_type(), x.frame) for x in legacy] == [("MISSION_ITEM", REL)] * 3
    assert legacy[0].x == pytest.approx(47.2771883, abs=1e-6) and legacy[0].z == pytest.approx(12.345, abs=1e-5)
    fence = m.download(FENCE)
    assert [x.frame for x in fence] == [mavlink.MAV_FRAME_GLOBAL_INT] * 2 and fence[0].autocontinue == 0


def test_an_upload_identical_to_the_stored_list_changes_nothing():
    m = Manager()
    m.upload([wp(0), wp(1, current=1)])
    version = m.p.versions[MISSION]
    m.upload([wp(0), wp(1)])  # the current flag is not part of PX4's CRC
    assert m.p.versions[MISSION] == version and m.p.uploaded_current[MISSION] == 1
    m.upload([wp(0), wp(1, z=21.0)])
    assert m.p.versions[MISSION] == version + 1 and m.p.uploaded_current[MISSION] == -1


def test_a_frame_2_items_x_and_y_come_back_in_float32_and_5_6_need_an_int_message():
    m = Manager()
    speed = WireItem(seq=0, frame=mavlink.MAV_FRAME_MISSION, command=mavlink.MAV_CMD_DO_CHANGE_SPEED,
                     param1=1, param2=5, x=472761189, y=114059634)
    assert m.upload([speed])[0] == 0
    assert (m.download()[0].x, m.download()[0].y) == (472761184, 114059632)
    legacy = replace(wp(0), frame=REL_INT).to_msg((1, 1), legacy=True)
    m.count(1)
    assert [x.type for x in m.send(legacy) if x.get_type() == "MISSION_ACK"] == \
        [mavlink.MAV_MISSION_UNSUPPORTED_FRAME]


_COMMANDS = (16, 19, 20, 21, 22, 178, 189, 5000, 5001, 5002, 5003, 5004, 5100)
_FRAMES = (0, 1, 2, 3, 4, 5, 6, 10, 11)


@pytest.mark.parametrize(("mission_type", "command", "frame"),
                         [c for c in itertools.product((MISSION, FENCE, RALLY), _COMMANDS, _FRAMES)
                          if not (c[0] != MISSION and c[1] in (20, 178, 189))])
def test_item_checks_agree_with_the_stations_model_of_px4(mission_type, command, frame):
    item = WireItem(seq=0, frame=frame, command=command, param1=4.0, x=472771883, y=114039709, z=20.0,
                    mission_type=mission_type)
    result = item_result(item, int_mode=True)
    if result == mavlink.MAV_MISSION_ACCEPTED:
        result = list_result(item)
    expected = px4_storage.refusal(item)
    if mission_type == MISSION and command == mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT and frame in (0, 3, 5, 6):
        expected = None  # not measured; PX4's mission list checks polygons, circles and rally points only
    assert (None if result == mavlink.MAV_MISSION_ACCEPTED else result) == expected


def test_unknown_commands_and_nan_roi_modes_are_refused_as_px4_parses_them():
    unknown = WireItem(seq=0, frame=REL, command=31010)
    assert item_result(unknown, int_mode=True) == mavlink.MAV_MISSION_UNSUPPORTED
    roi = WireItem(seq=0, frame=mavlink.MAV_FRAME_MISSION, command=mavlink.MAV_CMD_DO_SET_ROI, param1=math.nan)
    assert item_result(roi, int_mode=True) == mavlink.MAV_MISSION_ACCEPTED  # NaN reads as mode 0, ROI_NONE
    roi = replace(roi, param1=3.0)
    assert item_result(roi, int_mode=True) == mavlink.MAV_MISSION_INVALID_PARAM1
