"""The ground-station side of the MAVLink mission protocol (mavlink.io, "Mission Protocol").

`Upload` and `Download` are pure state machines: `start(now)`, `handle(msg, now)` and
`poll(now)` return the messages to send; time is passed in; nothing here touches a socket.
`transfer()` is the async driver over a `gcs.links.MavLink`, and `upload_verified()` uploads,
reads the list back and compares it item by item.

Protocol behaviour handled (upload): MISSION_COUNT, then answer every request with
MISSION_ITEM_INT, the legacy MISSION_REQUEST too (ArduPilot asks only with it; the
specification allows the INT answer and QGroundControl gives it, so no position is rounded
to float32); a duplicate or out-of-order request is answered with the item
asked for, unless that item went out a moment ago (`Upload`); a timeout re-sends the last
message (the COUNT, or the last item) up to `max_retries` times; MISSION_ACK INVALID_SEQUENCE
is not final (a stale item crossed a re-request, the vehicle asks again); any other error ACK
ends the transfer with that result.

Autopilot conventions (`Autopilot`):
- ArduPilot keeps the home position as mission item 0: we upload a placeholder there (the
  airport), a read-back returns the vehicle's own home in it, so item 0 is not compared; fence
  and rally lists have no home item. ArduPilot stores altitudes in centimetres and params as
  float32, so values are compared with tolerances; and it replaces the mission item by item
  while the upload runs (not atomically), so never upload to a vehicle flying AUTO: hold it
  first (the return leg does).
- PX4 keeps no home item and replaces the mission only once the upload completed."""

from __future__ import annotations

import asyncio
import math
import re
import time
from dataclasses import dataclass

from gcs.autopilots import Autopilot, compare_items
from gcs.autopilots.wire_item import MissionType, WireItem, renumber
from gcs.links import AUTOPILOT_COMPONENT_ID, MavLink, mavlink

__all__ = ["Download", "MissionTransferError", "MissionType", "Upload", "WireItem", "download", "renumber",
           "transfer", "upload_verified"]

MAVMessage = mavlink.MAVLink_message
MISSION_MESSAGES = ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK", "MISSION_COUNT", "MISSION_ITEM_INT",
                    "MISSION_ITEM")


class MissionTransferError(Exception):
    """A failed transfer; `result` is the MAV_MISSION_RESULT, None for a timeout; `capacity` the
    number of items the vehicle said it holds (ArduPilot says so with MAV_MISSION_NO_SPACE);
    `vehicle_gave_up`: the vehicle stopped waiting for the station (a slow or lossy link), not a
    refusal of what was sent."""

    def __init__(self, operation: str, result: int | None, detail: str = "", capacity: int | None = None) -> None:
        self.operation = operation
        self.result = result
        self.detail = detail
        self.capacity = capacity
        name = mavlink.enums["MAV_MISSION_RESULT"][result].name if result is not None else "TIMEOUT"
        super().__init__(f"{operation} failed: {name}{': ' + detail if detail else ''}")

    @property
    def vehicle_gave_up(self) -> bool:
        # OPERATION_CANCELLED: ArduPilot's "Mission upload timeout". MAV_MISSION_ERROR is how both
        # autopilots answer a message outside a transfer: ArduPilot an item when it is not receiving
        # (GCS_Common.cpp), PX4 an item after it dropped the transfer 5 s after the station's last
        # message ("Operation timeout", then "IGN MISSION_ITEM: No transfer") or a count while it is
        # still sending ("IGN MISSION_COUNT: Busy", mavlink_mission.cpp)
        return self.result in (mavlink.MAV_MISSION_OPERATION_CANCELLED, mavlink.MAV_MISSION_ERROR)


_CAPACITY = re.compile(r"Only (\d+) items are supported")


def _explained(error: MissionTransferError, machine: Upload | Download, texts: list[str]) -> MissionTransferError:
    """The error with what the vehicle said about it (its STATUSTEXT during the transfer) and,
    for NO_SPACE, its capacity."""
    if error.result is None:
        return error
    capacity = next((int(m.group(1)) for t in texts if (m := _CAPACITY.search(t))), None)
    detail = error.detail
    if error.result == mavlink.MAV_MISSION_NO_SPACE and isinstance(machine, Upload):
        room = (f"holds at most {capacity} items" if capacity else
                "has no mission storage yet (still starting up?)" if capacity == 0 else "has no room for them")
        detail = f"{len(machine.items)} items sent, the vehicle {room}"
    if texts:
        detail += f" (vehicle: {'; '.join(dict.fromkeys(texts))})"
    return MissionTransferError(error.operation, error.result, detail, capacity)


