"""Fitting a geofence into an autopilot's fence storage (`FenceCapacity`): where its rings have
more vertices than the vehicle holds, they are simplified outward, so the fence errs the safe
way. The inclusion ring only grows: it never cuts into the searched area or a plane's landing
corridor. An exclusion ring only grows, and only onto ground nothing is flown over
(`keep_clear`): a vehicle is never fenced out of a cell it may search or a leg it may fly home.

The simplification is greedy over two moves, each adding a triangle outside a ring and taking
one vertex away: dropping a reflex (inward) vertex, its neighbours then joined straight; and
collapsing an edge between two convex vertices into the point where its neighbouring edges,
extended, meet. The cheapest move of all rings goes first, its cost how far the ring then
reaches beyond what it had to enclose, until the rings fit; a move that would make a ring touch
itself, or an exclusion cover ground that must stay clear, is never made. Where no move is left
an inclusion ring is replaced by its convex hull and simplified on.

The geometry is planar in longitude and latitude, scaled to metres at the fence's latitude: an
affine map, so straight edges stay straight, as ArduPilot and PX4 test a fence (straight edges
between lat/lon vertices). A ring that contains its area here contains it on the vehicle, to the
1e-7 degree (1.1 cm) the autopilots store a vertex in."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from gcs.missions.fence import Fence, FenceCapacity, Ring

__all__ = ["FenceDoesNotFit", "FittedFence", "describe_fit", "fit_fence"]

EARTH_RADIUS_M = 6_371_008.8

#: A corner made by collapsing an edge is set this far outside the two edges it extends, so the
#: vertices it replaces stay inside the ring after the autopilot rounds it to 1e-7 degree.
OUTSET_M = 0.05

#: Cost samples along a chord that replaces a reflex vertex (fractions of its length).
_CHORD_SAMPLES = np.array([0.25, 0.5, 0.75])

#: A ring reaching no further than this beyond its source has not moved (float rounding).
_UNMOVED_M = 1e-6

#: How finely a fitted ring's edges are walked when measuring how far it reaches: every metre,
#: or so many points on a longer ring.
_MEASURE_STEP_M = 1.0
_MEASURE_SAMPLES = 20_000


class FenceDoesNotFit(ValueError):
    """No outward simplification brings the fence within the vehicle's capacity."""


@dataclass(frozen=True)
class FittedFence:
    """A fence as uploaded: `fence` holds `fence.vertices` of the `source_vertices` the area and
    zones have; its inclusion reaches at most `outside_m` beyond the ground it must include, and
    its exclusions at most `grown_m` beyond their zones."""

    fence: Fence
    source_vertices: int
    outside_m: float = 0.0
    grown_m: float = 0.0

    @property
    def simplified(self) -> bool:
        return self.fence.vertices != self.source_vertices

    def describe(self) -> str:
        return describe_fit(self.fence.vertices, self.source_vertices, self.outside_m, self.grown_m)


def describe_fit(vertices: int, source_vertices: int, outside_m: float, grown_m: float) -> str:
    """One line: "fence: 96 vertices simplified to 62, at most 38 m outside the area"."""
    if vertices == source_vertices:
        return f"fence: {vertices} vertices"
    grown = f", no-fly zones grown by at most {grown_m:.0f} m (the plan keeps out of them)" if grown_m >= 0.5 else ""
    return (f"fence: {source_vertices} vertices simplified to {vertices}, at most {outside_m:.0f} m outside the "
            f"area{grown}")


class _Metres:
    """Longitude and latitude scaled to metres at `lat0_deg`: affine, so lines stay lines."""

    def __init__(self, lat0_deg: float, lon0_deg: float) -> None:
        self.lat0, self.lon0 = lat0_deg, lon0_deg
        self.ky = math.radians(1.0) * EARTH_RADIUS_M
        self.kx = self.ky * math.cos(math.radians(lat0_deg))

    def from_lat_lon(self, ring: Ring) -> np.ndarray:
        lat, lon = np.asarray(ring, dtype=float).reshape(-1, 2).T
        return np.column_stack([(lon - self.lon0) * self.kx, (lat - self.lat0) * self.ky])

    def to_lat_lon(self, x: float, y: float) -> tuple[float, float]:
        return round(float(self.lat0 + y / self.ky), 9), round(float(self.lon0 + x / self.kx), 9)

    def geometry(self, lonlat: BaseGeometry) -> BaseGeometry:
        return shapely.transform(lonlat, lambda c: np.column_stack([(c[:, 0] - self.lon0) * self.kx,
                                                                     (c[:, 1] - self.lat0) * self.ky]))


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


