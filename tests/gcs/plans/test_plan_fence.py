"""`gcs plan` fits each UAV's fence to what the autopilots of its airframe hold: plan.json and the
mission table say how, the `.plan` carries the fitted polygons around the area and every zone,
the plan keeps out of the zones it grew, and a mission too long for the autopilots is warned of."""

from __future__ import annotations

import json

import shapely
from shapely.geometry import LineString, Point

from gcs.autopilots.capacity import fleet_fence_capacity
from gcs.cli import main
from gcs.display.plan_tables import mission_capacity_lines
from gcs.missions.items import Vehicle
from gcs.plans.area_file import read_area_file
from tests.gcs.autopilots.flights import assert_fence_holds_the_area, planned_fence
from tests.peers.site import WILDLAND


def test_the_wildland_is_planned_with_a_fence_every_copter_autopilot_holds(tmp_path, capsys):
    folder = tmp_path / "wild"
    folder.mkdir()
    area_file = folder / "site.geojson"
    area_file.write_text(json.dumps(WILDLAND.geojson()))
    assert main(["plan", "--area", str(area_file), "--out", str(folder / "plan"), "--no-rrd"]) == 0
    printed = capsys.readouterr().out
    data = json.loads((folder / "plan" / "plan.json").read_text())
    fence = data["uavs"][0]["fence"]
    assert fence["source_vertices"] == 124 and fence["vertices"] == 64
    assert 0 < fence["outside_m"] < 30 and 0 <= fence["grown_m"] <= 2 * WILDLAND.cell_m
    assert (f"fence: 124 vertices simplified to 64, at most {fence['outside_m']:.0f} m outside the area"
            in printed), printed
    polygons = planned_fence(folder / "plan")
    assert fleet_fence_capacity(False).holds([len(p.exterior.coords) - 1 for _, p in polygons])
    assert_fence_holds_the_area(area_file, polygons, 64)
    source = read_area_file(area_file)
    exclusions = shapely.union_all([p for inclusion, p in polygons if not inclusion])
    airport = source.airports[0]
    assert exclusions.distance(Point(airport.lon_deg, airport.lat_deg)) > 0
    path = LineString([(airport.lon_deg, airport.lat_deg), *((lon, lat) for lat, lon in data["uavs"][0]["waypoints"]),
                       (airport.lon_deg, airport.lat_deg)])
    assert not exclusions.buffer(-2e-7).intersects(path)  # the plan keeps out of the grown zone (to 2 cm)


def test_a_mission_longer_than_an_autopilot_holds_is_warned_of_before_any_upload():
    data = {"uavs": [{"id": 1, "mission_items": 650}, {"id": 2, "mission_items": 651}]}
    assert mission_capacity_lines(data, Vehicle.COPTER) == [
        "warning: UAV 2's mission has 651 items, more than ArduCopter holds (650): fly it on a vehicle that holds "
        "more, or give it a larger cell size"]
    assert mission_capacity_lines(data, Vehicle.PLANE) == []  # ArduPlane holds 655
