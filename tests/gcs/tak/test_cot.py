"""The CoT events, as pure functions of what they show: read back as a TAK client reads them
(the XML, and TAK protocol 1 through takproto)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from datetime import UTC, datetime, timedelta

import pytest
import takproto

from gcs.tak import cot
from tests.gcs.tak.helpers import Received

NOW = datetime(2026, 5, 1, 12, 0, 0, 250000, tzinfo=UTC)
LATER = NOW + timedelta(seconds=20)
NAMING = cot.Naming("valley")


def _read(event: ET.Element) -> Received:
    data = cot.encode(event)
    assert data.startswith(b"<?xml")
    text = data.decode()
    return Received(ET.fromstring(text[text.index("<event"):]), 0.0)


def test_a_uav_track_carries_position_course_speed_battery_and_stage():
    sample = cot.TrackSample(3, 46.123456789, 7.98765432, 61.6, "search", course_deg=-90.0, speed_m_s=12.34,
                             battery_pct=76.4, vehicle="copter")
    got = _read(cot.uav_track(NAMING, sample, NOW, LATER))
    assert (got.uid, got.type, got.callsign) == ("gcs.valley.uav.3", "a-f-A-M-H-Q", "valley UAV3")
    assert got.point == (46.1234567, 7.9876543)  # 7 decimals, about 1 cm
    assert got.time() == NOW and got.time("start") == NOW and got.time("stale") == LATER
    assert got.element.find("point").get("hae") == "9999999.0"  # the geoid is not guessed
    track = got.element.find("detail/track")
    assert (track.get("course"), track.get("speed")) == ("270.0", "12.3")
    assert got.element.find("detail/status").get("battery") == "76"
    assert got.remarks == "stage search, 62 m above home, 12.3 m/s, course 270, battery 76%"
    plane = _read(cot.uav_track(NAMING, cot.TrackSample(1, 46.0, 7.0, 0.0, "landed", vehicle="plane", note="x"),
                                NOW, LATER))
    assert plane.type == "a-f-A-M-F-Q" and plane.element.find("detail/status") is None
    assert plane.remarks == "stage landed, 0 m above home, x"


@pytest.mark.parametrize("closed", [True, False])
def test_an_area_is_a_closed_shape_whichever_way_its_ring_is_given(closed):
    ring = [(46.0, 7.0), (46.01, 7.0), (46.01, 7.01), (46.0, 7.01)]
    got = _read(cot.area_shape(NAMING, "area.1", "search area", ring + ring[:1] if closed else ring, False, NOW,
                               LATER))
    links = [link.get("point") for link in got.element.findall("detail/link")]
    assert links == ["46.0,7.0", "46.01,7.0", "46.01,7.01", "46.0,7.01", "46.0,7.0"]
    assert got.type == "u-d-f" and got.uid == "gcs.valley.area.1" and got.callsign == "valley search area"
    assert got.point == pytest.approx((46.005, 7.005))
    assert got.element.find("detail/strokeColor").get("value") == str(cot.AREA_STROKE) == "-256"  # opaque yellow
    keep_out = _read(cot.area_shape(NAMING, "keep-out.2", "keep-out 2", ring, True, NOW, LATER))
    assert keep_out.element.find("detail/strokeColor").get("value") == "-65536"  # opaque red
    assert "no UAV enters it" in keep_out.remarks


def test_a_path_is_a_route_through_every_waypoint_in_order():
    points = [(46.0 + i * 1e-3, 7.0 - i * 1e-3) for i in range(40)]
    got = _read(cot.path_route(NAMING, 2, points, 70.0, NOW, LATER))
    links = got.element.findall("detail/link")
    read = [float(v) for link in links for v in link.get("point").split(",")]
    assert read == pytest.approx([v for point in points for v in point], abs=1e-7)
    assert {link.get("type") for link in links} == {"b-m-p-w"} and links[0].get("uid") == "gcs.valley.uav.2.path.1"
    assert got.type == "b-m-r" and got.uid == "gcs.valley.uav.2.path" and got.callsign == "valley UAV2 path"
    assert got.element.find("detail/link_attr").get("method") == "Flying"
    assert got.remarks == "valley UAV2 path: 40 waypoints, 70 m above home"
    leg = _read(cot.path_route(NAMING, 2, points[:3], 70.0, NOW, LATER, kind="return"))
    assert leg.uid == "gcs.valley.uav.2.return-leg" and leg.callsign == "valley UAV2 return leg"


def test_markers_say_what_was_seen_where_when_and_by_whom():
    hit = _read(cot.reading_marker(NAMING, 1, 17, 46.2, 7.3, (12, 30), NOW, LATER))
    assert (hit.uid, hit.type, hit.callsign) == ("gcs.valley.uav.1.reading.17", "b-m-p-s-m", "valley UAV1 hit 17")
    assert hit.remarks == "positive reading: cell (12, 30), 12:00:00Z, valley UAV1, image 17"
    assert hit.element.find("detail/color").get("argb") == "-65536"
    outside = _read(cot.reading_marker(NAMING, 1, 18, 46.2, 7.3, None, NOW, LATER))
    assert "outside the grid" in outside.remarks
    home = _read(cot.stage_marker(NAMING, 4, "return", 46.2, 7.3, "going home: range", NOW, LATER))
    assert home.uid == "gcs.valley.uav.4.return" and home.remarks == "valley UAV4 return, 12:00:00Z, going home: range"
    with pytest.raises(ValueError, match="unknown marker kind 'detour'"):
        cot.stage_marker(NAMING, 4, "detour", 46.2, 7.3, "", NOW, LATER)


def test_the_station_hello_is_unique_per_connection_and_names_the_station():
    one, two = (_read(cot.station_hello(NAMING, c, NOW, LATER)) for c in ("a1", "b2"))
    assert one.uid == "gcs.valley.station.a1" != two.uid
    assert one.type == "t-x-d-d" and one.callsign == "valley station"


def test_tak_protocol_1_carries_the_same_event():
    """What `--tak-protocol protobuf` sends: takproto's mesh framing of the same XML."""
    sample = cot.TrackSample(3, 46.1234567, 7.9876543, 61.6, "return", course_deg=12.0, speed_m_s=9.5,
                             battery_pct=40.0)
    data = takproto.xml2proto(cot.encode(cot.uav_track(NAMING, sample, NOW, LATER)), takproto.TAKProtoVer.MESH)
    assert bytes(data[:3]) == b"\xbf\x01\xbf"
    event = takproto.parse_proto(data).cotEvent
    assert (event.uid, event.type) == ("gcs.valley.uav.3", "a-f-A-M-F-Q")
    assert (event.lat, event.lon) == pytest.approx((46.1234567, 7.9876543))
    assert event.staleTime - event.sendTime == 20_000
    assert event.detail.contact.callsign == "valley UAV3"
    assert (event.detail.track.course, event.detail.track.speed) == pytest.approx((12.0, 9.5))
    assert "stage return" in event.detail.xmlDetail


