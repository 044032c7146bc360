"""Return orders that reach a vehicle before it took off keep it on the ground, disarmed, and say so;
the others fly their plans."""

from __future__ import annotations

import asyncio

from gcs.flight.controller import FlightController
from gcs.flight.events import StageChanged
from gcs.links import open_links
from gcs.telemetry.status import Stage
from sim.plan_fleet import fleet_for_plan
from tests.gcs.flight.conftest import SPEEDUP, fast_options, fly


def test_a_return_ordered_before_take_off_keeps_the_vehicle_on_the_ground(plan):
    controller, fleet = fly(plan, fast_options(return_after_s={3: 0.0}))
    st = controller.status[3]
    assert st.stage is Stage.LANDED and not st.airborne_seen and st.return_reason == "order"
    assert "kept on the ground: return ordered before take-off" in st.note
    assert not fleet.vehicle(3).armed and fleet.vehicle(3).landed
    assert max(fleet.vehicle(3).state.alt_rel_m, 0.0) == 0.0
    assert all(controller.status[u].stage is Stage.LANDED and controller.status[u].airborne_seen for u in (1, 2, 4))


def test_a_return_ordered_after_the_mission_started_but_before_lift_off_disarms_it_there(plan):
    """The race the bus test met under load: the order arrives once the mission was started, before
    the vehicle is airborne; it is disarmed on the ground instead of taking off."""
    fleet = fleet_for_plan(plan, speedup=SPEEDUP).start()

    async def main() -> FlightController:
        async with open_links(fleet.connection_strings()) as links:
            controller = FlightController(plan, links, fast_options())

            def order_at_start(event, now):
                if isinstance(event, StageChanged) and event.uav_id == 2 and event.after is Stage.SEARCH:
                    controller.order_return(2)

            controller.subscribe(order_at_start)
            await controller.run()
            return controller

    try:
        controller = asyncio.run(asyncio.wait_for(main(), 120))
    finally:
        fleet.stop()
    st = controller.status[2]
    assert st.stage is Stage.LANDED and st.return_reason == "order" and not st.airborne_seen, st
    assert "kept on the ground" in st.note and not fleet.vehicle(2).armed
    assert all(controller.status[u].stage is Stage.LANDED and controller.status[u].airborne_seen for u in (1, 3, 4))
