"""Mission files for autopilots and GIS tools, written from a planned flight.

- `items`: the mission as MAVLink mission items (take-off, waypoints, landing).
- `wpl`: QGC WPL 110 text (`.waypoints`), item 0 the home position.
- `qgc_plan`: QGroundControl `.plan` JSON with geofence and rally point.
- `paths`: a GeoJSON FeatureCollection of the planned paths."""

from gcs.missions.from_plan import FlownPath, uav_mission
from gcs.missions.items import MavCmd, MavFrame, MissionItem, UavMission, Vehicle, mission_items
from gcs.missions.paths import paths_geojson
from gcs.missions.qgc_plan import qgc_plan
from gcs.missions.wpl import parse_wpl, wpl_text

__all__ = ["FlownPath", "MavCmd", "MavFrame", "MissionItem", "UavMission", "Vehicle", "mission_items",
           "parse_wpl", "paths_geojson", "qgc_plan", "uav_mission", "wpl_text"]
