"""What a flight publishes as it happens (`FlightController.subscribe`): stage changes,
take-offs, flight-mode changes, sensor readings, link changes, uploads and reattachments. The
Rerun recorder, the MQTT feed, the journal and the sortie log listen."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from gcs.links import LinkStatus
from gcs.telemetry.status import Detection, Stage


@dataclass(frozen=True, slots=True)
class StageChanged:
    uav_id: int
    before: Stage
    after: Stage
    note: str


@dataclass(frozen=True, slots=True)
class TookOff:
    """The vehicle was seen airborne for the first time."""

    uav_id: int
    alt_m: float
    mode: str


@dataclass(frozen=True, slots=True)
class ModeChanged:
    uav_id: int
    before: str
    after: str


@dataclass(frozen=True, slots=True)
class ReadingReceived:
    """One sensor reading (CAMERA_IMAGE_CAPTURED), as it arrived."""

    uav_id: int
    detection: Detection


@dataclass(frozen=True, slots=True)
class LinkChanged:
    """A link was lost, came back, gained a peer or refused signatures; `uav_ids` are the
    vehicles last heard on it (`uav_id` is the first, or None)."""

    status: LinkStatus
    uav_ids: tuple[int, ...]

    @property
    def uav_id(self) -> int | None:
        return self.uav_ids[0] if self.uav_ids else None


@dataclass(frozen=True, slots=True)
class MissionUploaded:
    """A mission was verified on board: the plan's search (`kind` "search") or a return leg
    ("return", its turn points `leg`)."""

    uav_id: int
    kind: str
    leg: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True, slots=True)
class Reattached:
    """A restarted station took the vehicle over again (`gcs fly --resume`): what it found."""

    uav_id: int
    stage: Stage
    found: str


FlightEvent = StageChanged | TookOff | ModeChanged | ReadingReceived | LinkChanged | MissionUploaded | Reattached
FlightListener = Callable[[FlightEvent, float], None]
