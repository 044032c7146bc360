"""A vehicle that goes silent before it is ready does not hold the flight up: it is marked lost,
given up after `lost_giveup_s`, and the others fly and land. One that fails in the air is sent
home by its autopilot's RTL at once, and the flight waits for it to land."""

from __future__ import annotations

from contextlib import asynccontextmanager

from gcs.flight.events import TookOff
from gcs.telemetry.status import Stage
from tests.gcs.flight.conftest import fast_options, fly


def test_a_vehicle_silent_while_getting_ready_is_given_up_and_the_others_fly(plan):
    controller, fleet = fly(plan, fast_options(lost_giveup_s=1.0),
                            during=lambda fleet: fleet.stop_answering(3, after_s=5.0))  # before its EKF is ready
    assert controller.status[3].stage is Stage.LOST and not controller.status[3].airborne_seen
    assert all(controller.status[u].stage is Stage.LANDED for u in (1, 2, 4))
    assert not fleet.vehicle(3).armed


class _FailsOnceAirborne:
    """A watcher that fails UAV `uid` as it is first seen airborne, as a failed command of the
    task flying it would: the station no longer flies it."""

    def __init__(self, uid: int) -> None:
        self.uid = uid

    @asynccontextmanager
    async def attach(self, controller):
        def on(event, now):
            if isinstance(event, TookOff) and event.uav_id == self.uid:
                controller.vehicles[self.uid].set_stage(Stage.FAILED, "a task's command failed in the air")

        unsubscribe = controller.subscribe(on)
        try:
            yield self
        finally:
            unsubscribe()


def test_a_vehicle_that_fails_in_the_air_is_sent_home_at_once_and_the_flight_waits_for_it(plan, capsys):
    controller, fleet = fly(plan, watchers=[_FailsOnceAirborne(1)])
    st = controller.status[1]
    said = capsys.readouterr().out
    assert "UAV 1: failed - a task's command failed in the air" in said
    assert "UAV 1: rtl - autopilot RTL" in said
    assert st.stage is Stage.LANDED  # the flight waited for it to come down
    state = fleet.vehicle(1).state
    assert state.landed and not state.armed
    search = sum(p.stage == "search" for p in plan.uavs[1].trajectory)
    assert st.track_index < search / 4  # home from near its airport, not at its plan's end
    assert all(controller.status[u].stage is Stage.LANDED for u in (2, 3, 4))
