"""Issue 23 on real autopilots: fleets fly the issue's field with stock energy profiles and spend
their batteries on the search, in still air and in a gusty 8 m/s wind; a learned profile closes
the loop; a vehicle whose charge cannot pay for its plan stays on the ground, naming both
figures; a copter that comes down away from its airport is reported for its crew to fetch.

Each vehicle is judged by an independent recorder on its own spare port (`tests.gcs.autopilots.
fleets`): it passes 90 % of its planned waypoints, or it comes home by fuel and touches down
within [reserve - 5, reserve + 10] %."""

from __future__ import annotations

import json
import re

import pytest

from tests.gcs.autopilots.fleets import RESERVE_PCT, WIND, FleetFlight, Vehicle, fly_fleet
from tests.peers.ardupilot import require_ardupilot
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import require_px4
from tests.peers.site import FIELD_COPTERS, FIELD_COPTERS_SHORT, FIELD_PLANES

#: each flies a fleet of three to its end (several minutes of vehicle time); one at a time, in
#: the real autopilots' worker (tests/peers/process.py)
pytestmark = [pytest.mark.autopilot, pytest.mark.timeout(900), SITL_WORKER]

#: PX4 SIH's stock battery halves in the first 30 s armed and stays there (docs/energy.md): no
#: pack a flight can be priced by. Our PX4 vehicles drain from full to empty in 20 minutes armed.
PX4_PACK = {"SIM_BAT_DRAIN": 1200.0, "SIM_BAT_MIN_PCT": 0.0}

#: UAV 2 with a small pack: 2200 mAh. The issue's 1800 mAh pays, after the launch, the landing and
#: the 30 % reserve, for about 500 m, less than the shortest way out of its airport and home under
#: 3OC on these 50 m cells (527 m): `gcs fly` keeps it on the ground, saying so (the refusal test)
COPTERS = [Vehicle(), Vehicle(params={"BATT_CAPACITY": 2200}), Vehicle()]
PLANES = [Vehicle(airframe="plane")] * 3
MIXED = [Vehicle(), Vehicle("px4", params=PX4_PACK), Vehicle("px4", params=PX4_PACK)]
#: Two PX4s at 8 (PX4_SPEEDUP) need more than the machine's two cores: the mixed fleet's flight
#: took as long (163 s) as at 5 (157-167 s); at 6.5, 122 s (an idle machine; docs/tests.md)
PX4_FLEET_SPEEDUP = 6.5


def judge(flight) -> None:
    """Every vehicle flew its search or spent its battery on it; the profile's prediction held."""
    for v in flight.verdicts.values():
        assert v.flew_its_search or (v.returned in ("battery", "range") and v.spent_its_battery), \
            f"{v}\n{flight.stdout[-4000:]}"
        assert v.landed_m is not None, f"{v}\n{flight.stdout[-4000:]}"
    assert flight.returncode == 0, flight.stdout[-4000:]


def judge_still_air(flight, fleet: list[Vehicle]) -> None:
    """`judge`, each prediction within 5 % where the autopilot measures its current, and no wind
    read from a copter's lean in still air (issue 38: a wind that cannot be told from none is not
    said). ArduPlane's own WIND reads 1.1-1.5 m/s in SITL's still air: said as its autopilot's."""
    judge(flight)
    assert not re.search(r"UAV \d: wind [\d.]+ ± [\d.]+ m/s .*\(its lean\)", flight.stdout), flight.stdout[-4000:]
    for speed in re.findall(r"UAV \d: wind ([\d.]+) ± [\d.]+ m/s .*\(its autopilot\)", flight.stdout):
        assert float(speed) <= 2.0, flight.stdout[-4000:]
    errors = flight.energy_errors()
    assert set(errors) == set(flight.verdicts), flight.stdout[-4000:]
    # the prediction is held to 5 % where the autopilot measures its current; PX4 SIH reports
    # only a percentage that rises with thrust (docs/energy.md): its "used" is no measurement
    measured = {i + 1 for i, v in enumerate(fleet) if v.autopilot != "px4"}
    assert all(abs(errors[u]) <= 5.0 for u in measured), f"{errors}\n{flight.stdout[-6000:]}"


