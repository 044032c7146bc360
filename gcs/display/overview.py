"""A PNG picture of a plan: the prior map, no-fly zones, known and key regions, every UAV's
closed path in its own colour (search solid, return dashed), airports, and targets found or
missed; the probability of success in the title (total) and the legend (per UAV); under the
axes a caption with the plan's expected finds against the upper bound on them (`bound_caption`).
Matplotlib with the Agg backend; the file is written atomically.

The picture is drawn in three parts, so that most of it can be drawn before the plan is known
and all but one line before its bound is: the map (`MapLayers`: prior, no-fly zones, regions,
cells earlier sorties searched, the search team's segments outlined, axes and colour bar), the
plan over it (`PlanLayers`: paths, airports, targets, title, legend and the segments' labels
with the plan's figures, plan.json's `search_theory`), both plain arrays and text, and the
caption, one line of text. `OverviewPicture` draws the map when it is made and keeps its
pixels; `render` puts them back and draws the plan on top; `finish` draws the caption last and
makes the PNG. The PNG is the one drawing everything at once gives, byte for byte: inside the
axes the plan's artists lie above the map's (the axes' frame, above the paths, is drawn with
the plan), the ticks, labels and colour bar drawn with the map lie outside the axes, which clip
the paths, and the caption lies below them all. `gcs.plans.make` has its pictures helper draw the map while the search
runs and the plan while the bound is solved. Neither matplotlib nor the planner is imported
before a picture is drawn, so that helper loads neither numba nor the planner."""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from gcs.atomic import staged_outputs
from gcs.colours import uav_colour
from gcs.display.bound_text import MOST, bound_terms

if TYPE_CHECKING:
    from planner.plan import Plan, UavPlan
    from planner.scenario import Scenario
    from planner.search_theory import SearchTheory, Segment, SegmentFigures

WIDTH_PX = 1400
HEIGHT_PX = 1000
DPI = 100
REGION_COLOURS = {"known": "tab:cyan", "key": "tab:orange"}
SEGMENT_COLOUR = "#1f3a93"
TITLE_CHARS = 150  # a title line wraps at this many characters: it fits the picture's width

# Named bands of the prior (P, chi) used to outline regions (Section 2.1 names them, it does not
# fix numbers): known where both are <= 0.1, key where P >= 0.8.
KNOWN_MAX = 0.1
KEY_MIN_TEP = 0.8


def region_masks(scenario: Scenario) -> dict[str, np.ndarray]:
    """Known and key regions of the prior (a later sortie's: the campaign's first prior TEP), by
    the bands above, outside no-fly cells."""
    m = scenario.search_map
    free, tep = ~m.no_fly, scenario.success_prior
    return {"known": free & (tep <= KNOWN_MAX) & (m.eu <= KNOWN_MAX), "key": free & (tep >= KEY_MIN_TEP)}


def mask_outline(mask: np.ndarray) -> np.ndarray:
    """The boundary of a [x, y] cell mask as (n, 2, 2) segments along cell edges, in image
    coordinates: x from the west edge, rows from the north edge, one unit per cell."""
    ny = mask.shape[1]
    padded = np.pad(np.asarray(mask, dtype=bool), 1)
    inside = padded[1:-1, 1:-1]
    segments = []
    for outside, horizontal, offset in ((padded[1:-1, 2:], True, 0), (padded[1:-1, :-2], True, 1),
                                        (padded[:-2, 1:-1], False, 0), (padded[2:, 1:-1], False, 1)):
        xs, ys = np.nonzero(inside & ~outside)
        top = ny - ys - 1.0
        if horizontal:  # north (offset 0) or south edge
            start, end = np.stack([xs, top + offset], -1), np.stack([xs + 1, top + offset], -1)
        else:  # west (offset 0) or east edge
            start, end = np.stack([xs + offset, top], -1), np.stack([xs + offset, top + 1], -1)
        segments.append(np.stack([start, end], axis=1))
    return np.concatenate(segments).astype(np.float64)


