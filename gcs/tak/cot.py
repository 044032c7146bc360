"""The Cursor-on-Target events a flight puts on a TAK map, as pure functions of what they show
and when: the vehicles as UAV tracks, the search area and keep-out zones as closed shapes, each
UAV's planned path (and a return leg flown instead of it) as a route, positive readings and the
return, landing and failure of each vehicle as markers. Each takes its time and its stale time;
pytak builds the event, its point and remarks, and serialises it (`encode`).

Every uid starts with `gcs.<name>.` (`Naming`), so two stations, or two sorties, that use the
same name update the same items on the map and different names never collide. Colours are
TAK's signed ARGB integers."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime

from gcs.tak.pytak_module import pytak

__all__ = ["MARKER_KINDS", "Naming", "TrackSample", "area_shape", "cot_time", "encode", "path_route",
           "reading_marker", "stage_marker", "station_hello", "uav_track", "utc_now"]

UNKNOWN = pytak.DEFAULT_COT_VAL  # CoT's "not known" for hae, ce and le
LAT_LON_DECIMALS = 7  # about 1 cm; pytak's default of 4 (11 m) is coarser than a search cell's detail

UAV_TYPES = {"plane": "a-f-A-M-F-Q", "copter": "a-f-A-M-H-Q"}  # MIL-STD-2525 friendly UAV, fixed or rotary wing
DEFAULT_UAV_TYPE = UAV_TYPES["plane"]
SHAPE_TYPE = "u-d-f"  # a drawn shape; closed when its last vertex repeats the first
ROUTE_TYPE = "b-m-r"
WAYPOINT_TYPE = "b-m-p-w"
MARKER_TYPE = "b-m-p-s-m"  # a spot map marker
HELLO_TYPE = "t-x-d-d"  # pytak's hello_event


def _argb(red: int, green: int, blue: int, alpha: int = 255) -> int:
    value = (alpha << 24) | (red << 16) | (green << 8) | blue
    return value - (1 << 32) if value >= 1 << 31 else value


UAV_COLOURS = (_argb(0, 170, 255), _argb(255, 140, 0), _argb(170, 0, 255), _argb(0, 200, 120), _argb(255, 0, 170),
               _argb(140, 100, 40))
AREA_STROKE, AREA_FILL = _argb(255, 255, 0), _argb(255, 255, 0, 40)
KEEP_OUT_STROKE, KEEP_OUT_FILL = _argb(255, 0, 0), _argb(255, 0, 0, 60)
SEGMENT_STROKE, SEGMENT_FILL = _argb(139, 69, 0), _argb(255, 140, 0, 25)
MARKER_COLOURS = {"reading": _argb(255, 0, 0), "return": _argb(255, 165, 0), "landed": _argb(0, 200, 0),
                  "failed": _argb(255, 0, 255)}
MARKER_KINDS = ("return", "landed", "failed")  # the stage markers; "reading" is the positive reading's


@dataclass(frozen=True, slots=True)
class Naming:
    """The name a station's items carry on TAK: uids `gcs.<name>.<item>`, callsigns `<name> UAV<N>`."""

    name: str

    def uid(self, *parts: object) -> str:
        return ".".join(["gcs", self.name, *map(str, parts)])

    def uav(self, uav: int) -> str:
        return f"{self.name} UAV{uav}"


@dataclass(frozen=True, slots=True)
class TrackSample:
    """One vehicle as the map shows it: where it is (`alt_m` above its home), where it goes, its
    battery, its flight stage and a note ("link lost")."""

    uav: int
    lat_deg: float
    lon_deg: float
    alt_m: float
    stage: str
    course_deg: float | None = None
    speed_m_s: float | None = None
    battery_pct: float | None = None
    vehicle: str | None = None
    note: str = ""


def utc_now() -> datetime:
    return datetime.now(UTC)


def cot_time(when: datetime) -> str:
    """A UTC datetime as CoT writes it (W3C XML Schema dateTime)."""
    return when.strftime(pytak.W3C_XML_DATETIME)


