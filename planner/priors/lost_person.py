"""Lost-person priors: where a subject is found, from the initial planning point (IPP), the
subject's category and the terrain (Koester, Lost Person Behavior, 2008: the ISRID distance
statistics), weighted by the features subjects are found near, and scaled by the team's segment
POAs (docs/areas.md#lost-person-priors).

Distances: the table gives the radii within which 25, 50, 75 and 95 % of the subjects of a
category were found. A log-normal distance distribution is fitted to them by least squares in
log space (ln r_p = mu + sigma z_p, z_p the standard normal quantiles of p), as SAREnv does
(`sarenv/core/generation.py`), and spread over the plane as a ring-area density,
pdf(r) / (2 pi r) per square metre, so that the mass within r of the IPP is the fitted CDF."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.georef import Grid

#: Standard normal quantiles of 25, 50, 75 and 95 %.
QUANTILE_Z = (-0.6744897501960817, 0.0, 0.6744897501960817, 1.6448536269514722)
QUANTILES = (0.25, 0.50, 0.75, 0.95)

#: (subject, terrain, climate) -> km within which 25 / 50 / 75 / 95 % of subjects were found.
#: Koester 2008 (ISRID), hiker, as SAREnv's `sarenv/utils/lost_person_behavior.py` tabulates it
#: (the only rows checked against a published source here; docs/areas.md).
DISTANCE_KM: dict[tuple[str, str, str], tuple[float, float, float, float]] = {
    ("hiker", "flat", "temperate"): (0.6, 1.8, 3.2, 9.9),
    ("hiker", "flat", "dry"): (1.3, 2.1, 6.6, 13.1),
    ("hiker", "mountainous", "temperate"): (1.1, 3.1, 5.8, 18.3),
    ("hiker", "mountainous", "dry"): (1.6, 3.2, 6.5, 19.3),
}

#: Share of subjects found on or near each kind of feature (Koester 2008's find locations, as
#: SAREnv's FEATURE_PROBABILITIES tabulates them; they sum to 1.01 there).
FIND_LOCATION: dict[str, float] = {
    "linear": 0.25, "field": 0.14, "structure": 0.13, "road": 0.13, "drainage": 0.12, "water": 0.08,
    "brush": 0.02, "scrub": 0.03, "woodland": 0.07, "rock": 0.04,
}

#: The words a search manager uses for a feature, as the kind of FIND_LOCATION it counts as.
FEATURE_KINDS: dict[str, str] = {
    **{kind: kind for kind in FIND_LOCATION},
    "trail": "linear", "path": "linear", "track": "linear", "railway": "linear", "powerline": "linear",
    "stream": "drainage", "river": "drainage", "ditch": "drainage", "lake": "water", "pond": "water",
    "meadow": "field", "forest": "woodland", "wood": "woodland", "building": "structure", "hut": "structure",
    "shrub": "scrub", "boulder": "rock",
}

#: A cell is near a feature when its centre is within this many metres of it plus half a cell
#: (SAREnv buffers features by 15 m).
NEAR_M = 15.0


def subjects() -> list[str]:
    return sorted({s for s, _, _ in DISTANCE_KM})


def terrains(subject: str) -> list[str]:
    return sorted({t for s, t, _ in DISTANCE_KM if s == subject})


def climates(subject: str, terrain: str) -> list[str]:
    return sorted({c for s, t, c in DISTANCE_KM if s == subject and t == terrain})


@dataclass(frozen=True)
class DistanceFit:
    """A log-normal distance from the IPP: ln(r / km) ~ N(mu, sigma^2)."""

    mu: float
    sigma: float

    def quantile_km(self, p_z: float) -> float:
        """The radius at standard normal quantile `p_z` (e.g. 0 for the median)."""
        return math.exp(self.mu + self.sigma * p_z)

    def cdf(self, r_km: float) -> float:
        """The share of subjects found within `r_km`."""
        if r_km <= 0:
            return 0.0
        return 0.5 * (1.0 + math.erf((math.log(r_km) - self.mu) / (self.sigma * math.sqrt(2.0))))

    def density_per_m2(self, r_m: np.ndarray) -> np.ndarray:
        """The ring-area density pdf(r) / (2 pi r) per square metre at `r_m` metres."""
        r_km = np.maximum(np.asarray(r_m, dtype=np.float64), 1e-9) / 1000.0
        pdf_per_km = np.exp(-((np.log(r_km) - self.mu) ** 2) / (2 * self.sigma**2)) / (
            r_km * self.sigma * math.sqrt(2 * math.pi))
        return pdf_per_km / 1000.0 / (2 * math.pi * r_km * 1000.0)


def fit_quartiles(radii_km: tuple[float, float, float, float]) -> DistanceFit:
    """The least-squares log-normal through the 25/50/75/95 % radii (in log space)."""
    z = np.array(QUANTILE_Z)
    a = np.column_stack([np.ones(4), z])
    (mu, sigma), *_ = np.linalg.lstsq(a, np.log(np.asarray(radii_km, dtype=np.float64)), rcond=None)
    return DistanceFit(float(mu), abs(float(sigma)))


def distance_mass(grid: Grid, ipp_m: tuple[float, float], fit: DistanceFit, samples: int = 5) -> np.ndarray:
    """(nx, ny) mass of `fit` around the IPP (local metres): the ring-area density integrated
    over each cell at samples x samples points (the whole plane holds 1; the grid what it covers)."""
    east, north = grid.centres_m()
    out = np.zeros(grid.shape)
    offsets = ((np.arange(samples) + 0.5) / samples - 0.5) * grid.cell_size_m
    for de in offsets:
        for dn in offsets:
            out += fit.density_per_m2(np.hypot(east + de - ipp_m[0], north + dn - ipp_m[1]))
    return out * (grid.cell_size_m / samples) ** 2


def feature_weighted(mass: np.ndarray, near: dict[str, np.ndarray]) -> np.ndarray:
    """`mass` (a distance prior over the grid) re-weighted by where subjects are found: for each
    kind k of FIND_LOCATION drawn, `near[k]` the cells near one, a share p_k of the mass goes to
    those cells (spread as `mass` is over them); the rest, 1 - sum p_k, stays spread as `mass`.
    Shares that sum above 1 are scaled down to 1. A kind near no cell with mass adds nothing."""
    total = float(mass.sum())
    shares = {k: FIND_LOCATION[k] for k, cells in near.items() if float(mass[cells].sum()) > 0}
    scale = max(1.0, sum(shares.values()))
    out = mass * (1.0 - sum(shares.values()) / scale)
    for kind, share in shares.items():
        inside = np.where(near[kind], mass, 0.0)
        out = out + inside * (total * share / scale / float(inside.sum()))
    return out


def segment_scaled(mass: np.ndarray, segments: list[tuple[np.ndarray, float]], searchable: np.ndarray) -> np.ndarray:
    """`mass` with each segment's cells (`(cells, poa)`, POAs summing to 1; a later segment
    wins where they overlap) holding its POA: spread as `mass` is over it, or evenly over its
    searchable cells where `mass` has none there. Cells outside every segment hold nothing."""
    owner = np.full(mass.shape, -1)
    for k, (cells, _) in enumerate(segments):
        owner[cells & searchable] = k
    out = np.zeros(mass.shape)
    for k, (_, poa) in enumerate(segments):
        mine = owner == k
        if not mine.any():
            continue
        part = np.where(mine, mass, 0.0)
        s = float(part.sum())
        out += part * (poa / s) if s > 0 else mine * (poa / float(mine.sum()))
    return out
