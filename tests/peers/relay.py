"""A UDP relay that can go silent: stands between a vehicle pushing to a ground-station port and
the station, as a radio link that drops out and comes back."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable


class UdpRelay:
    """Listens on `port` (where the vehicle sends), forwards to the station at `station_port` from
    its own socket, and sends the station's replies back to the vehicle. `silence()` drops
    everything both ways until `restore()`. The roles turn round for a vehicle the station calls
    first (PX4's GCS port): the station sends to `port`, and `station_port` is the vehicle's.
    `forward(datagram, to_station_port)`, when given, drops the datagrams it returns False for."""

    def __init__(self, station_port: int, forward: Callable[[bytes, bool], bool] | None = None) -> None:
        self.station = ("127.0.0.1", station_port)
        self._forward = forward
        self._vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._vehicle_side.bind(("127.0.0.1", 0))
        self._station_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._station_side.bind(("127.0.0.1", 0))
        self.port = self._vehicle_side.getsockname()[1]
        self._vehicle: tuple | None = None
        self._silent = threading.Event()
        self._stop = threading.Event()
        self.dropped = 0
        self._threads = [threading.Thread(target=self._pump, args=(self._vehicle_side, True), daemon=True),
                         threading.Thread(target=self._pump, args=(self._station_side, False), daemon=True)]

    def _pump(self, sock: socket.socket, from_vehicle: bool) -> None:
        sock.settimeout(0.2)
        while not self._stop.is_set():
            try:
                data, addr = sock.recvfrom(65536)
            except OSError:
                continue
            if from_vehicle:
                self._vehicle = addr
            if self._silent.is_set() or (self._forward is not None and not self._forward(data, from_vehicle)):
                self.dropped += 1
                continue
            if from_vehicle:
                self._station_side.sendto(data, self.station)
            elif self._vehicle is not None:
                self._vehicle_side.sendto(data, self._vehicle)

    def silence(self) -> None:
        self._silent.set()

    def restore(self) -> None:
        self._silent.clear()

    def __enter__(self) -> UdpRelay:
        for t in self._threads:
            t.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(2)
        self._vehicle_side.close()
        self._station_side.close()


#: MISSION_COUNT, MISSION_ITEM, MISSION_ITEM_INT: what a station sends to upload a mission
UPLOAD_MESSAGES = frozenset({44, 39, 73})


def first_message_id(datagram: bytes) -> int | None:
    """The id of the first MAVLink message in a UDP datagram (v2 or v1)."""
    if datagram[:1] == b"\xfd" and len(datagram) >= 10:
        return int.from_bytes(datagram[7:10], "little")
    if datagram[:1] == b"\xfe" and len(datagram) >= 6:
        return datagram[5]
    return None


def losing_uploads(lost: threading.Event, station_calls_first: bool = False) -> Callable[[bytes, bool], bool]:
    """A `UdpRelay` `forward` that drops the station's mission uploads while `lost` is set and
    passes everything else (the vehicle stays heard, its commands answered).
    `station_calls_first`: the relay's roles turned round (PX4's GCS port)."""
    def forward(datagram: bytes, to_station_port: bool) -> bool:
        from_station = to_station_port == station_calls_first
        return not (from_station and lost.is_set() and first_message_id(datagram) in UPLOAD_MESSAGES)
    return forward
