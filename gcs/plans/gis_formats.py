"""Area files in the formats search teams draw them in, read through GDAL (pyogrio) into the
GeoJSON FeatureCollection `gcs.plans.area_file.parse_area` checks, so that every format has the
same roles, properties and errors as GeoJSON (docs/areas.md, docs/search-team.md):

- KML / KMZ (Google Earth, CalTopo / SARTopo, QGIS, ogr2ogr): every Placemark is a feature;
- GPX (handheld GPS, CalTopo): routes and tracks are outlines, waypoints are points;
- GeoPackage (`.gpkg`, QGIS): every feature of every layer;
- Shapefile (`.shp`, a `.zip` of shapefiles, or a folder of them): every feature of every layer.

A feature's role is, in this order: its `role` attribute (a KML ExtendedData field, a GeoPackage
or Shapefile column, a GPX `<type>`); a `role: ...` line in its description (KML `<description>`,
GPX `<desc>` or `<cmt>`); the prefix of its name (`airport: West`); the name of its KML folder,
GeoPackage layer or shapefile (`Airports`, `no-fly`); for a GPX route or track, `area`. The other
properties (`heading`, `tep`, `range_m`, ...) come from attributes of the same name, then from
`key: value` lines of the description. Role and key names ignore case, `-` and spaces stand for
`_`, and a plural names its role (`No-fly zones` is not one, `no_fly` and `No fly` are).

Polygons come as polygons, wound counter-clockwise (holes clockwise); a KML line whose ends meet
and a GPX route or track (closed if it is not) become an outline. Heights are dropped, other
coordinate systems (a GeoPackage or Shapefile's own) are projected to WGS84. Nothing is imported
from GDAL until such a file is read."""

from __future__ import annotations

import hashlib
import html
import math
import re
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gcs.errors import UserError

ROLES = ("area", "no_fly", "prior", "airport", "target")
POLYGON_ROLES = ("area", "no_fly", "prior")
NUMBER_KEYS = ("tep", "eu", "range_m", "endurance_s", "altitude_m", "elevation_m", "cell_size_m")
KEYS = ("role", "heading", *NUMBER_KEYS)

# the formats by suffix: their name and the GDAL drivers that may read them
FORMATS = {".kml": ("KML file", ("LIBKML", "KML")), ".kmz": ("KMZ file", ("LIBKML",)), ".gpx": ("GPX file", ("GPX",)),
           ".gpkg": ("GeoPackage", ("GPKG",)), ".shp": ("Shapefile", ("ESRI Shapefile",)),
           ".zip": ("zip of shapefiles", ("ESRI Shapefile",))}
SHAPEFILE_PARTS = (".shp", ".shx", ".dbf", ".prj", ".cpg")
GPX_LAYERS = ("waypoints", "routes", "tracks")


def is_gis_area(path: str | Path) -> bool:
    """Whether `path` names an area file of a GIS format (else it is read as GeoJSON)."""
    path = Path(path)
    return path.suffix.lower() in FORMATS or path.is_dir()


def _format(path: Path) -> tuple[str, tuple[str, ...]]:
    return ("folder of shapefiles", ("ESRI Shapefile",)) if path.is_dir() else FORMATS[path.suffix.lower()]


def area_sha256(path: str | Path) -> str:
    """The hash of an area file as planned: its bytes, or for a shapefile or a folder of them, every
    file that makes them up (the attributes live beside the .shp)."""
    path = Path(path)
    if path.is_dir():
        parts = sorted(p for p in path.iterdir() if p.suffix.lower() in SHAPEFILE_PARTS)
    elif path.suffix.lower() == ".shp":
        parts = sorted(p for p in path.parent.glob(path.stem + ".*") if p.suffix.lower() in SHAPEFILE_PARTS)
    else:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part.name.encode() + b"\0" + hashlib.sha256(part.read_bytes()).digest())
    return digest.hexdigest()


