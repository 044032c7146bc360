"""Each vehicle's flight: its stage table, checked where the stage changes (off the table is a
bug, refused before anything is said or published), and a fleet controller that keeps no state
of its own per vehicle."""

from __future__ import annotations

import time

import pytest

from gcs.autopilots import Autopilot
from gcs.flight.controller import FlightController
from gcs.flight.events import StageChanged
from gcs.flight.vehicle_flight import TRANSITIONS, StageError, may_become
from gcs.telemetry.status import FINAL_STAGES, Stage
from tests.gcs.flight.conftest import fast_options

FLOWN = [Stage.CONNECTING, Stage.PREPARING, Stage.UPLOADING, Stage.ARMING, Stage.SEARCH, Stage.RETURN, Stage.RTL,
         Stage.LANDED]


def test_every_stage_lists_where_it_may_go_and_a_landing_is_the_end():
    assert set(TRANSITIONS) == set(Stage)
    for before, after in zip(FLOWN, FLOWN[1:]):
        assert may_become(before, after), (before, after)
    for landed in (Stage.LANDED, Stage.LANDED_AWAY):
        assert not [after for after in Stage if may_become(landed, after)]
    assert [after for after in Stage if may_become(Stage.FAILED, after)] == [Stage.RTL]  # failed in the air


@pytest.mark.parametrize(("before", "after"), [
    (Stage.CONNECTING, Stage.SEARCH), (Stage.UPLOADING, Stage.PREPARING), (Stage.ARMING, Stage.UPLOADING),
    (Stage.SEARCH, Stage.ARMING), (Stage.RETURN, Stage.SEARCH), (Stage.RTL, Stage.SEARCH),
    (Stage.LANDED, Stage.SEARCH), (Stage.LANDED_AWAY, Stage.LOST), (Stage.FAILED, Stage.LOST),
    (Stage.CONNECTING, Stage.LANDED_AWAY)])
def test_a_flight_never_goes_back_nor_on_from_its_end(before, after):
    assert not may_become(before, after)


def test_a_lost_vehicle_comes_back_to_its_stage_or_goes_on_from_it():
    assert may_become(Stage.LOST, Stage.SEARCH, Stage.SEARCH)
    assert may_become(Stage.LOST, Stage.RETURN, Stage.SEARCH)  # its return was ordered while it was silent
    assert may_become(Stage.LOST, Stage.FAILED, Stage.PREPARING)
    assert not may_become(Stage.LOST, Stage.SEARCH, Stage.RETURN)
    assert not may_become(Stage.LOST, Stage.CONNECTING)  # lost in no known stage
    assert all(may_become(stage, Stage.LOST) for stage in Stage if stage not in FINAL_STAGES | {Stage.LOST})


def test_a_stage_change_off_the_table_is_refused_and_changes_nothing(plan):
    lines: list[str] = []
    controller = FlightController(plan, [], fast_options(), out=lines.append)
    events = []
    controller.subscribe(lambda event, now: events.append(event) if isinstance(event, StageChanged) else None)
    vehicle = controller.vehicles[1]
    with pytest.raises(StageError, match="connecting -> search"):
        vehicle.set_stage(Stage.SEARCH, "skipping its preparation")
    assert vehicle.status.stage is Stage.CONNECTING and vehicle.status.note == "" and not events and not lines
    vehicle.set_stage(Stage.FAILED, "no HEARTBEAT")
    with pytest.raises(StageError):
        vehicle.set_stage(Stage.LANDED)
    assert vehicle.status.stage is Stage.FAILED and [e.after for e in events] == [Stage.FAILED] and len(lines) == 1


