"""vehicles.json: read, validated, merged atomically under a lock; ranges planned from it."""

from __future__ import annotations

import json
import multiprocessing
from dataclasses import replace

import pytest

from gcs.cli import main
from gcs.errors import UserError
from gcs.plans.vehicle_file import (
    STOCK_PROFILES,
    VehicleRecord,
    load_vehicles,
    merge_vehicles,
    profile_for_uav,
    stock_profile,
    vehicle_key,
    vehicles_to_dict,
)
from planner.energy import Airframe

COPTER = STOCK_PROFILES[("ardupilot", Airframe.COPTER)]


def record(key: str, uav: int, updated: str = "2026-11-27T10:00:00+00:00", capacity: float = 3300.0, flights=1):
    return VehicleRecord(key, uav, uav, "ardupilot", flights, updated, COPTER.with_capacity(capacity))


def _with_profile(**changes) -> dict:
    """A file of one stock ArduCopter whose profile has `changes` (None: the key left out)."""
    data = vehicles_to_dict({"sysid:1": record("sysid:1", 1)})
    profile = data["vehicles"]["sysid:1"]["profile"]
    for key, value in changes.items():
        if value is None:
            profile.pop(key)
        else:
            profile[key] = value
    return data


LAST_FLIGHT = {"wind": {"speed_m_s": 7.3, "from_deg": 250.0, "sigma_m_s": 0.6, "source": "its lean"},
               "heading_speeds": {"cruise_speed_m_s": 10.0,
                                  "bins": [{"towards_deg": 270.0, "seconds": 45.2, "ground_speed_m_s": 4.04}]}}


def _with_last_flight(last_flight: dict) -> dict:
    """A file of one stock ArduCopter with `last_flight` (the wind it last flew in, issue 38)."""
    data = vehicles_to_dict({"sysid:1": record("sysid:1", 1)})
    data["vehicles"]["sysid:1"]["last_flight"] = last_flight
    return data


def test_the_wind_a_vehicle_last_flew_in_round_trips(tmp_path):
    path = tmp_path / "vehicles.json"
    path.write_text(json.dumps(_with_last_flight(LAST_FLIGHT)))
    back = load_vehicles(path)["sysid:1"]
    assert back.last_flight == LAST_FLIGHT
    assert vehicles_to_dict({"sysid:1": back})["vehicles"]["sysid:1"]["last_flight"] == LAST_FLIGHT


def test_a_file_from_before_cornering_prices_every_path_by_its_metres(tmp_path):
    """A profile written before profiles priced a path by its time: its figure per metre, as then."""
    path = tmp_path / "vehicles.json"
    path.write_text(json.dumps(_with_profile(cornering=None, moving_mah_per_s=None)))
    profile = load_vehicles(path)["sysid:1"].profile
    assert profile.cornering is None and profile.moving_mah_per_s is None
    assert profile.path_mah_per_m([(0, 0), (0, 20), (20, 40), (20, 60)]) == COPTER.cruise_mah_per_m


def test_keys_name_the_board_else_the_system():
    assert vehicle_key(0x0123456789ABCDEF, 3) == "uid:0123456789abcdef"
    assert vehicle_key(0, 3) == vehicle_key(None, 3) == "sysid:3"


def test_a_file_round_trips_and_finds_the_vehicle_that_flew_as_a_uav(tmp_path):
    path = tmp_path / "vehicles.json"
    records = {"uid:0000000000000001": record("uid:0000000000000001", 1),
               "sysid:2": record("sysid:2", 2, "2026-11-27T09:00:00+00:00", 1800.0),
               "uid:00000000000000aa": record("uid:00000000000000aa", 2, "2026-11-27T11:00:00+00:00", 2200.0)}
    path.write_text(json.dumps(vehicles_to_dict(records)))
    back = load_vehicles(path)
    assert back == records
    assert profile_for_uav(back, 2).key == "uid:00000000000000aa"  # the newest of the two that flew as UAV 2
    assert profile_for_uav(back, 5) is None


def test_stock_profiles_cover_every_family():
    assert stock_profile("px4", "copter") is STOCK_PROFILES[("px4", Airframe.COPTER)]
    assert stock_profile("generic", "plane") is STOCK_PROFILES[("ardupilot", Airframe.PLANE)]


@pytest.mark.parametrize("text, says", [
    ("not json", "not a readable vehicles file"),
    ('{"schema_version": 1}', "vehicles"),
    ('{"schema_version": 1, "vehicles": {"bad key": {}}}', "bad key"),
    ('{"schema_version": 1, "vehicles": {"sysid:1": {"uav_id": 1, "system_id": 1, "autopilot": "ardupilot", '
     '"flights": 1, "updated": "x", "profile": {"airframe": "copter"}}}}', "capacity_mah"),
    (json.dumps(_with_profile(cornering={"accel_m_s2": 1.5, "corner_fractions": [[10, 1.0]]})), "start at 0 degrees"),
    (json.dumps(_with_profile(cornering={"accel_m_s2": 1.5, "corner_fractions": [[0, 1.0]]}, moving_mah_per_s=None)),
     "together"),
    (json.dumps(_with_profile(cornering={"accel_m_s2": 1.5, "corner_fractions": [[0, 1.0, 3]]})), "cornering"),
    (json.dumps(_with_last_flight({"wind": {"speed_m_s": -1, "from_deg": 250, "sigma_m_s": 1, "source": "its lean"},
                                   "heading_speeds": {"cruise_speed_m_s": 10, "bins": []}})), "last_flight"),
    (json.dumps(_with_last_flight({"wind": None, "heading_speeds": {"bins": []}})), "cruise_speed_m_s"),
])
def test_a_bad_file_is_one_line_naming_what_is_wrong(tmp_path, text, says):
    path = tmp_path / "vehicles.json"
    path.write_text(text)
    with pytest.raises(UserError, match=says) as err:
        load_vehicles(path)
    assert "\n" not in str(err.value)
    with pytest.raises(UserError, match="no such vehicles file"):
        load_vehicles(tmp_path / "none.json")