@pytest.fixture(scope="module")
def copters_in_still_air(tmp_path_factory: pytest.TempPathFactory) -> FleetFlight:
    """The three ArduCopters (one with a small pack) fly the field once with stock profiles: one
    test judges that flight, another plans the next from the profiles it learned (one flight of
    the real autopilots' worker, not two)."""
    require_ardupilot()
    return fly_fleet(tmp_path_factory.mktemp("copters-still-air"), FIELD_COPTERS, COPTERS, "--fit-charge")


def test_three_copters_one_with_a_small_pack_spend_their_batteries_on_the_search_in_still_air(copters_in_still_air):
    judge_still_air(copters_in_still_air, COPTERS)


@pytest.mark.parametrize("fleet, site, extra, wind, crew_wind", [
    pytest.param(PLANES, FIELD_PLANES, ("--vehicle", "plane"), False, False, id="still air-3 ArduPlane"),
    pytest.param(MIXED, FIELD_COPTERS_SHORT, (), False, False, id="still air-ArduCopter and 2 PX4"),
    pytest.param(COPTERS, FIELD_COPTERS, (), True, True, id="8 m/s wind-3 ArduCopter, one small pack"),
    pytest.param(PLANES, FIELD_PLANES, ("--vehicle", "plane"), True, True, id="8 m/s wind-3 ArduPlane"),
    # no crew's figure: the wind only the copters read in the air, from their lean in steady flight
    # (gcs/flight/lean_wind.py) and the ground speed each way makes good; stock packs (a 2200 mAh one
    # would fly a loop it cannot pay for in that wind, docs/energy.md). No PX4 fleet in wind: SIH
    # v1.15.3 has none, its vehicles would fly the still-air flight again
    pytest.param([Vehicle()] * 3, FIELD_COPTERS, (), True, False, id="8 m/s wind read in flight-3 ArduCopter"),
])
def test_a_fleet_spends_its_batteries_on_the_search(tmp_path, fleet, site, extra, wind, crew_wind):
    require_ardupilot()
    px4 = any(v.autopilot == "px4" for v in fleet)
    if px4:
        require_px4()
    speedup = PX4_FLEET_SPEEDUP if px4 else 10.0
    crew = ("--wind", f"{WIND['SIM_WIND_SPD']:g}@{WIND['SIM_WIND_DIR']:g}") if crew_wind else ()
    flight = fly_fleet(tmp_path, site, fleet, "--fit-charge", *crew, plan_args=extra, wind=wind, speedup=speedup)
    if wind:  # the bound in wind: nobody below reserve - 5; one whose charge cannot pay in it stays down
        for v in flight.verdicts.values():
            if v.touchdown_pct is None:
                assert re.search(rf"UAV {v.uav}: failed - not armed: .* in the wind", flight.stdout), \
                    f"{v}\n{flight.stdout[-4000:]}"
            else:
                assert v.touchdown_pct >= RESERVE_PCT - 5, f"{v}\n{flight.stdout[-4000:]}"
        assert any(v.touchdown_pct is not None for v in flight.verdicts.values())
        if not crew_wind:  # issue 38: the search flown or the battery spent on it, and the charge foreseen
            assert re.search(r"UAV \d: wind [\d.]+ ± [\d.]+ m/s from \d+ deg \(its lean\)", flight.stdout), \
                flight.stdout[-4000:]
            errors = flight.energy_errors()
            for v in flight.verdicts.values():
                assert v.flew_its_search or (v.touchdown_pct is not None
                                             and RESERVE_PCT - 5 <= v.touchdown_pct <= RESERVE_PCT + 12), \
                    f"{v}\n{flight.stdout[-4000:]}"
                assert abs(errors[v.uav]) <= 10.0, f"{errors}\n{flight.stdout[-4000:]}"
            # vehicles.json keeps the wind each was flown in and what each way made good in it
            records = json.loads((flight.plan_dir / "vehicles.json").read_text())["vehicles"].values()
            for r in records:
                wind, speeds = r["last_flight"]["wind"], r["last_flight"]["heading_speeds"]["bins"]
                assert wind["source"] == "its lean" and abs((wind["from_deg"] - 250.0 + 180.0) % 360.0 - 180.0) < 20.0
                assert min(b["ground_speed_m_s"] for b in speeds) < 8.0, speeds  # held back into the wind
    else:
        judge_still_air(flight, fleet)