def test_the_controller_keeps_no_state_per_vehicle(plan):
    options = fast_options(return_after_s={2: 0.0})
    controller = FlightController(plan, [], options, out=lambda line: None)
    containers = {name for name, value in vars(controller).items() if isinstance(value, (dict, set))}
    assert containers == {"vehicles", "status", "_tasks"}  # _tasks: the tasks it runs, not keyed by vehicle
    assert all(controller.status[uid] is vehicle.status for uid, vehicle in controller.vehicles.items())
    controller.order_return(3, "mqtt")
    controller.order_return(1)
    assert controller.vehicles[3].orders and controller.vehicles[1].orders
    assert controller.vehicles[2].return_due(0.0) and not controller.vehicles[2].return_due(1.0)  # once
    assert options.return_after_s == {2: 0.0}  # the options are not the timer
    assert controller.take_orders() == [(3, "mqtt"), (1, "order")]  # in the order given
    assert not any(vehicle.orders for vehicle in controller.vehicles.values())
    assert controller.finished(time.monotonic()) is False


@pytest.mark.parametrize("autopilot", [Autopilot.ARDUPILOT, Autopilot.PX4])
def test_a_vehicle_seen_now_and_then_keeps_its_place_on_the_plan_from_its_current_item(plan, autopilot):
    """Seen only at every sixth waypoint (a loaded station at high speed-up): each sighting, with
    the item it flies to, puts it at that waypoint's step, past the poses between that the
    nearest-pose walk alone may not pass. Outside its search list the item says nothing."""
    controller = FlightController(plan, [], fast_options(), out=lambda line: None)
    for uid, vehicle in controller.vehicles.items():
        st, track = vehicle.status, vehicle.track
        st.stage, st.autopilot = Stage.SEARCH, autopilot
        st.mode_name = "AUTO" if autopilot is Autopilot.ARDUPILOT else "MISSION"
        steps = track.waypoint_steps
        assert len(steps) == len(vehicle.task.waypoints) > 6
        for j in range(5, len(steps), 6):
            st.lat_deg, st.lon_deg = vehicle.task.waypoints[j]
            st.mission_seq = autopilot.first_mission_seq() + 1 + j + 1  # flying on to the next waypoint
            vehicle.watch()
            assert st.track_index == steps[j], (uid, j)
        st.track_index, st.mode_name = 0, "RTL"
        st.mission_seq = autopilot.first_mission_seq() + len(steps)
        st.lat_deg, st.lon_deg = vehicle.task.trajectory[0].lat_deg, vehicle.task.trajectory[0].lon_deg
        vehicle.watch()
        assert st.track_index == 0


def test_fit_charge_flies_the_plan_on_the_battery_but_never_a_charge_short_of_the_shortest_way_out_and_home(plan):
    """`--fit-charge` in a 4 m/s wind blowing north: a vehicle whose charge cannot pay for its
    plan flies it with no range in metres set (its battery calls it home), and stays on the ground
    exactly when what its charge buys of the mission is less, in mAh, than its first step and the
    way home from there in that wind."""
    from gcs.flight import preflight

    flown = refused = 0
    for used_pct in [30.0 + 2.0 * i for i in range(20)]:
        lines: list[str] = []
        controller = FlightController(plan, [], fast_options(fit_charge=True, wind_m_s=(0.0, 4.0)), out=lines.append)
        vehicle = controller.vehicles[2]
        fuel = vehicle.energy.fuel
        fuel.used_mah = fuel.capacity_mah * used_pct / 100
        path_m = float(vehicle.plan.raw_uav(2).get("length_m", vehicle.track.length_m))
        charge = vehicle.energy.plan_charge(path_m, vehicle.track)
        assert charge is not None and not charge.enough, used_pct
        home = fuel.way_cost(vehicle.track.home_legs(1))
        buys_mah = (charge.covers_m - (path_m - vehicle.track.length_m)) * charge.mah_per_m
        shortest_mah = vehicle.track.flown_m(1) * charge.mah_per_m + home.mah
        if preflight.charge_covers_plan(vehicle):
            flown += 1
            assert buys_mah >= shortest_mah, (used_pct, lines)
            assert vehicle.operator_range is None and "until its battery calls it home" in lines[-1]
        else:
            refused += 1
            assert buys_mah < shortest_mah, (used_pct, lines)
            assert vehicle.status.stage is Stage.FAILED and "less than its shortest way out and home" in lines[-1]
    assert flown and refused
