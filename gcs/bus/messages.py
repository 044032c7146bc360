"""The fleet bus's topic tree and JSON payloads: pure functions building and checking them.

Topic tree (every topic starts with `gcs/<fleet>/`):

    uav/<id>/telemetry      telemetry sample, QoS 0, at most `telemetry_hz` per UAV
    uav/<id>/state          last known state, QoS 1, retained
    uav/<id>/event          events, QoS 1, `seq` 1, 2, 3 ... per UAV and session
    station/<name>          station presence, QoS 1, retained (will: online = false)
    cmd                     commands in, QoS 1
    cmd/reply/<request id>  acknowledgements, QoS 1 (`cmd/reply/_invalid` when the command
                            was too broken to carry a request id)

One JSON Schema per message type lives in gcs/schemas/bus/."""

from __future__ import annotations

import json
import math
import re
import time
from dataclasses import dataclass
from enum import Enum
from functools import cache
from pathlib import Path
from typing import Any

import jsonschema
from referencing import Registry, Resource

__all__ = ["STAGES", "EVENT_KINDS", "Command", "CommandKind", "InvalidCommand", "MessageType", "Telemetry",
           "Topics", "parse_command", "validate"]

VERSION = 1
SCHEMA_DIR = Path(__file__).resolve().parent.parent / "schemas" / "bus"
STAGES = ("connecting", "preparing", "uploading", "arming", "search", "return", "rtl", "landed", "lost", "failed")
EVENT_KINDS = ("takeoff", "return", "rtl", "landed", "detection", "link_lost", "link_back", "failed", "stage", "note")
INVALID_REQUEST = "_invalid"
_NAME = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


class MessageType(str, Enum):
    TELEMETRY = "telemetry"
    STATE = "state"
    EVENT = "event"
    COMMAND = "command"
    REPLY = "reply"
    STATION = "station"


def check_name(value: str, what: str) -> str:
    """Fleet and station names become topic levels: letters, digits, `_.-` only."""
    if not _NAME.match(value):
        raise ValueError(f"{what} {value!r} must be 1-64 letters, digits, '_', '.' or '-'")
    return value


@dataclass(frozen=True)
class Topics:
    """The topic tree of one fleet."""

    fleet: str

    def __post_init__(self) -> None:
        check_name(self.fleet, "fleet name")

    @property
    def root(self) -> str:
        return f"gcs/{self.fleet}"

    def telemetry(self, uav: int | str) -> str:
        return f"{self.root}/uav/{uav}/telemetry"

    def state(self, uav: int | str) -> str:
        return f"{self.root}/uav/{uav}/state"

    def event(self, uav: int | str) -> str:
        return f"{self.root}/uav/{uav}/event"

    def station(self, name: str) -> str:
        return f"{self.root}/station/{name}"

    @property
    def command(self) -> str:
        return f"{self.root}/cmd"

    def reply(self, request_id: str) -> str:
        return f"{self.root}/cmd/reply/{request_id}"

    def classify(self, topic: str) -> tuple[MessageType, int | None] | None:
        """(message type, UAV id or None) of a topic of this fleet; None for anything else."""
        parts = topic.split("/")
        if parts[:2] != ["gcs", self.fleet]:
            return None
        rest = parts[2:]
        if len(rest) == 3 and rest[0] == "uav" and rest[1].isdigit() and rest[2] in ("telemetry", "state", "event"):
            return MessageType(rest[2]), int(rest[1])
        if len(rest) == 2 and rest[0] == "station":
            return MessageType.STATION, None
        if rest == ["cmd"]:
            return MessageType.COMMAND, None
        if len(rest) == 3 and rest[:2] == ["cmd", "reply"]:
            return MessageType.REPLY, None
        return None


# ---- schemas ---------------------------------------------------------------------------------


@cache
def _validators() -> dict[MessageType, jsonschema.protocols.Validator]:
    schemas = {kind: json.loads((SCHEMA_DIR / f"{kind.value}.schema.json").read_text(encoding="utf-8"))
               for kind in MessageType}
    registry = Registry().with_resources((s["$id"], Resource.from_contents(s)) for s in schemas.values())
    out = {}
    for kind, schema in schemas.items():
        cls = jsonschema.validators.validator_for(schema)
        cls.check_schema(schema)
        out[kind] = cls(schema, registry=registry)
    return out


def schema_errors(kind: MessageType, payload: Any) -> list[str]:
    """Every way `payload` breaks its schema, one short line each (empty when valid); a failing
    sub-schema's `description` is its message when it has one."""
    lines = []
    for error in sorted(_validators()[kind].iter_errors(payload), key=lambda e: list(e.absolute_path)):
        error = jsonschema.exceptions.best_match([error])
        where = "/".join(map(str, error.absolute_path)) or "(top)"
        schema = error.schema if isinstance(error.schema, dict) else {}
        message = schema.get("description") if error.validator == "not" and "description" in schema else error.message
        lines.append(f"{where}: {message}")
    return lines