def test_a_plans_segments_are_shapes_with_their_poa_pod_and_pos(tmp_path):
    """segments.geojson (as an area plan writes it) becomes one shape per polygon, its figures
    in the remarks; a folder without one gives none."""
    import json

    from gcs.tak.publisher import segment_events

    square = [[7.0, 46.0], [7.01, 46.0], [7.01, 46.01], [7.0, 46.01], [7.0, 46.0]]
    segments = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [square]},
         "properties": {"segment": "A1", "poa_pct": 12.5, "description": "POA 12.5%, POD 80.0%, POS 10.0%"}},
        {"type": "Feature", "geometry": None, "properties": {"segment": "rest of the area"}}]}
    (tmp_path / "segments.geojson").write_text(json.dumps(segments))
    events = segment_events(NAMING, tmp_path / "segments.geojson", NOW, LATER)
    assert len(events) == 1
    got = _read(events[0])
    assert got.type == "u-d-f" and got.uid == "gcs.valley.segment.A1" and got.callsign == "valley segment A1"
    assert [link.get("point") for link in got.element.findall("detail/link")][:2] == ["46.0,7.0", "46.0,7.01"]
    assert "POA 12.5%, POD 80.0%, POS 10.0%" in got.remarks
    assert segment_events(NAMING, tmp_path / "none.geojson", NOW, LATER) == []
