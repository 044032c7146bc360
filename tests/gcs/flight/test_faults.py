"""A vehicle that goes silent before it is ready does not hold the flight up: it is marked lost,
given up after `lost_giveup_s`, and the others fly and land."""

from __future__ import annotations

from gcs.telemetry.status import Stage
from tests.gcs.flight.conftest import fast_options, fly


def test_a_vehicle_silent_while_getting_ready_is_given_up_and_the_others_fly(plan):
    controller, fleet = fly(plan, fast_options(lost_giveup_s=1.0),
                            during=lambda fleet: fleet.stop_answering(3, after_s=5.0))  # before its EKF is ready
    assert controller.status[3].stage is Stage.LOST and not controller.status[3].airborne_seen
    assert all(controller.status[u].stage is Stage.LANDED for u in (1, 2, 4))
    assert not fleet.vehicle(3).armed
