"""The search team's segments in a Rerun recording (`planner.search_theory`, docs/search-team.md):
their outlines, names and figures (POA, POD, POS, cumulative POD, POA after), coloured by POA, from
finished results only: the plan's figures in the plan's recording
(`gcs.recording.plan.PlanRecorder.log_segments`), the flight's in the flight's
(`gcs.recording.flight.FlightRecorder`, from its sortie record).

One entity per kind, segment k the k-th value of each (in plan.json's order):

- `segments`: `AnyValues` `name`, `cells`, `poa`, `pod`, `pos`, `cumulative_pod`, `poa_after`,
  one value per segment (shares in [0, 1]);
- `world/segments`: the outlines along cell edges in the 2-D grid view (one strip per cell edge),
  and `world/segments/labels` each segment's name, POA and POD at a cell inside it (plans);
- `geo/segments`: the same outlines on the map (`GeoLineStrings`, lat/lon).

(Rerun pays some 4 KB a log: the paper's 36 blocks as an entity each added 600 KB to a 500 KB
recording, as these four 48 KB; a 400 x 400 grid's 36 blocks add 250 KB, one strip per cell
edge.) An outline's colour is its segment's POA against the largest, on the maps' colour scale
(`gcs.recording.plan.MAP_LUT`, viridis: dark the least likely, yellow the likeliest)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gcs.display.overview import label_cell, mask_outline
from planner.search_theory import SearchTheory, Segment

ROOT = "segments"
FIELDS = ("name", "cells", "poa", "pod", "pos", "cumulative_pod", "poa_after")


@dataclass(frozen=True)
class SegmentOutlines:
    """Every segment's outline as cell edges, `view` in the 2-D grid view's coordinates (x from
    the west edge, rows from the north edge) and `cells` in fractional 0-based cells (what a
    cells -> lat/lon function maps onto the map), each (n, 2, 2); `colours` one RGB per edge;
    `label_cells` a cell inside each segment and `labels` its name, POA and POD."""

    view: np.ndarray
    cells: np.ndarray
    colours: np.ndarray
    label_cells: np.ndarray
    labels: list[str]


def poa_colours(theory: SearchTheory, lut: np.ndarray) -> np.ndarray:
    """Each segment's colour: its POA over the largest, on the colour scale `lut` (256 RGB rows)."""
    poa = np.array([f.poa for f in theory.segments], dtype=np.float64)
    top = poa.max(initial=0.0)
    shares = poa / top if top > 0 else np.zeros_like(poa)
    return np.asarray(lut)[np.rint(shares * 255).astype(np.int64)].reshape(-1, 3)


def outlines(segments: list[Segment], theory: SearchTheory, lut: np.ndarray) -> SegmentOutlines:
    """The outlines of the segments that hold a cell, coloured by POA, with their labels."""
    colours = poa_colours(theory, lut)
    views, edge_colours, label_cells, labels = [], [], [], []
    for seg, fig, colour in zip(segments, theory.segments, colours):
        if not np.any(seg.cells):
            continue
        view = mask_outline(seg.cells)
        views.append(view)
        edge_colours.append(np.repeat(colour[None], len(view), axis=0))
        label_cells.append(label_cell(seg.cells))
        labels.append(f"{fig.name}\nPOA {fig.poa:.0%} POD {fig.pod:.0%}")
    if not views:
        empty = np.zeros((0, 2, 2))
        return SegmentOutlines(empty, empty, np.zeros((0, 3), dtype=np.uint8), np.zeros((0, 2)), [])
    view = np.concatenate(views)
    ny = segments[0].cells.shape[1]
    cells = np.stack([view[..., 0] - 0.5, ny - 0.5 - view[..., 1]], axis=-1)
    return SegmentOutlines(view, cells, np.concatenate(edge_colours), np.array(label_cells, dtype=np.float64), labels)


def figure_values(theory: SearchTheory) -> dict[str, list]:
    """The segments' figures, one list per field (`FIELDS`), segment k the k-th value of each."""
    return {field: [getattr(f, field) for f in theory.segments] for field in FIELDS}