def role_name(text: Any) -> str | None:
    """The role `text` names (`No fly` -> no_fly, `Airports` -> airport), or None."""
    if not isinstance(text, str):
        return None
    key = re.sub(r"[\s\-]+", "_", text.strip().lower())
    for role in ROLES:
        if key in (role, role + "s", role.replace("_", "")):
            return role
    return None


def _key_name(text: str) -> str:
    return re.sub(r"[\s\-]+", "_", text.strip().lower())


_TAG = re.compile(r"<[^>]+>")
_LINE_BREAK = re.compile(r"<\s*(br|/p|/div|/li|/tr)\s*/?\s*>", re.IGNORECASE)
_KEY_VALUE = re.compile(r"^\s*([A-Za-z][\w \-]*?)\s*[:=]\s*(.*?)\s*$")


def description_values(text: Any) -> dict[str, str]:
    """`key: value` (or `key = value`) lines of a description naming a known key; HTML markup
    (Google Earth balloons) is read as text, other lines are notes and ignored."""
    if not isinstance(text, str) or not text.strip():
        return {}
    plain = html.unescape(_TAG.sub("", _LINE_BREAK.sub("\n", text)))
    found: dict[str, str] = {}
    for line in plain.splitlines():
        match = _KEY_VALUE.match(line)
        if match:
            key = _key_name(match.group(1))
            if key in KEYS and key not in found:
                found[key] = match.group(2)
    return found


def _name_prefix(name: str) -> tuple[str | None, str]:
    """`airport: West` -> ('airport', 'West'); a name without a role prefix -> (None, name)."""
    head, sep, rest = name.partition(":")
    role = role_name(head) if sep else None
    return (role, rest.strip()) if role else (None, name)


def _plain(value: Any) -> Any:
    """A GDAL field value as JSON would give it: numpy scalars to Python, NaN and blanks to None."""
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, str) and not value.strip():
        return None
    return value


def _value(key: str, value: Any) -> Any:
    """A property value as the GeoJSON reader expects it: numbers written as text become numbers
    (a text that is no number is left for `parse_area` to refuse, naming it)."""
    if isinstance(value, str) and (key in NUMBER_KEYS or key == "heading"):
        try:
            number = float(value.strip())
        except ValueError:
            return value.strip()
        return number if math.isfinite(number) else value
    return value


@dataclass
class _Source:
    """One feature as read: where it is, its attributes and description, and its geometry."""

    place: str
    layer: str
    name: str | None
    attributes: dict[str, Any]
    description: Any
    geometry: Any  # shapely
    outline: bool = False  # a GPX route or track: the outline of a polygon
    default_role: str | None = None
    camera_heading: bool = False  # a KML Placemark with a Camera heading


def _attributes(fields: dict[str, Any], shapefile: bool) -> dict[str, Any]:
    """The known keys among a feature's attributes (any case; a Shapefile cuts names to 10
    characters: `endurance_` is endurance_s)."""
    out: dict[str, Any] = {}
    for raw_key, raw in fields.items():
        key = _key_name(raw_key)
        if shapefile and len(key) == 10 and key not in KEYS:
            key = next((k for k in KEYS if k[:10] == key), key)
        value = _plain(raw)
        if key in KEYS and value is not None:
            out[key] = value
    return out


def _role(src: _Source, hint: str) -> tuple[str, str]:
    """The feature's role and its name without a role prefix; UserError naming how to give one."""
    name = src.name or ""
    prefixed, bare = _name_prefix(name)
    described = description_values(src.description)
    found = {how: role for how, role in (("its role attribute", src.attributes.get("role")),
                                         ("its description", described.get("role")),
                                         ("its name", prefixed)) if role is not None}
    roles = {how: role_name(role) for how, role in found.items()}
    for how, role in roles.items():
        if role is None:
            raise UserError(f"{src.place}: {how} gives the role {found[how]!r}, not one of {', '.join(ROLES)}")
    if len(set(roles.values())) > 1:
        given = ", ".join(f"{role} ({how})" for how, role in roles.items())
        raise UserError(f"{src.place}: two roles given: {given}")
    role = next(iter(roles.values()), None) or role_name(src.layer) or src.default_role
    if role is None:
        raise UserError(f"{src.place}: no role; give it one of {', '.join(ROLES)}: {hint}")
    return role, bare if prefixed else name