def label_cell(mask: np.ndarray) -> tuple[int, int]:
    """The [x, y] mask's cell nearest its cells' centroid (0-based): where a segment's label
    sits, inside it."""
    cells = np.argwhere(mask)
    nearest = int(np.argmin(((cells - cells.mean(axis=0)) ** 2).sum(axis=1)))
    return int(cells[nearest, 0]), int(cells[nearest, 1])


def searched_before(scenario: Scenario) -> np.ndarray | None:
    """Cells read by earlier sorties of a campaign (None for a first sortie)."""
    looks = scenario.looks_before
    return None if looks is None or not np.any(looks) else np.asarray(looks) > 0


def hatch_image(mask: np.ndarray, px_per_cell: int) -> np.ndarray:
    """An RGBA image (rows from the south, `px_per_cell` pixels a cell) greying the cells of a
    [x, y] mask and hatching them with diagonal lines."""
    nx, ny = mask.shape
    cells = np.repeat(np.repeat(np.asarray(mask, dtype=bool).T, px_per_cell, axis=0), px_per_cell, axis=1)
    rows, cols = np.indices(cells.shape)
    lines = (rows + cols) % max(px_per_cell, 3) < max(1, px_per_cell // 4)
    image = np.zeros((ny * px_per_cell, nx * px_per_cell, 4), dtype=np.uint8)
    image[cells] = (140, 140, 140, 90)
    image[cells & lines] = (25, 25, 25, 180)
    return image


def campaign_outcome(plan: Plan, scenario: Scenario) -> str | None:
    """A later sortie's line: the campaign's probability of success before and after it, and this
    sortie's share of what the earlier ones left (the POS its segments table sums to)."""
    if plan.success is None or scenario.looks_before is None or not plan.success.available:
        return None
    from planner.success import expected_finds

    m = scenario.search_map
    before = expected_finds(scenario.success_prior, ~m.no_fly, scenario.sensor.pc, scenario.looks_before)
    available = plan.success.available
    left = available - before
    conditional = f", {plan.success.expected / left:.1%} of what earlier sorties left" if left > 0 else ""
    return (f"campaign PoS {before / available:.1%} -> {(before + plan.success.expected) / available:.1%} "
            f"(this sortie +{plan.success.share:.1%}{conditional})")


def _rgb(colour: tuple[int, int, int]) -> tuple[float, float, float]:
    return tuple(c / 255.0 for c in colour)  # type: ignore[return-value]


def _legs(trajectory: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Search and return legs as arrays of 1-based (x, y); the return leg starts where search ended."""
    points = np.array([(p.x + 1, p.y + 1) for p in trajectory], dtype=float).reshape(-1, 2)
    searching = np.array([p.stage.value == "search" for p in trajectory])
    first_return = int(np.argmin(searching)) if not searching.all() else len(points)
    return points[:first_return], points[max(first_return - 1, 0):] if first_return < len(points) else points[:0]


def title_outcome(plan: Plan) -> str:
    """The outcome in one line, probability of success first: "PoS 24.8% (E 299.8 of 1207.9
    targets), 6/10 targets found, 60 false alarms, mean eta 99.6%"."""
    parts = []
    if plan.success is not None:
        pos = plan.success
        parts.append(f"PoS {pos.share:.1%} (E {pos.expected:.1f} of {pos.available:.1f} targets)")
    if plan.targets:
        parts.append(f"{plan.targets_found}/{len(plan.targets)} targets found")
    if plan.found_before:
        parts.append(f"{len(plan.found_before)} found by earlier sorties")
    parts.append(f"{plan.false_alarms} false alarms, mean eta {plan.mean_eta:.1%}")
    return ", ".join(parts)


def bound_caption(expected: float | None, bound: dict | None) -> str | None:
    """The caption under the picture: the plan's expected finds `expected` against the upper
    bound on them, `bound` being plan.json's `summary.bound` (`gcs.plans.plan_bound`; None when
    none was asked for): "E = 2.31 of a bound 2.55 (90.6%): ...", or E alone and why there is no
    bound. None without expected finds (a plan without a prior)."""
    if expected is None:
        return None
    if bound is None:
        return f"E = {expected:.2f} expected finds; no bound asked for (--bound-time 0)"
    terms = bound_terms(bound)
    if terms.missing is not None:
        return f"E = {expected:.2f} expected finds; no bound: {terms.missing}"
    return (f"E = {expected:.2f} of a bound {terms.expected_max} ({terms.share}): {MOST} (PoS <= {terms.pos_max}; "
            f"{terms.lp})")


def uav_label(plan: Plan, u: UavPlan) -> str:
    """A UAV's legend entry: its legs and range use; its PoS and why it turned home."""
    steps = f"UAV {u.uav_id}: {u.search_steps} + {u.return_steps} steps"
    if plan.unit_m is None:
        label = f"{steps} of {u.range_units}, eta {u.eta:.0%}"
    else:
        used_km, range_km = plan.metres(u.spent) / 1000, plan.metres(u.range_units) / 1000
        label = f"{steps}, {used_km:.2f} of {range_km:.2f} km, eta {u.eta:.0%}"
    more = [f"PoS {plan.success.share_of(u.uav_id):.1%}"] if plan.success else []
    if u.return_reason:
        more.append(f"returned at step {u.return_step}: {u.return_reason.value}")
    return label + ("\n    " + ", ".join(more) if more else "")


STRATEGY_NAMES = {"cpio": "CPIO", "exhaustive": "exhaustive search", "lawnmower": "lawnmower"}


def settings_text(settings: dict) -> str:
    """The plan's settings in one line a crew reads: "look-ahead 5 steps, 3OC turns, CPIO, exact
    return, horizon value w 1 L 1, whole-mission improvement"; a reserve and a diagonal's cost
    only where they are not the default (none; sqrt 2 of a side), other keys as "key value"."""
    out = []
    for key, value in settings.items():
        if key == "np":
            out.append(f"look-ahead {value} steps")
        elif key == "oc":
            out.append(f"{value} turns")
        elif key == "strategy":
            out.append(STRATEGY_NAMES.get(value, str(value)))
        elif key == "return_planner":
            out.append(f"{'ST' if value == 'st' else value} return")
        elif key == "reserve_steps":
            out.extend([f"reserve {value} cell sides"] if value else [])
        elif key == "move_costs" and isinstance(value, dict):
            ratio = value["diagonal"] / value["straight"]
            out.extend([] if abs(ratio - math.sqrt(2)) < 1e-3 else [f"a diagonal costs {ratio:.3g} sides"])
        elif key == "horizon_value" and isinstance(value, dict):
            out.append(f"horizon value w {value['weight']:g} L {value['length']:g}")
        elif key == "improved" and value is True:
            out.append("whole-mission improvement")
        elif value is True:
            out.append(key)
        else:
            out.append(f"{key} {value}")
    return ", ".join(out)


def warm_up() -> None:
    """Import matplotlib and what a picture draws with (the Agg canvas, collections, lines,
    patches, the PNG writer); drawing the map ahead then warms the rest (fonts, caches)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.backends.backend_agg
    import matplotlib.collections
    import matplotlib.figure
    import matplotlib.image
    import matplotlib.legend
    import matplotlib.lines
    import matplotlib.patches


class SegmentPlace(NamedTuple):
    """Where a segment's label goes, in 1-based cells: hanging from (x, y), its north-west
    corner (a block of the grid), or `centred` on (x, y), a cell inside it (an area file's
    segment)."""

    name: str
    x: float
    y: float
    centred: bool = False


@dataclass(frozen=True)
class MapLayers:
    """What the picture shows of a scenario, in plain arrays: the prior (a later sortie's belief
    before it) TEP and no-fly cells, the known and key regions, the cells earlier sorties
    searched (None for a first sortie) and the colour bar's label; over a real area its cell
    side `cell_m` (the axes then in metres from the grid's south-west corner) and the segments
    plan.json reports over: blocks of the grid (`blocks`: name, x0, y0, x1, y1 in 0-based
    cells, ends exclusive) or the area file's (`outlines`: their cells' edges, each once, as
    `mask_outline` gives them), and where each segment's label goes (`places`, in plan.json's
    order; None for a segment without a cell)."""

    tep: np.ndarray
    no_fly: np.ndarray
    regions: dict[str, np.ndarray]
    searched: np.ndarray | None
    tep_label: str
    cell_m: float | None = None
    blocks: tuple[tuple[str, int, int, int, int], ...] = ()
    outlines: np.ndarray | None = None
    places: tuple[SegmentPlace | None, ...] = ()


def map_layers(scenario: Scenario, segments: Sequence[Segment] = ()) -> MapLayers:
    """The map of `scenario` with `segments` (`gcs.plans.segments.area_segments`: the area
    file's, else blocks of the grid; none for a built-in scenario) outlined."""
    m = scenario.search_map
    blocks = tuple((s.name, *s.block) for s in segments if s.block is not None)
    drawn = [s.cells for s in segments if s.block is None]
    return MapLayers(np.asarray(m.tep), np.asarray(m.no_fly), region_masks(scenario), searched_before(scenario),
                     "prior TEP" if scenario.looks_before is None else "belief TEP before this sortie",
                     cell_side_m(scenario), blocks, segment_edges(drawn) if drawn else None,
                     tuple(segment_place(s) for s in segments))


def segment_edges(masks: Sequence[np.ndarray]) -> np.ndarray:
    """The outlines of [x, y] cell masks (`mask_outline`), an edge two of them share once."""
    edges = np.concatenate([mask_outline(mask) for mask in masks])
    return np.unique(edges.reshape(-1, 4), axis=0).reshape(-1, 2, 2)


def segment_place(segment: Segment) -> SegmentPlace | None:
    """Where `segment`'s label goes: a block's north-west corner, else centred on `label_cell`
    of its cells; None when it holds no cell."""
    if segment.block is not None:
        x0, _, _, y1 = segment.block
        return SegmentPlace(segment.name, x0 + 0.6, y1 + 0.4)
    if not np.any(segment.cells):
        return None
    x, y = label_cell(segment.cells)
    return SegmentPlace(segment.name, x + 1.0, y + 1.0, centred=True)


def cell_side_m(scenario: Scenario) -> float | None:
    """A real area's cell side in metres (None for a built-in scenario, drawn in cells)."""
    if scenario.unit_m is None:
        return None
    return float(scenario.unit_m * scenario.move_costs.straight)


def nice_length(limit: float) -> float:
    """The longest of 1, 2, 5 x 10^k not above `limit` (a scale bar's length)."""
    k = 10 ** math.floor(math.log10(limit))
    return max(f * k for f in (1, 2, 5) if f * k <= limit)


class SegmentLabel(NamedTuple):
    """A segment's label: its text at (x, y) (1-based cells), hanging from that point as its
    north-west corner or `centred` on it (`SegmentPlace`)."""

    x: float
    y: float
    text: str
    centred: bool = False


def segment_labels(places: Sequence[SegmentPlace | None], figures: Sequence[SegmentFigures]
                   ) -> tuple[SegmentLabel, ...]:
    """Per segment its name, POA and the POD the plan gives it, as `figures` has them
    (plan.json's `search_theory.segments`, `gcs.plans.segments.plan_theory`: POAs counting the
    rest of the world), at its place (`map_layers`; a segment without a place has no label).
    A block's two lines: "A1 POA 12%", "POD 30%"; an area file's segment's: "North-west",
    "POA 21.4%, POD 7.9%". ValueError when the places and the figures are not of the same
    segments, in order."""
    if len(places) != len(figures):
        raise ValueError(f"{len(places)} segments' places for {len(figures)} segments' figures")
    labels = []
    for place, f in zip(places, figures):
        if place is None:
            continue
        if place.name != f.name:
            raise ValueError(f"segment {place.name!r}'s place paired with {f.name!r}'s figures")
        text = (f"{f.name}\nPOA {f.poa:.1%}, POD {f.pod:.1%}" if place.centred
                else f"{f.name} POA {f.poa:.0%}\nPOD {f.pod:.0%}")
        labels.append(SegmentLabel(place.x, place.y, text, place.centred))
    return tuple(labels)


@dataclass(frozen=True)
class UavLayer:
    """One UAV's part of the picture: its search and return legs (1-based cells), its airport
    (0-based cell), its id and its legend entry."""

    search: np.ndarray
    back: np.ndarray
    airport: tuple[int, int]
    uav_id: int
    label: str


@dataclass(frozen=True)
class PlanLayers:
    """What the picture shows of a plan over its map, in plain arrays and text: every UAV,
    targets found and missed (1-based cells), the title, the segments' labels and the rest of
    the world's POA (`segment_labels`), the targets earlier sorties found."""

    uavs: tuple[UavLayer, ...]
    found: np.ndarray
    missed: np.ndarray
    title: str
    segments: tuple[SegmentLabel, ...] = ()
    rest_poa: float = 0.0
    found_before: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


def plan_layers(plan: Plan, scenario: Scenario, places: Sequence[SegmentPlace | None] = (),
                theory: SearchTheory | None = None) -> PlanLayers:
    """The plan over its map; with `theory`, the plan's figures over the segments of the map's
    `places` (`MapLayers.places`), their labels."""
    uavs = tuple(UavLayer(*_legs(u.trajectory), (int(u.airport[0]), int(u.airport[1])), u.uav_id, uav_label(plan, u))
                 for u in plan.uavs)
    found = np.array([(t.x + 1, t.y + 1) for t in plan.targets if t.found_step is not None], dtype=float).reshape(-1, 2)
    missed = np.array([(t.x + 1, t.y + 1) for t in plan.targets if t.found_step is None], dtype=float).reshape(-1, 2)
    before = np.array([(x + 1, y + 1) for x, y, _ in plan.found_before], dtype=float).reshape(-1, 2)
    campaign = campaign_outcome(plan, scenario)
    lines = [f"{plan.scenario}: {title_outcome(plan)}", *([campaign] if campaign else []), settings_text(plan.settings)]
    title = "\n".join(textwrap.fill(line, TITLE_CHARS, subsequent_indent="  ") for line in lines)
    if theory is None:
        return PlanLayers(uavs, found, missed, title, found_before=before)
    return PlanLayers(uavs, found, missed, title, segment_labels(places, theory.segments), theory.rest_poa, before)


CAPTION_SIZE = 11
LEGEND_SIZE = 10
EDGE_PX = 4  # the least white between what is drawn and the picture's edge
CAPTION_GAP_PX = 8  # between the x axis' label and the caption's top
CAPTION_MIN_PX = 22  # the caption's top at least this far above the figure's bottom edge


def fit_legend(fig: Any, handles: list) -> Any:
    """The legend right of the map, its font shrunk (to 6 pt at least) until it fits inside the
    picture: a fleet of eight UAVs' labels ran off its right edge at 10 pt."""
    size = float(LEGEND_SIZE)
    while True:
        legend = fig.legend(handles=handles, loc="center left", bbox_to_anchor=(0.71, 0.5), fontsize=size,
                            frameon=False, labelspacing=0.8)
        box = legend.get_window_extent(fig.canvas.get_renderer())
        scale = min((WIDTH_PX - EDGE_PX - box.x0) / max(box.width, 1.0),
                    (HEIGHT_PX - 2 * EDGE_PX) / max(box.height, 1.0))
        if scale >= 1.0 or size <= 6.0:
            return legend
        legend.remove()
        size = max(6.0, math.floor(size * scale * 10) / 10)


class OverviewPicture:
    """The overview of one plan over the map of `layers`: the map is drawn when the picture is
    made (`draw_map` False: with the plan and the caption, all at once); `render` draws the plan
    over it, `finish` the caption under it, last, into PNG bytes; `save` writes them. A picture
    is rendered and finished once; finished, it keeps only the PNG."""

    def __init__(self, layers: MapLayers, draw_map: bool = True) -> None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection
        from matplotlib.figure import Figure

        nx, ny = layers.tep.shape
        self.shape = (nx, ny)
        self.layers = layers
        fig = Figure(figsize=(WIDTH_PX / DPI, HEIGHT_PX / DPI), dpi=DPI)
        FigureCanvasAgg(fig)
        ax = fig.add_axes((0.05, 0.07, 0.6, 0.84))
        extent = (0.5, nx + 0.5, 0.5, ny + 0.5)
        prior = ax.imshow(layers.tep.T, origin="lower", extent=extent, cmap="Greys", vmin=0.0, vmax=1.6,
                          interpolation="nearest")
        overlay = np.zeros((ny, nx, 4))
        overlay[layers.no_fly.T] = (0.8, 0.1, 0.1, 0.55)
        self._map: list[Any] = [prior, ax.imshow(overlay, origin="lower", extent=extent, interpolation="nearest")]
        if layers.searched is not None:
            self._map.append(ax.imshow(hatch_image(layers.searched, max(2, min(8, 1600 // max(nx, ny)))),
                                       origin="lower", extent=extent, interpolation="nearest", zorder=1.5))
        for name, mask in layers.regions.items():
            if mask.any():
                segments = mask_outline(mask)
                segments[..., 0] += 0.5
                segments[..., 1] = ny + 0.5 - segments[..., 1]
                self._map.append(ax.add_collection(LineCollection(segments, colors=REGION_COLOURS[name],
                                                                  linewidths=2.2, zorder=2)))
        if layers.blocks:
            edges = [((x0 + 0.5, y0 + 0.5), (x1 + 0.5, y0 + 0.5), (x1 + 0.5, y1 + 0.5), (x0 + 0.5, y1 + 0.5),
                      (x0 + 0.5, y0 + 0.5)) for _, x0, y0, x1, y1 in layers.blocks]
            self._map.append(ax.add_collection(LineCollection(edges, colors=SEGMENT_COLOUR, linewidths=0.9,
                                                              linestyles=(0, (4, 3)), alpha=0.7, zorder=1.8)))
        if layers.outlines is not None and len(layers.outlines):
            edges = layers.outlines.copy()
            edges[..., 0] += 0.5
            edges[..., 1] = ny + 0.5 - edges[..., 1]
            self._map.append(ax.add_collection(LineCollection(edges, colors=SEGMENT_COLOUR, linewidths=1.6,
                                                              alpha=0.85, zorder=1.8)))
        ax.set_xlim(extent[0] - 1, extent[1] + 1)
        ax.set_ylim(extent[2] - 1, extent[3] + 1)
        ax.set_aspect("equal")
        if layers.cell_m is None:
            ax.set_xlabel("x (cell, east)")
            ax.set_ylabel("y (cell, north)")
        else:
            from matplotlib.ticker import FuncFormatter, MaxNLocator

            cell = layers.cell_m
            for axis, n in ((ax.xaxis, nx), (ax.yaxis, ny)):
                ticks_m = MaxNLocator(nbins=8, steps=[1, 2, 2.5, 5, 10]).tick_values(0, n * cell)
                axis.set_ticks([t / cell + 0.5 for t in ticks_m if 0 <= t <= n * cell])
                axis.set_major_formatter(FuncFormatter(lambda v, _: f"{(v - 0.5) * cell:,.0f}"))
            ax.set_xlabel("metres east of the grid's south-west corner")
            ax.set_ylabel("metres north of the grid's south-west corner")
        ax.apply_aspect()  # the axes' box as drawn: the caption goes under its x axis, left-aligned with it
        renderer = fig.canvas.get_renderer()
        left = ax.yaxis.get_tightbbox(renderer)
        if left is not None and left.x0 < EDGE_PX:  # wide tick labels (10,000) push the y label off the picture
            box = ax.get_position()
            shift = (EDGE_PX - left.x0) / WIDTH_PX
            ax.set_position((box.x0 + shift, box.y0, box.width - shift, box.height))
            ax.apply_aspect()
        below = ax.xaxis.get_tightbbox(renderer)
        self._caption_xy = (ax.get_position().x0,
                            max(CAPTION_MIN_PX, (below.y0 if below is not None else 0) - CAPTION_GAP_PX) / HEIGHT_PX)
        self._map += [ax.xaxis, ax.yaxis]
        cbar = fig.colorbar(prior, cax=fig.add_axes((0.67, 0.3, 0.012, 0.4)))
        cbar.set_label(layers.tep_label)
        cbar.ax.set_ylim(0, 1)
        self._figure: Any = fig
        self._axes: Any = ax
        self._background: Any = None
        self._rendered = False
        self.png: bytes | None = None
        if draw_map:  # everything but what lies above the paths: the axes' frame (and the title, empty yet)
            for spine in ax.spines.values():
                spine.set_visible(False)
            fig.canvas.draw()
            self._background = fig.canvas.copy_from_bbox(fig.bbox)
            for spine in ax.spines.values():
                spine.set_visible(True)

    def render(self, plan: PlanLayers) -> None:
        """Draw `plan` over the map (all at once: lay it out); `finish` adds the caption and
        makes the PNG."""
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        if self._figure is None or self._rendered:
            raise RuntimeError("this picture is rendered already")
        self._rendered = True
        fig, ax = self._figure, self._axes
        nx, ny = self.shape
        for i, u in enumerate(plan.uavs):
            colour = _rgb(uav_colour(i))
            ax.plot(u.search[:, 0], u.search[:, 1], "-", color=colour, lw=1.8, solid_capstyle="round")
            if len(u.back):
                ax.plot(u.back[:, 0], u.back[:, 1], "--", color=colour, lw=2.2, dashes=(3, 1.5))
                ax.plot(*u.back[0], "o", ms=7, mfc="white", mec=colour, mew=2)
            ax.plot(u.airport[0] + 1, u.airport[1] + 1, "^", ms=14, color=colour, mec="black", mew=1.2, zorder=5)
            inward = np.sign([(nx + 1) / 2 - (u.airport[0] + 1), (ny + 1) / 2 - (u.airport[1] + 1)])
            ax.annotate(f"UAV {u.uav_id}", (u.airport[0] + 1, u.airport[1] + 1), textcoords="offset points",
                        xytext=tuple(24 * inward + (0, -5)), ha="center", fontsize=11, fontweight="bold",
                        color=colour, zorder=6,
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
        found, missed = plan.found, plan.missed
        ax.plot(found[:, 0], found[:, 1], "*", ms=17, color="gold", mec="black", mew=1.0, zorder=7, ls="none")
        ax.plot(missed[:, 0], missed[:, 1], "X", ms=11, color="crimson", mec="black", mew=0.8, zorder=7, ls="none")
        before = plan.found_before
        ax.plot(before[:, 0], before[:, 1], "*", ms=13, color="white", mec="dimgrey", mew=1.2, zorder=7, ls="none")
        ax.set_title(plan.title, fontsize=11, loc="left")
        for x, y, text, centred in plan.segments:
            if centred:  # an area file's segment: on a cell inside it
                ax.text(x, y, text, fontsize=9, color=SEGMENT_COLOUR, va="center", ha="center", zorder=4,
                        multialignment="center",
                        bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none", "alpha": 0.75})
            else:  # a block: from its north-west corner
                ax.text(x, y, text, fontsize=7.5, color=SEGMENT_COLOUR, va="top", ha="left", zorder=4,
                        bbox={"boxstyle": "round,pad=0.12", "fc": "white", "ec": "none", "alpha": 0.6})
        if self.layers.cell_m is not None:
            self._scale_and_north(ax, self.layers.cell_m)

        handles = [Line2D([], [], color=_rgb(uav_colour(i)), lw=2.5, label=u.label) for i, u in enumerate(plan.uavs)]
        handles += [
            Line2D([], [], color="black", lw=1.8, label="search leg"),
            Line2D([], [], color="black", lw=2.2, ls="--", dashes=(3, 1.5), label="return leg"),
            Line2D([], [], marker="o", ls="none", ms=7, mfc="white", mec="black", mew=2, label="switch to return"),
            Line2D([], [], marker="^", ls="none", ms=12, color="grey", mec="black", label="airport"),
            Line2D([], [], marker="*", ls="none", ms=15, color="gold", mec="black",
                   label=f"target found ({len(found)})"),
            Line2D([], [], marker="X", ls="none", ms=10, color="crimson", mec="black",
                   label=f"target missed ({len(missed)})"),
            *([Line2D([], [], marker="*", ls="none", ms=13, color="white", mec="dimgrey", mew=1.2,
                      label=f"found by an earlier sortie ({len(before)})")] if len(before) else []),
            Patch(color=(0.8, 0.1, 0.1, 0.55), label="no-fly"),
            Patch(facecolor="none", edgecolor=REGION_COLOURS["known"], lw=2, label="known region"),
            Patch(facecolor="none", edgecolor=REGION_COLOURS["key"], lw=2, label="key region"),
        ]
        if self.layers.searched is not None:
            handles.append(Patch(facecolor=(0.55, 0.55, 0.55, 0.35), edgecolor=(0.1, 0.1, 0.1, 0.7), hatch="///",
                                 lw=0, label=f"searched in earlier sorties ({int(self.layers.searched.sum())} cells)"))
        if plan.segments:
            label = "segment: POA, POD this sortie gives it" + (
                f"\n    (rest of the world: POA {plan.rest_poa:.1%})" if plan.rest_poa > 0 else "")
            if self.layers.outlines is not None:
                handles.append(Line2D([], [], color=SEGMENT_COLOUR, lw=1.6, alpha=0.85, label=label))
            else:
                handles.append(Line2D([], [], color=SEGMENT_COLOUR, lw=0.9, ls=(0, (4, 3)), label=label))
        legend = fit_legend(fig, handles)
        canvas = fig.canvas
        if self._background is not None:  # the map's pixels, then the axes without the map's artists
            canvas.restore_region(self._background)  # (in their order), then the legend
            ax.patch.set_visible(False)
            for artist in self._map:
                artist.set_visible(False)
            renderer = canvas.get_renderer()
            ax.draw(renderer)
            legend.draw(renderer)

    def finish(self, caption: str | None = None) -> None:
        """Draw `caption` (`bound_caption`; None: none) under the axes, last, and make `png`."""
        if not self._rendered:
            raise RuntimeError("this picture is not rendered yet")
        if self._figure is None:
            raise RuntimeError("this picture is finished already")
        fig, canvas = self._figure, self._figure.canvas
        text = None
        if caption:
            text = fig.text(*self._caption_xy, caption, fontsize=CAPTION_SIZE, ha="left", va="top")
        if self._background is None:
            canvas.draw()
        elif text is not None:  # below everything drawn: over the white of the figure alone
            text.draw(canvas.get_renderer())
        from matplotlib.image import imsave

        png = io.BytesIO()
        imsave(png, canvas.buffer_rgba(), format="png", origin="upper", dpi=DPI)  # as savefig writes it
        self.png = png.getvalue()
        self._figure = self._axes = self._background = None
        self._map = []

    def _scale_and_north(self, ax: Any, cell_m: float) -> None:
        """A scale bar (bottom left) and a north arrow (top right) inside the axes."""
        from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

        nx, _ = self.shape
        length_m = nice_length(nx * cell_m / 4)
        label = f"{length_m / 1000:g} km" if length_m >= 1000 else f"{length_m:g} m"
        ax.add_artist(AnchoredSizeBar(ax.transData, length_m / cell_m, label, "lower left", pad=0.4, sep=4,
                                      frameon=True, size_vertical=0.15, fontproperties={"size": 10}))
        ax.annotate("N", xy=(0.965, 0.975), xytext=(0.965, 0.89), xycoords="axes fraction", ha="center",
                    va="center", fontsize=13, fontweight="bold",
                    arrowprops={"arrowstyle": "-|>", "lw": 2, "color": "black"},
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8}, zorder=8)

    def save(self, path: str | Path) -> Path:
        """Write the finished picture to `path`, atomically."""
        if self.png is None:
            raise RuntimeError("this picture is not " + ("finished" if self._rendered else "rendered") + " yet")
        path = Path(path)
        with staged_outputs([path]) as staged:
            staged[path].write_bytes(self.png)
        return path


def draw_overview(plan: Plan, scenario: Scenario, path: str | Path, caption: str | None = None,
                  segments: Sequence[Segment] = (), theory: SearchTheory | None = None) -> Path:
    """Write the overview PNG of `plan` (flown over `scenario`) to `path` (WIDTH_PX x HEIGHT_PX),
    `caption` under it (`bound_caption`), `segments` outlined and, with `theory` (the plan's
    figures over them: `gcs.plans.segments.sortie_segments`), labelled."""
    layers = map_layers(scenario, segments)
    picture = OverviewPicture(layers)
    picture.render(plan_layers(plan, scenario, layers.places, theory))
    picture.finish(caption)
    return picture.save(path)