def validate(kind: MessageType, payload: Any) -> None:
    """Raise ValueError naming the first schema violation."""
    errors = schema_errors(kind, payload)
    if errors:
        raise ValueError(f"{kind.value} message: {errors[0]}")


# ---- payloads ------------------------------------------------------------------------------


def _finite(value: float | None) -> float | None:
    """JSON has no infinity: unknown or unbounded numbers travel as null."""
    if value is None or not math.isfinite(value):
        return None
    return float(value)


@dataclass(frozen=True, slots=True)
class Telemetry:
    """One telemetry sample of one UAV, as the fleet layer hands it to the bus."""

    uav: int
    stage: str
    lat_deg: float | None = None
    lon_deg: float | None = None
    alt_m: float | None = None
    heading_deg: float | None = None
    battery_pct: float | None = None
    range_left_m: float | None = None
    margin_m: float | None = None
    t_s: float | None = None

    def payload(self, fleet: str) -> dict:
        if self.stage not in STAGES:
            raise ValueError(f"unknown stage {self.stage!r} (one of {', '.join(STAGES)})")
        heading = None if self.heading_deg is None else float(self.heading_deg) % 360.0
        return {"v": VERSION, "fleet": fleet, "uav": int(self.uav),
                "t_s": self.t_s if self.t_s is not None else time.time(),
                "lat_deg": _finite(self.lat_deg), "lon_deg": _finite(self.lon_deg), "alt_m": _finite(self.alt_m),
                "heading_deg": _finite(heading), "battery_pct": _finite(self.battery_pct), "stage": self.stage,
                "range_left_m": _finite(self.range_left_m), "margin_m": _finite(self.margin_m)}


def event_payload(fleet: str, station: str, session: str, uav: int, seq: int, kind: str, reason: str | None,
                  text: str, data: dict) -> dict:
    if kind not in EVENT_KINDS:
        raise ValueError(f"unknown event kind {kind!r} (one of {', '.join(EVENT_KINDS)})")
    return {"v": VERSION, "fleet": fleet, "uav": int(uav), "station": station, "session": session, "seq": seq,
            "t_s": time.time(), "kind": kind, "reason": reason, "text": text, "data": data}


def state_payload(fleet: str, station: str, session: str, uav: int, stage: str, telemetry: dict | None,
                  last_event: dict | None, return_reason: str | None) -> dict:
    """`last_event` is the last event payload (summarised here) or None."""
    summary = None if last_event is None else {k: last_event[k] for k in ("seq", "kind", "reason", "text", "t_s")}
    return {"v": VERSION, "fleet": fleet, "uav": int(uav), "station": station, "session": session, "t_s": time.time(),
            "stage": stage, "telemetry": telemetry, "last_event_seq": 0 if summary is None else summary["seq"],
            "last_event": summary, "return_reason": return_reason}


def station_payload(fleet: str, station: str, session: str, online: bool) -> dict:
    return {"v": VERSION, "fleet": fleet, "station": station, "session": session, "online": online, "t_s": time.time()}


def reply_payload(fleet: str, station: str, request_id: str | None, reason: str | None) -> dict:
    return {"v": VERSION, "fleet": fleet, "station": station, "request_id": request_id, "ok": reason is None,
            "reason": reason}


# ---- commands ------------------------------------------------------------------------------


class CommandKind(str, Enum):
    RETURN = "return"  # fly the planned way home
    RANGE = "range"  # the UAV's range changed (metres along its plan from take-off)
    ABORT = "abort"  # autopilot RTL at once


@dataclass(frozen=True, slots=True)
class Command:
    """A validated command: `uav` None means every UAV."""

    request_id: str
    kind: CommandKind
    uav: int | None
    range_m: float | None = None
    sender: str | None = None

    def payload(self) -> dict:
        out: dict = {"v": VERSION, "request_id": self.request_id, "kind": self.kind.value,
                     "uav": "all" if self.uav is None else self.uav}
        if self.range_m is not None:
            out["range_m"] = self.range_m
        if self.sender is not None:
            out["sender"] = self.sender
        return out


class InvalidCommand(ValueError):
    """A command the bus refuses before the fleet sees it; `request_id` when one could be read."""

    def __init__(self, reason: str, request_id: str | None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.request_id = request_id


def parse_command(raw: bytes) -> Command:
    """Decode and validate a command payload; InvalidCommand with a reason otherwise."""
    try:
        data = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InvalidCommand(f"malformed command: not JSON ({exc})", None) from None
    request_id = None
    if isinstance(data, dict) and isinstance(data.get("request_id"), str) and _NAME.match(data["request_id"]):
        request_id = data["request_id"]
    errors = schema_errors(MessageType.COMMAND, data)
    if errors:
        raise InvalidCommand(f"invalid command: {errors[0]}", request_id)
    uav = data["uav"]
    return Command(data["request_id"], CommandKind(data["kind"]), None if uav == "all" else int(uav),
                   data.get("range_m"), data.get("sender"))


def encode(payload: dict) -> bytes:
    return json.dumps(payload, separators=(",", ":"), allow_nan=False).encode()