def test_a_learned_profile_plans_a_flight_that_spends_the_battery(tmp_path, copters_in_still_air):
    """Fly once with stock profiles, plan again with the vehicles.json that flight wrote, fly
    again: every vehicle flies its new plan and lands with at most reserve + 10 %."""
    first = copters_in_still_air
    learned = first.plan_dir / "vehicles.json"
    assert learned.exists(), first.stdout[-3000:]
    records = json.loads(learned.read_text())["vehicles"]
    assert {r["uav_id"] for r in records.values()} == {1, 2, 3}
    assert {r["uav_id"]: r["profile"]["capacity_mah"] for r in records.values()}[2] == 2200
    plan_dir = FIELD_COPTERS.plan(tmp_path / "second", "--vehicles", str(learned))
    second = fly_fleet(tmp_path / "second", FIELD_COPTERS, COPTERS, "--vehicles", str(learned), plan_dir=plan_dir)
    for v in second.verdicts.values():
        assert v.flew_its_search and v.touchdown_pct is not None and v.touchdown_pct <= RESERVE_PCT + 10, \
            f"{v}\n{second.stdout[-4000:]}"
    assert second.returncode == 0, second.stdout[-3000:]


def test_a_vehicle_whose_charge_cannot_pay_for_its_plan_stays_on_the_ground_naming_both(tmp_path):
    require_ardupilot()
    fleet = [Vehicle(), Vehicle(params={"BATT_CAPACITY": 1800}), Vehicle()]
    flight = fly_fleet(tmp_path, FIELD_COPTERS, fleet)
    out = flight.stdout
    assert "UAV 2: failed - not armed: charge 100% = 1800 mAh pays for" in out, out[-3000:]
    assert "the plan needs" in out and "--fit-charge" in out
    assert flight.returncode == 1
    assert flight.verdicts[2].passed == 0 and not flight.flown[2].armed_seen
    # the sortie record keeps why it stayed down
    record = json.loads((tmp_path / "field" / "plan" / "sortie.json").read_text())
    grounded = next(v for v in record["vehicles"] if v["id"] == 2)
    assert grounded["end"] == "failed" and grounded["note"].startswith("not armed: charge 100% = 1800 mAh pays for")


def test_a_range_cut_that_cannot_fly_its_shortest_way_out_and_home_is_not_flown_and_a_copter_down_away_is_reported(
        tmp_path):
    """One flight for two checks (a SITL start fewer). `--fit-charge` flies a range cut to the
    charge, but not one shorter than the plan's first step and the way home from it: UAV 2's
    1800 mAh would fly a loop its charge does not pay for, and stays down. UAV 1's GPS fails once
    it is 150 m from its airport, searching: ArduCopter's EKF failsafe lands it where it is, and
    the station reports it for its crew to fetch."""
    require_ardupilot()
    fleet = [Vehicle(), Vehicle(params={"BATT_CAPACITY": 1800}), Vehicle()]
    flight = fly_fleet(tmp_path, FIELD_COPTERS_SHORT, fleet, "--fit-charge",
                       inject=(1, 150.0, {"SIM_GPS1_ENABLE": 0.0}))
    out = flight.stdout
    assert re.search(r"UAV 2: failed - not armed: charge 100% = 1800 mAh pays for \d+ m of its plan's \d+ m .*, less "
                     r"than its shortest way out and home \(\d+ m\)", out), out[-3000:]
    assert not flight.flown[2].armed_seen
    assert "UAV 1: landed away - LANDED AWAY at" in out and "fetch it" in out, out[-3000:]
    assert "LANDED AWAY: UAV 1" in out
    assert flight.verdicts[3].landed_m is not None, out[-4000:]
    assert flight.returncode == 1
