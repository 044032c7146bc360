"""The geofence a UAV is given (its QGroundControl `.plan`'s `geoFence`, which `gcs fly` and
`gcs upload` send to the vehicle): inclusion rings, the area's outer rings, one of them joined
with a plane's landing corridor (a runway at the area's edge is landed on from outside it); and
exclusion rings, the area's holes and the no-fly zones' outlines. Rings are lists of (lat, lon).

ArduPilot (unless FENCE_OPTIONS bit 1 is set) and PX4 keep a vehicle inside every inclusion
polygon at once, so the corridor is merged into the area's ring, never sent as a polygon of its
own; and their fence storage is small (`FenceCapacity`: ArduPlane 83 vertices, ArduCopter 69,
PX4 64, all polygons together), so the corridor adds only the few vertices where it leaves the
area, and a fence that still does not fit is simplified outward (`gcs.missions.fence_fit`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

Ring = list[tuple[float, float]]

#: How far a no-fly zone's fence may grow beyond the zone, in cells, where it must be simplified.
FENCE_GROWTH_CELLS = 2

#: How close a grown no-fly zone's fence may come to an airport's cell (metres).
FENCE_CLEARANCE_M = 5.0

#: Fence vertices kept free for a plane's landing corridor, per inclusion ring, when the area's
#: fence is fitted before the corridor is known (it adds 4 where the runway is at a straight edge).
CORRIDOR_VERTICES = 6

#: ArduPilot's fence storage: a 4-byte header, then per polygon a 2-byte type and count and 8
#: bytes per vertex, then a 1-byte end marker (AC_PolyFence_loader::write_fence), in the 8 bytes
#: an item its "Only N items" counts. A fence that leaves no byte for the marker passes its
#: size check and then fails to store: ArduCopter SITL never answers the upload.
ARDUPILOT_HEADER_BYTES = 4
ARDUPILOT_END_BYTES = 1
ARDUPILOT_POLYGON_BYTES = 2
ARDUPILOT_VERTEX_BYTES = 8


@dataclass(frozen=True)
class FenceCapacity:
    """What a vehicle holds of a polygon fence: at most `items` fence items, and, where it packs
    them in `storage_bytes` (ArduPilot), the polygons' bytes within that; `name` says whose."""

    items: int
    storage_bytes: int | None = None
    name: str = "vehicle"

    @classmethod
    def ardupilot(cls, items: int, name: str = "ArduPilot") -> FenceCapacity:
        """The capacity an ArduPilot vehicle reports ("Only N items are supported")."""
        return cls(items, ARDUPILOT_VERTEX_BYTES * items, name)

    def holds(self, ring_vertices: Sequence[int]) -> bool:
        """Whether polygons of these vertex counts fit."""
        if sum(ring_vertices) > self.items:
            return False
        return self.storage_bytes is None or ARDUPILOT_HEADER_BYTES + ARDUPILOT_END_BYTES + sum(
            ARDUPILOT_POLYGON_BYTES + ARDUPILOT_VERTEX_BYTES * n for n in ring_vertices) <= self.storage_bytes

    def less(self, vertices: int) -> FenceCapacity:
        """This capacity with `vertices` kept free for later."""
        return FenceCapacity(self.items - vertices, None if self.storage_bytes is None
                             else self.storage_bytes - ARDUPILOT_VERTEX_BYTES * vertices, self.name)

    def within(self, other: FenceCapacity) -> FenceCapacity:
        """What fits both this and `other`."""
        stores = [s for s in (self.storage_bytes, other.storage_bytes) if s is not None]
        return FenceCapacity(min(self.items, other.items), min(stores) if stores else None,
                             f"{self.name} and {other.name}")

    def describe(self) -> str:
        single = self.items if self.storage_bytes is None else min(self.items, (
            self.storage_bytes - ARDUPILOT_HEADER_BYTES - ARDUPILOT_END_BYTES - ARDUPILOT_POLYGON_BYTES)
            // ARDUPILOT_VERTEX_BYTES)
        return f"fence storage ({self.name}: {single} vertices in one polygon, fewer in several)"


@dataclass(frozen=True)
class Fence:
    """Closed rings of (lat, lon): the vehicle stays inside every `inclusion` ring and outside
    every `exclusion` ring."""

    inclusion: list[Ring]
    exclusion: list[Ring]

    @property
    def vertices(self) -> int:
        """Fence items the rings make on the wire (one per vertex, the closing one not repeated)."""
        return sum(len(r) - 1 for r in self.inclusion + self.exclusion)


def _lat_lon(ring) -> Ring:
    return [(float(lat), float(lon)) for lon, lat in ring.coords]


def uav_fence(area_lonlat: BaseGeometry, no_fly_lonlat: Sequence[BaseGeometry],
              corridor_lonlat: Polygon | None = None) -> Fence:
    """The fence of a UAV over `area_lonlat` (a (multi)polygon in lon/lat, as GeoJSON has it);
    with `corridor_lonlat`, the inclusion rings are those of the area joined with it (pockets
    the join closes off are included: they are outside the area, not forbidden)."""
    parts = shapely.get_parts(area_lonlat)
    allowed = parts if corridor_lonlat is None else shapely.get_parts(shapely.union(area_lonlat, corridor_lonlat))
    inclusion = [_lat_lon(p.exterior) for p in allowed]
    holes = [_lat_lon(h) for p in parts for h in p.interiors]
    zones = [_lat_lon(p.exterior) for zone in no_fly_lonlat for p in shapely.get_parts(zone)]
    return Fence(inclusion, holes + zones)

