"""The `gcs experiment` figures as a Rerun recording: every plotted series of each matplotlib
figure as scalars."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from gcs.recording.plan import APPLICATION_ID, FLUSH_TIMEOUT_S

if TYPE_CHECKING:
    from matplotlib.figure import Figure




def _slug(text: str, default: str) -> str:
    text = re.sub(r"^\(\w\)\s*", "", text.strip())  # a panel letter, "(a) "
    text = text.split("(")[0].strip().lower()
    slug = re.sub(r"[^a-z0-9]+", "_", text).strip("_")
    return slug or default


def figure_series(figure: Figure) -> list[tuple[str, str, list[float], list[float], bool]]:
    """Every plotted series of a matplotlib figure: (axes slug, series name, x, y, bars) for
    lines (plot, errorbar: the data line, not its caps) and bar groups. Axes are named by their
    title (without the panel letter), series by their label."""
    from matplotlib.container import BarContainer, ErrorbarContainer

    out = []
    for i, ax in enumerate(figure.axes):
        axes_name = _slug(ax.get_title(), f"axes{i + 1}")
        caps, labels = set(), {}
        for container in ax.containers:
            if isinstance(container, ErrorbarContainer):
                caps.update(container.lines[1])
                if container.lines[0] is not None:
                    labels[container.lines[0]] = container.get_label() or ""
        unnamed = 0
        for line in ax.get_lines():
            if line in caps:
                continue
            unnamed += 1
            label = labels.get(line, line.get_label())
            if not label or label.startswith("_"):
                label = f"series{unnamed}"
            x = [float(v) for v in np.asarray(line.get_xdata(), dtype=float)]
            y = [float(v) for v in np.asarray(line.get_ydata(), dtype=float)]
            if x:
                out.append((axes_name, label, x, y, False))
        bars = [c for c in ax.containers if isinstance(c, BarContainer)]
        for j, container in enumerate(bars):
            label = container.get_label()
            if not label or label.startswith("_"):
                label = f"bars{j + 1}"
            x = [p.get_x() + p.get_width() / 2 for p in container.patches]
            y = [p.get_height() for p in container.patches]
            if x:
                out.append((axes_name, label, x, y, True))
    return out


def record_figures(rrd_path: str | Path, figures: list[tuple[str, Figure]], name: str = "experiments") -> Path:
    """Log every figure's series as scalar plots, one entity per series,
    `<figure>/<axes title>/<series label>`, on a sequence timeline named after the axes'
    x label (`np`, `time_step`, `iteration`, ...) when the x values are whole numbers, else on
    `index` (the point's position in the series). One time-series view per axes. Written
    atomically (a temporary file renamed at the end)."""
    from gcs.atomic import staged_outputs

    rrd_path = Path(rrd_path)
    rrd_path.parent.mkdir(parents=True, exist_ok=True)
    with staged_outputs([rrd_path]) as staged:
        _write_figures(staged[rrd_path], figures, name)
    return rrd_path


def _write_figures(rrd_path: Path, figures: list[tuple[str, Figure]], name: str) -> None:
    rec = rr.RecordingStream(APPLICATION_ID)
    views = []
    entities_by_axes: dict[str, list] = {}
    for figure_name, figure in figures:
        for axes_index, ax in enumerate(figure.axes):
            entities_by_axes[f"{figure_name}/{_slug(ax.get_title(), f'axes{axes_index + 1}')}"] = [ax.get_xlabel(),
                                                                                                  ax.get_ylabel()]
    for origin, (_xlabel, ylabel) in entities_by_axes.items():
        views.append(rrb.TimeSeriesView(name=f"{origin}: {ylabel}", origin=f"/{origin}"))
    blueprint = rrb.Blueprint(rrb.Grid(*views) if views else rrb.Vertical(), rrb.TimePanel(state="collapsed"))
    rec.set_sinks(rr.FileSink(str(rrd_path)), default_blueprint=blueprint)
    rec.send_recording_name(name)
    for figure_name, figure in figures:
        xlabels = {_slug(ax.get_title(), f"axes{i + 1}"): ax.get_xlabel() for i, ax in enumerate(figure.axes)}
        for axes_name, label, x, y, bars in figure_series(figure):
            path = f"{figure_name}/{axes_name}/{_slug(label, 'series')}"
            if bars:  # grouped bars sit beside their whole-number position
                x = [round(v) for v in x]
            whole = all(math.isfinite(v) and float(v).is_integer() for v in x) and len(set(x)) == len(x)
            timeline = _slug(xlabels.get(axes_name, ""), "x") if whole else "index"
            seq = [int(v) for v in x] if whole else list(range(len(x)))
            rec.log(path, rr.SeriesLines(names=label), static=True)
            rec.send_columns(path, [rr.TimeColumn(timeline, sequence=seq)],
                             rr.Scalars.columns(scalars=np.asarray(y, dtype=float)))
    rec.flush(timeout_sec=FLUSH_TIMEOUT_S)
    rec.disconnect()