def _geojson_geometry(geometry, role: str, src: _Source) -> dict | None:
    """The shapely geometry as GeoJSON lists of [lon, lat] (heights dropped); lines become the
    outlines polygon roles need where that is unambiguous."""
    import shapely
    from shapely.geometry import LineString, MultiPolygon, Polygon, mapping

    if geometry is None or geometry.is_empty:
        return None
    geometry = shapely.force_2d(geometry)
    if role in POLYGON_ROLES:
        if isinstance(geometry, LineString):
            coords = list(geometry.coords)
            if src.outline and coords and coords[0] != coords[-1]:
                coords.append(coords[0])
            if len(set(coords)) < 3 or coords[0] != coords[-1]:
                what = "fewer than 3 points" if len(set(coords)) < 3 else "a line whose ends do not meet"
                raise UserError(f"{src.place}: the {role} needs an outline, got {what} (draw it as a polygon)")
            geometry = Polygon(coords)
        elif geometry.geom_type == "GeometryCollection" and all(isinstance(g, Polygon) for g in geometry.geoms):
            geometry = MultiPolygon(list(geometry.geoms))
        if isinstance(geometry, (Polygon, MultiPolygon)):  # as RFC 7946 and KML ask (a Shapefile winds the other way)
            geometry = shapely.orient_polygons(geometry)
    return _lists(mapping(geometry))


def _lists(value):
    """Tuples to lists all the way down (`parse_area` checks positions are lists)."""
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_lists(v) for v in value]
    return value


def _open(path: Path) -> tuple[str, list[str]]:
    """The GDAL driver reading `path` and its layers; UserError when it is not what its name says."""
    import pyogrio
    from pyogrio.errors import DataSourceError

    kind, drivers = _format(path)
    if not path.exists():
        raise UserError(f"cannot read area file {path}: No such file or directory")
    try:
        layers = [str(name) for name, _ in pyogrio.list_layers(path)]
        driver = pyogrio.read_info(path, layer=layers[0])["driver"] if layers else None
    except (DataSourceError, OSError) as exc:
        reason = str(exc).split(";")[0].strip()
        raise UserError(f"{path}: not a {kind} GDAL can read ({reason})") from None
    if driver is None:
        raise UserError(f"{path}: not a {kind} GDAL can read (it holds no layer)")
    if driver not in drivers:
        raise UserError(f"{path}: GDAL reads this file as {driver}, not {kind}")
    return driver, layers


def _read_layer(path: Path, layer: str, **kwargs) -> tuple[dict, list, list[dict[str, Any]]]:
    """(metadata, shapely geometries, attribute dicts) of one layer."""
    import shapely
    from pyogrio.errors import DataLayerError, DataSourceError
    from pyogrio.raw import read

    try:
        with warnings.catch_warnings():  # GDAL's notes on what it skipped: the checks below say what matters
            warnings.simplefilter("ignore", RuntimeWarning)
            meta, _, wkb, columns = read(path, layer=layer, **kwargs)
    except (DataSourceError, DataLayerError, OSError) as exc:
        raise UserError(f"{path}: layer {layer!r} cannot be read ({exc})") from None
    names = list(meta["fields"])
    rows = [dict(zip(names, values)) for values in zip(*columns)] if names else [{} for _ in range(len(wkb))]
    try:
        geometries = [] if wkb is None else [None if g is None else shapely.from_wkb(g) for g in wkb]
    except shapely.errors.GEOSException as exc:
        raise UserError(f"{path}: layer {layer!r} holds a geometry GEOS cannot read ({exc})") from None
    return meta, geometries, rows


