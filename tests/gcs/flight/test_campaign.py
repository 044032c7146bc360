"""Sortie after sortie (docs/campaigns.md): `gcs fly` leaves the posterior of the flight's real
readings, the tracks and the detections in the plan folder; `gcs plan --continue` plans the next
sortie from it with fresh batteries; bad folders are refused with the reason."""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from gcs.cli import main
from gcs.flight.events import ReadingReceived
from gcs.flight.sortie import SortieLog
from gcs.plans.belief_file import file_sha256, validate_belief_dict, validate_sortie_dict
from gcs.plans.campaign import continued_start
from gcs.plans.charge_fit import fit_ranges_to_paths
from gcs.plans.options import options_record
from gcs.plans.plan_file import validate_plan_dict
from gcs.plans.plan_folder import load_plan_dir
from gcs.plans.planning import build_area_search
from gcs.plans.vehicle_file import load_vehicles, profile_for_uav
from gcs.telemetry.status import Detection
from planner.motion import OC3
from planner.success import expected_finds
from tests.gcs.flight.conftest import fly
from tests.planner.helpers import assert_plan_safe

SPEEDUP = "60"


def _json(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def _grid(rows) -> np.ndarray:
    return np.asarray(rows, dtype=float)


def closed_form_posterior(p0: np.ndarray, eu0: np.ndarray, cells_hits, pc: float, pf: float):
    """The posterior of independent readings on odds (the reference, not eq. 2-4 applied in
    turn): each report multiplies a cell's odds by Pc/Pf, each silent look by (1-Pc)/(1-Pf)."""
    hits, misses = np.zeros(p0.shape), np.zeros(p0.shape)
    for (x, y), hit in cells_hits:
        (hits if hit else misses)[x, y] += 1
    inner = (p0 > 0) & (p0 < 1)
    odds = np.where(inner, p0 / np.where(inner, 1 - p0, 1) * (pc / pf) ** hits * ((1 - pc) / (1 - pf)) ** misses, 0)
    return np.where(inner, odds / (1 + odds), p0), eu0 * 0.5 ** (hits + misses), hits, misses


@pytest.fixture(scope="module")
def campaign(tmp_path_factory, flight_area):
    """Sortie 1 of the paper area (at the test flights' range) flown by `gcs fly --area ... --sim`
    (the area file copied, so tests may change it)."""
    base = tmp_path_factory.mktemp("campaign")
    area = base / "paper.geojson"
    shutil.copy(flight_area, area)
    first = base / "paper"
    assert main(["fly", "--area", str(area), "--sim", "--speedup", SPEEDUP, "--out", str(first), "--no-rrd",
                 "--link-timeout", "2"]) == 0
    return SimpleNamespace(base=base, area=area, first=first)


def test_a_flight_leaves_the_posterior_of_its_readings_its_tracks_and_its_detections(campaign):
    folder = campaign.first
    record, plan, prior = _json(folder / "sortie.json"), _json(folder / "plan.json"), _json(folder / "belief.json")
    validate_sortie_dict(record)
    validate_belief_dict(prior)
    assert record["sortie"] == 1 and record["finished"] is True and record["reason"] is None and record["observed"]
    assert record["plan_sha256"] == file_sha256(folder / "plan.json")
    assert record["area"] == {"file": str(campaign.area.resolve()), "sha256": file_sha256(campaign.area)}
    log = record["reading_log"]
    assert len(log) == record["readings"]["count"] == sum(v["readings"] for v in record["vehicles"]) > 180
    assert record["readings"]["positive"] == sum(r[4] for r in log) > 0
    assert all(v["end"] == "landed" for v in record["vehicles"])
    # what the crew's summary said of each vehicle, and the charge it came down with
    assert all(re.fullmatch(r"battery \d+%, [\d.]+ m from its airport", v["note"]) for v in record["vehicles"])
    assert all(25.0 < v["battery_pct"] <= 100.0 for v in record["vehicles"])  # reserve 30 %, less the slack

    options = plan["campaign"]["options"]
    pc, pf = options["pc"], options["pf"]
    p0, eu0 = _grid(prior["tep"]), _grid(prior["eu"])
    tep, eu = closed_form_posterior(p0, eu0, [((x - 1, y - 1), hit) for _, _, x, y, hit, _ in log], pc, pf)[:2]
    belief = record["belief"]
    assert np.allclose(_grid(belief["tep"]), tep, rtol=1e-9, atol=1e-15)
    assert np.allclose(_grid(belief["eu"]), eu, rtol=1e-12)
    looks = np.zeros(p0.shape, dtype=int)
    for _, _, x, y, _, _ in log:
        looks[x - 1, y - 1] += 1
    assert np.array_equal(np.asarray(belief["looks"]), looks)
    assert np.array_equal(np.asarray(belief["sortie_looks"]), looks)
    negative_only = looks > 0
    for _, _, x, y, hit, _ in log:
        negative_only[x - 1, y - 1] &= not hit
    assert np.all(_grid(belief["tep"])[negative_only] <= p0[negative_only])
    searchable = np.ones(p0.shape, dtype=bool)
    for x, y in plan["grid"]["no_fly"]:
        searchable[x - 1, y - 1] = False
    assert record["campaign"]["expected_after"] == pytest.approx(expected_finds(p0, searchable, pc, looks), rel=1e-12)
    assert record["campaign"]["expected_before"] == 0.0
    theory = record["search_theory"]  # the crew's figures of what the flight read, over the plan's segments
    assert [g["name"] for g in theory["segments"]] == [g["name"] for g in plan["search_theory"]["segments"]]
    assert sum(g["poa"] for g in theory["segments"]) == pytest.approx(1.0, abs=1e-5)
    assert theory["pos"] == pytest.approx(record["campaign"]["pos_after"], abs=1e-5)
    assert all(g["pos"] == pytest.approx(g["poa"] * g["pod"], abs=2e-6) for g in theory["segments"])

    tracks = _json(folder / "tracks.geojson")["features"]
    fleet = load_plan_dir(folder)
    assert [t["properties"]["uav"] for t in tracks] == sorted(fleet.uavs)
    for t in tracks:
        coords = t["geometry"]["coordinates"]
        airport = fleet.uavs[t["properties"]["uav"]].airport_lat_lon
        assert len(coords) > 20 and t["properties"]["end"] == "landed"
        for lon, lat in (coords[0], coords[-1]):
            assert np.hypot(*np.subtract(fleet.local_m(lat, lon), fleet.local_m(*airport))) < 2 * fleet.cell_size_m
    detections = _json(folder / "detections.geojson")["features"]
    assert len(detections) == record["readings"]["positive"]
    hits = {(r[0], r[1]): (r[2], r[3]) for r in log if r[4]}
    assert all(tuple(d["properties"]["cell"]) == hits[(d["properties"]["uav"], d["properties"]["index"])]
               for d in detections)
    # the exercise's true targets the flight found (a report in their cell) go on record for the next sortie
    truth = {(t["x"], t["y"]) for t in plan["targets"]}
    reported = {(x, y) for _, _, x, y, hit, _ in log if hit}
    assert truth & reported, "the test flight found no target: the record of found targets goes untested"
    assert belief.get("found_targets", []) == [[x, y, 1] for x, y in sorted(truth & reported)]


def test_a_flight_leaves_its_tracks_and_detections_as_kml_and_gpx(campaign):
    """tracks.kml/.gpx and detections.kml/.gpx, read back with GDAL, hold what the GeoJSON files
    hold: every vehicle's track point for point, every positive reading where it was taken."""
    import pyogrio
    import pyogrio.raw
    import shapely

    folder = campaign.first
    for stem, layers in (("tracks", {".kml": "tracks", ".gpx": "tracks"}),
                         ("detections", {".kml": "detections", ".gpx": "waypoints"})):
        features = _json(folder / f"{stem}.geojson")["features"]
        assert features
        for suffix, layer in layers.items():
            path = folder / f"{stem}{suffix}"
            assert pyogrio.read_info(path, layer=layer)["driver"] == ("LIBKML" if suffix == ".kml" else "GPX")
            meta, _, wkb, columns = pyogrio.raw.read(path, layer=layer)
            fields = dict(zip(meta["fields"], columns))
            assert len(wkb) == len(features)
            names = list(fields["Name" if suffix == ".kml" else "name"])
            uav = fields["uav" if suffix == ".kml" else "ogr_uav"]
            for k, feature in enumerate(features):
                props = feature["properties"]
                assert int(uav[k]) == props["uav"]
                expected = np.asarray(feature["geometry"]["coordinates"], dtype=float).reshape(-1, 2)
                read = shapely.get_coordinates(shapely.from_wkb(wkb[k]))
                assert read.shape == expected.shape and np.abs(read - expected).max() < 1e-9
                if stem == "tracks":
                    assert names[k] == f"UAV {props['uav']}"
                else:
                    assert names[k] == f"UAV {props['uav']} reading {props['index']}"


def test_gcs_fly_area_plans_what_gcs_plan_area_plans_with_the_same_defaults(campaign, tmp_path):
    """`gcs fly --area` calls the planning `gcs plan --area` calls, with the same options and
    defaults (the paper's CPIO among them): the same plan, missions and belief."""
    out = tmp_path / "planned"
    assert main(["plan", "--area", str(campaign.area), "--out", str(out), "--no-rrd", "--quiet"]) == 0
    flown_plan = _json(campaign.first / "plan.json")
    assert flown_plan["settings"]["strategy"] == "cpio"

    def text(folder, name):  # (the campaign rows name the folder)
        return (folder / name).read_text().replace(str(campaign.area.resolve()), "AREA").replace(str(folder), "OUT")

    for name in ("plan.json", "belief.json", "paths.geojson", "uav1.waypoints", "uav4.plan"):
        assert text(out, name) == text(campaign.first, name), name


def _search_cells(plan: dict) -> list[tuple[int, int]]:
    return [(p["x"] - 1, p["y"] - 1) for u in plan["uavs"] for p in u["trajectory"][1:] if p["stage"] == "search"]


def test_the_next_sortie_plans_from_the_posterior_with_fresh_batteries_and_stays_closed(campaign, capsys):
    first, second = campaign.first, campaign.first.parent / "paper-sortie2"
    assert main(["plan", "--continue", str(first), "--no-rrd"]) == 0  # default --out: FOLDER-sortie2
    printed = capsys.readouterr().out
    record, plan1, plan2 = _json(first / "sortie.json"), _json(first / "plan.json"), _json(second / "plan.json")
    validate_plan_dict(plan2)
    c = plan2["campaign"]
    assert c["sortie"] == 2 and c["belief"] == "flight" and c["continued_from"] == str(first)
    learned = str((first / "vehicles.json").resolve())  # what the flight's vehicles taught prices sortie 2
    assert c["options"] == {**plan1["campaign"]["options"], "vehicles": learned}
    assert c["area"] == plan1["campaign"]["area"]
    assert plan2["seed"] == plan1["seed"] + 1_000_003  # a sortie's own seed
    assert [r["status"] for r in c["sorties"]] == ["flown", "planned"]
    assert c["sorties"][0]["readings"] == record["readings"]["count"]
    assert c["pos_before"] == pytest.approx(record["campaign"]["pos_after"], abs=1e-6)
    assert c["pos_after"] > c["pos_before"] + 0.05  # the cumulative probability of success rises
    assert c["expected_after"] == pytest.approx(c["expected_before"] + plan2["summary"]["expected_targets_found"],
                                                abs=1e-5)
    assert "campaign: the prior puts" in printed and "flown" in printed
    belief = _json(second / "belief.json")
    validate_belief_dict(belief)
    assert belief["source"] == "flight" and belief["sortie"] == 2 and belief["tep"] == record["belief"]["tep"]
    # targets the flight found are no longer there to find: drawn and counted as found before, not missed
    found = {tuple(t[:2]) for t in record["belief"]["found_targets"]}
    assert belief["found_targets"] == record["belief"]["found_targets"]
    assert {(t["x"], t["y"]) for t in plan2["targets"]} == {(t["x"], t["y"]) for t in plan1["targets"]} - found
    assert [(t["x"], t["y"], t["sortie"]) for t in plan2["targets_found_before"]] == \
        [(x, y, 1) for x, y in sorted(found)]
    assert plan2["summary"]["targets"] == len(plan1["targets"]) - len(found)
    assert f"({len(found)} found by earlier sorties)" in printed
    vehicles = load_vehicles(learned)
    for u1, u2 in zip(plan1["uavs"], plan2["uavs"]):  # fresh batteries, ranges from the learned profiles
        vehicle = profile_for_uav(vehicles, u2["id"])
        assert vehicle is not None and "range_source" not in u1
        assert u2["range_source"].startswith(  # then the charge fit's, where it fitted (gcs.plans.charge_fit)
            f"{learned}: vehicle {vehicle.key}, {vehicle.profile.capacity_mah:.0f} mAh, 30% reserve")
        straight_m = vehicle.profile.range_m(u2["altitude_m"], 30.0)
        if "fitted to" in u2["range_source"]:
            assert u2["range_m"] < straight_m and f"of the {straight_m:.0f} m it pays for" in u2["range_source"]
        else:
            assert u2["range_m"] == pytest.approx(straight_m, abs=1.0)

    # closed and legal: the same sortie planned again from the options plan.json recorded, checked step by step
    nxt = continued_start(first)
    assert (nxt.area_file, Path(nxt.out)) == (campaign.area.resolve(), second.resolve())
    assert options_record(nxt.area, nxt.search) == c["options"]
    setup = build_area_search(nxt.area_file, nxt.area, nxt.search, nxt.start.belief)
    setup, _ = fit_ranges_to_paths(setup, load_vehicles(nxt.area.vehicles))  # as `gcs plan` does with --vehicles
    for _ in setup.search.run():
        pass
    replanned = setup.search.plan()
    assert_plan_safe(replanned, setup.search.scenario, OC3)
    assert [[(p.x + 1, p.y + 1) for p in u.trajectory] for u in replanned.uavs] == \
        [[(p["x"], p["y"]) for p in u["trajectory"]] for u in plan2["uavs"]]

    # what the first sortie read empty and the belief now ranks below unsearched ground is left alone
    p0, posterior = _grid(belief["p0"]), _grid(belief["tep"])
    looks = np.asarray(record["belief"]["sortie_looks"])
    searchable = np.ones(p0.shape, dtype=bool)
    for x, y in plan2["grid"]["no_fly"]:
        searchable[x - 1, y - 1] = False
    low = (looks > 0) & (posterior < np.median(posterior[(looks == 0) & searchable]) - 1e-9)
    cells = _search_cells(plan2)
    again = sum(low[c] for c in cells) / len(cells)
    first_cells = _search_cells(plan1)
    print(f"sortie 2 search steps over cells sortie 1 read empty: {again:.1%} (sortie 1 flew {low.sum()} such cells "
          f"in {len(first_cells)} steps); campaign PoS {c['pos_before']:.1%} -> {c['pos_after']:.1%}")
    assert again < 0.05
    assert (second / "plan.png").exists()


def test_sortie_after_sortie_the_campaign_counts_every_flight(campaign, capsys):
    second = campaign.first.parent / "paper-sortie2"
    if not (second / "plan.json").exists():
        assert main(["plan", "--continue", str(campaign.first), "--no-rrd", "--quiet"]) == 0
    assert main(["fly", "--plan", str(second), "--sim", "--speedup", SPEEDUP, "--no-rrd", "--link-timeout", "2"]) == 0
    printed = capsys.readouterr().out
    record = _json(second / "sortie.json")
    assert record["sortie"] == 2 and record["finished"] and "sortie 2 recorded" in printed
    first_record = _json(campaign.first / "sortie.json")
    assert record["campaign"]["expected_before"] == pytest.approx(first_record["campaign"]["expected_after"])
    assert record["campaign"]["pos_after"] > record["campaign"]["pos_before"]
    looks = np.asarray(record["belief"]["looks"])
    assert np.array_equal(looks, np.asarray(first_record["belief"]["looks"])
                          + np.asarray(record["belief"]["sortie_looks"]))

    third = campaign.base / "third"
    assert main(["plan", "--continue", str(second), "--out", str(third), "--no-rrd", "--quiet"]) == 0
    c = _json(third / "plan.json")["campaign"]
    assert [(r["sortie"], r["status"]) for r in c["sorties"]] == [(1, "flown"), (2, "flown"), (3, "planned")]
    third_plan = _json(third / "plan.json")  # every target found so far, each with the sortie that found it
    found_first = {tuple(t[:2]) for t in first_record["belief"].get("found_targets", [])}
    assert {(t["x"], t["y"]) for t in third_plan["targets_found_before"] if t["sortie"] == 1} == found_first
    assert not {(t["x"], t["y"]) for t in third_plan["targets"]} & {
        (t["x"], t["y"]) for t in third_plan["targets_found_before"]}
    cumulative = [r["cumulative_pos"] for r in c["sorties"]]
    assert cumulative == sorted(cumulative) and cumulative[0] < cumulative[-1]
    assert c["sorties"][1]["cumulative_pos"] == pytest.approx(record["campaign"]["pos_after"], abs=1e-6)
    assert c["sorties"][1]["expected_targets_found"] == pytest.approx(record["campaign"]["expected_targets_found"],
                                                                      abs=1e-5)


def test_a_sortie_planned_on_learned_profiles_is_flown_on_them_and_not_without_them(campaign, tmp_path, capsys):
    """`gcs fly` prices the sortie with the vehicles file its ranges came from (on the stock
    profile the simulated vehicles' 10100 mAh would not pay for that plan); when that file is gone
    it says so in one line and flies nothing."""
    first = _copy_plan(campaign.first, tmp_path / "first")
    second = tmp_path / "second"
    assert main(["plan", "--continue", str(first), "--out", str(second), "--no-rrd", "--quiet"]) == 0
    assert _json(second / "plan.json")["campaign"]["options"]["vehicles"] == str((first / "vehicles.json").resolve())
    (first / "vehicles.json").unlink()
    capsys.readouterr()
    assert main(["fly", "--plan", str(second), "--sim", "--speedup", SPEEDUP, "--no-rrd"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "was planned with the energy profiles of" in err and "give --vehicles FILE" in err
    assert not (second / "sortie.json").exists()


def _copy_plan(plan_dir: Path, to: Path) -> Path:
    shutil.copytree(plan_dir, to)
    return to


def test_a_vehicle_without_readings_still_leaves_its_track_and_the_prior(plan_dir, tmp_path):
    """A real vehicle without `gcs detector` sends no readings: nothing was observed."""
    folder = _copy_plan(plan_dir, tmp_path / "plan")
    plan = load_plan_dir(folder)
    log = SortieLog(plan)

    def no_sensor(fleet):
        for uid in plan.uavs:
            sensor = fleet.vehicle(uid).sensor
            sensor.config = replace(sensor.config, min_alt_m=1e9)

    fly(plan, during=no_sensor, watchers=[log])
    record = _json(folder / "sortie.json")
    validate_sortie_dict(record)
    assert record["finished"] and not record["observed"] and record["readings"]["count"] == 0
    assert record["belief"]["tep"] == _json(folder / "belief.json")["tep"]
    assert record["campaign"]["expected_after"] == 0.0
    tracks = _json(folder / "tracks.geojson")["features"]
    assert len(tracks) == len(plan.uavs) and all(len(t["geometry"]["coordinates"]) > 20 for t in tracks)
    assert _json(folder / "detections.geojson")["features"] == []
    assert "nothing was observed" in log.report()


@pytest.fixture(scope="module")
def reading_plan(tmp_path_factory, plan_dir):
    return load_plan_dir(_copy_plan(plan_dir, tmp_path_factory.mktemp("readings") / "plan"))


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_the_posterior_never_says_more_than_the_readings(reading_plan, data):
    """Any stream of readings, in any order, outside the grid too: a cell ends where its readings
    put it and no higher (a cell read only negatively never above its prior); unread cells keep it."""
    plan = reading_plan
    log = SortieLog(plan)
    start = log.start.search_map
    nx, ny = start.shape
    cell = st.tuples(st.integers(0, nx - 1), st.integers(0, ny - 1))
    readings = data.draw(st.lists(st.tuples(st.sampled_from(sorted(plan.uavs)), cell, st.booleans()), max_size=80))
    for i, (uid, (x, y), hit) in enumerate(readings):
        lat, lon = plan.cell_lat_lon(x, y)
        log.on_event(ReadingReceived(uid, Detection(i, lat, lon, hit, float(i))), 0.0)
    log.on_event(ReadingReceived(1, Detection(999, 0.0, 0.0, True, 0.0)), 0.0)  # far outside the grid
    assert sum(r.cell is None for r in log.readings) == 1
    tep, eu, hits, misses = closed_form_posterior(start.tep, start.eu, [(c, h) for _, c, h in readings], log.pc, log.pf)
    got = log.belief.search_map
    assert np.allclose(got.tep, tep, rtol=1e-9, atol=1e-15) and np.allclose(got.eu, eu)
    negative_only = (misses > 0) & (hits == 0)
    assert np.all(got.tep[negative_only] <= start.tep[negative_only])
    unread = hits + misses == 0
    assert np.array_equal(got.tep[unread], start.tep[unread])
    assert np.array_equal(got.visits, hits + misses)


def test_an_interrupted_flight_is_recorded_as_unfinished_and_cannot_be_continued(plan_dir, tmp_path, capsys):
    folder = _copy_plan(plan_dir, tmp_path / "plan")
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "fly", "--plan", str(folder), "--sim", "--speedup", "10",
                             "--no-rrd", "--link-timeout", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=tmp_path)
    for line in proc.stdout:
        if "mission started" in line:
            break
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=120)
    assert proc.returncode == 130
    record = _json(folder / "sortie.json")
    assert record["finished"] is False and "stopped by the operator" in record["reason"]
    out = tmp_path / "next"
    assert main(["plan", "--continue", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:")
    assert "the flight did not finish (the flight was stopped" in err[0]
    assert not out.exists()


def _break_nothing(folder, campaign):
    return []


def _no_record(folder, campaign):
    (folder / "sortie.json").unlink()
    return []


def _plan_changed(folder, campaign):
    with open(folder / "plan.json", "a", encoding="utf-8") as fh:
        fh.write("\n")
    return []


def _not_json(folder, campaign):
    (folder / "sortie.json").write_text("{ half a record", encoding="utf-8")
    return []


def _found_off_the_grid(folder, campaign):
    data = _json(folder / "sortie.json")
    data["belief"]["found_targets"] = [[0, 5, 1]]
    (folder / "sortie.json").write_text(json.dumps(data), encoding="utf-8")
    return []


def _no_campaign(folder, campaign):
    data = _json(folder / "plan.json")
    del data["campaign"]
    (folder / "plan.json").write_text(json.dumps(data), encoding="utf-8")
    return []


@pytest.mark.parametrize("damage, extra, message", [
    (None, [], "no such folder"),
    (_no_record, [], "this plan was never flown; fly it first"),
    (_plan_changed, [], "plan.json changed since the flight"),
    (_not_json, [], "sortie.json is not readable JSON"),
    (_no_campaign, [], "has no campaign record"),
    (_found_off_the_grid, [], "found_targets must be [x, y, sortie] of cells in the grid"),
    (_break_nothing, ["--strategy", "cpio", "--np", "3"], "leave out --np, --strategy"),
    (_break_nothing, ["--area", "x.geojson"], "leave out --area"),
    (_break_nothing, ["--out", "SAME"], "that is the folder being continued"),
    (_break_nothing, ["--out", "FLOWN"], "holds a flown sortie (sortie.json)"),
])
def test_continue_refuses_a_folder_that_is_not_a_finished_flight(campaign, tmp_path, capsys, damage, extra, message):
    folder = tmp_path / "flown"
    if damage is not None:
        shutil.copytree(campaign.first, folder)
        damage(folder, campaign)
    out = tmp_path / "next"
    if "FLOWN" in extra:  # another flown sortie's folder
        out = shutil.copytree(campaign.first, tmp_path / "other")
    before = sorted(p.name for p in out.iterdir()) if out.exists() else None
    extra = [str(folder) if e == "SAME" else str(out) if e == "FLOWN" else e for e in extra]
    args = ["plan", "--continue", str(folder)] + (extra if "--out" in extra else extra + ["--out", str(out)])
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0], err
    assert (sorted(p.name for p in out.iterdir()) if out.exists() else None) == before  # nothing written


@pytest.mark.parametrize("change, message", [
    ("edit", "changed since the plan was made"),
    ("remove", "is gone; put it back"),
])
def test_continue_refuses_when_the_area_file_changed_or_is_gone(campaign, tmp_path, capsys, change, message):
    original = campaign.area.read_bytes()
    try:
        if change == "edit":
            doc = json.loads(original)
            doc["features"][0]["properties"]["name"] = "renamed"
            campaign.area.write_text(json.dumps(doc), encoding="utf-8")
        else:
            campaign.area.unlink()
        out = tmp_path / "next"
        assert main(["plan", "--continue", str(campaign.first), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0] and str(campaign.area.resolve()) in err[0], err
        assert not out.exists()
    finally:
        campaign.area.write_bytes(original)
