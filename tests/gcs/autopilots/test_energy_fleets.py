"""Issue 23 on real autopilots: fleets fly the issue's field with stock energy profiles and spend
their batteries on the search, in still air and in a gusty 8 m/s wind; a learned profile closes
the loop; in a mixed fleet a fast-draining PX4 comes home by fuel first and a vehicle whose charge
cannot pay for its plan stays on the ground, naming both figures; a copter that comes down away
from its airport is reported for its crew to fetch.

Each vehicle is judged by an independent recorder on its own spare port (`tests.gcs.autopilots.
fleets`): it passes 90 % of its planned waypoints, or it comes home by fuel and touches down
within [reserve - 5, reserve + 10] %."""

from __future__ import annotations

import json
import re
import threading

import pytest

from gcs.plans.plan_folder import load_plan_dir
from tests.gcs.autopilots.fleets import RESERVE_PCT, WIND, FleetFlight, Vehicle, fly_fleet
from tests.gcs.autopilots.flights import bus_events, depth_in_no_fly_cell
from tests.gcs.bus.helpers import Mosquitto
from tests.peers.ardupilot import require_ardupilot
from tests.peers.process import SITL_WORKER
from tests.peers.px4 import PX4_SPEEDUP, require_px4
from tests.peers.site import FIELD_COPTERS, FIELD_COPTERS_SHORT, FIELD_PLANES

#: each flies a fleet of three to its end (several minutes of vehicle time); one at a time, in
#: the real autopilots' worker (tests/peers/process.py)
pytestmark = [pytest.mark.autopilot, pytest.mark.timeout(900), SITL_WORKER]


#: UAV 2 with a small pack: 2200 mAh. The issue's 1800 mAh pays, after the launch, the landing and
#: the 30 % reserve, for about 500 m, less than the shortest way out of its airport and home under
#: 3OC on these 50 m cells (527 m): `gcs fly` keeps it on the ground, saying so (the refusal test)
COPTERS = [Vehicle(), Vehicle(params={"BATT_CAPACITY": 2200}), Vehicle()]
PLANES = [Vehicle(airframe="plane")] * 3


def judge(flight) -> None:
    """Every vehicle flew its search or spent its battery on it; the profile's prediction held."""
    for v in flight.verdicts.values():
        assert v.flew_its_search or (v.returned in ("battery", "range") and v.spent_its_battery), \
            f"{v}\n{flight.stdout[-4000:]}"
        assert v.landed_m is not None, f"{v}\n{flight.stdout[-4000:]}"
    assert flight.returncode == 0, flight.stdout[-4000:]


def judge_still_air(flight) -> None:
    """`judge`, each prediction within 5 %, and no wind
    read from a copter's lean in still air (issue 38: a wind that cannot be told from none is not
    said). ArduPlane's own WIND reads 1.1-1.5 m/s in SITL's still air: said as its autopilot's."""
    judge(flight)
    assert not re.search(r"UAV \d: wind [\d.]+ ± [\d.]+ m/s .*\(its lean\)", flight.stdout), flight.stdout[-4000:]
    for speed in re.findall(r"UAV \d: wind ([\d.]+) ± [\d.]+ m/s .*\(its autopilot\)", flight.stdout):
        assert float(speed) <= 2.0, flight.stdout[-4000:]
    errors = flight.energy_errors()
    assert set(errors) == set(flight.verdicts), flight.stdout[-4000:]
    assert all(abs(e) <= 5.0 for e in errors.values()), f"{errors}\n{flight.stdout[-6000:]}"


@pytest.fixture(scope="module")
def copters_in_still_air(tmp_path_factory: pytest.TempPathFactory) -> FleetFlight:
    """The three ArduCopters (one with a small pack) fly the field once with stock profiles: one
    test judges that flight, another plans the next from the profiles it learned (one flight of
    the real autopilots' worker, not two)."""
    require_ardupilot()
    return fly_fleet(tmp_path_factory.mktemp("copters-still-air"), FIELD_COPTERS, COPTERS, "--fit-charge")


def test_three_copters_one_with_a_small_pack_spend_their_batteries_on_the_search_in_still_air(copters_in_still_air):
    judge_still_air(copters_in_still_air)


