"""The geofence a UAV is given: the area (joined with a plane's landing corridor) to stay in, the
area's holes and the no-fly zones to stay out of."""

from __future__ import annotations

import pytest
import shapely
from shapely.geometry import Polygon, box

from gcs.missions.fence import uav_fence

AREA = box(8.0, 47.0, 8.02, 47.0135)  # lon/lat, about 1.5 km square
NO_FLY = box(8.012, 47.008, 8.014, 47.01)


def _polygon(ring) -> Polygon:
    return Polygon([(lon, lat) for lat, lon in ring])


def test_without_a_corridor_the_fence_is_the_area_and_its_zones():
    holed = Polygon(AREA.exterior, [box(8.002, 47.002, 8.004, 47.004).exterior])
    fence = uav_fence(holed, [NO_FLY])
    assert len(fence.inclusion) == 1 and _polygon(fence.inclusion[0]).equals(AREA)
    assert [_polygon(r).equals(z) for r, z in zip(fence.exclusion, [box(8.002, 47.002, 8.004, 47.004), NO_FLY])] \
        == [True, True]
    assert fence.vertices == 4 + 4 + 4


def test_the_corridor_is_merged_into_the_area_ring_as_one_simple_polygon():
    corridor = box(8.006, 46.994, 8.010, 47.001)  # from inside the area out across its south edge
    fence = uav_fence(AREA, [NO_FLY], corridor)
    assert len(fence.inclusion) == 1  # ArduPilot and PX4 keep a vehicle inside every inclusion polygon at once
    ring = _polygon(fence.inclusion[0])
    assert ring.is_valid and ring.covers(AREA) and ring.covers(corridor)
    assert ring.area == pytest.approx(shapely.union(AREA, corridor).area)
    assert len(fence.inclusion[0]) - 1 == 8  # the square's 4 corners and the corridor's 4 outside it
    assert len(fence.exclusion) == 1 and _polygon(fence.exclusion[0]).equals(NO_FLY)
    assert fence.vertices == 12


def test_a_pocket_the_corridor_closes_off_is_included_and_the_rings_stay_simple():
    u_shape = Polygon([(8.0, 47.0), (8.02, 47.0), (8.02, 47.01), (8.015, 47.01), (8.015, 47.003), (8.005, 47.003),
                       (8.005, 47.01), (8.0, 47.01)])
    bridge = box(8.004, 47.008, 8.016, 47.012)  # across the U's mouth
    fence = uav_fence(u_shape, [], bridge)
    assert len(fence.inclusion) == 1
    ring = _polygon(fence.inclusion[0])
    assert ring.is_valid and not ring.interiors and ring.covers(box(8.006, 47.004, 8.014, 47.009))
    assert fence.exclusion == []


def test_a_multipart_area_keeps_its_other_parts():
    parts = shapely.MultiPolygon([AREA, box(8.03, 47.0, 8.04, 47.01)])
    fence = uav_fence(parts, [], box(8.006, 46.994, 8.010, 47.001))
    assert len(fence.inclusion) == 2
    assert sorted(len(r) - 1 for r in fence.inclusion) == [4, 8]
