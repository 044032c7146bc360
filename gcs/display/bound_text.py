"""plan.json's `summary.bound` (`gcs.plans.plan_bound`) in words: the phrases the summary's bound
line (`gcs.display.plan_tables.bound_line`) and the picture's caption
(`gcs.display.overview.bound_caption`) both say, formatted once."""

from __future__ import annotations

from dataclasses import dataclass

#: What the bound is: the expected finds no plan can pass.
MOST = "the most any plan of these airports and ranges could expect"


@dataclass(frozen=True)
class BoundTerms:
    """A bound's figures as text: `share` the plan's share of it ("77.3%"), `expected_max` and
    `pos_max` the bound on expected finds ("396.36") and on the PoS ("32.8%"), `lp` the model it
    was solved over ("the LP over blocks 17x17", "the Lagrangian dual of the LP over headings"); all
    None when it was not had in time, and then
    `missing` says so ("not had within --bound-time 0.5 s (cells model)")."""

    share: str | None
    expected_max: str | None
    pos_max: str | None
    lp: str | None
    missing: str | None


def bound_terms(bound: dict) -> BoundTerms:
    """The words of plan.json's `summary.bound` (a bound was asked for)."""
    if "share_of_max" not in bound:
        return BoundTerms(None, None, None, None,
                          f"not had within --bound-time {bound['time_limit_s']:g} s ({bound['model']} model)")
    if bound["model"] == "lagrangian":
        over = "the Lagrangian dual of the LP over headings"
    else:
        over = "the LP over " + bound["model"] + (f" {bound['block']}x{bound['block']}" if bound["block"] > 1 else "")
    return BoundTerms(f"{bound['share_of_max']:.1%}", f"{bound['expected_targets_found_max']:.2f}",
                      f"{bound['probability_of_success_max']:.1%}", over, None)
