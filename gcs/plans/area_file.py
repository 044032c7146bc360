"""The search-area file: a GeoJSON FeatureCollection (RFC 7946, WGS84 lon/lat) whose features
carry a `role` property. See docs/areas.md for the format and a complete example.

- `area`     Polygon / MultiPolygon, holes allowed: the search region (several are merged).
- `no_fly`   Polygon / MultiPolygon: no-fly zones (their holes are ignored: the whole outline is
             kept out of, for the planner and the geofence alike).
- `prior`    Polygon / MultiPolygon with `tep` and `eu` in [0, 1]: a prior target probability and
             uncertainty; later features win where they overlap.
- `airport`  Point, one per UAV: `heading` (degrees clockwise from north, or N, NE, E, SE, S, SW, W,
             NW), optional `range_m` or `endurance_s`, `altitude_m` (flight altitude above the airport),
             `elevation_m` (the airport's ground altitude above mean sea level), `name`.
- `target`   Point (optional): a target for simulation and evaluation.
- `raster_prior`  no geometry: `path` to a raster of probability mass (GeoTIFF or any raster GDAL
             reads, its own coordinate system; or a `.npy` array with `crs`, `bounds` and `row0`),
             optional `weight`; `gcs.plans.raster_prior` reads it.
- `ipp`      Point: the initial planning point of a lost-person prior, with `subject`, `terrain`
             and optional `climate` (`planner.priors.lost_person`), optional `weight`.
- `feature`  Point, LineString or Polygon (and Multi-): a `kind` of place subjects are found near
             (trail, road, drainage, water, field, woodland, structure, ...).
- `segment`  Polygon / MultiPolygon: a search segment with its `poa` in percent, or `poas`, several
             planners' POAs (their mean is used: the Mattson consensus); POAs sum to 100; each
             its own `name` (case and surrounding spaces do not matter), none named `REST`.

A suggested cell size may be given as `cell_size_m` in the area feature's properties or in the
FeatureCollection's `properties` member. Rings may wind either way. Bad input raises `UserError`
with one line saying what and where.

KML/KMZ, GPX, GeoPackage and Shapefile area files (by their suffix, or a folder of shapefiles)
are read by `gcs.plans.gis_formats` into the same FeatureCollection and checked here alike.

The GeoJSON's JSON Schema is `gcs/schemas/area.schema.json` (`area_schema`, `validate_area_dict`):
for editors and other tools that write area files; every file this module accepts follows it, and
what a schema cannot say (closed, valid rings; IPPs inside the area; POAs summing to 100; segment
names unique and not `REST`'s; the lost-person table's words) is still checked here."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import shapely
from shapely.geometry import MultiPolygon, Polygon, shape
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union
from shapely.validation import explain_validity

from gcs.errors import UserError
from planner.georef import heading_from_degrees
from planner.motion import COMPASS

ROLES = ("area", "no_fly", "prior", "airport", "target", "raster_prior", "ipp", "feature", "segment")
FORMATS = ("area files are GeoJSON (.geojson, .json), KML (.kml, .kmz), GPX (.gpx), GeoPackage (.gpkg) or "
           "Shapefile (.shp, a .zip or a folder of them)")
POLYGONAL = ("Polygon", "MultiPolygon")
FEATURE_GEOMETRIES = ("Point", "LineString", "MultiLineString", "Polygon", "MultiPolygon")
#: How far segment POAs may sum from 100 % (rounding of hand-entered percentages).
POA_TOLERANCE_PCT = 0.5
#: The name the reports give the searchable cells no segment covers: no segment of a file may take it.
REST = "rest of the area"


@dataclass(frozen=True)
class Airport:
    """One UAV's airport; `heading` is the grid heading 0..7 (0 = N, clockwise)."""

    index: int
    name: str
    lon_deg: float
    lat_deg: float
    heading: int
    range_m: float | None = None
    endurance_s: float | None = None
    altitude_m: float | None = None
    elevation_m: float | None = None


@dataclass(frozen=True)
class Prior:
    name: str
    geometry: BaseGeometry
    tep: float
    eu: float


@dataclass(frozen=True)
class Target:
    name: str
    lon_deg: float
    lat_deg: float


@dataclass(frozen=True)
class RasterPrior:
    """A raster prior: `path` resolved against the area file's folder; `crs`, `bounds` (west,
    south, east, north in `crs` units) and `row0` ("north" or "south": the edge of row 0) place
    a `.npy` array; a GeoTIFF carries its own. `weight` mixes it with the area's other mass priors."""

    name: str
    path: Path
    crs: str | None = None
    bounds: tuple[float, float, float, float] | None = None
    row0: str = "north"
    weight: float = 1.0