def _to_wgs84(meta: dict, geometries: list, where: str) -> list:
    """Geometries of a layer in its own coordinate system, projected to WGS84 lon/lat."""
    import numpy as np
    import shapely
    from pyproj import CRS, Transformer

    if meta.get("crs") is None:
        raise UserError(f"{where}: has no coordinate reference system (a Shapefile's .prj is missing?); "
                        f"save it with one, e.g. EPSG:4326")
    crs = CRS.from_user_input(meta["crs"])
    if crs.equals(CRS.from_epsg(4326), ignore_axis_order=True):
        return geometries
    to_wgs84 = Transformer.from_crs(crs, 4326, always_xy=True)
    return [None if g is None else shapely.transform(g, lambda xy: np.column_stack(to_wgs84.transform(xy[:, 0],
                                                                                                      xy[:, 1])))
            for g in geometries]


CAMERA_HEADING = "kml_camera_heading"
KML_READING = {"LIBKML_HEADING_FIELD": CAMERA_HEADING, "LIBKML_READ_GROUND_OVERLAY": "NO"}


@contextmanager
def _kml_reading() -> Iterator[None]:
    """GDAL's LIBKML driver set to read placemarks only (no image overlays), with a Placemark's
    Camera heading in the field CAMERA_HEADING instead of `heading`, where it would pass for an
    airport's (GDAL writes a `heading` attribute as such a Camera, the text `E` as 0)."""
    import pyogrio

    pyogrio.set_gdal_config_options(KML_READING)
    try:
        yield
    finally:
        pyogrio.set_gdal_config_options(dict.fromkeys(KML_READING))


def _kml_sources(path: Path, layers: list[str]) -> list[_Source]:
    sources = []
    with _kml_reading():
        read = [(layer, *_read_layer(path, layer)[1:]) for layer in layers]
    for layer, geometries, rows in read:
        for k, (geometry, row) in enumerate(zip(geometries, rows)):
            name = _plain(row.get("Name"))
            place = f"{path}: folder {layer!r}, " + (f"placemark {name!r}" if name else f"placemark {k + 1}")
            attributes = _attributes({k: v for k, v in row.items() if k not in ("Name", "description")}, False)
            sources.append(_Source(place, layer, name and str(name), attributes, _plain(row.get("description")),
                                   geometry, camera_heading=_plain(row.get(CAMERA_HEADING)) is not None))
    return sources


def _gpx_sources(path: Path, layers: list[str]) -> list[_Source]:
    """Waypoints, then routes and tracks (their points read from route_points / track_points, so
    that a segment of one point does not stop the reading)."""
    from shapely.geometry import LineString

    sources = []
    for layer in (name for name in GPX_LAYERS if name in layers):
        what = layer[:-1]
        if layer == "waypoints":
            _, geometries, rows = _read_layer(path, layer)
        else:
            _, _, rows = _read_layer(path, layer, read_geometry=False)
            _, points, point_rows = _read_layer(path, f"{what}_points")
            owner = "route_fid" if what == "route" else "track_fid"
            lines: dict[int, list] = {}
            for point, prow in zip(points, point_rows):
                lines.setdefault(int(prow[owner]), []).append((point.x, point.y))
            geometries = [LineString(lines[k]) if len(lines.get(k, [])) > 1 else None for k in range(len(rows))]
        for k, (geometry, row) in enumerate(zip(geometries, rows)):
            name = _plain(row.get("name"))
            label = f"{what} {name!r}" if name else f"{what} {k + 1}"
            kind = _plain(row.get("type"))  # a GPX <type> may class a waypoint otherwise: a role only if it names one
            attributes = {"role": kind} if role_name(kind) else {}
            description = "\n".join(str(v) for v in (_plain(row.get("desc")), _plain(row.get("cmt"))) if v)
            outline = layer != "waypoints"
            if outline and geometry is None:
                raise UserError(f"{path}: {label} has fewer than 2 points")
            sources.append(_Source(f"{path}: {label}", "", name and str(name), attributes, description, geometry,
                                   outline=outline, default_role="area" if outline else None))
    return sources


