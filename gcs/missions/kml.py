"""KML of a plan's paths and a flight's tracks and detections, for Google Earth, CalTopo /
SARTopo and QGIS: one Folder of Placemarks in a Document, each UAV's in its colour
(`gcs.colours`: the colours of plan.png), every property as ExtendedData (Google Earth shows
them in the balloon, QGIS as attributes). Lines are drawn on the ground (clampToGround: the
flight altitude is a property, above home or terrain). Written by GDAL's LIBKML driver
(`gcs.missions.gdal_layer`), so what QGIS and ogr2ogr read back is what GDAL wrote."""

from __future__ import annotations

from collections.abc import Sequence

from gcs.colours import uav_colour
from gcs.missions.gdal_layer import Layer, layer_text

LINE_WIDTH_PX = 3
# Google Earth's white circle, tinted with the UAV's colour (GDAL 3.12's LIBKML writer crashes on
# a SYMBOL style without an icon id)
POINT_ICON = "http://maps.google.com/mapfiles/kml/shapes/placemark_circle.png"


def _hex(rgb: tuple[int, int, int]) -> str:
    return "#{:02X}{:02X}{:02X}".format(*rgb)


def segment_fill(poa_pct: float) -> str:
    """A segment's fill: orange, its opacity growing with its POA (a quarter at 25 % and above)."""
    alpha = int(round(40 + 160 * min(max(poa_pct, 0.0), 25.0) / 25.0))
    return f"#FF8C00{alpha:02X}"


def feature_style(properties: dict, geometry_type: str) -> str:
    """The OGR feature style of a feature (GDAL writes it as the Placemark's KML Style): its UAV's
    colour, a line or an icon; a segment's polygon shaded by its POA."""
    if geometry_type == "Polygon":
        return f"BRUSH(fc:{segment_fill(float(properties.get('poa_pct') or 0.0))});PEN(c:#8B4500,w:2px)"
    colour = _hex(uav_colour(int(properties.get("uav") or 1) - 1))
    if geometry_type == "LineString":
        return f"PEN(c:{colour},w:{LINE_WIDTH_PX}px)"
    return f'SYMBOL(id:"{POINT_ICON}",c:{colour})'


def kml_text(collection: dict, folder: str, names: Sequence[str], title: str, geometry_type: str) -> str:
    """A KML document `title` with one Folder `folder` holding the collection's features (all
    `geometry_type`, "LineString", "Point" or "Polygon"; None geometries are Placemarks without one), named
    `names`; their properties, but `name`, as ExtendedData."""
    features = collection["features"]
    fields = list(dict.fromkeys(k for f in features for k in (f.get("properties") or {}) if k != "name"))
    styles = [feature_style(f.get("properties") or {}, geometry_type) for f in features]
    layer = Layer(folder, features, names, fields, {"OGR_STYLE": styles})
    return layer_text(layer, "LIBKML", geometry_type, dataset_options={"NAME": title},
                      layer_options={"FOLDER": "YES"})
