"""A plane's landing approach may leave the searched area but never cross a no-fly zone (nor its
margin, nor a hole in the area); the corridor it lands through, which its fence includes."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, box

from gcs.missions.approach import Approach, ApproachOptions, landing_approach
from planner.area_grid import build_area_grid
from planner.georef import LocalFrame

FRAME = LocalFrame(47.0, 8.0)
AIRPORT = (-400.0, -750.0)  # on the south edge of the 1.5 km square; heading 0 lands northwards, into the area


def _lonlat(geometry_m):
    return shapely.transform(geometry_m, lambda xy: np.column_stack(FRAME.local2geodetic(xy[:, 0], xy[:, 1])[::-1]))


def _meadow(*no_fly_m, margin_m: float = 0.0, holes=()):
    """The 1.5 km square of 100 m cells, with no-fly boxes and holes given in local metres."""
    area = shapely.Polygon(box(-750, -750, 750, 750).exterior, [h.exterior for h in holes])
    return build_area_grid(_lonlat(area), [_lonlat(z) for z in no_fly_m], 100.0, margin_m)


def _local(grid, point_m) -> tuple[float, float]:
    """A point of FRAME in the grid's own frame (centred on the area's bounding box)."""
    lat, lon = FRAME.local2geodetic(*point_m)
    return grid.point_m(float(lon), float(lat))


def test_an_approach_outside_the_area_is_kept_at_its_full_length():
    grid = _meadow()
    airport = _local(grid, AIRPORT)
    approach = landing_approach(grid, airport, 0.0, np.array(_local(grid, (-400.0, -700.0))), ApproachOptions())
    assert approach.distance_m == 500.0 and not approach.over_airport
    assert approach.point_m == pytest.approx((airport[0], airport[1] - 500.0))
    assert grid.area_m.distance(Point(approach.point_m)) == pytest.approx(500.0, abs=0.05)  # wholly outside
    assert approach.circuit_m == 1000.0


def test_a_no_fly_zone_across_the_approach_shortens_it():
    grid = _meadow(box(-450, -1150, -350, -1070))  # across the axis 320-400 m out
    approach = landing_approach(grid, _local(grid, AIRPORT), 0.0, np.array(_local(grid, (-400.0, -700.0))),
                                ApproachOptions())
    assert approach.distance_m == 300.0


def test_a_no_fly_zone_across_the_first_250_m_refuses_the_approach_in_one_line():
    grid = _meadow(box(-450, -950, -350, -850))  # 100-200 m out
    with pytest.raises(ValueError) as refused:
        landing_approach(grid, _local(grid, AIRPORT), 0.0, np.array(_local(grid, (-400.0, -700.0))),
                         ApproachOptions(), "airport 'edge' (UAV 1)")
    message = str(refused.value)
    assert "\n" not in message and message.startswith("airport 'edge' (UAV 1): no landing approach of 250 m")
    assert "clear of the no-fly zones" in message and "heading 0 degrees" in message
    # a shorter approach, asked for, fits before the zone
    short = landing_approach(grid, _local(grid, AIRPORT), 0.0, np.array(_local(grid, (-400.0, -700.0))),
                             ApproachOptions(distance_m=90.0, min_distance_m=90.0))
    assert short.distance_m == 90.0


def test_the_margin_keeps_the_approach_away_from_a_no_fly_zone_beside_it():
    beside = box(-390, -1100, -300, -1000)  # 10 m east of the axis, 250-350 m out
    grid = _meadow(beside)
    assert landing_approach(grid, _local(grid, AIRPORT), 0.0, np.array(_local(grid, (-400.0, -700.0))),
                            ApproachOptions()).distance_m == 500.0
    grid = _meadow(beside, margin_m=20.0)
    with pytest.raises(ValueError, match="no-fly zones \\(and their 20 m margin\\)"):
        landing_approach(grid, _local(grid, AIRPORT), 0.0, np.array(_local(grid, (-400.0, -700.0))), ApproachOptions())


def test_the_plane_flies_over_the_airport_when_the_leg_from_its_last_waypoint_crosses_a_no_fly_zone():
    grid = _meadow(box(-100, -1000, 100, -850))  # outside the area, between (300, -700) and the approach point
    airport, last = _local(grid, AIRPORT), np.array(_local(grid, (300.0, -700.0)))
    approach = landing_approach(grid, airport, 0.0, last, ApproachOptions())
    assert approach.distance_m == 500.0 and approach.over_airport and approach.entry_m == pytest.approx(airport)
    direct = landing_approach(_meadow(), airport, 0.0, last, ApproachOptions())
    assert not direct.over_airport and direct.entry_m == pytest.approx(tuple(last))


def test_a_hole_in_the_area_is_kept_out_of_like_a_no_fly_zone():
    hole = box(-450, 300, -350, 400)
    grid = _meadow(holes=[hole])
    north_edge = _local(grid, (-400.0, 750.0))  # lands southwards: the approach runs north, outside
    assert landing_approach(grid, north_edge, 180.0, np.array(north_edge), ApproachOptions()).distance_m == 500.0
    inside = _local(grid, (-400.0, 150.0))  # lands southwards from inside: the approach crosses the hole
    with pytest.raises(ValueError, match="and the area's holes"):
        landing_approach(grid, inside, 180.0, np.array(inside), ApproachOptions())


def test_the_corridor_covers_every_leg_of_the_landing_with_room_to_turn():
    approach = Approach((0.0, 0.0), (0.0, -500.0), 500.0, (600.0, 400.0), False)
    corridor = approach.corridor(150.0, (30.0, 30.0))
    assert corridor.is_valid and len(corridor.exterior.coords) - 1 <= 12
    for start in ((0.0, 0.0), (600.0, 400.0), (30.0, 30.0)):
        room = LineString([start, (0.0, -500.0)]).buffer(149.0, cap_style="square")
        assert corridor.covers(room), start
    assert corridor.covers(Point(0.0, -500.0).buffer(149.0))  # the turn onto the runway axis
    assert not corridor.covers(Point(0.0, -500.0).buffer(250.0))


def test_a_straight_in_corridor_is_a_rectangle():
    """Airport, cell centre and last waypoint on the runway axis (to round-off): four corners,
    not a sliver triangle whose sharp ends reach far out."""
    approach = Approach((-399.9999999997, -749.95), (-399.9999999997, -1249.95), 500.0, (-400.0, -699.95), False)
    corridor = approach.corridor(150.0, (-400.0, -699.95))
    assert len(corridor.exterior.coords) - 1 == 4
    assert corridor.bounds == pytest.approx((-550.0, -1399.95, -250.0, -549.95), abs=0.01)
