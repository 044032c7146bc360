"""Search theory's figures per segment, as a search manager reads them: the probability of area
(POA), the probability of detection a sortie gives it (POD), the cumulative POD of the campaign,
the probability of success (POS = POA x POD) and the POAs shifted after an unsuccessful sortie.

They come from the same model as `planner.success`: the campaign's first prior P0 per cell
(normalised, a share of the subject), a look at a cell holding the subject detects it with
probability Pc, looks independent. For a segment S, with n(c) this sortie's looks and b(c) the
earlier sorties':

    POA before  = sum_S p(c)                     p(c) = P0(c) (1 - Pc)^b(c) / sum_area P0 (1 - Pc)^b
    POD         = 1 - sum_S p(c) (1 - Pc)^n(c) / POA
    POS         = POA x POD                      (their sum over segments: the sortie's POS)
    cum. POD    = 1 - sum_S P0(c) (1 - Pc)^(b(c) + n(c)) / sum_S P0(c)
    POA after   = POA (1 - POD) / (1 - sum of POS)      (Bayes: the sortie found no one)

p is the first prior after the earlier sorties found no one (Bayes, cell by cell), so POA before
is the POA after of the sortie before. For a first sortie the sum of POS is `Success.share`.
With `inside` < 1 (part of the subject's probability lies outside the area: the rest of the
world), every POA is scaled by it and the rest of the world keeps the remainder.

Segments are the search team's polygons, as cell masks, or else `block_segments`: square
blocks of the grid named like a map's squares (A1 north-west, letters west to east, numbers
north to south)."""

from __future__ import annotations

import math
import string
from dataclasses import dataclass

import numpy as np

__all__ = ["Segment", "SegmentFigures", "SearchTheory", "block_segments", "block_side_cells", "looks_per_cell",
           "search_theory"]

#: Blocks per side of the grid's longer axis at most (`block_side_cells`).
MAX_BLOCKS_PER_SIDE = 6


@dataclass(frozen=True)
class Segment:
    """A named segment: the grid cells it holds (`cells[x, y]`); `block` its cell range
    (x0, y0, x1, y1, ends exclusive) when it is a block of the grid."""

    name: str
    cells: np.ndarray
    block: tuple[int, int, int, int] | None = None


@dataclass(frozen=True)
class SegmentFigures:
    """One segment's figures, shares in [0, 1]."""

    name: str
    cells: int
    poa: float
    pod: float
    pos: float
    cumulative_pod: float
    poa_after: float

    def as_dict(self) -> dict[str, float | int | str]:
        return {"name": self.name, "cells": self.cells, "poa": round(self.poa, 6), "pod": round(self.pod, 6),
                "pos": round(self.pos, 6), "cumulative_pod": round(self.cumulative_pod, 6),
                "poa_after": round(self.poa_after, 6)}


@dataclass(frozen=True)
class SearchTheory:
    """Every segment's figures and the sortie's: `pos` the sum of the segments' POS (this
    sortie, given the earlier ones found no one), `cumulative_pos` the campaign's (the first
    prior's share found by all looks so far), `rest_poa` and `rest_poa_after` the rest of the
    world's POA before and after, `inside` the first prior's share inside the area (what a later
    reckoning of the same campaign, a flight's, must count with)."""

    segments: tuple[SegmentFigures, ...]
    pos: float
    cumulative_pos: float
    pc: float
    rest_poa: float = 0.0
    rest_poa_after: float = 0.0
    inside: float = 1.0

    def as_dict(self) -> dict[str, object]:
        return {"pc": self.pc, "pos": round(self.pos, 6), "cumulative_pos": round(self.cumulative_pos, 6),
                "rest_of_world_poa": round(self.rest_poa, 6), "rest_of_world_poa_after": round(self.rest_poa_after, 6),
                "inside_area": self.inside, "segments": [s.as_dict() for s in self.segments]}

    @classmethod
    def from_dict(cls, data: dict[str, object]) -> SearchTheory:
        """The figures `as_dict` wrote (plan.json's and sortie.json's `search_theory`)."""
        segments = data["segments"]
        assert isinstance(segments, list)
        return cls(tuple(SegmentFigures(**s) for s in segments), float(data["pos"]),  # type: ignore[arg-type]
                   float(data["cumulative_pos"]), float(data["pc"]),  # type: ignore[arg-type]
                   float(data.get("rest_of_world_poa", 0.0)), float(data.get("rest_of_world_poa_after", 0.0)),  # type: ignore[arg-type]
                   float(data.get("inside_area", 1.0)))  # type: ignore[arg-type]

    def table(self) -> str:
        """The segments as a search manager's table, then the sortie's POS."""
        w = max([8, *(len(s.name) for s in self.segments)])  # the area file's names may be long
        rows = [f"{'segment':<{w}} {'cells':>5} {'POA':>6} {'POD':>6} {'POS':>6} {'cum POD':>7} {'POA after':>9}"]
        for s in self.segments:
            rows.append(f"{s.name:<{w}} {s.cells:>5} {s.poa:>6.1%} {s.pod:>6.1%} {s.pos:>6.1%} "
                        f"{s.cumulative_pod:>7.1%} {s.poa_after:>9.1%}")
        rest = (f"; rest of the world POA {self.rest_poa:.1%} -> {self.rest_poa_after:.1%}" if self.rest_poa > 0
                else "")
        rows.append(f"POS this sortie {self.pos:.1%} (sum of POA x POD), campaign {self.cumulative_pos:.1%}; "
                    f"POA after assumes this sortie finds no one{rest}")
        return "\n".join(rows)