def _meets_any(p: np.ndarray, q: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> bool:
    """Whether segment p-q meets (crosses or touches) any of the segments starts[k]-ends[k]."""
    if len(starts) == 0:
        return False
    d1, d2 = _cross(starts, ends, p), _cross(starts, ends, q)
    d3, d4 = _cross(p, q, starts), _cross(p, q, ends)
    hit = (d1 * d2 <= 0) & (d3 * d4 <= 0)
    collinear = (d1 == 0) & (d2 == 0)
    if collinear.any():
        lo, hi = np.minimum(p, q), np.maximum(p, q)
        overlap = ((np.minimum(starts, ends) <= hi) & (np.maximum(starts, ends) >= lo)).all(axis=1)
        hit &= ~collinear | overlap
    return bool(hit.any())


class _Ring:
    """One ring being simplified: vertices in a linked list, counter-clockwise, over a growing
    array of points (a collapse adds one); `lat_lon[k]` keeps a source vertex's exact degrees."""

    def __init__(self, xy: np.ndarray, lat_lon: list[tuple[float, float] | None], inclusion: bool,
                 source: BaseGeometry, allowed: BaseGeometry | None) -> None:
        if Polygon(xy).exterior.is_ccw is False:
            xy, lat_lon = xy[::-1], lat_lon[::-1]
        n = len(xy)
        self.xy = np.zeros((2 * n + 2, 2))
        self.xy[:n] = xy
        self.lat_lon: list[tuple[float, float] | None] = list(lat_lon) + [None] * (n + 2)
        self.nxt = np.array([(i + 1) % n for i in range(n)] + [-1] * (n + 2))
        self.prv = np.array([(i - 1) % n for i in range(n)] + [-1] * (n + 2))
        self.alive = np.zeros(2 * n + 2, dtype=bool)
        self.alive[:n] = True
        self.version = np.zeros(2 * n + 2, dtype=np.int64)
        self.used = n
        self.count = n
        self.inclusion = inclusion
        self.source = source
        self.allowed = allowed
        shapely.prepare(source)
        if allowed is not None:
            shapely.prepare(allowed)

    def walk(self, start: int, steps: int, forward: bool) -> list[int]:
        out, k = [], start
        for _ in range(steps):
            k = int(self.nxt[k] if forward else self.prv[k])
            out.append(k)
        return out

    def order(self) -> list[int]:
        start = int(np.flatnonzero(self.alive)[0])
        return [start] + self.walk(start, self.count - 1, True)

    # ---- the two moves ------------------------------------------------------------------

    def drop_cost(self, i: int) -> float | None:
        """Dropping reflex (or straight) vertex `i`: how far its chord reaches, None if `i` is convex."""
        if self.count <= 3:
            return None
        a, b = self.xy[self.prv[i]], self.xy[self.nxt[i]]
        if _cross(a, self.xy[i], b) > 1e-9 * max(1.0, float(np.dot(b - a, b - a))):
            return None
        points = a + _CHORD_SAMPLES[:, None] * (b - a)
        return float(shapely.distance(shapely.points(points), self.source).max())

    def collapse_point(self, i: int) -> np.ndarray | None:
        """Where the edges before `i` and after its successor meet, set OUTSET_M outside them,
        when they meet beyond the edge i -> successor; else None."""
        if self.count <= 3:
            return None
        a, b = int(self.prv[i]), int(self.nxt[i])
        c = int(self.nxt[b])
        d1 = self.xy[i] - self.xy[a]
        d2 = self.xy[b] - self.xy[c]
        n1 = np.array([d1[1], -d1[0]]) / max(np.hypot(*d1), 1e-12)
        n2 = np.array([-d2[1], d2[0]]) / max(np.hypot(*d2), 1e-12)
        det = d1[0] * (-d2[1]) - d1[1] * (-d2[0])
        if abs(det) <= 1e-9 * np.hypot(*d1) * np.hypot(*d2):
            return None
        rhs = (self.xy[b] + OUTSET_M * n2) - (self.xy[i] + OUTSET_M * n1)
        s = (rhs[0] * (-d2[1]) - rhs[1] * (-d2[0])) / det
        t = (d1[0] * rhs[1] - d1[1] * rhs[0]) / det
        if s <= 0 or t <= 0:
            return None
        p = self.xy[i] + OUTSET_M * n1 + s * d1
        if _cross(self.xy[i], self.xy[b], p) >= 0:
            return None
        return p

    def collapse_cost(self, i: int) -> float | None:
        p = self.collapse_point(i)
        return None if p is None else float(shapely.distance(shapely.points(p), self.source))

    def _edges_but(self, skip: set[int]) -> tuple[np.ndarray, np.ndarray]:
        """The ring's edges (start, end points), leaving out those starting at `skip`."""
        starts = np.flatnonzero(self.alive)
        starts = starts[~np.isin(starts, list(skip))]
        return self.xy[starts], self.xy[self.nxt[starts]]

    def _stays_allowed(self, triangle: np.ndarray) -> bool:
        if self.allowed is None:
            return True
        added = Polygon(triangle)
        return shapely.difference(added, self.allowed).area <= 1e-6 * added.area + 1e-6

    def drop(self, i: int) -> bool:
        a, b = int(self.prv[i]), int(self.nxt[i])
        starts, ends = self._edges_but({int(self.prv[a]), a, i, b})
        if _meets_any(self.xy[a], self.xy[b], starts, ends):
            return False
        if not self._stays_allowed(self.xy[[a, i, b]]):
            return False
        self.nxt[a], self.prv[b] = b, a
        self.alive[i] = False
        self.count -= 1
        return True

    def collapse(self, i: int) -> int | None:
        """Collapse the edge from `i`; the new vertex, or None when the move is not allowed."""
        p = self.collapse_point(i)
        if p is None:
            return None
        a, b = int(self.prv[i]), int(self.nxt[i])
        c = int(self.nxt[b])
        starts, ends = self._edges_but({a, i, b})
        if _meets_any(self.xy[i], p, starts, ends) or _meets_any(p, self.xy[b], starts, ends):
            return None
        if not self._stays_allowed(np.array([self.xy[i], p, self.xy[b]])):
            return None
        k = self.used
        self.used += 1
        self.xy[k] = p
        self.alive[[i, b]] = False
        self.alive[k] = True
        self.nxt[a], self.prv[k], self.nxt[k], self.prv[c] = k, a, c, k
        self.count -= 1
        return k

    def ring(self, metres: _Metres) -> Ring:
        out = [self.lat_lon[k] or metres.to_lat_lon(*self.xy[k]) for k in self.order()]
        return out + out[:1]

    def polygon(self) -> Polygon:
        return Polygon(self.xy[self.order()])


def _moves(rings: list[_Ring], r: int, vertices: list[int], heap: list, tick: list[int]) -> None:
    ring = rings[r]
    for k in vertices:
        ring.version[k] += 1
        for kind, cost in (("drop", ring.drop_cost(k)), ("collapse", ring.collapse_cost(k))):
            if cost is not None:
                tick[0] += 1
                heapq.heappush(heap, (cost, tick[0], r, k, kind, int(ring.version[k])))


def _simplify(rings: list[_Ring], capacity: FenceCapacity) -> bool:
    """Take the cheapest allowed move of any ring until they fit `capacity`; False when no move is left."""
    heap: list = []
    tick = [0]
    for r, ring in enumerate(rings):
        _moves(rings, r, ring.order(), heap, tick)
    while not capacity.holds([ring.count for ring in rings]):
        if not heap:
            return False
        _, _, r, k, kind, version = heapq.heappop(heap)
        ring = rings[r]
        if not ring.alive[k] or ring.version[k] != version or ring.count <= 3:
            continue
        if kind == "drop":
            before = ring.walk(k, 2, False)
            if not ring.drop(k):
                continue
            centre = before[0]
        else:
            made = ring.collapse(k)
            if made is None:
                continue
            centre = made
        near = ring.walk(centre, 3, False)[::-1] + [centre] + ring.walk(centre, 3, True)
        _moves(rings, r, list(dict.fromkeys(near)), heap, tick)
    return True


def _reach_m(polygons: list[Polygon], sources: list[BaseGeometry]) -> float:
    """How far the rings' edges reach beyond their sources, at most: sampled along the edges,
    plus half the sampling step (the distance to a source changes by no more than the step)."""
    far = 0.0
    for polygon, source in zip(polygons, sources):
        step = max(_MEASURE_STEP_M, polygon.exterior.length / _MEASURE_SAMPLES)
        edge = shapely.segmentize(polygon.exterior, step)
        reach = float(shapely.distance(shapely.points(shapely.get_coordinates(edge)), source).max())
        if reach > _UNMOVED_M:
            far = max(far, reach + step / 2)
    return far


def fit_fence(fence: Fence, capacity: FenceCapacity, keep_clear_lonlat: BaseGeometry | None = None,
              growth_limit_m: float = 0.0) -> FittedFence:
    """`fence` as it fits `capacity`: itself when it fits, else its rings simplified outward.

    Exclusion rings grow only with `keep_clear_lonlat` (lon/lat: the ground the vehicle may fly
    over, which they must leave clear) and then at most `growth_limit_m` beyond their zones;
    without it they are kept as they are. FenceDoesNotFit, saying what it needs, when no
    simplification fits."""
    source_vertices = fence.vertices
    rings = fence.inclusion + fence.exclusion
    if capacity.holds([len(r) - 1 for r in rings]):
        return FittedFence(fence, source_vertices)
    lat0, lon0 = np.asarray(fence.inclusion[0] if fence.inclusion else rings[0], dtype=float).mean(axis=0)
    metres = _Metres(float(lat0), float(lon0))
    clear = metres.geometry(keep_clear_lonlat) if keep_clear_lonlat is not None else None
    work: list[_Ring] = []
    for k, ring in enumerate(rings):
        inclusion = k < len(fence.inclusion)
        points = list(ring[:-1]) if ring[0] == ring[-1] else list(ring)
        xy = metres.from_lat_lon(points)
        source = Polygon(xy)
        allowed = None
        if not inclusion:
            room = source.buffer(growth_limit_m) if clear is not None and growth_limit_m > 0 \
                else source
            allowed = shapely.union(source, shapely.difference(room, clear)) if clear is not None else source
        work.append(_Ring(xy, points, inclusion, source, allowed))
    fitted = _simplify(work, capacity)
    if not fitted:
        for k, ring in enumerate(work):
            if ring.inclusion:
                hull = ring.polygon().convex_hull.exterior
                xy = np.asarray(hull.coords)[:-1]
                work[k] = _Ring(xy, [None] * len(xy), True, ring.source, None)
        fitted = _simplify(work, capacity)
    if not fitted:
        counts = [ring.count for ring in work]
        raise FenceDoesNotFit(
            f"the fence ({source_vertices} vertices in {len(rings)} polygons) does not fit the vehicle's "
            f"{capacity.describe()} even simplified ({sum(counts)} vertices left; no-fly zones only grow where "
            "nothing is flown): draw the zones with fewer vertices")
    polygons = [ring.polygon() for ring in work]
    inclusion_count = len(fence.inclusion)
    outside = _reach_m(polygons[:inclusion_count], [r.source for r in work[:inclusion_count]])
    grown = _reach_m(polygons[inclusion_count:], [r.source for r in work[inclusion_count:]])
    out = [ring.ring(metres) for ring in work]
    return FittedFence(Fence(out[:inclusion_count], out[inclusion_count:]), source_vertices, outside, grown)
