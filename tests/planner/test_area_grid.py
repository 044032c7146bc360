"""The area on its grid: where airports may stand, and what no leg may enter."""

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, box

from planner.area_grid import LEG_TOLERANCE_M, airport_cell, build_area_grid
from planner.georef import LocalFrame

FRAME = LocalFrame(47.0, 8.0)


def _lonlat(geometry_m):
    return shapely.transform(geometry_m, lambda xy: np.column_stack(FRAME.local2geodetic(xy[:, 0], xy[:, 1])[::-1]))


def _square(*no_fly_m, margin_m: float = 0.0, holes=()):
    """A 1.5 km square of 100 m cells around FRAME's origin."""
    area = shapely.Polygon(box(-750, -750, 750, 750).exterior, [h.exterior for h in holes])
    return build_area_grid(_lonlat(area), [_lonlat(z) for z in no_fly_m], 100.0, margin_m)


def _local(grid, point_m) -> tuple[float, float]:
    lat, lon = FRAME.local2geodetic(*point_m)
    return grid.point_m(float(lon), float(lat))


@pytest.mark.parametrize("edge", [(-400.0, -750.0), (750.0, 100.0), (-200.0, 750.0), (-750.0, 0.0), (750.0, 750.0)])
def test_an_airport_drawn_on_the_area_edge_is_inside_it(edge):
    """Drawn on the edge (a runway at the edge of a meadow), the airport is a round-off outside
    or inside the projected area, and on the grid's last row or column."""
    grid = _square()
    east, north = _local(grid, edge)
    x, y = airport_cell(grid, east, north, "airport")
    assert grid.free[x, y] and grid.grid.centre_m(x, y) == pytest.approx((east, north), abs=100.0)


def test_an_airport_off_the_edge_is_still_outside_the_area():
    grid = _square()
    with pytest.raises(ValueError, match="outside the area"):
        airport_cell(grid, *_local(grid, (-400.0, -751.0)), "airport")


def test_what_no_leg_may_enter_is_the_no_fly_zones_and_holes_grown_by_the_margin():
    zone, hole = box(1000, 0, 1100, 100), box(-300, -300, -200, -200)  # a zone outside the area, a hole
    grid = _square(zone, holes=[hole], margin_m=20.0)
    keep_out = grid.keep_out_m
    outside_zone, beside_hole = _local(grid, (990.0, 50.0)), _local(grid, (-190.0, -250.0))
    assert keep_out.covers(Point(outside_zone)) and keep_out.covers(Point(beside_hole))  # within the margin
    assert not keep_out.covers(Point(_local(grid, (970.0, 50.0))))
    assert not keep_out.covers(Point(_local(grid, (0.0, 0.0))))  # the area itself, and beyond it, are open
    assert not keep_out.covers(Point(_local(grid, (0.0, -900.0))))
    assert keep_out.area == pytest.approx(shapely.unary_union([zone.buffer(20.0), hole.buffer(20.0)]).area, rel=1e-3)
    edge = _local(grid, (1000.0 - 20.0 - LEG_TOLERANCE_M / 2, 50.0))  # a leg touching the margin's edge is clear
    assert not keep_out.covers(Point(edge))