@dataclass(frozen=True)
class Ipp:
    """The initial planning point of a lost-person prior (`planner.priors.lost_person`)."""

    name: str
    lon_deg: float
    lat_deg: float
    subject: str
    terrain: str
    climate: str
    weight: float = 1.0


@dataclass(frozen=True)
class PlaceFeature:
    """A place subjects are found near: `kind` is a FIND_LOCATION kind (the word given mapped)."""

    name: str
    kind: str
    geometry: BaseGeometry


@dataclass(frozen=True)
class Segment:
    """A search segment and its POA as a share (0..1): the mean of the planners' POAs."""

    name: str
    geometry: BaseGeometry
    poa: float


@dataclass(frozen=True)
class AreaFile:
    """A parsed, validated area file; geometries are shapely, in lon/lat."""

    name: str
    area: BaseGeometry
    no_fly: tuple[BaseGeometry, ...]
    priors: tuple[Prior, ...]
    airports: tuple[Airport, ...]
    targets: tuple[Target, ...]
    cell_size_m: float | None
    rasters: tuple[RasterPrior, ...] = ()
    ipps: tuple[Ipp, ...] = ()
    features: tuple[PlaceFeature, ...] = ()
    segments: tuple[Segment, ...] = ()


@lru_cache(maxsize=1)
def area_schema() -> dict:
    """The JSON Schema of an area GeoJSON file (`gcs/schemas/area.schema.json`)."""
    return json.loads(resources.files("gcs").joinpath("schemas/area.schema.json").read_text())


def validate_area_dict(data: object) -> None:
    """Raise jsonschema.ValidationError when `data` does not follow the area file's schema."""
    import jsonschema  # ~0.1 s to import: only where a file is checked against the schema, never to plan

    jsonschema.validate(data, area_schema(), cls=jsonschema.Draft202012Validator)


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number JSON allows")


def read_area_file(path: str | Path) -> AreaFile:
    path = Path(path)
    if path.suffix.lower() not in (".geojson", ".json"):
        from gcs.plans.gis_formats import is_gis_area, read_gis_area

        if is_gis_area(path):
            gis = read_gis_area(path)
            return parse_area(gis.collection, name=path.stem, source=str(path), places=gis.places,
                              folder=path.parent)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise UserError(f"cannot read area file {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a UTF-8 text file") from None
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        formats = "" if path.suffix.lower() in (".geojson", ".json") else f"; {FORMATS}"
        raise UserError(f"{path}: not JSON ({exc.msg} at line {exc.lineno} column {exc.colno}){formats}") from None
    except ValueError as exc:
        raise UserError(f"{path}: not valid JSON: {exc}") from None
    return parse_area(data, name=path.stem, source=str(path), folder=path.parent)


def _where(index: int, feature: dict) -> str:
    props = feature.get("properties") or {}
    label = props.get("name") if isinstance(props, dict) else None
    role = props.get("role") if isinstance(props, dict) else None
    return f"feature {index}" + (f" ({role} {label!r})" if label else f" ({role})" if role else "")