def _event(uid: str, cot_type: str, lat_deg: float, lon_deg: float, when: datetime, stale: datetime, *,
           how: str = "m-g", callsign: str | None = None,
           children: Sequence[ET.Element] = (), remarks: Sequence[object] = ()) -> ET.Element:
    point = pytak.cot_point(lat_deg, lon_deg, UNKNOWN, UNKNOWN, UNKNOWN, precision=LAT_LON_DECIMALS)
    detail = pytak.cot_detail(*children, flow_tag=False)
    if remarks:
        pytak.add_remarks(detail, remarks, separator=", ")
    event = pytak.cot_event(uid=uid, cot_type=cot_type, how=how, point=point, detail=detail, callsign=callsign,
                            flow_tag=False)
    event.set("time", cot_time(when))
    event.set("start", cot_time(when))
    event.set("stale", cot_time(stale))
    return event


def _element(tag: str, **attributes: object) -> ET.Element:
    return ET.Element(tag, {key: str(value) for key, value in attributes.items()})


def _point_text(lat_deg: float, lon_deg: float) -> str:
    return f"{pytak.truncate_float(lat_deg, LAT_LON_DECIMALS)},{pytak.truncate_float(lon_deg, LAT_LON_DECIMALS)}"


def uav_colour(uav: int) -> int:
    return UAV_COLOURS[(uav - 1) % len(UAV_COLOURS)]


def uav_track(naming: Naming, sample: TrackSample, when: datetime, stale: datetime) -> ET.Element:
    """The vehicle's track: a friendly UAV with its course, speed and battery, its stage and
    height in the remarks. The point's height is left unknown: MAVLink gives heights above home
    and above mean sea level, CoT wants one above the ellipsoid, and gcs does not guess the geoid."""
    s = sample
    children = [_element("track", course=f"{(s.course_deg or 0.0) % 360.0:.1f}", speed=f"{s.speed_m_s or 0.0:.1f}"),
                _element("precisionlocation", geopointsrc="GPS", altsrc="???")]
    if s.battery_pct is not None:
        children.append(_element("status", battery=f"{max(0.0, s.battery_pct):.0f}"))
    remarks = [f"stage {s.stage}", f"{s.alt_m:.0f} m above home",
               None if s.speed_m_s is None else f"{s.speed_m_s:.1f} m/s",
               None if s.course_deg is None else f"course {s.course_deg % 360.0:03.0f}",
               None if s.battery_pct is None else f"battery {s.battery_pct:.0f}%", s.note or None]
    return _event(naming.uid("uav", s.uav), UAV_TYPES.get(s.vehicle or "", DEFAULT_UAV_TYPE), s.lat_deg, s.lon_deg,
                  when, stale, callsign=naming.uav(s.uav), children=children, remarks=remarks)


def _centre(points: Sequence[tuple[float, float]]) -> tuple[float, float]:
    return sum(p[0] for p in points) / len(points), sum(p[1] for p in points) / len(points)


def area_shape(naming: Naming, key: str, label: str, ring: Sequence[tuple[float, float]], keep_out: bool,
               when: datetime, stale: datetime) -> ET.Element:
    """A closed shape over `ring` (lat, lon): the search area (yellow) or a keep-out zone (red)."""
    vertices = list(ring[:-1]) if len(ring) > 1 and tuple(ring[0]) == tuple(ring[-1]) else list(ring)
    stroke, fill = (KEEP_OUT_STROKE, KEEP_OUT_FILL) if keep_out else (AREA_STROKE, AREA_FILL)
    children = [_element("link", point=_point_text(lat, lon)) for lat, lon in [*vertices, vertices[0]]]
    children += [_element("strokeColor", value=stroke), _element("strokeWeight", value="3.0"),
                 _element("fillColor", value=fill), _element("labels_on", value="true")]
    lat, lon = _centre(vertices)
    return _event(naming.uid(key), SHAPE_TYPE, lat, lon, when, stale, how="h-e", callsign=f"{naming.name} {label}",
                  children=children, remarks=[f"{naming.name}: {label}", "no UAV enters it" if keep_out else None])


def segment_shape(naming: Naming, key: str, name: str, ring: Sequence[tuple[float, float]], remark: str,
                  when: datetime, stale: datetime) -> ET.Element:
    """A search segment over `ring` (lat, lon), labelled with its name, its POA, POD and POS in
    the remarks (`gcs.plans.segments`)."""
    vertices = list(ring[:-1]) if len(ring) > 1 and tuple(ring[0]) == tuple(ring[-1]) else list(ring)
    children = [_element("link", point=_point_text(lat, lon)) for lat, lon in [*vertices, vertices[0]]]
    children += [_element("strokeColor", value=SEGMENT_STROKE), _element("strokeWeight", value="2.0"),
                 _element("fillColor", value=SEGMENT_FILL), _element("labels_on", value="true")]
    lat, lon = _centre(vertices)
    return _event(naming.uid(key), SHAPE_TYPE, lat, lon, when, stale, how="h-e",
                  callsign=f"{naming.name} segment {name}", children=children,
                  remarks=[f"{naming.name}: segment {name}", remark])


