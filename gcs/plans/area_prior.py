"""The mass prior of an area file: its raster priors, resampled onto the grid, mixed by their
weights and kept on the searchable cells (`planner.priors`). None when the file gives none: the
area is then searched from its `prior` polygons over the default TEP and EU."""

from __future__ import annotations

import numpy as np

from gcs.plans.area_file import AreaFile
from gcs.plans.raster_prior import raster_mass, read_raster
from planner.area_grid import AreaGrid
from planner.priors import MassPrior, searchable_mass


def area_mass_prior(source: AreaFile, area: AreaGrid) -> MassPrior | None:
    """The mixture of the file's mass priors on `area`'s searchable cells, each source counted
    as a whole (mass off the grid included) before it is weighted; None without any."""
    parts: list[tuple[np.ndarray, float]] = []
    for raster_prior in source.rasters:
        raster = read_raster(raster_prior, f"{source.name}: raster_prior {raster_prior.name!r}")
        parts.append((raster_mass(raster, area.frame, area.grid) / float(raster.values.sum()), raster_prior.weight))
    if not parts:
        return None
    total_weight = sum(w for _, w in parts)
    mixed = sum(w * m for m, w in parts) / total_weight
    return searchable_mass(mixed, 1.0, area.free)
