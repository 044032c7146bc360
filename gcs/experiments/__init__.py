"""The paper's Section 6 experiments: each runner writes CSV tables and a PNG plot."""

from gcs.experiments import fig6, fig8, fig10, fig12
from gcs.experiments.common import ExperimentSettings

EXPERIMENTS = {"fig6": fig6.run, "fig8": fig8.run, "fig10": fig10.run, "fig12": fig12.run}

__all__ = ["EXPERIMENTS", "ExperimentSettings"]
