"""Mission files for autopilots and GIS tools, written from a planned flight.

- `items`: the mission as MAVLink mission items (take-off, waypoints, landing).
- `wpl`: QGC WPL 110 text (`.waypoints`), item 0 the home position.
- `qgc_plan`: QGroundControl `.plan` JSON with geofence and rally point.
- `paths`: a GeoJSON FeatureCollection of the planned paths.
- `approach`: a plane's landing approach and the corridor its landing may use.
- `fence`: the geofence each UAV is given (the area, a plane's landing corridor, no-fly zones).
- `kml`, `gpx`: paths, tracks and detections as KML and GPX for search teams (through GDAL,
  `gdal_layer`, imported only when they are written).

The names below are imported from their modules when first used: `gcs.missions.items` alone
(what the command line's options need) does not load `from_plan`, and with it the planner."""

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gcs.missions.from_plan import FlownPath, uav_mission
    from gcs.missions.items import MavCmd, MavFrame, MissionItem, UavMission, Vehicle, mission_items
    from gcs.missions.paths import paths_geojson
    from gcs.missions.qgc_plan import qgc_plan
    from gcs.missions.wpl import parse_wpl, wpl_text

_HOMES = {"FlownPath": "from_plan", "uav_mission": "from_plan", "MavCmd": "items", "MavFrame": "items",
          "MissionItem": "items", "UavMission": "items", "Vehicle": "items", "mission_items": "items",
          "paths_geojson": "paths", "qgc_plan": "qgc_plan", "parse_wpl": "wpl", "wpl_text": "wpl"}

__all__ = ["FlownPath", "MavCmd", "MavFrame", "MissionItem", "UavMission", "Vehicle", "mission_items",
           "parse_wpl", "paths_geojson", "qgc_plan", "uav_mission", "wpl_text"]


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{_HOMES[name]}"), name)
    globals()[name] = value
    return value
