"""The mass prior of an area file (`planner.priors`): its raster priors, resampled onto the grid,
and its IPPs' lost-person distance priors, mixed by their weights; then weighted by the places
subjects are found near (`feature`s), kept on the searchable cells, and scaled by the segments'
POAs. None when the file gives none of these: the area is then searched from its `prior`
polygons over the default TEP and EU."""

from __future__ import annotations

import numpy as np

from gcs.errors import UserError
from gcs.plans.area_file import AreaFile
from gcs.plans.raster_prior import raster_mass, read_raster
from planner.area_grid import AreaGrid
from planner.priors import MassPrior, searchable_mass
from planner.priors.lost_person import (
    DISTANCE_KM,
    NEAR_M,
    distance_mass,
    feature_weighted,
    fit_quartiles,
    segment_scaled,
)
from planner.rasterise import cells_inside


def area_mass_prior(source: AreaFile, area: AreaGrid) -> MassPrior | None:
    """The file's mass prior on `area`'s searchable cells; each source is counted as a whole (mass
    off the grid included) before it is weighted. None without rasters, IPPs or segments."""
    parts: list[tuple[np.ndarray, float]] = []
    for raster_prior in source.rasters:
        raster = read_raster(raster_prior, f"{source.name}: raster_prior {raster_prior.name!r}")
        parts.append((raster_mass(raster, area.frame, area.grid) / float(raster.values.sum()), raster_prior.weight))
    for ipp in source.ipps:
        fit = fit_quartiles(DISTANCE_KM[(ipp.subject, ipp.terrain, ipp.climate)])
        parts.append((distance_mass(area.grid, area.point_m(ipp.lon_deg, ipp.lat_deg), fit), ipp.weight))
    if parts:
        total_weight = sum(w for _, w in parts)
        mixed = sum(w * m for m, w in parts) / total_weight
    elif source.segments:
        mixed = area.free / float(area.free.sum())
    else:
        return None
    if source.features:
        near: dict[str, np.ndarray] = {}
        reach = NEAR_M + 0.5 * area.grid.cell_size_m
        for place in source.features:
            cells = cells_inside(area.to_local(place.geometry).buffer(reach), area.grid)
            near[place.kind] = near.get(place.kind, np.zeros(area.grid.shape, dtype=bool)) | cells
        on_grid = float(mixed.sum())
        mixed = feature_weighted(mixed, near) if on_grid > 0 else mixed
    prior = searchable_mass(mixed, 1.0, area.free)
    if not source.segments:
        return prior
    segments = []
    for seg in source.segments:
        cells = cells_inside(area.to_local(seg.geometry), area.grid) & area.free
        if seg.poa > 0 and not cells.any():
            raise UserError(f"{source.name}: segment {seg.name!r} (POA {100 * seg.poa:g}%) covers no searchable cell")
        segments.append((cells, seg.poa))
    scaled = segment_scaled(prior.mass, segments, area.free)
    return MassPrior(scaled / float(scaled.sum()), prior.inside)
