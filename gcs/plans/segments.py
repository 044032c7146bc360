"""The search team's figures per segment for a plan or a flight (`planner.search_theory`): POA
before, the POD the sortie gives, the campaign's cumulative POD, POS = POA x POD and the POAs
shifted after an unsuccessful sortie, over the area file's own segments when it has them, else
named blocks of the grid (A1 north-west). In plan.json / sortie.json (`search_theory`, whose
`segments_from` says which), as polygons with those figures in `segments.geojson` and
`segments.kml`, in the printed summaries, and outlined and labelled in the plan's picture. A
flight reports over the segments its plan did (`plan_folder_segments`: the plan folder's
`segments.geojson` laid again on the plan's grid)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.errors import ShapelyError
from shapely.geometry import box, mapping, shape
from shapely.geometry.base import BaseGeometry

from gcs.plans.area_file import REST, AreaFile  # REST: the cells no segment covers (no segment may take the name)
from planner.area_grid import AreaGrid
from planner.campaign import look_counts
from planner.georef import Grid
from planner.rasterise import cells_inside
from planner.search_theory import SearchTheory, Segment, block_segments, search_theory

if TYPE_CHECKING:
    from gcs.plans.plan_folder import FleetPlan
    from gcs.plans.planning import AreaSetup
    from planner.plan import Plan

#: `search_theory.segments_from` in plan.json and sortie.json: the area file's segments, or the grid's blocks.
FROM_AREA_FILE, FROM_GRID = "area file", "grid blocks"
SEGMENTS_FILE = "segments.geojson"

#: The figures a segment's map feature carries, in per cent (attribute name -> SegmentFigures field).
MAP_FIELDS = {"poa_pct": "poa", "pod_pct": "pod", "pos_pct": "pos", "cumulative_pod_pct": "cumulative_pod",
              "poa_after_pct": "poa_after"}


def area_segments(area: AreaGrid, source: AreaFile | None = None) -> list[Segment]:
    """The segments of an area: the area file's own (`segment` features: their searchable cells,
    and `REST` for searchable cells none of them covers), else named blocks of its grid."""
    if source is None or not source.segments:
        return block_segments(area.free)
    return drawn_segments([(seg.name, area.to_local(seg.geometry)) for seg in source.segments], area.grid, area.free)


def segments_from(source: AreaFile | None) -> str:
    """Where `area_segments` takes an area's segments from: `FROM_AREA_FILE` or `FROM_GRID`."""
    return FROM_AREA_FILE if source is not None and source.segments else FROM_GRID


def drawn_segments(polygons_m: Sequence[tuple[str, BaseGeometry]], grid: Grid, free: np.ndarray) -> list[Segment]:
    """Named polygons (local metres) as segments of `grid`: each the free cells whose centre it
    holds and no earlier polygon took, then `REST` for the free cells none holds."""
    out, covered = [], np.zeros(grid.shape, dtype=bool)
    for name, polygon_m in polygons_m:
        cells = cells_inside(polygon_m, grid) & free & ~covered
        covered |= cells
        out.append(Segment(name, cells))
    rest = free & ~covered
    if rest.any():
        out.append(Segment(REST, rest))
    return out


def plan_folder_segments(plan: FleetPlan, searchable: np.ndarray) -> list[Segment]:
    """The segments `plan`'s figures were reported over (plan.json's `search_theory`): the area
    file's, read back from the folder's `segments.geojson` and laid on the plan's grid as
    `area_segments` laid them, else the grid's blocks. ValueError when segments.geojson is missing
    or no longer gives the plan's segments (their names and cells)."""
    theory = plan.raw.get("search_theory") or {}
    if theory.get("segments_from") != FROM_AREA_FILE:
        return block_segments(searchable)
    path = Path(plan.folder) / SEGMENTS_FILE
    to_local = plan.frame.lonlat2local_coords
    try:
        features = json.loads(path.read_text(encoding="utf-8"))["features"]
        polygons = [(str(f["properties"]["segment"]), shapely.transform(shape(f["geometry"]), to_local))
                    for f in features if f.get("geometry") is not None]
        segments = drawn_segments(polygons, plan.grid, searchable)
    except (OSError, ValueError, KeyError, TypeError, AttributeError, ShapelyError) as exc:
        # an edited file: a geometry type shapely does not know (GeometryTypeError), one GEOS cannot use, ...
        raise ValueError(f"{SEGMENTS_FILE} is not readable ({type(exc).__name__}: {exc})") from None
    planned = [(s.get("name"), s.get("cells")) for s in theory.get("segments", [])]
    if [(s.name, int(s.cells.sum())) for s in segments] != planned:
        raise ValueError(f"{SEGMENTS_FILE} no longer gives plan.json's segments (changed since the plan?)")
    return segments


def plan_theory(setup: AreaSetup, plan: Plan, segments: list[Segment]) -> SearchTheory:
    """The figures of an area plan: its readings (every cell flown, each airport at step 0, the
    footprint's cells) after the campaign's earlier sorties, over its first prior."""
    belief, sensor = setup.belief, setup.search.scenario.sensor
    assert belief is not None
    inside = setup.prior_mass.inside if setup.prior_mass is not None else 1.0
    return theory_of_looks(belief.p0, belief.searchable, sensor.pc, look_counts(plan, sensor.footprint_radius),
                           segments, belief.looks_before, inside)


@dataclass
class SortieSegments:
    """An area sortie's segments (`area_segments`), known before its plan is (the picture's map
    outlines them), and `figures`, the plan's figures over them as plan.json reports them
    (`plan_theory`): what plan.json, the plan's picture and its recording give, reckoned once."""

    setup: AreaSetup
    segments: list[Segment]
    _figures: tuple[Plan, SearchTheory] | None = field(default=None, repr=False)

    def figures(self, plan: Plan) -> SearchTheory:
        if self._figures is None or self._figures[0] is not plan:
            self._figures = (plan, plan_theory(self.setup, plan, self.segments))
        return self._figures[1]


def sortie_segments(setup: AreaSetup) -> SortieSegments:
    """The segments of `setup`'s sortie (`area_segments` of its area and area file)."""
    return SortieSegments(setup, area_segments(setup.area, setup.source))


def theory_of_looks(p0: np.ndarray, searchable: np.ndarray, pc: float, looks: np.ndarray, segments: list[Segment],
                    looks_before: np.ndarray, inside: float = 1.0) -> SearchTheory:
    """`planner.search_theory.search_theory` of one sortie's readings per cell."""
    return search_theory(p0, searchable, pc, looks, segments, looks_before=looks_before, inside=inside)


def segment_polygon_lonlat(area: AreaGrid, segment: Segment, drawn: BaseGeometry | None = None) -> dict | None:
    """A segment's outline as a GeoJSON Polygon (lon, lat): `drawn`, the area file's polygon it
    was laid from, when given; else its block of the grid clipped to the area; None for `REST`."""
    if drawn is not None:
        return mapping(drawn)  # type: ignore[no-any-return]
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
    per cent and a one-line description a map's balloon shows. `segments` are `area_segments`'
    of `source`: the area file's k-th segment is the k-th, paired by place, not by name."""
    features = []
    drawn = [seg.geometry for seg in source.segments] if source is not None and source.segments else []
    for k, (seg, fig) in enumerate(zip(segments, theory.segments)):
        geometry = segment_polygon_lonlat(area, seg, drawn[k] if k < len(drawn) else None)
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
