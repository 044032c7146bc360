"""The search team's figures per segment for a plan or a flight (`planner.search_theory`): POA
before, the POD the sortie gives, the campaign's cumulative POD, POS = POA x POD and the POAs
shifted after an unsuccessful sortie, over named blocks of the grid (A1 north-west; the area
file's segments once it has them). In plan.json / sortie.json (`search_theory`), as polygons with
those figures in `segments.geojson` and `segments.kml`, and in the printed summaries."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import box, mapping

from gcs.plans.area_file import AreaFile
from planner.area_grid import AreaGrid
from planner.campaign import look_counts
from planner.rasterise import cells_inside
from planner.search_theory import SearchTheory, Segment, block_segments, search_theory

if TYPE_CHECKING:
    from gcs.plans.planning import AreaSetup
    from planner.plan import Plan

#: The name of the searchable cells no segment of the area file covers.
REST = "rest of the area"

#: The figures a segment's map feature carries, in per cent (attribute name -> SegmentFigures field).
MAP_FIELDS = {"poa_pct": "poa", "pod_pct": "pod", "pos_pct": "pos", "cumulative_pod_pct": "cumulative_pod",
              "poa_after_pct": "poa_after"}


def area_segments(area: AreaGrid, source: AreaFile | None = None) -> list[Segment]:
    """The segments of an area: the area file's own (`segment` features: their searchable cells,
    and `REST` for searchable cells none of them covers), else named blocks of its grid."""
    if source is None or not source.segments:
        return block_segments(area.free)
    out, covered = [], np.zeros(area.grid.shape, dtype=bool)
    for seg in source.segments:
        cells = cells_inside(area.to_local(seg.geometry), area.grid) & area.free & ~covered
        covered |= cells
        out.append(Segment(seg.name, cells))
    rest = area.free & ~covered
    if rest.any():
        out.append(Segment(REST, rest))
    return out


def plan_theory(setup: AreaSetup, plan: Plan, segments: list[Segment]) -> SearchTheory:
    """The figures of an area plan: its readings (every cell flown, each airport at step 0, the
    footprint's cells) after the campaign's earlier sorties, over its first prior."""
    belief, sensor = setup.belief, setup.search.scenario.sensor
    assert belief is not None
    inside = setup.prior_mass.inside if setup.prior_mass is not None else 1.0
    return theory_of_looks(belief.p0, belief.searchable, sensor.pc, look_counts(plan, sensor.footprint_radius),
                           segments, belief.looks_before, inside)


def theory_of_looks(p0: np.ndarray, searchable: np.ndarray, pc: float, looks: np.ndarray, segments: list[Segment],
                    looks_before: np.ndarray, inside: float = 1.0) -> SearchTheory:
    """`planner.search_theory.search_theory` of one sortie's readings per cell."""
    return search_theory(p0, searchable, pc, looks, segments, looks_before=looks_before, inside=inside)


def segment_polygon_lonlat(area: AreaGrid, segment: Segment, source: AreaFile | None = None) -> dict | None:
    """A segment's outline as a GeoJSON Polygon (lon, lat): the area file's polygon, or a block
    of the grid clipped to the area; None for `REST`."""
    drawn = {seg.name: seg.geometry for seg in source.segments} if source is not None else {}
    if segment.name in drawn:
        return mapping(drawn[segment.name])  # type: ignore[no-any-return]
    if segment.block is None:
        return None
    x0, y0, x1, y1 = segment.block
    g = area.grid
    square = box(g.east0_m + x0 * g.cell_size_m, g.north0_m + y0 * g.cell_size_m,
                 g.east0_m + x1 * g.cell_size_m, g.north0_m + y1 * g.cell_size_m)
    return mapping(area.to_lonlat(square.intersection(area.area_m)))  # type: ignore[no-any-return]


def segments_geojson(area: AreaGrid, segments: list[Segment], theory: SearchTheory, name: str,
                     source: AreaFile | None = None) -> dict:
    """A FeatureCollection of the segments (polygons clipped to the area) with their figures in
    per cent and a one-line description a map's balloon shows."""
    features = []
    for seg, fig in zip(segments, theory.segments):
        geometry = segment_polygon_lonlat(area, seg, source)
        props: dict[str, object] = {"segment": fig.name, "cells": fig.cells}
        props.update({key: round(100 * getattr(fig, field), 2) for key, field in MAP_FIELDS.items()})
        props["description"] = (f"POA {fig.poa:.1%}, POD {fig.pod:.1%}, POS {fig.pos:.1%}, cumulative POD "
                                f"{fig.cumulative_pod:.1%}; POA after an unsuccessful sortie {fig.poa_after:.1%}")
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return {"type": "FeatureCollection", "name": f"{name}: segments", "features": features}


def segments_for_teams(collection: dict, name: str) -> dict[str, str]:
    """segments.geojson and segments.kml (Google Earth, CalTopo, QGIS: a polygon per segment
    shaded by its POA, the figures as ExtendedData)."""
    import json

    from gcs.missions.kml import kml_text

    names = [f"{f['properties']['segment']} POA {f['properties']['poa_pct']:.1f}% POD {f['properties']['pod_pct']:.1f}%"
             for f in collection["features"]]
    return {"segments.geojson": json.dumps(collection, indent=1) + "\n",
            "segments.kml": kml_text(collection, "segments", names, f"{name}: segments, POA / POD / POS", "Polygon")}