def _number(value, what: str, low: float | None = None, high: float | None = None, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise UserError(f"{what} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise UserError(f"{what} must be positive, got {value!r}")
    if (low is not None and value < low) or (high is not None and value > high):
        raise UserError(f"{what} must lie in [{low}, {high}], got {value!r}")
    return float(value)


def _check_position(pos, where: str) -> None:
    if not isinstance(pos, list) or len(pos) < 2:
        raise UserError(f"{where}: a position must be [longitude, latitude], got {pos!r}")
    for v in pos:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise UserError(f"{where}: coordinate {v!r} is not a finite number")
    lon, lat = pos[0], pos[1]
    if not -180.0 <= lon <= 180.0:
        raise UserError(f"{where}: longitude {lon} is out of range [-180, 180]")
    if not -90.0 <= lat <= 90.0:
        raise UserError(f"{where}: latitude {lat} is out of range [-90, 90]")


def _check_polygon_coords(rings, where: str) -> None:
    if not isinstance(rings, list) or not rings:
        raise UserError(f"{where}: a Polygon needs a list of rings")
    for k, ring in enumerate(rings):
        label = f"{where} {'exterior ring' if k == 0 else f'hole {k}'}"
        if not isinstance(ring, list) or len(ring) < 4:
            raise UserError(f"{label}: a ring needs at least 4 positions (first = last)")
        for pos in ring:
            _check_position(pos, label)
        if ring[0][:2] != ring[-1][:2]:
            raise UserError(f"{label}: ring is not closed (its first and last positions differ)")


def _geometry(feature: dict, allowed: tuple[str, ...], where: str) -> BaseGeometry:
    geom = feature.get("geometry")
    if not isinstance(geom, dict) or "type" not in geom:
        raise UserError(f"{where}: missing geometry")
    kind = geom["type"]
    if kind not in allowed:
        raise UserError(f"{where}: geometry must be {' or '.join(allowed)}, got {kind}")
    coords = geom.get("coordinates")
    if kind == "Point":
        _check_position(coords, where)
    elif kind in ("LineString", "MultiLineString"):
        lines = [coords] if kind == "LineString" else coords
        if not isinstance(lines, list) or not lines:
            raise UserError(f"{where}: a {kind} needs a list of positions")
        for line in lines:
            if not isinstance(line, list) or len(line) < 2:
                raise UserError(f"{where}: a line needs at least 2 positions")
            for pos in line:
                _check_position(pos, where)
    elif kind == "Polygon":
        _check_polygon_coords(coords, where)
    elif kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise UserError(f"{where}: a MultiPolygon needs a list of polygons")
        for i, rings in enumerate(coords):
            _check_polygon_coords(rings, f"{where} polygon {i}")
    result = shape({"type": kind, "coordinates": coords})
    if kind in POLYGONAL:
        if not result.is_valid:
            reason = explain_validity(result)
            raise UserError(f"{where}: invalid polygon: {_readable_validity(reason)}")
        if result.area <= 0:
            raise UserError(f"{where}: polygon has no area")
    return result


def _readable_validity(reason: str) -> str:
    """'Self-intersection[8.54 47.39]' -> 'Self-intersection at lon 8.540000, lat 47.390000'."""
    if "[" in reason and reason.endswith("]"):
        what, _, where = reason[:-1].partition("[")
        parts = where.split()
        try:
            lon, lat = float(parts[0]), float(parts[1])
        except (IndexError, ValueError):
            return reason
        return f"{what} at lon {lon:.6f}, lat {lat:.6f}"
    return reason


def _heading(value, where: str) -> int:
    if isinstance(value, str):
        key = value.strip().upper()
        if key in COMPASS:
            return COMPASS.index(key)
        raise UserError(f"{where}: heading {value!r} is not one of {', '.join(COMPASS)} or a number of degrees")
    return heading_from_degrees(_number(value, f"{where}: heading"))


def _outline(geometry: BaseGeometry) -> BaseGeometry:
    """A polygon or multipolygon without its holes."""
    parts = geometry.geoms if isinstance(geometry, MultiPolygon) else [geometry]
    return unary_union([Polygon(p.exterior) for p in parts])


def _raster_prior(props: dict, label: str, where: str, folder: Path) -> RasterPrior:
    """A `raster_prior` feature's properties, checked (the raster itself is read later)."""
    path = props.get("path")
    if not isinstance(path, str) or not path.strip():
        raise UserError(f"{where}: a raster_prior needs 'path', the raster file (relative to the area file)")
    resolved = Path(path) if Path(path).is_absolute() else folder / path
    weight = _number(props.get("weight", 1.0), f"{where}: weight", positive=True)
    if resolved.suffix.lower() != ".npy":
        extra = [key for key in ("crs", "bounds", "row0") if key in props]
        if extra:
            raise UserError(f"{where}: '{extra[0]}' is for .npy arrays; a raster file carries its own georeference")
        return RasterPrior(label, resolved, weight=weight)
    crs, bounds, row0 = props.get("crs"), props.get("bounds"), props.get("row0", "north")
    if not isinstance(crs, str) or not crs.strip():
        raise UserError(f"{where}: a .npy raster_prior needs 'crs' (e.g. \"EPSG:32632\")")
    if not isinstance(bounds, list) or len(bounds) != 4:
        raise UserError(f"{where}: a .npy raster_prior needs 'bounds': [west, south, east, north] in its crs")
    west, south, east, north = (_number(b, f"{where}: bounds") for b in bounds)
    if not (west < east and south < north):
        raise UserError(f"{where}: bounds must be [west, south, east, north] with west < east and south < north")
    if row0 not in ("north", "south"):
        raise UserError(f"{where}: row0 must be \"north\" or \"south\" (the edge of the array's row 0), got {row0!r}")
    return RasterPrior(label, resolved, crs.strip(), (west, south, east, north), row0, weight)


def _ipp(props: dict, label: str, point: BaseGeometry, where: str) -> Ipp:
    from planner.priors.lost_person import climates, subjects, terrains

    def word(key: str, choices: list[str], default: str | None = None) -> str:
        value = props.get(key, default)
        if value is None:
            raise UserError(f"{where}: an ipp needs '{key}' (one of {', '.join(choices)})")
        text = str(value).strip().lower()
        if text not in choices:
            raise UserError(f"{where}: {key} {value!r} is not in the lost-person table "
                            f"(it holds: {', '.join(choices)})")
        return text

    subject = word("subject", subjects())
    terrain = word("terrain", terrains(subject))
    known = climates(subject, terrain)
    climate = word("climate", known, "temperate" if "temperate" in known else None)
    weight = _number(props.get("weight", 1.0), f"{where}: weight", positive=True)
    return Ipp(label, point.x, point.y, subject, terrain, climate, weight)


def _segment_poa(props: dict, where: str) -> float:
    if "poa" in props and "poas" in props:
        raise UserError(f"{where}: give 'poa' or 'poas' (several planners' POAs), not both")
    if "poas" in props:
        poas = props["poas"]
        if not isinstance(poas, list) or not poas:
            raise UserError(f"{where}: poas must be a list of percentages, one per planner")
        values = [_number(v, f"{where}: poas", 0.0, 100.0) for v in poas]
        return sum(values) / len(values) / 100.0
    if "poa" not in props:
        raise UserError(f"{where}: a segment needs 'poa' (percent) or 'poas' (several planners' percentages)")
    return _number(props["poa"], f"{where}: poa", 0.0, 100.0) / 100.0


def _segment_name(name: str, where: str, taken: dict[str, str], place: str) -> None:
    """Refuse a segment name the reports cannot tell apart: `REST`'s, or one an earlier segment
    has (case and surrounding spaces aside); else note in `taken` that `place` has it."""
    key = name.strip().casefold()
    if key == REST:
        raise UserError(f"{where}: '{REST}' names the searchable cells no segment covers: "
                        f"give this segment another name")
    if key in taken:
        raise UserError(f"{where}: the segment name {name.strip()!r} is taken by {taken[key]}: "
                        f"give each segment its own name")
    taken[key] = place


def parse_area(data, name: str = "area", source: str = "area file", places: Sequence[str] | None = None,
               folder: Path | None = None) -> AreaFile:
    """Validate a decoded GeoJSON document and return its parts; `places` says where each feature
    came from in the file it was read from (for other formats: `gcs.plans.gis_formats`); relative
    raster paths are read from `folder` (None: the working folder)."""
    folder = Path(".") if folder is None else folder
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        raise UserError(f"{source}: not a GeoJSON FeatureCollection")
    features = data.get("features")
    if not isinstance(features, list):
        raise UserError(f"{source}: FeatureCollection has no 'features' list")
    areas, no_fly, priors, airports, targets, rasters = [], [], [], [], [], []
    ipps: list[Ipp] = []
    spots: list[PlaceFeature] = []
    segments: list[Segment] = []
    segment_where: dict[str, str] = {}
    ipp_where: list[str] = []
    cell_size = None
    collection_props = data.get("properties")
    if collection_props is not None and not isinstance(collection_props, dict):
        raise UserError(f"{source}: the FeatureCollection's properties must be an object, got {collection_props!r}")
    if collection_props is not None and collection_props.get("cell_size_m") is not None:
        cell_size = _number(collection_props["cell_size_m"], f"{source}: properties.cell_size_m", positive=True)
    for i, feature in enumerate(features):
        if not isinstance(feature, dict) or feature.get("type") != "Feature":
            raise UserError(f"{source}: feature {i} is not a GeoJSON Feature")
        props = feature.get("properties") or {}
        if not isinstance(props, dict):
            raise UserError(f"{source}: feature {i}: properties must be an object")
        where = f"{source}: {_where(i, feature)}" if places is None else f"{places[i]} ({props.get('role')})"
        role = props.get("role")
        if role not in ROLES:
            raise UserError(f"{where}: 'role' must be one of {', '.join(ROLES)}, got {role!r}")
        label = str(props.get("name", f"{role} {i}"))
        if role == "area":
            areas.append(_geometry(feature, POLYGONAL, where))
            if props.get("cell_size_m") is not None:
                cell_size = _number(props["cell_size_m"], f"{where}: cell_size_m", positive=True)
        elif role == "no_fly":
            no_fly.append(_outline(_geometry(feature, POLYGONAL, where)))
        elif role == "prior":
            geom = _geometry(feature, POLYGONAL, where)
            for key in ("tep", "eu"):
                if key not in props:
                    raise UserError(f"{where}: a prior needs '{key}'")
            priors.append(Prior(label, geom, _number(props["tep"], f"{where}: tep", 0.0, 1.0),
                                _number(props["eu"], f"{where}: eu", 0.0, 1.0)))
        elif role == "airport":
            point = _geometry(feature, ("Point",), where)
            if "heading" not in props:
                raise UserError(f"{where}: an airport needs a 'heading' (degrees or {', '.join(COMPASS)})")
            range_m = props.get("range_m")
            endurance_s = props.get("endurance_s")
            if range_m is not None and endurance_s is not None:
                raise UserError(f"{where}: give range_m or endurance_s, not both")
            altitude = props.get("altitude_m")
            elevation = props.get("elevation_m")
            airports.append(Airport(
                len(airports), str(props.get("name", f"UAV {len(airports) + 1}")), point.x, point.y,
                _heading(props["heading"], where),
                None if range_m is None else _number(range_m, f"{where}: range_m", positive=True),
                None if endurance_s is None else _number(endurance_s, f"{where}: endurance_s", positive=True),
                None if altitude is None else _number(altitude, f"{where}: altitude_m", positive=True),
                None if elevation is None else _number(elevation, f"{where}: elevation_m", -500.0, 9000.0)))
        elif role == "ipp":
            ipps.append(_ipp(props, label, _geometry(feature, ("Point",), where), where))
            ipp_where.append(where)
        elif role == "feature":
            from planner.priors.lost_person import FEATURE_KINDS

            geom = _geometry(feature, FEATURE_GEOMETRIES, where)
            kind = str(props.get("kind", "")).strip().lower()
            if kind not in FEATURE_KINDS:
                raise UserError(f"{where}: kind {props.get('kind')!r} is not a kind of place subjects are found near "
                                f"(one of {', '.join(sorted(FEATURE_KINDS))})")
            spots.append(PlaceFeature(label, FEATURE_KINDS[kind], geom))
        elif role == "segment":
            segments.append(Segment(label, _geometry(feature, POLYGONAL, where), _segment_poa(props, where)))
            _segment_name(label, where, segment_where, where.removeprefix(f"{source}: "))
        elif role == "raster_prior":
            if feature.get("geometry") is not None:
                raise UserError(f"{where}: a raster_prior has no geometry (null): the raster places itself")
            rasters.append(_raster_prior(props, label, where, folder))
        else:
            point = _geometry(feature, ("Point",), where)
            targets.append(Target(label, point.x, point.y))
    if not areas:
        raise UserError(f"{source}: no feature with role 'area'")
    if not airports:
        raise UserError(f"{source}: no feature with role 'airport' (one Point per UAV)")
    area = unary_union(areas)
    min_lon, _, max_lon, _ = area.bounds
    if max_lon - min_lon > 180.0:
        raise UserError(f"{source}: the area spans more than 180 degrees of longitude (areas across the "
                        f"antimeridian are not supported)")
    for ipp, at in zip(ipps, ipp_where):
        if not area.covers(shapely.Point(ipp.lon_deg, ipp.lat_deg)):
            raise UserError(f"{at}: the IPP at lon {ipp.lon_deg}, lat {ipp.lat_deg} is outside the area")
    if segments:
        total = 100.0 * sum(seg.poa for seg in segments)
        if abs(total - 100.0) > POA_TOLERANCE_PCT:
            raise UserError(f"{source}: the segments' POAs sum to {total:g}%, not 100% ("
                            + ", ".join(f"{seg.name} {100 * seg.poa:g}%" for seg in segments)
                            + "): correct them, or give the rest of the area a segment of its own")
        segments = [Segment(seg.name, seg.geometry, seg.poa * 100.0 / total) for seg in segments]
    return AreaFile(name, area, tuple(no_fly), tuple(priors), tuple(airports), tuple(targets), cell_size,
                    tuple(rasters), tuple(ipps), tuple(spots), tuple(segments))
