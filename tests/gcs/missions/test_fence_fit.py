"""A fence fitted to an autopilot's storage: what fits is left alone; what does not is simplified
outward, every ring valid, the inclusion still covering the area, every exclusion still covering
its zone and growing only where it is allowed to; and the storage rule is ArduPilot's own (our
simulated ArduPilot's check, which tests/gcs/autopilots/test_sim_matches_sitl.py holds to SITL)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings, strategies as st
from shapely.geometry import Point, Polygon

from gcs.autopilots.capacity import ARDUCOPTER_FENCE, ARDUPLANE_FENCE, PX4_FENCE, fleet_fence_capacity
from gcs.missions.fence import Fence, FenceCapacity, uav_fence
from gcs.missions.fence_fit import FenceDoesNotFit, fit_fence
from gcs.plans.plan_folder import fence_wire
from sim.autopilot.ardupilot import fence_leaves_no_end_marker, fence_problems

#: Containment is checked to 1e-9 degree (0.1 mm); the autopilots store 1e-7 (1.1 cm).
TOLERANCE_DEG = 1e-9


def _blob(seed: int, vertices: int, centre=(8.0, 47.0), radius_deg=0.02, wobble=0.35) -> Polygon:
    """A random star-shaped ring (a traced outline): radius varying with the angle, each vertex
    in its own sector of the circle, so valid."""
    rng = np.random.default_rng(seed)
    angles = (np.arange(vertices) + rng.uniform(0, 0.8, vertices)) * 2 * math.pi / vertices
    radii = radius_deg * (1 - wobble * rng.uniform(0, 1, vertices))
    return Polygon(np.column_stack([centre[0] + radii * np.cos(angles) / math.cos(math.radians(centre[1])),
                                    centre[1] + radii * np.sin(angles)]))


def _polygon(ring) -> Polygon:
    return Polygon([(lon, lat) for lat, lon in ring])


def _counts(fence: Fence) -> list[int]:
    return [len(r) - 1 for r in fence.inclusion + fence.exclusion]


def test_a_fence_that_fits_is_left_as_it_is():
    fence = uav_fence(_blob(1, 40), [_blob(2, 12, radius_deg=0.003)])
    fitted = fit_fence(fence, ARDUCOPTER_FENCE)
    assert fitted.fence is fence and not fitted.simplified
    assert fitted.describe() == "fence: 52 vertices"


def test_the_issues_outline_of_96_vertices_fits_every_autopilot_and_says_how():
    area = _blob(7, 96)
    fence = uav_fence(area, [])
    for capacity in (ARDUCOPTER_FENCE, ARDUPLANE_FENCE, PX4_FENCE):
        fitted = fit_fence(fence, capacity)
        assert capacity.holds(_counts(fitted.fence))
        ring = _polygon(fitted.fence.inclusion[0])
        assert ring.is_valid and ring.buffer(TOLERANCE_DEG).covers(area)
    fitted = fit_fence(fence, fleet_fence_capacity(False))
    assert fitted.fence.vertices == 64
    assert fitted.describe() == \
        f"fence: 96 vertices simplified to 64, at most {fitted.outside_m:.0f} m outside the area"
    assert 0 < fitted.outside_m < 150  # notches up to 780 m deep on a 4.4 km outline, two thirds of its vertices kept


@settings(deadline=None, max_examples=60)
@given(seed=st.integers(0, 10_000), vertices=st.integers(20, 160), zones=st.integers(0, 3),
       items=st.integers(6, 70), ardupilot=st.booleans())
def test_a_fitted_fence_is_valid_holds_its_area_and_zones_and_fits(seed, vertices, zones, items, ardupilot):
    assume(items >= 8 * zones + 6)  # room for the zones as they are and a small inclusion ring
    area = _blob(seed, vertices)
    rng = np.random.default_rng(seed)
    clear = Point(8.0, 47.0).buffer(0.0003)  # an airport, say: no zone may grow onto it
    no_fly: list[Polygon] = []
    for k in range(zones):
        zone = _blob(seed + 1 + k, 8, centre=(8.0 + rng.uniform(-0.006, 0.006), 47.0 + rng.uniform(-0.006, 0.006)),
                     radius_deg=0.001)
        if zone.distance(clear) > 1e-4 and not any(zone.intersects(z) for z in no_fly):
            no_fly.append(zone)
    capacity = FenceCapacity.ardupilot(items) if ardupilot else FenceCapacity(items)
    fitted = fit_fence(uav_fence(area, no_fly), capacity, clear, 90.0)
    out = fitted.fence
    assert capacity.holds(_counts(out))
    assert len(out.inclusion) == 1 and len(out.exclusion) == len(no_fly)
    inclusion = _polygon(out.inclusion[0])
    assert inclusion.is_valid and inclusion.buffer(TOLERANCE_DEG).covers(area)
    for ring, zone in zip(out.exclusion, no_fly):
        grown = _polygon(ring)
        assert grown.is_valid and grown.buffer(TOLERANCE_DEG).covers(zone)
        assert grown.intersection(clear).area < 1e-12  # never onto ground that must stay clear
        assert grown.difference(zone.buffer(0.0013)).area < 1e-12  # 90 m at most (0.0012 degree of longitude)
    if ardupilot:
        assert fence_problems(fence_wire([(True, r[:-1]) for r in out.inclusion]
                                         + [(False, r[:-1]) for r in out.exclusion]), items) == []


@given(counts=st.lists(st.integers(3, 40), min_size=1, max_size=6), items=st.integers(10, 90))
@example(counts=[41, 28], items=70)  # 560 bytes of 560: no room for the end marker (SITL never answered)
@example(counts=[40, 28], items=70)
def test_the_storage_rule_is_the_one_ardupilot_checks(counts, items):
    rings = [(True, [(47.0 + 1e-4 * math.sin(k), 8.0 + 1e-4 * math.cos(k)) for k in range(n)]) for n in counts]
    wire = fence_wire(rings)
    if len(wire) > items:
        assert not FenceCapacity.ardupilot(items).holds(counts)  # refused at the count (NO_SPACE)
    else:
        stored = fence_problems(wire, items) == [] and not fence_leaves_no_end_marker(wire, items)
        assert FenceCapacity.ardupilot(items).holds(counts) == stored


def test_a_zone_with_nothing_clear_around_it_is_kept_and_a_fence_that_cannot_fit_says_why():
    area = _blob(3, 30)
    zone = _blob(4, 30, radius_deg=0.002)
    fence = uav_fence(area, [zone])
    fitted = fit_fence(fence, FenceCapacity(40))  # no ground given to grow on: the zone stays exact
    assert len(fitted.fence.exclusion[0]) - 1 == 30 and fitted.grown_m == 0
    assert fitted.fence.vertices <= 40
    with pytest.raises(FenceDoesNotFit, match=r"does not fit the vehicle's fence storage \(vehicle: 32 vertices in "
                       r"one polygon, fewer in several\) even simplified \(33 vertices left; no-fly zones only grow "
                       r"where nothing is flown\): draw the zones with fewer vertices$"):
        fit_fence(fence, FenceCapacity(32))


def test_a_circle_loses_vertices_evenly():
    circle = Point(8.0, 47.0).buffer(0.01, quad_segs=24)  # 96 vertices
    fitted = fit_fence(uav_fence(circle, []), FenceCapacity(48))
    ring = _polygon(fitted.fence.inclusion[0])
    assert fitted.fence.vertices == 48 and ring.buffer(TOLERANCE_DEG).covers(circle)
    # an ellipse of 1.11 by 0.76 km (0.01 degree): a regular 48-gon around a circle of 1.11 km would
    # reach 1110 (1/cos(pi/48) - 1) = 2.4 m beyond it
    assert fitted.outside_m < 8.0