class _Machine:
    """Shared timing: a deadline per expected answer, re-sending the last message on timeout."""

    operation = "transfer"

    def __init__(self, target: tuple[int, int], mission_type: int, timeout_s: float, max_retries: int) -> None:
        self.target = target
        self.mission_type = int(mission_type)
        self.timeout_s = timeout_s
        self.max_retries = max_retries
        self.retries = 0
        self.resends = 0
        self.deadline = math.inf
        self.done = False
        self.error: MissionTransferError | None = None
        self._last: MAVMessage | None = None

    @property
    def finished(self) -> bool:
        return self.done or self.error is not None

    def _send(self, msg: MAVMessage, now: float) -> list[MAVMessage]:
        self._last = msg
        self.deadline = now + self.timeout_s
        return [msg]

    def _progress(self) -> None:
        self.retries = 0

    def _fail(self, result: int | None, detail: str = "") -> list[MAVMessage]:
        self.error = MissionTransferError(f"{self.operation} ({MissionType(self.mission_type).name.lower()})",
                                          result, detail)
        self.deadline = math.inf
        return []

    def _give_up(self, detail: str) -> list[MAVMessage]:
        """Fail (TIMEOUT) and send the protocol's cancel, so the vehicle leaves the transfer at once
        (PX4 would otherwise stay busy for 5 s and refuse the next one with "IGN MISSION_COUNT: Busy")."""
        self._fail(None, detail)
        return [mavlink.MAVLink_mission_ack_message(*self.target, mavlink.MAV_MISSION_OPERATION_CANCELLED,
                                                    self.mission_type)]

    def _mine(self, msg: MAVMessage) -> bool:
        return msg.get_srcSystem() == self.target[0] and getattr(msg, "mission_type", 0) == self.mission_type

    def poll(self, now: float) -> list[MAVMessage]:
        """Re-send the last message when its answer is overdue; after `max_retries` fail and send
        the vehicle MISSION_ACK OPERATION_CANCELLED."""
        if self.finished or now < self.deadline or self._last is None:
            return []
        if self.retries >= self.max_retries:
            return self._give_up(f"no answer after {self.max_retries} re-sends")
        self.retries += 1
        self.resends += 1
        return self._send(self._last, now)


class Upload(_Machine):
    """Send `items` (already numbered from 0) as the vehicle requests them. A vehicle re-requests
    an item it waits for on its own clock (PX4 every 0.25 s, a fifth of that at SITL's speed-up 5,
    a simulated one at 30 times real time every 8 ms): a re-request of an item sent less than a
    quarter of `timeout_s` ago crossed it and is not answered, or a station a little late would
    answer each one and drown both ends in copies; a vehicle that goes on asking for items it was
    sent, taking none, for `max_retries` timeouts fails the transfer (TIMEOUT) instead of holding
    it forever."""

    operation = "upload"

    def __init__(self, target: tuple[int, int], items: list[WireItem], mission_type: int = MissionType.MISSION, *,
                 timeout_s: float = 0.5, max_retries: int = 10) -> None:
        super().__init__(target, mission_type, timeout_s, max_retries)
        self.items = renumber(items, mission_type)
        self.requested: set[int] = set()
        self.legacy_requests = 0
        self.last_item_sends = 0
        self.unconfirmed = False
        self._sent_at: dict[int, float] = {}  # when each item was last sent
        self._progress_at = math.inf          # when the vehicle last asked for an item it had not

    def start(self, now: float) -> list[MAVMessage]:
        self._progress_at = now
        msg = mavlink.MAVLink_mission_count_message(*self.target, len(self.items), self.mission_type)
        return self._send(msg, now)

    def poll(self, now: float) -> list[MAVMessage]:
        out = super().poll(now)
        if out and out[0].get_type() == "MISSION_ITEM_INT" and out[0].seq == len(self.items) - 1:
            self.last_item_sends += 1
        return out

    def handle(self, msg: MAVMessage, now: float) -> list[MAVMessage]:
        if self.finished or not self._mine(msg):
            return []
        kind = msg.get_type()
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if not 0 <= msg.seq < len(self.items):
                return []  # a request beyond our list: stale, from another transfer
            self.legacy_requests += kind == "MISSION_REQUEST"
            if msg.seq not in self.requested:
                self.requested.add(msg.seq)
                self._progress()
                self._progress_at = now
            elif now - self._sent_at.get(msg.seq, -math.inf) < self.timeout_s / 4:
                return []  # a re-request crossing the item just sent (see the class docstring)
            elif now - self._progress_at > self.timeout_s * self.max_retries:
                return self._give_up(f"the vehicle asked for item {msg.seq} again and again for "
                                     f"{now - self._progress_at:.1f} s and never took it")
            self.last_item_sends += msg.seq == len(self.items) - 1
            self._sent_at[msg.seq] = now
            return self._send(self.items[msg.seq].to_msg(self.target), now)
        if kind == "MISSION_ACK":
            last_asked = not self.items or len(self.items) - 1 in self.requested
            if msg.type == mavlink.MAV_MISSION_ACCEPTED:
                if last_asked:
                    self.done = True
                    self.deadline = math.inf
                return []  # an ACK before our last item was asked for is stale
            if msg.type == mavlink.MAV_MISSION_INVALID_SEQUENCE:
                return []
            if msg.type == mavlink.MAV_MISSION_ERROR and last_asked and self.last_item_sends > 1:
                # ArduPilot answers an item that arrives after its upload ended with ERROR: our
                # re-sent last item crossed its ACCEPTED. Finished, unconfirmed: the read-back settles it.
                self.done = self.unconfirmed = True
                self.deadline = math.inf
                return []
            return self._fail(msg.type, "refused by the vehicle")
        return []


