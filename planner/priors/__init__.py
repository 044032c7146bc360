"""Priors as probability mass per grid cell, and the TEP/EU maps the planner searches from them.

A raster (`planner.priors.raster`) or a lost person's distance statistics
(`planner.priors.lost_person`) give each cell the probability that the subject is in it. The
planner's reward reads TEP and EU as beliefs in [0, 1] beside terms of a fixed size (eq. 7), so
the mass is scaled to a peak TEP (`tep_of_mass`): the shape is kept below the top 1 % of cells,
and the probability of success, E / the mass in the area, is computed from the TEP map the
planner searches."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The TEP (and EU) of the most likely cells of a mass prior: the paper's key regions' 0.9. Below 1,
#: where a cell's TEP could never fall after a look that sees nothing (eq. 3).
PEAK_TEP = 0.9

#: The share of the cells with mass that lie below the one scaled to PEAK_TEP: the cells above it
#: are held at the peak. A few cells holding much of the mass (a hut where 13 % of subjects are
#: found) would otherwise scale every other cell to near nothing beside the reward's other terms.
PEAK_QUANTILE = 0.99


def tep_of_mass(mass: np.ndarray, peak: float = PEAK_TEP, quantile: float = PEAK_QUANTILE) -> np.ndarray:
    """TEP per cell: `mass` scaled so that its `quantile` cell (among those with mass) is `peak`,
    the cells above it held at `peak`; zeros where it has none."""
    mass = np.asarray(mass, dtype=np.float64)
    positive = mass[mass > 0]
    if positive.size == 0:
        return np.zeros(mass.shape)
    return np.clip(mass * (peak / float(np.quantile(positive, quantile))), 0.0, peak)


def mixture(masses: list[np.ndarray], weights: list[float]) -> np.ndarray:
    """The weighted mean of several mass maps, each first normalised to 1 (a map with no mass
    adds nothing)."""
    out = np.zeros(np.shape(masses[0]))
    total = 0.0
    for mass, weight in zip(masses, weights):
        s = float(np.sum(mass))
        if s > 0:
            out += weight * np.asarray(mass) / s
            total += weight
    return out / total if total > 0 else out


@dataclass(frozen=True)
class MassPrior:
    """The probability that the subject is in each cell: `mass` sums to 1 over the searchable
    cells (0 elsewhere); `inside` is the share of the sources' mass that fell on them (the rest is
    outside the area, in no-fly zones or off the grid: the search's "rest of the world")."""

    mass: np.ndarray
    inside: float

    @property
    def tep(self) -> np.ndarray:
        return tep_of_mass(self.mass)


def searchable_mass(mass: np.ndarray, total: float, searchable: np.ndarray) -> MassPrior:
    """`mass` (of `total` in all, some of it perhaps off the grid) kept on the searchable cells
    and normalised there. ValueError when none of it falls on them."""
    kept = np.where(searchable, np.asarray(mass, dtype=np.float64), 0.0)
    s = float(kept.sum())
    if s <= 0:
        raise ValueError("the prior puts no mass on a searchable cell (is it placed over the area?)")
    return MassPrior(kept / s, s / total if total > 0 else 0.0)