@pytest.mark.parametrize("fleet, site, extra, wind, crew_wind", [
    pytest.param(PLANES, FIELD_PLANES, ("--vehicle", "plane"), False, False, id="still air-3 ArduPlane"),
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
    crew = ("--wind", f"{WIND['SIM_WIND_SPD']:g}@{WIND['SIM_WIND_DIR']:g}") if crew_wind else ()
    flight = fly_fleet(tmp_path, site, fleet, "--fit-charge", *crew, plan_args=extra, wind=wind)
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
        judge_still_air(flight)


def test_a_learned_profile_plans_a_flight_that_spends_the_battery(tmp_path, copters_in_still_air):
    """Fly once with stock profiles, plan again with the vehicles.json that flight wrote, fly
    again: every vehicle flies its new plan and lands with at most reserve + 10 %. The second
    plan fits each copter's range to what its path costs (`gcs.plans.charge_fit`): without that,
    UAV 3's learned cruise metre (1.055 mAh, what the first flight's path cost) sized a range whose
    plan cost 6.6 % more a metre, and it came home by battery at 16 of 20 waypoints (2026-12-02)."""
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


def test_a_mixed_fleet_brings_its_fast_draining_px4_home_first_and_a_pack_that_cannot_pay_stays_down(tmp_path):
    """One flight for three checks (two SITL starts and two flights fewer than until 2026-12-02):
    the field's 800 m plans flown as planned (no `--fit-charge`), both autopilots at one speed-up,
    so "first" means the same in vehicle time. UAV 1, an ArduCopter with a stock pack, flies its
    search. UAV 2's 1800 mAh pays for about 500 m: it stays on the ground, naming both figures and
    `--fit-charge`. UAV 3, a PX4 whose battery lasts 300 s armed (SIM_BAT_DRAIN), less than its
    search and the way home from its end need at PX4's 5 m/s, is brought home by fuel, first. The
    bus carries both flying vehicles' events alike, in order. (Until 2026-12-02 this was four
    flights: an ArduCopter with two PX4s in still air, an ArduCopter and a fast-draining PX4, two
    ArduCopters one of them fast-draining, and the 1800 mAh pack's refusal beside two flying
    copters; an ArduCopter that draws more than its profile is brought home by fuel in
    `test_ardupilot_resume.py`, fleets of ArduCopters spend their batteries above.)"""
    require_ardupilot()
    require_px4()
    fleet = [Vehicle(), Vehicle(params={"BATT_CAPACITY": 1800}),
             Vehicle("px4", params={"SIM_BAT_DRAIN": 300.0, "SIM_BAT_MIN_PCT": 0.0})]
    (tmp_path / "mosquitto").mkdir()
    broker = Mosquitto(tmp_path / "mosquitto")
    broker.start()
    events: list = []
    stop = threading.Event()
    try:
        listener = bus_events(broker.port, "mixed", events, stop)
        flight = fly_fleet(tmp_path, FIELD_COPTERS_SHORT, fleet, "--mqtt", f"mqtt://127.0.0.1:{broker.port}",
                           "--fleet", "mixed", speedup=PX4_SPEEDUP)
        stop.set()
        listener.join(5)
    finally:
        broker.stop()
    out = flight.stdout
    assert "UAV 1: preparing - ardupilot autopilot" in out and "UAV 3: preparing - px4 autopilot" in out, out[-3000:]
    assert "UAV 2: failed - not armed: charge 100% = 1800 mAh pays for" in out, out[-3000:]
    assert "the plan needs" in out and "--fit-charge" in out
    assert flight.returncode == 1
    assert flight.verdicts[2].passed == 0 and not flight.flown[2].armed_seen
    record = json.loads((tmp_path / "field" / "plan" / "sortie.json").read_text())
    grounded = next(v for v in record["vehicles"] if v["id"] == 2)
    assert grounded["end"] == "failed" and grounded["note"].startswith("not armed: charge 100% = 1800 mAh pays for")
    assert re.search(r"UAV 3: battery \d+% \(\d+ mAh\) pays for \d+ m above the 30% reserve and the landing; the way "
                     r"home is \d+ m", out), out[-3000:]
    first, px4 = flight.verdicts[1], flight.verdicts[3]
    assert first.returned == "plan" and first.flew_its_search, f"{first}\n{out[-4000:]}"
    assert px4.returned == "battery", f"{px4}\n{out[-4000:]}"
    assert out.index("UAV 3: return - going home (battery)") < out.index("UAV 1: landed")
    for v in (first, px4):
        assert v.landed_m is not None and v.landed_m <= 3.0, f"{v}\n{out[-4000:]}"
    plan = load_plan_dir(flight.plan_dir)
    for uid in (1, 3):
        deepest = max(depth_in_no_fly_cell(plan, lat, lon) for lat, lon, *_ in flight.flown[uid].positions)
        assert deepest <= 3.0, f"UAV {uid} went {deepest:.1f} m into a no-fly cell"
    by_uav: dict[int, list] = {1: [], 3: []}
    for e in events:
        by_uav.setdefault(e["uav"], []).append(e)
    for seq in (by_uav[1], by_uav[3]):
        assert [e["seq"] for e in seq] == sorted(e["seq"] for e in seq), seq
        kinds = [e["kind"] for e in seq]
        assert "takeoff" in kinds and kinds[-1] == "landed" and kinds.index("takeoff") < kinds.index("landed"), kinds
    assert [e["reason"] for e in by_uav[3] if e["kind"] == "return"] == ["battery"]
    assert not [e for e in by_uav[1] if e["kind"] == "return"]
    assert not [e for e in by_uav.get(2, []) if e["kind"] in ("takeoff", "landed")]


def test_a_charge_short_of_its_shortest_way_out_and_home_stays_down_and_a_copter_down_away_is_reported(
        tmp_path):
    """One flight for two checks (a SITL start fewer). `--fit-charge` flies a plan on the
    battery, but not with a charge short of the plan's first step and the way home from it: UAV 2's
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