class Download(_Machine):
    """Read the vehicle's list: REQUEST_LIST, COUNT, then REQUEST_INT / ITEM_INT per item. A
    vehicle busy receiving an upload answers MISSION_ACK DENIED (ArduPilot, for up to 8 s after the
    uploader's last item): asked again on timeout, or, with `busy_is_final`, failed at once."""

    operation = "read-back"

    def __init__(self, target: tuple[int, int], mission_type: int = MissionType.MISSION, *,
                 timeout_s: float = 0.5, max_retries: int = 10, busy_is_final: bool = False) -> None:
        super().__init__(target, mission_type, timeout_s, max_retries)
        self.busy_is_final = busy_is_final
        self.count: int | None = None
        self.items: list[WireItem] = []

    def start(self, now: float) -> list[MAVMessage]:
        return self._send(mavlink.MAVLink_mission_request_list_message(*self.target, self.mission_type), now)

    def _request_next(self, now: float) -> list[MAVMessage]:
        if self.count is not None and len(self.items) >= self.count:
            self.done = True
            self.deadline = math.inf
            return [mavlink.MAVLink_mission_ack_message(*self.target, mavlink.MAV_MISSION_ACCEPTED, self.mission_type)]
        return self._send(mavlink.MAVLink_mission_request_int_message(*self.target, len(self.items),
                                                                      self.mission_type), now)

    def handle(self, msg: MAVMessage, now: float) -> list[MAVMessage]:
        if self.finished or not self._mine(msg):
            return []
        kind = msg.get_type()
        if kind == "MISSION_COUNT":
            if self.count is None:
                self.count = msg.count
                self._progress()
                return self._request_next(now)
            return []
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and self.count is not None:
            if msg.seq != len(self.items):
                return []  # a duplicate or an answer to an older request
            self.items.append(WireItem.from_msg(msg))
            self._progress()
            return self._request_next(now)
        if kind == "MISSION_ACK" and msg.type == mavlink.MAV_MISSION_ERROR:
            return []  # a read-back never ends in ERROR: the answer to an upload's stale last item
        if kind == "MISSION_ACK" and msg.type != mavlink.MAV_MISSION_ACCEPTED:
            if msg.type == mavlink.MAV_MISSION_DENIED and self.count is None:
                if self.busy_is_final:
                    return self._fail(msg.type, "the vehicle is receiving an upload")
                return []  # busy with another transfer: our timeout asks again
            return self._fail(msg.type, "refused by the vehicle")
        return []


async def transfer(link: MavLink, machine: Upload | Download) -> None:
    """Drive a state machine over `link` until it finishes; raise its error, with what the
    vehicle said (STATUSTEXT) while it ran."""
    texts: list[str] = []
    async with link.listen(machine.target[0], (*MISSION_MESSAGES, "STATUSTEXT")) as queue:
        for msg in machine.start(time.monotonic()):
            link.send(msg)
        while not machine.finished:
            wait = max(0.0, machine.deadline - time.monotonic())
            try:
                async with asyncio.timeout(wait):
                    msg = await queue.get()
            except TimeoutError:
                out = machine.poll(time.monotonic())
            else:
                if msg.get_type() == "STATUSTEXT":
                    if msg.severity <= mavlink.MAV_SEVERITY_WARNING or _CAPACITY.search(_text(msg)):
                        texts.append(_text(msg))
                    continue
                out = machine.handle(msg, time.monotonic())
            for m in out:
                link.send(m)
        if machine.error is not None:
            await asyncio.sleep(0.05)  # the vehicle's reason often follows its ACK
            while not queue.empty():
                msg = queue.get_nowait()
                if msg.get_type() == "STATUSTEXT" and (msg.severity <= mavlink.MAV_SEVERITY_WARNING
                                                       or _CAPACITY.search(_text(msg))):
                    texts.append(_text(msg))
    if machine.error is not None:
        raise _explained(machine.error, machine, texts)


