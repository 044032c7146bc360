"""The autopilot's words as the operator sees them: STATUSTEXT chunks (MAVLink `id`/`chunk_seq`,
which PX4 uses for texts over 50 characters) joined into one text, decoded from real MAVLink
bytes."""

from __future__ import annotations

from gcs.links import mavlink
from gcs.telemetry.status import VehicleStatus

LONG = "Preflight Fail: Vehicle is in safety configuration, resolve system health failures first"


def _chunks(text: str, text_id: int) -> list[bytes]:
    """STATUSTEXT messages as a sender splits `text`, each packed to wire bytes."""
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    parts = [text[i:i + 50] for i in range(0, len(text), 50)] or [""]
    if len(parts[-1]) == 50:
        parts.append("")  # a text of whole chunks ends with an empty one
    return [mav.statustext_encode(mavlink.MAV_SEVERITY_CRITICAL, part.encode(), text_id, seq).pack(mav)
            for seq, part in enumerate(parts)]


def _decoded(frames: list[bytes]):
    mav = mavlink.MAVLink(None)
    return [mav.parse_char(frame) for frame in frames]


def test_a_text_in_chunks_is_joined_and_a_single_text_replaces_it():
    status = VehicleStatus(1)
    frames = _chunks(LONG, 7)
    assert len(frames) == 2
    first, last = _decoded(frames)
    status.update(first, 0.0)
    assert status.last_text == LONG[:50]  # the start shows before the rest comes
    status.update(last, 0.1)
    assert status.last_text == LONG
    assert status.text_chunks == {}
    (single,) = _decoded(_chunks("Disarmed by auto preflight disarming\t", 0))  # PX4 ends its texts with a tab
    status.update(single, 0.2)
    assert status.last_text == "Disarmed by auto preflight disarming"


def test_chunks_of_two_texts_interleaved_stay_apart_and_out_of_order_chunks_are_ordered():
    status = VehicleStatus(1)
    a, b = _decoded(_chunks(LONG, 3)), _decoded(_chunks("x" * 60, 4))
    status.update(a[1], 0.0)
    status.update(b[0], 0.1)
    status.update(a[0], 0.2)
    assert status.last_text == LONG
    status.update(b[1], 0.3)
    assert status.last_text == "x" * 60
    assert status.text_chunks == {}
