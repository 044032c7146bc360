"""GPX 1.1 of a plan's paths and a flight's tracks and detections, for handheld GPS units and
phone apps: paths and tracks as `<trk>` (many handhelds keep only a few hundred points of a
route, and thousands of a track), detections as `<wpt>`, the other properties as `<extensions>` (ogr
namespace, ignored by units that do not know it). Written by GDAL's GPX driver
(`gcs.missions.gdal_layer`)."""

from __future__ import annotations

from collections.abc import Sequence

from gcs.missions.gdal_layer import Layer, layer_text


def gpx_text(collection: dict, names: Sequence[str], geometry_type: str) -> str:
    """The collection's features (all `geometry_type`: "LineString" become tracks, "Point"
    waypoints) named `names`."""
    features = collection["features"]
    fields = list(dict.fromkeys(k for f in features for k in (f.get("properties") or {}) if k != "name"))
    layer = Layer("tracks" if geometry_type == "LineString" else "waypoints", features, names, fields)
    options = {"FORCE_GPX_TRACK": "YES"} if geometry_type == "LineString" else {}
    return layer_text(layer, "GPX", geometry_type, dataset_options={"GPX_USE_EXTENSIONS": "YES"},
                      layer_options=options)
