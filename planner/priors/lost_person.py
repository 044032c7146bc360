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

def _whole_ecoregion(subject: str, climate: str, km: tuple[float, float, float, float]
                     ) -> dict[tuple[str, str, str], tuple[float, float, float, float]]:
    """One row of the book's for a whole ecoregion, as the table's rows of both terrains."""
    return {(subject, terrain, climate): km for terrain in ("flat", "mountainous")}


def _urban(subject: str, km: tuple[float, float, float, float]
           ) -> dict[tuple[str, str, str], tuple[float, float, float, float]]:
    """One row of the book's urban ecoregion (towns, in any climate), as the table's `urban`
    terrain in both climates."""
    return {(subject, "urban", climate): km for climate in ("temperate", "dry")}


#: (subject, terrain, climate) -> km within which 25 / 50 / 75 / 95 % of subjects were found:
#: Koester, Lost Person Behavior (dbS Productions, 2008), the ISRID "distance from the IPP"
#: tables, whose kilometre column is given here. A row is here only when two independent sources
#: agree on it: the kilometre column as transcribed in public code, and the mile column of the
#: same table in IGT4SAR (github.com/dferguso/IGT4SAR, IPP_EuclideanDistance2.py at 18e222b6,
#: "IPP Distances are provided by Robert Koester (dbs Productions - Lost Person Behavior)"), every
#: radius within 0.15 km of miles x 1.609344 (the two columns' rounding). `n` in the comments is
#: the cases behind a row. The book's urban ecoregion (one column, not split by terrain or
#: climate) is the terrain `urban`. Sources per category: docs/areas.md#lost-person-priors.
DISTANCE_KM: dict[tuple[str, str, str], tuple[float, float, float, float]] = {
    # Hiker: as SAREnv's `sarenv/utils/lost_person_behavior.py` tabulates it, and as the km
    # transcriptions and IGT4SAR's miles give it.
    ("hiker", "flat", "temperate"): (0.6, 1.8, 3.2, 9.9),  # n 274
    ("hiker", "flat", "dry"): (1.3, 2.1, 6.6, 13.1),  # n 58
    ("hiker", "mountainous", "temperate"): (1.1, 3.1, 5.8, 18.3),  # n 568
    ("hiker", "mountainous", "dry"): (1.6, 3.2, 6.5, 19.3),  # n 221
    # Dementia: the book's Dementia chapter as github.com/benfirth-parks/lost-person-probability
    # (packages/behaviour/src/lpb.ts at 78103ae7) checked it against the publisher's copy
    # (dbs-sar.com/LPB/Dementia.pdf, pp. 165-166), kilometres and miles; IGT4SAR's miles agree.
    ("dementia", "flat", "temperate"): (0.3, 1.0, 2.4, 12.8),  # n 175
    ("dementia", "flat", "dry"): (0.5, 1.6, 3.6, 11.8),  # n 15
    ("dementia", "mountainous", "temperate"): (0.3, 0.8, 1.9, 8.3),  # n 95
    ("dementia", "mountainous", "dry"): (1.0, 1.9, 3.1, 6.1),  # n 14
    # The book's rows for one ecoregion and terrain: the km transcriptions, IGT4SAR's miles.
    ("angler", "mountainous", "temperate"): (0.3, 1.5, 5.5, 9.9),  # n 25
    ("atv", "mountainous", "temperate"): (1.6, 3.2, 5.6, 8.0),  # n 19
    ("camper", "flat", "temperate"): (0.2, 1.1, 3.2, 12.8),  # n 18
    ("child 1-3", "flat", "temperate"): (0.2, 0.3, 1.0, 3.2),  # n 61
    ("child 4-6", "flat", "temperate"): (0.2, 0.6, 1.5, 6.6),  # n 90
    ("child 4-6", "mountainous", "temperate"): (0.2, 0.8, 1.5, 3.7),  # n 38
    ("child 7-9", "flat", "temperate"): (0.2, 0.8, 2.0, 8.0),  # n 79
    ("child 7-9", "mountainous", "temperate"): (0.8, 1.6, 3.2, 11.3),  # n 38
    ("child 7-9", "mountainous", "dry"): (0.4, 1.2, 3.2, 7.2),  # n 18
    ("child 10-12", "flat", "temperate"): (0.4, 1.6, 4.8, 10.0),  # n 57
    ("child 10-12", "mountainous", "temperate"): (0.8, 1.6, 3.2, 9.0),  # n 72
    ("child 10-12", "mountainous", "dry"): (0.8, 2.0, 7.2, 16.1),  # n 22
    ("child 13-15", "flat", "temperate"): (0.6, 1.3, 3.2, 10.0),  # n 80
    ("child 13-15", "mountainous", "temperate"): (0.8, 2.1, 4.8, 21.4),  # n 74
    ("child 13-15", "mountainous", "dry"): (2.4, 3.2, 4.8, 11.9),  # n 19
    ("despondent", "flat", "temperate"): (0.3, 0.8, 2.3, 17.3),  # n 193
    ("despondent", "flat", "dry"): (0.5, 1.9, 3.7, 20.7),  # n 14
    ("despondent", "mountainous", "dry"): (0.8, 1.6, 3.4, 18.0),  # n 20
    ("gatherer", "mountainous", "temperate"): (1.5, 3.2, 6.4, 12.9),  # n 94
    ("hunter", "flat", "temperate"): (0.6, 1.6, 3.1, 13.7),  # n 465
    ("hunter", "flat", "dry"): (1.6, 3.1, 6.4, 11.3),  # n 40
    ("hunter", "mountainous", "temperate"): (1.0, 2.1, 4.8, 17.2),  # n 355
    ("hunter", "mountainous", "dry"): (2.1, 4.8, 8.1, 22.2),  # n 138
    ("intellectual disability", "flat", "temperate"): (0.3, 1.0, 2.1, 11.8),  # n 36
    ("intellectual disability", "mountainous", "temperate"): (0.6, 1.6, 3.2, 11.3),  # n 31
    ("mental illness", "flat", "temperate"): (0.8, 1.0, 2.3, 8.1),  # n 23
    ("mental illness", "mountainous", "temperate"): (0.6, 2.3, 8.3, 14.6),  # n 23
    ("mountain biker", "mountainous", "temperate"): (3.1, 4.0, 11.3, 25.0),  # n 25
    ("skier-alpine", "mountainous", "temperate"): (1.1, 2.7, 4.8, 15.2),  # n 16
    ("skier-nordic", "mountainous", "temperate"): (1.6, 3.5, 6.4, 19.6),  # n 29
    ("skier-nordic", "mountainous", "dry"): (1.9, 4.3, 6.4, 19.5),  # n 41
    ("snowboarder", "mountainous", "temperate"): (1.6, 3.2, 6.2, 15.4),  # n 31
    ("snowmobiler", "flat", "temperate"): (1.3, 4.7, 41.1, 96.1),  # n 14 (one km transcription: the other has miles)
    ("snowmobiler", "mountainous", "temperate"): (3.2, 6.4, 11.1, 16.1),  # n 26
    # The book's rows for a whole ecoregion, not split by terrain (as both sources give them): the
    # one figure stands for its flat and its mountainous terrain alike.
    **_whole_ecoregion("autistic", "temperate", (0.6, 1.6, 3.7, 15.2)),  # n 20, temperate
    **_whole_ecoregion("child 1-3", "dry", (0.6, 1.3, 3.9, 9.0)),  # n 13, dry
    **_whole_ecoregion("child 4-6", "dry", (0.6, 1.9, 3.2, 8.2)),  # n 19, dry
    **_whole_ecoregion("climber", "temperate", (0.2, 1.6, 3.2, 14.7)),  # n 25, temperate
    **_whole_ecoregion("gatherer", "dry", (1.6, 2.6, 5.8, 11.1)),  # n 14, dry
    **_whole_ecoregion("intellectual disability", "dry", (1.1, 4.0, 8.7, 62.6)),  # n 21, dry
    **_whole_ecoregion("runner", "temperate", (1.4, 2.6, 3.4, 5.8)),  # n 14, temperate
    # The book's urban ecoregion: K2's kilometres (K1's too but for child 1-3, where K1 has the
    # miles), D's for dementia, and M's miles agree (child 10-12's too, but it is not log-normal).
    **_urban("autistic", (0.3, 1.0, 3.8, 8.0)),  # n 16
    **_urban("child 1-3", (0.2, 0.5, 0.8, 1.1)),  # n 17
    **_urban("child 4-6", (0.1, 0.5, 1.0, 3.4)),  # n 25
    **_urban("child 7-9", (0.2, 0.5, 1.5, 5.2)),  # n 22
    **_urban("dementia", (0.3, 1.1, 3.2, 12.6)),  # n 336
    **_urban("despondent", (0.1, 0.5, 1.5, 13.1)),  # n 96
    **_urban("intellectual disability", (0.3, 0.8, 3.7, 9.9)),  # n 44
    **_urban("mental illness", (0.3, 0.6, 1.5, 12.5)),  # n 38
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
