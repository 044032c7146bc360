"""A careful GCS-side mission transfer over a pymavlink connection, retrying on a lossy link.

Used by the tests and the benchmark to drive the simulator the way a ground station would; it
works against any autopilot that follows the MAVLink mission protocol.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import MissionType, WireItem


class MissionTransferError(Exception):
    """A transfer that failed: `result` is the MAV_MISSION_RESULT (or None on a timeout)."""

    def __init__(self, operation: str, result: int | None, detail: str = "") -> None:
        self.operation = operation
        self.result = result
        name = mavlink.enums["MAV_MISSION_RESULT"][result].name if result is not None else "TIMEOUT"
        super().__init__(f"mission {operation} failed: {name}{': ' + detail if detail else ''}")


@dataclass(frozen=True, slots=True, kw_only=True)
class TransferStats:
    elapsed_s: float
    resends: int


class MissionClient:
    """Upload and download for one target over `conn` (a pymavlink mavutil connection)."""

    def __init__(self, conn, target_system: int, target_component: int = 1, *,
                 timeout_s: float = 0.25, deadline_s: float = 60.0) -> None:
        self.conn = conn
        self.target = (target_system, target_component)
        self.timeout_s = timeout_s
        self.deadline_s = deadline_s
        self.resends = 0

    def _recv(self, types: list[str], wait_s: float):
        """The next message of one of `types` from our target, or None after `wait_s`."""
        end = time.monotonic() + wait_s
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return None
            msg = self.conn.recv_match(type=types, blocking=True, timeout=left)
            if msg is not None and msg.get_srcSystem() == self.target[0]:
                return msg

    def upload(self, items: list[WireItem], mission_type: int = MissionType.MISSION) -> TransferStats:
        """Send `items`; returns when the vehicle ACKs, raises MissionTransferError otherwise."""
        mav = self.conn.mav
        start = time.monotonic()
        resends0 = self.resends
        send_last = lambda: mav.mission_count_send(*self.target, len(items), mission_type)  # noqa: E731
        last_sends = 0
        send_last()
        while time.monotonic() - start < self.deadline_s:
            msg = self._recv(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], self.timeout_s)
            if msg is None:
                self.resends += 1
                send_last()
                continue
            if msg.mission_type != mission_type:
                continue
            if msg.get_type() == "MISSION_ACK":
                if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                    return TransferStats(elapsed_s=time.monotonic() - start, resends=self.resends - resends0)
                if msg.type == mavlink.MAV_MISSION_INVALID_SEQUENCE:
                    continue  # a stale item crossed a re-request; the vehicle asks again
                if msg.type == mavlink.MAV_MISSION_ERROR and last_sends > 1 and self._count(mission_type) == len(items):
                    # ArduPilot answers the last item re-sent after its ACK was lost with an
                    # error (it no longer receives); the list it holds says the upload is done
                    return TransferStats(elapsed_s=time.monotonic() - start, resends=self.resends - resends0)
                raise MissionTransferError("upload", msg.type)
            if not 0 <= msg.seq < len(items):
                continue
            # MISSION_ITEM_INT, also for ArduPilot's MISSION_REQUEST
            out = replace(items[msg.seq], seq=msg.seq, mission_type=mission_type).to_msg(self.target)
            last_sends = 0
            is_last = msg.seq == len(items) - 1  # bound now: `msg` is the next message by the time of a re-send

            def send_last(out=out, last=is_last) -> None:
                nonlocal last_sends
                last_sends += last
                mav.send(out)

            send_last()
        raise MissionTransferError("upload", None, f"no ACK within {self.deadline_s} s")

    def _count(self, mission_type: int) -> int | None:
        """The vehicle's item count of one list, or None if it does not answer."""
        for _ in range(5):
            self.conn.mav.mission_request_list_send(*self.target, mission_type)
            msg = self._recv(["MISSION_COUNT"], self.timeout_s)
            if msg is not None and msg.mission_type == mission_type:
                self.conn.mav.mission_ack_send(*self.target, mavlink.MAV_MISSION_ACCEPTED, mission_type)
                return msg.count
        return None

    def download(self, mission_type: int = MissionType.MISSION) -> list[WireItem]:
        mav = self.conn.mav
        start = time.monotonic()
        count = None
        while count is None:
            if time.monotonic() - start > self.deadline_s:
                raise MissionTransferError("download", None, "no MISSION_COUNT")
            mav.mission_request_list_send(*self.target, mission_type)
            msg = self._recv(["MISSION_COUNT", "MISSION_ACK"], self.timeout_s)
            if msg is None or msg.mission_type != mission_type:
                self.resends += 1
                continue
            if msg.get_type() == "MISSION_ACK":
                # a late or duplicated ACK of an earlier upload, or ArduPilot's error for its
                # re-sent last item (see below)
                if msg.type in (mavlink.MAV_MISSION_ACCEPTED, mavlink.MAV_MISSION_ERROR):
                    continue
                raise MissionTransferError("download", msg.type)
            count = msg.count
        items: list[WireItem] = []
        while len(items) < count:
            if time.monotonic() - start > self.deadline_s:
                raise MissionTransferError("download", None, f"stuck at item {len(items)}")
            mav.mission_request_int_send(*self.target, len(items), mission_type)
            msg = self._recv(["MISSION_ITEM_INT", "MISSION_ACK"], self.timeout_s)
            if msg is None:
                self.resends += 1
                continue
            if msg.get_type() == "MISSION_ACK":
                # MAV_MISSION_ERROR never answers a read-back: it is ArduPilot's answer to an item
                # that arrived after the upload had ended (a re-sent last item)
                if msg.mission_type == mission_type and msg.type not in (mavlink.MAV_MISSION_ACCEPTED,
                                                                          mavlink.MAV_MISSION_ERROR):
                    raise MissionTransferError("download", msg.type)
                continue
            if msg.seq == len(items) and msg.mission_type == mission_type:
                items.append(WireItem.from_msg(msg))
        mav.mission_ack_send(*self.target, mavlink.MAV_MISSION_ACCEPTED, mission_type)
        return items