def _table_sources(path: Path, layers: list[str], shapefile: bool) -> list[_Source]:
    sources = []
    for layer in sorted(layers) if shapefile else layers:
        where = f"{path}: layer {layer!r}" if len(layers) > 1 or not shapefile else str(path)
        meta, geometries, rows = _read_layer(path, layer)
        geometries = _to_wgs84(meta, geometries, where)
        for k, (geometry, row) in enumerate(zip(geometries, rows)):
            name = next((_plain(v) for key, v in row.items() if key.lower() == "name"), None)
            label = f"feature {k + 1}" + (f" ({name!r})" if name else "")
            description = next((_plain(v) for key, v in row.items() if key.lower() in ("description", "desc")),
                               None)
            sources.append(_Source(f"{where}, {label}", layer, name and str(name), _attributes(row, shapefile),
                                   description, geometry))
    return sources


KML_HINT = ("an ExtendedData field 'role', a line 'role: ...' in the description, a name like 'airport: West', "
            "or a folder named after the role")
GPX_HINT = "a <type> naming it, a line 'role: ...' in <desc>, or a name like 'airport: West'"
TABLE_HINT = "a 'role' column, a name like 'airport: West', or a layer named after the role"


@dataclass(frozen=True)
class GisArea:
    """A GIS area file as the GeoJSON `parse_area` reads, and where each feature came from."""

    collection: dict
    places: list[str]


def read_gis_area(path: str | Path) -> GisArea:
    """The features of a KML/KMZ, GPX, GeoPackage or Shapefile area file with their roles, as a
    GeoJSON FeatureCollection; UserError (one line, naming what is missing) when it cannot be."""
    path = Path(path)
    driver, layers = _open(path)
    if driver in ("LIBKML", "KML"):
        sources, hint = _kml_sources(path, layers), KML_HINT
    elif driver == "GPX":
        sources, hint = _gpx_sources(path, layers), GPX_HINT
    else:
        sources, hint = _table_sources(path, layers, shapefile=driver == "ESRI Shapefile"), TABLE_HINT
    features, places = [], []
    for src in sources:
        role, name = _role(src, hint)
        properties: dict[str, Any] = {"role": role}
        if name:
            properties["name"] = name
        for key, value in {**description_values(src.description), **src.attributes}.items():
            if key != "role":
                properties[key] = _value(key, value)
        if role == "airport" and src.camera_heading and "heading" not in properties:
            raise UserError(f"{src.place}: its heading was written as a KML Camera (GDAL's LIBKML driver does so with "
                            f"a 'heading' attribute, and turns N, NE, ... into 0); write the KML with GDAL's KML "
                            f"driver (ogr2ogr -f KML) or put 'heading: ...' in the description")
        geometry = _geojson_geometry(src.geometry, role, src)
        features.append({"type": "Feature", "geometry": geometry, "properties": properties})
        places.append(src.place)
    roles = {f["properties"]["role"] for f in features}
    if "area" not in roles:
        if driver == "GPX":
            raise UserError(f"{path}: no route or track to outline the area")
        raise UserError(f"{path}: no area polygon: give the search area the role 'area' ({hint})")
    if "airport" not in roles:
        more = ("; a shapefile holds one kind of geometry: put the airports in a shapefile beside it and "
                "give the folder or a .zip of both") if path.suffix.lower() == ".shp" else ""
        raise UserError(f"{path}: no airport (one point per UAV with the role 'airport': {hint}){more}")
    return GisArea({"type": "FeatureCollection", "features": features}, places)
