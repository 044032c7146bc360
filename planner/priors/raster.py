"""A raster of probability mass resampled onto the planning grid with its mass kept.

The raster's pixel corners come in local metres (the caller projects them from the raster's
coordinate system: `gcs.plans.raster_prior`); each pixel is split into s x s sub-pixels placed
by bilinear interpolation between its four corners, each carrying 1/s^2 of its mass into the
grid cell holding its centre. The split is area-weighted to 1/s of a pixel at a cell edge, exact
for whole pixels, and keeps every bit of mass that falls inside the grid."""

from __future__ import annotations

import math

import numpy as np

from planner.georef import Grid

#: Most sub-pixels one resampling places (bounds time and memory: about 0.1 s per million).
MAX_SAMPLES = 4_000_000


def subdivision(pixel_m: float, cell_size_m: float, pixels: int, max_samples: int = MAX_SAMPLES) -> int:
    """Sub-pixels per pixel side: four per cell side where pixels are larger than a quarter of a
    cell, fewer where that would place more than `max_samples` sub-pixels; at least 1."""
    wanted = max(1, math.ceil(4.0 * pixel_m / cell_size_m))
    cap = max(1, int(math.sqrt(max_samples / max(pixels, 1))))
    return int(min(wanted, cap, 64))


def mass_on_grid(values: np.ndarray, corners_east_m: np.ndarray, corners_north_m: np.ndarray, grid: Grid,
                 max_samples: int = MAX_SAMPLES) -> np.ndarray:
    """(nx, ny) mass per grid cell of `values` (rows x cols of mass per pixel, >= 0);
    `corners_*_m[i, j]` is the local position of the corner between pixel rows i-1, i and pixel
    columns j-1, j (shape (rows + 1, cols + 1)). Mass falling outside the grid is dropped."""
    values = np.asarray(values, dtype=np.float64)
    rows, cols = values.shape
    if corners_east_m.shape != (rows + 1, cols + 1) or corners_north_m.shape != (rows + 1, cols + 1):
        raise ValueError(f"pixel corners must be {rows + 1}x{cols + 1}, got {corners_east_m.shape}")
    out = np.zeros(grid.cells)
    i, j = np.nonzero(values > 0)
    if len(i) == 0:
        return out.reshape(grid.shape)
    mass = values[i, j]
    e00, n00 = corners_east_m[i, j], corners_north_m[i, j]
    e01, n01 = corners_east_m[i, j + 1], corners_north_m[i, j + 1]
    e10, n10 = corners_east_m[i + 1, j], corners_north_m[i + 1, j]
    e11, n11 = corners_east_m[i + 1, j + 1], corners_north_m[i + 1, j + 1]
    pixel_m = float(np.median(np.hypot(e01 - e00, n01 - n00)))
    s = subdivision(pixel_m, grid.cell_size_m, len(i), max_samples)
    share = mass / (s * s)
    for u in (np.arange(s) + 0.5) / s:  # along the pixel's rows (i)
        for v in (np.arange(s) + 0.5) / s:  # along its columns (j)
            east = (1 - u) * ((1 - v) * e00 + v * e01) + u * ((1 - v) * e10 + v * e11)
            north = (1 - u) * ((1 - v) * n00 + v * n01) + u * ((1 - v) * n10 + v * n11)
            x = np.floor((east - grid.east0_m) / grid.cell_size_m).astype(np.int64)
            y = np.floor((north - grid.north0_m) / grid.cell_size_m).astype(np.int64)
            inside = (x >= 0) & (x < grid.nx) & (y >= 0) & (y < grid.ny)
            out += np.bincount(x[inside] * grid.ny + y[inside], weights=share[inside], minlength=grid.cells)
    return out.reshape(grid.shape)
