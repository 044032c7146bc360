"""`gcs experiment NAME`: reproduce a figure of the paper's Section 6 (fig6, fig8, fig10, fig12,
or all), writing its CSV tables and a PNG plot into --out, and every figure's series to the Rerun
recording experiment.rrd there (docs/recording.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.errors import UserError

NAMES = ("fig6", "fig8", "fig10", "fig12")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("experiment", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("name", choices=(*NAMES, "all"), help="which figure")
    p.add_argument("--out", default="runs/experiments", help="folder for the CSV and PNG files")
    p.add_argument("--runs", type=int, default=None,
                   help="seeded runs per setting (default per figure: fig6 10, fig8 100, fig10 2, fig12 20)")
    p.add_argument("--seed", type=int, default=0, help="first seed; run r uses seed + r")
    p.add_argument("--footprint", type=int, default=0, help="sensor footprint radius in cells (0: the cell below)")
    p.add_argument("--range", dest="range_steps", type=int, default=130, help="range T_i of every UAV, in steps")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.add_argument("--no-rrd", action="store_true", help="write no Rerun recording (experiment.rrd)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.runs is not None and args.runs < 1:
        raise UserError(f"--runs must be at least 1, got {args.runs}")
    if args.footprint < 0:
        raise UserError(f"--footprint must be >= 0, got {args.footprint}")
    if args.range_steps < 10:
        raise UserError(f"--range must be at least 10 steps, got {args.range_steps}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file, not a folder")
    from gcs.experiments import EXPERIMENTS, ExperimentSettings  # the planner and numba: after the checks

    figures: list = []
    settings = ExperimentSettings(out, args.runs, args.seed, args.footprint, args.range_steps, args.quiet,
                                  on_figure=None if args.no_rrd else lambda name, fig: figures.append((name, fig)))
    for name in NAMES if args.name == "all" else (args.name,):
        written = EXPERIMENTS[name](settings)
        if not args.quiet:
            print(f"{name}: " + ", ".join(str(p) for p in written))
    if figures:
        from gcs.recording.figures import record_figures  # rerun takes ~0.45 s to import

        rrd = record_figures(out / "experiment.rrd", figures, name=f"experiment {args.name}")
        if not args.quiet:
            print(f"recording {rrd}")
    return 0