def _text(msg: MAVMessage) -> str:
    text = msg.text
    # the last rstrip(): PX4 ends with a tab
    return (text.decode(errors="replace") if isinstance(text, bytes) else text).rstrip("\x00").rstrip()


async def download(link: MavLink, sysid: int, mission_type: int = MissionType.MISSION, *,
                   timeout_s: float = 0.5, busy_is_final: bool = False) -> list[WireItem]:
    machine = Download((sysid, AUTOPILOT_COMPONENT_ID), mission_type, timeout_s=timeout_s,
                       busy_is_final=busy_is_final)
    await transfer(link, machine)
    return machine.items


async def clear(link: MavLink, sysid: int, mission_type: int = MissionType.MISSION, *, timeout_s: float = 0.5,
                tries: int = 3) -> bool:
    """MISSION_CLEAR_ALL for one list; True once the vehicle acknowledged it."""
    for _ in range(tries):
        async with link.listen(sysid, ("MISSION_ACK",)) as queue:
            link.send(mavlink.MAVLink_mission_clear_all_message(sysid, AUTOPILOT_COMPONENT_ID, mission_type))
            try:
                while True:
                    async with asyncio.timeout(timeout_s):
                        ack = await queue.get()
                    if getattr(ack, "mission_type", 0) == mission_type:
                        return ack.type == mavlink.MAV_MISSION_ACCEPTED
            except TimeoutError:
                continue
    return False


@dataclass(frozen=True, slots=True)
class UploadReport:
    items: int
    attempts: int
    resends: int
    legacy_requests: int
    elapsed_s: float


async def upload_verified(link: MavLink, sysid: int, items: list[WireItem], autopilot: Autopilot,
                          mission_type: int = MissionType.MISSION, *, timeout_s: float = 0.5,
                          attempts: int = 3, fixed_wing: bool = False) -> UploadReport:
    """Upload `items` (for ArduPilot's mission list, item 0 must be the home placeholder), read
    them back and compare with what the autopilot should hold (`gcs.autopilots.compare_items`);
    retries the whole upload when the read-back differs, and when the vehicle gave up waiting for
    an item (`MissionTransferError.vehicle_gave_up`: a slow link). A refused upload raises at once and is
    never reported as uploaded: ArduPilot replaces items as they arrive, so after a refusal it
    holds the new items up to the refused one and the old ones after it; that mixed list is
    cleared (MISSION_CLEAR_ALL) so it cannot be flown, and the error says so."""
    items = renumber(items, mission_type)
    start = time.monotonic()
    resends = legacy = 0
    problems: list[str] = []
    for attempt in range(1, attempts + 1):
        up = Upload((sysid, AUTOPILOT_COMPONENT_ID), items, mission_type, timeout_s=timeout_s)
        try:
            await transfer(link, up)
            back = await download(link, sysid, mission_type, timeout_s=timeout_s)
        except MissionTransferError as exc:
            resends += up.resends
            if exc.vehicle_gave_up and attempt < attempts:
                # the vehicle gave up waiting for an item (ArduPilot: 8 s, "Mission upload timeout";
                # PX4: 5 s), or left the transfer: a slow link, not a refusal; a partly replaced list
                # goes, the upload starts again
                await asyncio.sleep(timeout_s)  # answers still on their way to the old upload arrive first
                if up.requested and autopilot.replaces_items_as_they_arrive():
                    await clear(link, sysid, mission_type, timeout_s=timeout_s)
                continue
            if exc.result is not None and up.requested and not up.done and autopilot.replaces_items_as_they_arrive():
                cleared = await clear(link, sysid, mission_type, timeout_s=timeout_s)
                raise MissionTransferError(exc.operation, exc.result, exc.detail + (
                    "; the partly replaced list was cleared" if cleared else
                    "; the vehicle may hold a partly replaced list: clear it before flying"), exc.capacity) from None
            if exc.result is not None or attempt == attempts:
                raise
            continue
        resends += up.resends
        legacy += up.legacy_requests
        problems = compare_items(items, back, autopilot, fixed_wing=fixed_wing)
        if not problems:
            return UploadReport(len(items), attempt, resends, legacy, time.monotonic() - start)
    raise MissionTransferError(f"verify ({MissionType(mission_type).name.lower()})", None,
                               "; ".join(problems[:3]))
