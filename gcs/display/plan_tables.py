"""What `gcs plan` (and `gcs fly --area` before it flies) prints about a plan: the summary per UAV
with the probability of success, the missions of an area plan, and a campaign's sorties."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from gcs.autopilots.capacity import fleet_mission_capacity
from gcs.display.bound_text import MOST, bound_terms
from gcs.missions.fence_fit import describe_fit
from gcs.missions.items import AltitudeReference, Vehicle

if TYPE_CHECKING:
    from gcs.plans.campaign import CampaignResult
    from gcs.plans.make import ScenarioResult
    from gcs.plans.planning import AreaSetup
    from planner.plan import Plan


def bound_line(bound: dict | None) -> str | None:
    """The plan against the upper bound on expected finds (plan.json's `summary.bound`), in one
    line; None when no bound was asked for."""
    if bound is None:
        return None
    terms = bound_terms(bound)
    if terms.missing is not None:
        return f"bound: {terms.missing}; a longer --bound-time may have it"
    return f"bound: at least {terms.share} of {MOST} (E <= {terms.expected_max}, PoS <= {terms.pos_max}; {terms.lp})"


def summary_table(plan: Plan, bound: dict | None = None) -> str:
    """Per UAV its legs, range use (steps; over a real area the metres of range left for the
    grid, `grid m`, and the grid path's length, `flown m`: the mission table adds the airport legs
    and a plane's landing circuit to both) and probability of success
    (expected targets found, and that as a share of what the prior puts in the area); then the
    totals, the plan against the upper bound (`bound_line`), and the simulated finds."""
    found_by: dict[int, int] = {}
    for t in plan.targets:
        if t.found_by is not None:
            found_by[t.found_by] = found_by.get(t.found_by, 0) + 1
    pos = plan.success
    metric = plan.unit_m is not None
    ranges = f"{'grid m':>8}  {'flown m':>8}" if metric else f"{'range':>5}"
    rows = [f"{'UAV':>3}  {'airport':>9}  {'search':>6}  {'return':>6}  {ranges}  {'eta':>6}  {'E[found]':>8}  "
            f"{'PoS':>6}  {'found':>5}  return reason"]
    for u in plan.uavs:
        airport = f"({u.airport[0] + 1},{u.airport[1] + 1})"
        reason = u.return_reason.value if u.return_reason else "-"
        expected = (f"{pos.by_uav.get(u.uav_id, 0.0):>8.2f}  {pos.share_of(u.uav_id):>6.1%}" if pos
                    else f"{'-':>8}  {'-':>6}")
        found = found_by.get(u.uav_id, 0) if len(plan.targets) else "-"
        used = (f"{plan.metres(u.range_units):>8.0f}  {plan.metres(u.spent):>8.0f}" if metric
                else f"{u.range_units:>5}")
        rows.append(f"{u.uav_id:>3}  {airport:>9}  {u.search_steps:>6}  {u.return_steps:>6}  {used}  "
                    f"{u.eta:>6.1%}  {expected}  {found:>5}  {reason}")
    if pos is not None:
        rows.append(f"probability of success {pos.share:.1%}: expected targets found {pos.expected:.2f} of the "
                    f"{pos.available:.2f} the prior puts in the area")
    line = bound_line(bound)
    if line is not None:
        rows.append(line)
    simulated = (f"targets found {plan.targets_found}/{len(plan.targets)}" if len(plan.targets)
                 else "no targets left to find" if plan.found_before else "no targets placed (none to find)")
    if plan.found_before:
        simulated += f" ({len(plan.found_before)} found by earlier sorties)"
    rows.append(f"simulated: {simulated}, false alarms {plan.false_alarms}, mean eta {plan.mean_eta:.1%}")
    return "\n".join(rows)


def mission_table(setup: AreaSetup, files: dict[str, str]) -> str:
    """Per UAV of an area plan its name, altitude and layer, range and what the plan uses of it
    (the grid path, the airport legs and a plane's landing circuit), the mission path's length and
    waypoints (as plan.json in `files` has them); the altitude layers and the grid."""
    data = json.loads(files["plan.json"])
    rows = [f"{'UAV':>3}  {'name':<16} {'alt m':>6} {'layer':>5} {'range m':>8} {'used m':>8} {'used':>6} "
            f"{'path m':>8} {'waypoints':>9}"]
    for u in data["uavs"]:
        layer = u.get("altitude_layer")
        rows.append(f"{u['id']:>3}  {u['name'][:16]:<16} {u['altitude_m']:>6.0f} {layer or '-':>5} "
                    f"{u['range_m']:>8.0f} {u['range_used_m']:>8.0f} {u['range_used_m'] / u['range_m']:>6.1%} "
                    f"{u['length_m']:>8.0f} {len(u['waypoints']):>9}")
    layers = setup.layers
    above = "the ground below" if setup.altitude_reference is AltitudeReference.TERRAIN else "each airport"
    if layers.levels_m:
        rows.append(f"altitude layers {layers.levels_m[0]:g}-{layers.levels_m[-1]:g} m above {above} "
                    f"({len(layers.levels_m)} layers)")
    for level, uavs in sorted(layers.shared.items()):
        rows.append(f"UAVs {', '.join(map(str, uavs))} share layer {level} ({layers.levels_m[level - 1]:g} m): "
                    "the plan keeps them out of each other's cells; raise --ceiling or lower --altitude-step to part "
                    "them")
    fences: dict[str, list[int]] = {}
    for u in data["uavs"]:
        fence = u.get("fence")
        if fence is not None:
            fences.setdefault(describe_fit(**fence), []).append(u["id"])
    for line, uids in fences.items():
        rows.append(line if len(fences) == 1 else f"UAV {', '.join(map(str, uids))}: {line}")
    rows += mission_capacity_lines(data, setup.vehicle)
    g = setup.area.grid
    rows.append(f"grid {g.nx}x{g.ny} cells of {g.cell_size_m:g} m, {int(setup.area.free.sum())} searchable, "
                f"{setup.area.edge_blocked} blocked at edges")
    return "\n".join(rows)


def mission_capacity_lines(data: dict, vehicle: Vehicle) -> list[str]:
    """A warning per UAV whose mission has more items than an autopilot that flies `vehicle` holds."""
    items, whose = fleet_mission_capacity(vehicle is Vehicle.PLANE)
    return [f"warning: UAV {u['id']}'s mission has {u['mission_items']} items, more than {whose} holds ({items}): "
            "fly it on a vehicle that holds more, or give it a larger cell size"
            for u in data["uavs"] if u.get("mission_items", 0) > items]


def campaign_table(rows: list[dict], available: float) -> str:
    """Every sortie of a campaign so far: flown or planned, what it was planned from, its
    readings, its expected finds and probability of success, and the cumulative one."""
    lines = [f"campaign: the prior puts {available:.2f} targets in the area",
             f"{'sortie':>6}  {'status':<8} {'planned from':<12} {'readings':>8}  {'E[found]':>8}  {'PoS':>6}  "
             f"{'cumulative PoS':>14}"]
    for r in rows:
        readings = f"{r['readings']}" if "readings" in r else "-"
        lines.append(f"{r['sortie']:>6}  {r['status']:<8} {r['belief']:<12} {readings:>8}  "
                     f"{r['expected_targets_found']:>8.2f}  {r['probability_of_success']:>6.1%}  "
                     f"{r['cumulative_pos']:>14.1%}")
    return "\n".join(lines)


def segments_table(files: dict[str, str]) -> str:
    """POA, POD, POS, cumulative POD and POA after per segment, from plan.json in `files`
    (`planner.search_theory`; the map's copy: segments.kml / segments.geojson)."""
    from planner.search_theory import SearchTheory

    return SearchTheory.from_dict(json.loads(files["plan.json"])["search_theory"]).table()


def scenario_report(result: ScenarioResult) -> str:
    """The summary of a built-in scenario's plan and where its files went."""
    return "\n".join([summary_table(result.plan, result.bound),
                      f"plan written to {result.path}, picture {result.picture}"
                      + (f", recording {result.rrd}" if result.rrd else "")])


def grounded_lines(result: CampaignResult) -> list[str]:
    """A warning per UAV an area plan left on the ground, its range too short to leave its airport."""
    seen = dict.fromkeys((uid, why) for sortie in result.sorties for uid, why in sortie.setup.grounded.items())
    names = {ap.index + 1: ap.name for ap in result.sorties[0].setup.source.airports} if result.sorties else {}
    return [f"warning: UAV {uid} ({names.get(uid, '?')}) stays on the ground, planned without it: {why}"
            for uid, why in seen]


def area_report(result: CampaignResult) -> str:
    """Per sortie of an area plan its summary, its missions and where its files went; then the
    campaign's sorties when there are several, and where campaign.json went."""
    several = result.campaign_file is not None
    lines = []
    for sortie in result.sorties:
        if several or len(result.rows) > 1:
            lines.append(f"-- sortie {sortie.setup.belief.sortie} ({sortie.folder}) --")
        lines.append(summary_table(sortie.plan, json.loads(sortie.files["plan.json"])["summary"].get("bound")))
        lines.append(mission_table(sortie.setup, sortie.files))
        lines.append(segments_table(sortie.files))
        lines.append(f"plan, missions and paths written to {sortie.folder}/ ({', '.join(sorted(sortie.files))}), "
                     f"picture {sortie.picture.name}" + (f", recording {sortie.rrd}" if sortie.rrd else ""))
    if len(result.rows) > 1:
        lines.append(campaign_table(result.rows, result.available))
    if result.campaign_file is not None:
        lines.append(f"campaign summary written to {result.campaign_file}")
    return "\n".join(lines)
