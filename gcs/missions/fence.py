"""The geofence a UAV is given (its QGroundControl `.plan`'s `geoFence`, which `gcs fly` and
`gcs upload` send to the vehicle): inclusion rings, the area's outer rings, one of them joined
with a plane's landing corridor (a runway at the area's edge is landed on from outside it); and
exclusion rings, the area's holes and the no-fly zones' outlines. Rings are lists of (lat, lon).

ArduPilot (unless FENCE_OPTIONS bit 1 is set) and PX4 keep a vehicle inside every inclusion
polygon at once, so the corridor is merged into the area's ring, never sent as a polygon of its
own; and their fence storage is small (ArduPlane 83 vertices, ArduCopter 69, PX4 64 fence items,
all polygons together), so the corridor adds only the few vertices where it leaves the area."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

Ring = list[tuple[float, float]]


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