def path_route(naming: Naming, uav: int, waypoints: Sequence[tuple[float, float]], alt_m: float, when: datetime,
               stale: datetime, kind: str = "path") -> ET.Element:
    """UAV `uav`'s planned path (or, `kind` "return", the return leg it was sent home on) as a route
    through its waypoints (lat, lon), flown `alt_m` above home."""
    key = naming.uid("uav", uav, "path" if kind == "path" else "return-leg")  # "return" is the marker's
    children = [_element("link", uid=f"{key}.{i}", callsign=f"{'R' if kind == 'return' else 'W'}{i}",
                         type=WAYPOINT_TYPE, point=_point_text(lat, lon), relation="c")
                for i, (lat, lon) in enumerate(waypoints, 1)]
    colour = uav_colour(uav)
    children += [_element("link_attr", color=colour, method="Flying", direction="Infil", routetype="Primary",
                          order="Ascending Check Points", prefix="W", stroke="3"),
                 _element("strokeColor", value=colour), _element("strokeWeight", value="3.0"),
                 _element("labels_on", value="false")]
    lat, lon = waypoints[0]
    label = "path" if kind == "path" else "return leg"
    return _event(key, ROUTE_TYPE, lat, lon, when, stale, how="h-e", callsign=f"{naming.uav(uav)} {label}",
                  children=children, remarks=[f"{naming.uav(uav)} {label}: {len(waypoints)} waypoints",
                                              f"{alt_m:.0f} m above home"])


def reading_marker(naming: Naming, uav: int, index: int, lat_deg: float, lon_deg: float,
                   cell: tuple[int, int] | None, when: datetime, stale: datetime) -> ET.Element:
    """A positive reading of UAV `uav` (its image `index`) at the centre of `cell` (1-based x, y)."""
    where = "outside the grid" if cell is None else f"cell ({cell[0]}, {cell[1]})"
    return _marker(naming.uid("uav", uav, "reading", index), "reading", lat_deg, lon_deg, when, stale,
                   callsign=f"{naming.uav(uav)} hit {index}",
                   remarks=[f"positive reading: {where}", f"{when:%H:%M:%S}Z", naming.uav(uav), f"image {index}"])


def stage_marker(naming: Naming, uav: int, kind: str, lat_deg: float, lon_deg: float, text: str, when: datetime,
                 stale: datetime) -> ET.Element:
    """Where UAV `uav` turned home (`kind` "return"), landed or failed, and why (`text`)."""
    if kind not in MARKER_KINDS:
        raise ValueError(f"unknown marker kind {kind!r} (one of {', '.join(MARKER_KINDS)})")
    return _marker(naming.uid("uav", uav, kind), kind, lat_deg, lon_deg, when, stale,
                   callsign=f"{naming.uav(uav)} {kind}",
                   remarks=[f"{naming.uav(uav)} {kind}", f"{when:%H:%M:%S}Z", text or None])


def _marker(uid: str, kind: str, lat_deg: float, lon_deg: float, when: datetime, stale: datetime, *, callsign: str,
            remarks: Sequence[object]) -> ET.Element:
    colour = MARKER_COLOURS[kind]
    children = [_element("color", argb=colour),
                _element("usericon", iconsetpath=f"COT_MAPPING_SPOTMAP/{MARKER_TYPE}/{colour}")]
    return _event(uid, MARKER_TYPE, lat_deg, lon_deg, when, stale, callsign=callsign, children=children,
                  remarks=remarks)


def station_hello(naming: Naming, connection: str, when: datetime, stale: datetime) -> ET.Element:
    """What a connection to a TAK server opens with: a ping (the type of pytak's hello) that
    names the station. A server such as FreeTAKServer takes a connection's first event as the
    client's own (its callsign greets it; it is not relayed) and its uid as the connection's:
    `connection` makes it unique, so a new connection is never taken for a dead one."""
    return _event(naming.uid("station", connection), HELLO_TYPE, 0.0, 0.0, when, stale,
                  callsign=f"{naming.name} station")


def encode(event: ET.Element) -> bytes:
    return pytak.serialize_cot(event)
