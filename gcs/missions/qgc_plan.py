"""QGroundControl `.plan` JSON (QGC developer guide, "Plan File Format"): mission version 2 of
SimpleItems, geofence version 2 (polygons: lat/lon vertices, clockwise, not closed; `inclusion`
true keeps the vehicle inside, false outside), rally points version 2 ([lat, lon, alt above home]).

The geofence holds the area's outer rings as inclusion polygons and the area's holes and the
no-fly zones as exclusion polygons."""

from __future__ import annotations

from gcs.missions.items import AltitudeReference, MavCmd, MavFrame, MissionItem, UavMission, mission_items

FIRMWARE_ARDUPILOT = 3     # MAV_AUTOPILOT_ARDUPILOTMEGA
ALTITUDE_MODE_MIXED = 0  # QGroundControl's AltitudeMode: 0 mixed (per item), 1 above home, 4 the terrain frame
ALTITUDE_MODE_RELATIVE = 1
ALTITUDE_MODE_TERRAIN_FRAME = 4


def _clockwise(ring: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """`ring` of (lat, lon), without the closing vertex, in clockwise order seen on a map."""
    pts = list(ring[:-1]) if len(ring) > 1 and ring[0] == ring[-1] else list(ring)
    twice_area = sum(a[1] * b[0] - b[1] * a[0] for a, b in zip(pts, pts[1:] + pts[:1]))  # x = lon, y = lat
    return pts if twice_area < 0 else pts[::-1]


def _simple_item(item: MissionItem, jump_id: int) -> dict:
    yaw = None if item.command in (MavCmd.NAV_WAYPOINT, MavCmd.NAV_TAKEOFF, MavCmd.NAV_LAND) else item.params[3]
    params = [item.params[0], item.params[1], item.params[2], yaw, item.lat_deg, item.lon_deg, item.alt_m]
    frame = item.frame.in_files
    return {
        "AMSLAltAboveTerrain": None,
        "Altitude": item.alt_m,
        "AltitudeMode": ALTITUDE_MODE_TERRAIN_FRAME if frame is MavFrame.GLOBAL_TERRAIN_ALT else ALTITUDE_MODE_RELATIVE,
        "autoContinue": item.autocontinue,
        "command": int(item.command),
        "doJumpId": jump_id,
        "frame": int(frame),
        "params": params,
        "type": "SimpleItem",
    }


def qgc_plan(mission: UavMission, inclusion: list[list[tuple[float, float]]],
             exclusion: list[list[tuple[float, float]]], cruise_speed_m_s: float) -> dict:
    """The .plan document; fence rings are lists of (lat, lon). Speeds are whole metres per
    second (Mission Planner's .plan importer fails on `12.0`); the planned home position carries
    the airport's ground altitude above mean sea level."""
    items = [_simple_item(it, k) for k, it in enumerate(mission_items(mission), start=1)]
    fences = [{"inclusion": True, "polygon": [list(p) for p in _clockwise(r)], "version": 1} for r in inclusion]
    fences += [{"inclusion": False, "polygon": [list(p) for p in _clockwise(r)], "version": 1} for r in exclusion]
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": fences, "version": 2},
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": round(cruise_speed_m_s),
            "firmwareType": FIRMWARE_ARDUPILOT,
            "globalPlanAltitudeMode": (ALTITUDE_MODE_RELATIVE if mission.altitude_reference is AltitudeReference.HOME
                                       else ALTITUDE_MODE_MIXED),
            "hoverSpeed": round(cruise_speed_m_s),
            "items": items,
            "plannedHomePosition": [mission.home_lat_deg, mission.home_lon_deg, mission.home_amsl_m],
            "vehicleType": mission.vehicle.mav_type,
            "version": 2,
        },
        "rallyPoints": {"points": [[mission.home_lat_deg, mission.home_lon_deg, mission.altitude_m]], "version": 2},
        "version": 1,
    }
