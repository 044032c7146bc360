"""The planned paths as GeoJSON (RFC 7946: [lon, lat] positions) for any GIS tool."""

from __future__ import annotations

from gcs.missions.items import UavMission


def paths_geojson(missions: list[UavMission], lengths_m: dict[int, float], name: str) -> dict:
    """One LineString per UAV: airport, waypoints, airport; properties say who flies it and how far."""
    features = []
    for m in missions:
        coords = [[m.home_lon_deg, m.home_lat_deg]] + [[lon, lat] for lat, lon in m.waypoints] \
            + [[m.home_lon_deg, m.home_lat_deg]]
        features.append({
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": coords},
            "properties": {"uav": m.uav_id, "name": m.name, "vehicle": m.vehicle.value, "altitude_m": m.altitude_m,
                           "waypoints": len(m.waypoints), "length_m": round(lengths_m.get(m.uav_id, 0.0), 1)},
        })
    return {"type": "FeatureCollection", "name": name, "features": features}


def uav_label(uav_id: int, name: str) -> str:
    """How map files name a UAV: `UAV 2 (west)`, or `UAV 2` when its airport's name says no more."""
    return f"UAV {uav_id}" if name.replace(" ", "").lower() in ("", f"uav{uav_id}") else f"UAV {uav_id} ({name})"
