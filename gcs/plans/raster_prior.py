"""Raster priors read from files: a GeoTIFF (or any raster GDAL reads, through rasterio) or a
`.npy` array placed by the area file (`crs`, `bounds`, `row0`: SAREnv's heatmaps), projected
into the area's local frame and resampled onto its grid with their mass kept
(`planner.priors.raster`). Bad rasters raise `UserError` naming the feature."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyproj

from gcs.errors import UserError
from gcs.plans.area_file import RasterPrior
from planner.georef import Grid, LocalFrame
from planner.priors.raster import mass_on_grid


@dataclass(frozen=True)
class Raster:
    """Mass per pixel (`values[row, col]`, row 0 along the top edge of `transform`), the affine
    `transform` (a, b, c, d, e, f: x = a col + b row + c, y = d col + e row + f) and its CRS."""

    values: np.ndarray
    transform: tuple[float, float, float, float, float, float]
    crs: pyproj.CRS


def read_raster(prior: RasterPrior, where: str) -> Raster:
    """The raster of `prior`; UserError when it cannot be read, has no coordinate system, or holds
    negative or non-finite values."""
    if prior.path.suffix.lower() == ".npy":
        raster = _read_npy(prior, where)
    else:
        raster = _read_gdal(prior, where)
    values = raster.values
    if not np.all(np.isfinite(values)):
        raise UserError(f"{where}: {prior.path} holds values that are not finite numbers")
    if values.size and values.min() < 0:
        raise UserError(f"{where}: {prior.path} holds negative values (least {values.min():g}); a prior is "
                        "probability mass, >= 0")
    if not values.any():
        raise UserError(f"{where}: {prior.path} holds no mass (every value is 0)")
    return raster


def _read_npy(prior: RasterPrior, where: str) -> Raster:
    try:
        values = np.load(prior.path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise UserError(f"{where}: cannot read {prior.path} as a .npy array ({exc})") from None
    if values.ndim != 2 or not np.issubdtype(values.dtype, np.number) or min(values.shape) < 1:
        raise UserError(f"{where}: {prior.path} is not a 2-D array of numbers (shape {values.shape}, {values.dtype})")
    assert prior.bounds is not None and prior.crs is not None
    west, south, east, north = prior.bounds
    rows, cols = values.shape
    values = np.asarray(values, dtype=np.float64)
    if prior.row0 == "south":
        values = values[::-1]
    try:
        crs = pyproj.CRS.from_user_input(prior.crs)
    except pyproj.exceptions.CRSError:
        raise UserError(f"{where}: crs {prior.crs!r} is not a coordinate system PROJ knows") from None
    return Raster(values, ((east - west) / cols, 0.0, west, 0.0, -(north - south) / rows, north), crs)


def _read_gdal(prior: RasterPrior, where: str) -> Raster:
    import rasterio
    from rasterio.errors import RasterioIOError

    try:
        with rasterio.open(prior.path) as dataset:
            band = dataset.read(1, masked=True)
            crs, transform = dataset.crs, dataset.transform
    except RasterioIOError as exc:
        raise UserError(f"{where}: cannot read {prior.path} as a raster ({exc})") from None
    if crs is None:
        raise UserError(f"{where}: {prior.path} has no coordinate system; give the raster one (gdal_edit.py -a_srs)")
    values = np.ma.filled(band.astype(np.float64), 0.0)
    return Raster(values, tuple(transform)[:6], pyproj.CRS.from_user_input(crs.to_wkt()))


#: Pixel corners are projected every this many pixels and interpolated bilinearly between: both
#: projections are smooth, and over 16 pixels of 30 m the interpolation is off by under a
#: millimetre, while projecting every corner of a 660 x 660 raster takes seconds.
PROJECTED_EVERY = 16


def _lattice(n: int) -> np.ndarray:
    return np.unique(np.append(np.arange(0, n + 1, PROJECTED_EVERY), n))


def _interpolate(coarse: np.ndarray, at: np.ndarray, n: int, axis: int) -> np.ndarray:
    """`coarse` known at indices `at` along `axis`, linearly interpolated to every index 0..n."""
    full = np.arange(n + 1)
    k = np.clip(np.searchsorted(at, full, side="right") - 1, 0, len(at) - 2) if len(at) > 1 else np.zeros_like(full)
    if len(at) == 1:
        return np.take(coarse, k, axis=axis)
    w = (full - at[k]) / (at[k + 1] - at[k])
    shape = [1, 1]
    shape[axis] = n + 1
    w = w.reshape(shape)
    return np.take(coarse, k, axis=axis) * (1 - w) + np.take(coarse, k + 1, axis=axis) * w


def raster_corners_m(raster: Raster, frame: LocalFrame) -> tuple[np.ndarray, np.ndarray]:
    """(rows + 1, cols + 1) east and north of the raster's pixel corners in `frame`."""
    rows, cols = raster.values.shape
    a, b, c, d, e, f = raster.transform
    rs, cs = _lattice(rows), _lattice(cols)
    col, row = np.meshgrid(cs.astype(np.float64), rs.astype(np.float64))
    to_local = pyproj.Transformer.from_crs(raster.crs, pyproj.CRS.from_proj4(frame.proj_string), always_xy=True)
    east, north = (np.asarray(v) for v in to_local.transform(a * col + b * row + c, d * col + e * row + f))
    if not (np.all(np.isfinite(east)) and np.all(np.isfinite(north))):
        raise ValueError("the raster's corners do not project into the area's frame (is its coordinate system right?)")
    east = _interpolate(_interpolate(east, cs, cols, 1), rs, rows, 0)
    north = _interpolate(_interpolate(north, cs, cols, 1), rs, rows, 0)
    return east, north


def raster_mass(raster: Raster, frame: LocalFrame, grid: Grid) -> np.ndarray:
    """(nx, ny) mass of `raster` on `grid`, its pixel corners projected into `frame`; the share of
    the raster's mass outside the grid is dropped."""
    east, north = raster_corners_m(raster, frame)
    return mass_on_grid(raster.values, east, north, grid)