def block_side_cells(shape: tuple[int, int]) -> int:
    """The side of a block in cells: at most `MAX_BLOCKS_PER_SIDE` blocks along the longer axis."""
    return max(1, math.ceil(max(shape) / MAX_BLOCKS_PER_SIDE))


def _letters(i: int) -> str:
    out = ""
    i += 1
    while i:
        i, r = divmod(i - 1, 26)
        out = string.ascii_uppercase[r] + out
    return out


def block_segments(searchable: np.ndarray, side: int | None = None) -> list[Segment]:
    """Square blocks of `side` cells (default `block_side_cells`) over the grid (`[x, y]`, y
    north), each holding some searchable cell, named by column letter (A west) and row number
    (1 north): A1 is the north-west block."""
    searchable = np.asarray(searchable, dtype=bool)
    nx, ny = searchable.shape
    side = side or block_side_cells((nx, ny))
    if side < 1:
        raise ValueError(f"a block is at least one cell, got {side}")
    rows = math.ceil(ny / side)
    out = []
    for bx in range(math.ceil(nx / side)):
        for row in range(rows):
            y1 = ny - row * side
            y0 = max(0, y1 - side)
            x0, x1 = bx * side, min(nx, (bx + 1) * side)
            mask = np.zeros((nx, ny), dtype=bool)
            mask[x0:x1, y0:y1] = searchable[x0:x1, y0:y1]
            if mask.any():
                out.append(Segment(f"{_letters(bx)}{row + 1}", mask, (x0, y0, x1, y1)))
    return out


def looks_per_cell(rows: list[tuple[int, int, int, int]], shape: tuple[int, int]) -> np.ndarray:
    """Readings per cell of `planner.success.plan_looks` rows (step, uav_id, x, y)."""
    looks = np.zeros(shape, dtype=np.int64)
    for _, _, x, y in rows:
        looks[x, y] += 1
    return looks


def search_theory(p0: np.ndarray, searchable: np.ndarray, pc: float, looks: np.ndarray, segments: list[Segment],
                  looks_before: np.ndarray | None = None, inside: float = 1.0) -> SearchTheory:
    """The figures of a sortie whose readings per cell are `looks`, after earlier sorties'
    `looks_before`, over the first prior `p0` (any non-negative scale) and `segments`.
    ValueError when the prior has no mass on a searchable cell, Pc or `inside` is outside (0, 1]."""
    if not 0 < pc <= 1:
        raise ValueError(f"Pc must be in (0, 1], got {pc:g}")
    if not 0 < inside <= 1:
        raise ValueError(f"the share of the subject inside the area must be in (0, 1], got {inside:g}")
    first = np.where(np.asarray(searchable, dtype=bool), np.asarray(p0, dtype=np.float64), 0.0)
    if first.min(initial=0.0) < 0 or not first.sum() > 0:
        raise ValueError("the prior must be >= 0 with some mass on a searchable cell")
    first = first / first.sum() * inside
    before = np.zeros(first.shape) if looks_before is None else np.asarray(looks_before, dtype=np.float64)
    now = np.asarray(looks, dtype=np.float64)
    missed_before = first * (1.0 - pc) ** before
    not_found_before = float(missed_before.sum()) + (1.0 - inside)
    p = missed_before / not_found_before
    missed = p * (1.0 - pc) ** now
    pos = float((p - missed).sum())
    figures = []
    for seg in segments:
        mask = np.asarray(seg.cells, dtype=bool)
        poa, left = float(p[mask].sum()), float(missed[mask].sum())
        pod = 1.0 - left / poa if poa > 0 else 0.0
        f0 = float(first[mask].sum())
        cum_pod = 1.0 - float((first[mask] * (1.0 - pc) ** (before[mask] + now[mask])).sum()) / f0 if f0 > 0 else 0.0
        figures.append(SegmentFigures(seg.name, int(mask.sum()), poa, pod, poa * pod, cum_pod,
                                      left / (1.0 - pos) if pos < 1 else 0.0))
    cumulative = 1.0 - float((first * (1.0 - pc) ** (before + now)).sum()) - (1.0 - inside)
    rest = (1.0 - inside) / not_found_before
    return SearchTheory(tuple(figures), pos, cumulative, float(pc), rest, rest / (1.0 - pos) if pos < 1 else 0.0,
                        float(inside))