def test_merging_replaces_a_vehicle_and_keeps_the_others(tmp_path):
    path = tmp_path / "fleet" / "vehicles.json"
    merge_vehicles(path, {"sysid:1": record("sysid:1", 1), "sysid:2": record("sysid:2", 2)})
    newer = record("sysid:2", 2, "2026-11-28T10:00:00+00:00", 2500.0, flights=2)
    merged = merge_vehicles(path, {"sysid:2": newer})
    assert set(merged) == {"sysid:1", "sysid:2"} and load_vehicles(path)["sysid:2"] == newer
    assert [p.name for p in path.parent.iterdir() if not p.name.startswith(".")] == ["vehicles.json"]


def test_a_bad_file_is_left_as_it_was_by_a_merge(tmp_path):
    path = tmp_path / "vehicles.json"
    path.write_text("{broken")
    with pytest.raises(UserError):
        merge_vehicles(path, {"sysid:1": record("sysid:1", 1)})
    assert path.read_text() == "{broken"


def _merge_one(args):
    path, i = args
    merge_vehicles(path, {f"sysid:{i}": record(f"sysid:{i}", i)})


def test_stations_merging_at_once_lose_nothing(tmp_path):
    """Several processes merge into one file at the same time: the lock keeps every vehicle."""
    path = tmp_path / "vehicles.json"
    with multiprocessing.get_context("fork").Pool(4) as pool:
        pool.map(_merge_one, [(path, i) for i in range(1, 17)])
    assert set(load_vehicles(path)) == {f"sysid:{i}" for i in range(1, 17)}


def test_plan_ranges_come_from_the_vehicles_file(tmp_path, capsys):
    """gcs plan --vehicles: each UAV's range is what its vehicle's battery pays for at its
    altitude, the reserve kept; a UAV whose vehicle is not in the file keeps the file's range."""
    small = COPTER.with_capacity(1800.0)
    path = tmp_path / "vehicles.json"
    path.write_text(json.dumps(vehicles_to_dict({"sysid:1": replace(record("sysid:1", 1), profile=small)})))
    out = tmp_path / "plan"
    assert main(["plan", "--area", "missions/paper.geojson", "--out", str(out), "--vehicles", str(path),
                 "--reserve-pct", "25", "--quiet", "--no-rrd"]) == 0
    uavs = {u["id"]: u for u in json.loads((out / "plan.json").read_text())["uavs"]}
    straight_m = small.range_m(uavs[1]["altitude_m"], 25.0)
    assert "sysid:1" in uavs[1]["range_source"] and "1800 mAh" in uavs[1]["range_source"]
    if "fitted to" in uavs[1]["range_source"]:  # its path's corners priced (gcs.plans.charge_fit)
        assert uavs[1]["range_m"] < straight_m and f"of the {straight_m:.0f} m" in uavs[1]["range_source"]
    else:
        assert uavs[1]["range_m"] == pytest.approx(straight_m, abs=1e-3)
    assert uavs[2]["range_m"] == 3700 and "range_source" not in uavs[2]
    assert uavs[1]["range_used_m"] <= uavs[1]["range_m"]
    bad = tmp_path / "bad.json"
    bad.write_text("[]")
    code = main(["plan", "--area", "missions/paper.geojson", "--out", str(tmp_path / "x"), "--vehicles", str(bad),
                 "--quiet", "--no-rrd"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "vehicles schema" in err and not (tmp_path / "x").exists()


def test_the_issues_small_pack_stays_on_the_ground_and_the_fleet_is_planned_without_it(tmp_path, capsys):
    """Issue 23's 1800 mAh ArduCopter on the field's 50 m cells: its range (510 m with the 30 %
    reserve, 440 m over the grid) is shorter than the shortest loop out of its airport and home
    under 3OC, so UAV 2 stays on the ground with its reason and UAVs 1 and 3 are planned."""
    from tests.peers.site import FIELD_COPTERS

    path = tmp_path / "vehicles.json"
    path.write_text(json.dumps(vehicles_to_dict({"sysid:2": record("sysid:2", 2, capacity=1800.0)})))
    out = FIELD_COPTERS.plan(tmp_path, "--vehicles", str(path))
    err = capsys.readouterr().err
    plan = json.loads((out / "plan.json").read_text())
    assert [u["id"] for u in plan["uavs"]] == [1, 3]
    [grounded] = plan["grounded"]
    assert grounded["id"] == 2 and "too short to leave its airport and come back under 3OC" in grounded["reason"]
    range_m = COPTER.with_capacity(1800.0).range_m(60.0, 30.0)
    assert f"range {range_m:.0f} m" in grounded["reason"] and 300 < range_m < 527
    assert f"warning: UAV 2 (south) stays on the ground, planned without it: range {range_m:.0f} m" in err
