"""Online mode: the planner in the loop. Every step the DTSCS search decides each vehicle's next
cell from the vehicles' observed cells and the shared map, which is Bayes-updated (eq. 2-4) with
every reading the vehicles report (CAMERA_IMAGE_CAPTURED, positive or negative); the vehicles are
steered in GUIDED with SET_POSITION_TARGET_GLOBAL_INT (ArduCopter) or DO_REPOSITION as COMMAND_INT
(PX4, and ArduPlane, which ignores position targets and circles the point it is sent to).

Steps are flown in lock step: every flying vehicle gets its next cell, and the next decision is
taken when every one of them has reported that cell (a reading comes as a vehicle passes within
half a cell of the centre, so vehicles fly on without stopping; a vehicle that arrived without
reporting is waited for `reading_timeout_s`), so the map a decision sees is the one the planner
would have after the same steps. A vehicle whose last step reached its airport cell lands from
there. The return decision
is the planner's (eq. 23-24, its exact table, the joint conflict-free ways home); battery state
enters it as a range change (`set_range`), operator orders as `order_return`.

The search is `planner.dtscs.ClosedSearch` without simulated sensing: readings enter through its
`observe()`, the vehicles' observed cells through `set_position()`."""

from __future__ import annotations

import asyncio
import contextlib
import math
import time

from gcs.flight.events import ReadingReceived
from gcs.links import LinkError, mavlink
from gcs.telemetry.status import FINAL_STAGES, Stage
from planner.dtscs import ClosedSearch
from planner.plan import Stage as PlanStage

__all__ = ["OnlineFlight", "observed_search"]

POSITION_ONLY_MASK = 0b0000_1101_1111_1000  # ignore velocity, acceleration, yaw, yaw rate
LANDING_ACCURACY_M = 1.0


def observed_search(scenario, config, seed: int) -> ClosedSearch:
    """The DTSCS search fed by the vehicles: no simulated sensing, readings through `observe()`,
    observed cells through `set_position()`."""
    return ClosedSearch(scenario, config, seed=seed, simulate_sensing=False)


class OnlineFlight:
    """Drives an `observed_search` with a `FlightController`'s links and telemetry."""

    def __init__(self, controller, search: ClosedSearch, *, arrive_m: float | None = None,
                 step_timeout_s: float = 10.0, reading_timeout_s: float = 2.0) -> None:
        self.c = controller
        self.search = search
        self.plan = controller.plan
        self.arrive_m = arrive_m or 0.25 * self.plan.cell_size_m
        self.step_timeout_s = step_timeout_s
        self.reading_timeout_s = reading_timeout_s
        self.expected: dict[int, tuple[tuple[int, int], int]] = {}
        self.reported: dict[int, tuple[int, int]] = {}
        self._range_cap: dict[int, int] = {}  # planner units
        self._range_set: dict[int, int] = {}
        self.targets: dict[int, tuple[float, float]] = {}
        self.seen: dict[int, int] = dict.fromkeys(self.plan.uavs, 0)
        self.landing: set[int] = set()

    # ---- readings ----------------------------------------------------------------------

    def _fold_readings(self) -> None:
        for uid, st in self.c.status.items():
            new = st.detections[self.seen[uid]:]
            self.seen[uid] = len(st.detections)
            for d in new:
                cell = self.plan.cell_of(d.lat_deg, d.lon_deg)
                if cell is None:
                    continue
                self.search.observe(cell, d.hit, self.pc, self.pf, by=uid)

    def _has_reading(self, uid: int) -> bool:
        """The vehicle's reading of the cell it was sent to has arrived (or none is expected)."""
        if uid not in self.expected:
            return True
        cell, since = self.expected[uid]
        detections = self.c.status[uid].detections
        return any(self.plan.cell_of(d.lat_deg, d.lon_deg) == cell for d in detections[since:])

    def _expect(self, uid: int, cell: tuple[int, int]) -> None:
        self.expected[uid] = (cell, len(self.c.status[uid].detections))

    @property
    def pc(self) -> float:
        return self.search.scenario.sensor.pc

    @property
    def pf(self) -> float:
        return self.search.scenario.sensor.pf

    # ---- commands ----------------------------------------------------------------------

    async def _take_off(self, uid: int) -> bool:
        c, vehicle, task = self.c, self.c.vehicles[uid], self.plan.uavs[uid]
        st, commands = vehicle.status, vehicle.commands
        if not await vehicle.prepare(mission=False):
            return False
        vehicle.set_stage(Stage.ARMING)
        try:
            await commands.set_mode("GUIDED")
            if not await vehicle.arm(give_up=lambda: c.stopping):
                return vehicle.kept_down()
            _, takeoff_alt = st.autopilot.command_altitude(task.altitude_m, st.home[2] if st.home else 0.0)
            await commands.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, takeoff_alt)
        except LinkError as exc:
            vehicle.set_stage(Stage.FAILED, f"take-off: {exc}")
            return False
        if not await c.wait_until(lambda: st.rel_alt_m >= task.altitude_m - 1.0, 120.0):
            vehicle.set_stage(Stage.FAILED, "did not reach its altitude")
            return False
        vehicle.set_stage(Stage.SEARCH, "online search")
        self.targets[uid] = self.plan.cell_lat_lon(*task.airport_cell)  # step 0: over the airport cell
        self.expected[uid] = (task.airport_cell, 0)  # read on the way up, or on reaching its centre
        return True

    def _steer(self, uid: int) -> None:
        """(Re-)send the current target; cheap, so it is repeated until the vehicle arrives."""
        st, link = self.c.status[uid], self.c.vehicles[uid].link
        if link is None or uid not in self.targets:
            return
        lat, lon = self.targets[uid]
        alt = self.plan.uavs[uid].altitude_m
        if st.autopilot.steers_by_reposition(st.fixed_wing):
            frame, z = st.autopilot.command_altitude(alt, st.home[2] if st.home else 0.0)
            link.send(mavlink.MAVLink_command_int_message(
                uid, 1, frame, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0,
                math.nan, round(lat * 1e7), round(lon * 1e7), z))
        else:
            link.send(mavlink.MAVLink_set_position_target_global_int_message(
                0, uid, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POSITION_ONLY_MASK, round(lat * 1e7),
                round(lon * 1e7), alt, 0, 0, 0, 0, 0, 0, 0, 0))

    def _arrived(self, uid: int, within_m: float | None = None) -> bool:
        st = self.c.status[uid]
        if uid not in self.targets or not st.has_position:
            return True
        e0, n0 = self.plan.local_m(*self.targets[uid])
        e1, n1 = self.plan.local_m(st.lat_deg, st.lon_deg)
        return math.hypot(e1 - e0, n1 - n0) <= (within_m or self.arrive_m)

    async def _land(self, uid: int) -> None:
        c, vehicle = self.c, self.c.vehicles[uid]
        self.targets[uid] = self.plan.uavs[uid].airport_lat_lon
        end = time.monotonic() + self.step_timeout_s
        while not self._arrived(uid, LANDING_ACCURACY_M) and time.monotonic() < end:
            self._steer(uid)
            await asyncio.sleep(self.c.options.tick_s)
        try:
            await vehicle.commands.command(mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, math.nan,
                                           *self.plan.uavs[uid].airport_lat_lon, 0)
        except LinkError as exc:
            c.say(uid, f"LAND not acknowledged ({exc}); commanding RTL")
            await vehicle.rtl()
        self.targets.pop(uid, None)

    # ---- the loop ----------------------------------------------------------------------

    def _battery_range(self) -> None:
        """Battery range as the range, re-read every step: what the fuel gauge says the charge
        above the reserve and the landing still buys (metres of cruise, in planner units), added
        to what was flown. Never above the planned range, or a range an operator set since."""
        unit_m = self.plan.cell_size_m / self.plan.move_costs.straight
        for uid, st in self.c.status.items():
            u = self.search.uavs[uid]
            if u.stage is not PlanStage.SEARCH:
                continue
            if u.range_units != self._range_set.get(uid, u.range_units):
                self._range_cap[uid] = u.range_units  # changed by someone else
            vehicle = self.c.vehicles[uid]
            if vehicle.operator_range is not None:
                self._range_cap[uid] = int(vehicle.operator_range / unit_m)
            cap = self._range_cap.setdefault(uid, u.range_units)
            energy = vehicle.energy
            fuel = energy.fuel
            want = cap
            if fuel.remaining_mah is not None:
                left_m = fuel.cruise_m_for(fuel.remaining_mah - fuel.reserve_mah(energy.reserve_pct)
                                           - energy.landing_mah())
                st.range_left = left_m
                want = min(cap, max(self.plan.move_costs.cheapest, u.flown + int(left_m / unit_m)))
            if want != u.range_units:
                self.search.set_range(uid, want)
            self._range_set[uid] = want
            st.margin = (u.range_units - u.flown - u.home_cost) * unit_m

    async def _fly_step(self, uids: set[int]) -> None:
        """Steer `uids` to their cells until every one has reported its cell (the reading comes
        within half a cell of the centre, so vehicles fly on without stopping), or has arrived
        and its reading stayed away for `reading_timeout_s`, or the step timed out."""
        c = self.c
        now = time.monotonic()
        end, reading_end = now + self.step_timeout_s, None
        while not c.interrupted and now < end:
            for uid in uids:
                c.vehicles[uid].update_stage(now)
            waiting = [uid for uid in uids if not self._has_reading(uid) and self._steered(uid)]
            if not waiting:
                break
            if all(self._arrived(uid) for uid in waiting):
                reading_end = reading_end or now + self.reading_timeout_s
                if now >= reading_end:
                    break
                c.recover_readings(now)
            for uid in waiting:
                if not self._arrived(uid):
                    self._steer(uid)
            self._reading.clear()
            with contextlib.suppress(TimeoutError):  # woken by the reading itself, not the next tick
                async with asyncio.timeout(c.options.tick_s):
                    await self._reading.wait()
            now = time.monotonic()
        self.reported = {}
        for uid in uids:
            if self._has_reading(uid):
                if uid in self.expected:
                    self.reported[uid] = self.expected[uid][0]
            elif self._steered(uid):
                c.say(uid, f"no reading of cell {self.expected[uid][0]} in time; deciding without it")
            self.expected.pop(uid, None)

    def _on_event(self, event, now: float) -> None:
        if isinstance(event, ReadingReceived):
            self._reading.set()

    def _steered(self, uid: int) -> bool:
        """Not down, failed, or brought home by its autopilot (its battery failsafe's RTL). A
        vehicle whose link is lost stays: it is steered again when heard."""
        stage = self.c.status[uid].stage
        return stage not in FINAL_STAGES and stage is not Stage.RTL

    def _out_of_step(self, flying: set[int]) -> set[int]:
        """Vehicles the station no longer steers (`_steered`); each is said once and leaves the
        search, so no step waits for its reading."""
        gone = {uid for uid in flying if not self._steered(uid)}
        for uid in sorted(gone):
            self.c.say(uid, f"out of the lock step ({self.c.status[uid].stage.value}); the others fly on")
            self.search.order_return(uid)
            self.targets.pop(uid, None)
            self.expected.pop(uid, None)
        return gone

    async def run(self) -> None:
        c = self.c
        self._reading = asyncio.Event()
        unsubscribe = c.subscribe(self._on_event)
        try:
            await self._run()
        finally:
            unsubscribe()

    async def _run(self) -> None:
        c, search = self.c, self.search
        ok = await asyncio.gather(*(self._take_off(uid) for uid in self.plan.uavs))
        for uid, good in zip(self.plan.uavs, ok):
            if not good:
                search.order_return(uid)  # stays out of the search; its plan ends at once
        flying = {uid for uid, good in zip(self.plan.uavs, ok) if good}
        at_airport: set[int] = set()
        landing_tasks = []
        while not c.interrupted:
            flying -= self._out_of_step(flying)
            await self._fly_step(flying | at_airport)
            landing_tasks += [asyncio.create_task(self._land(uid)) for uid in at_airport]
            at_airport.clear()
            if search.done:
                break
            start = time.monotonic()
            c.recover_readings(start)
            self._fold_readings()
            for uid, reason in c.take_orders():
                if uid in flying:
                    search.order_return(uid)
                    c.status[uid].return_reason = reason
            self._battery_range()
            for uid in flying:  # the cell it reported is where it is; telemetry may be a sample behind
                if uid in self.reported:
                    search.set_position(uid, self.reported[uid])
                elif c.status[uid].has_position:
                    search.set_position(uid, c.plan.cell_of(c.status[uid].lat_deg, c.status[uid].lon_deg))
            record = search.step()
            for ev in record.returns:
                st = c.status[ev.uav_id]
                if st.stage in FINAL_STAGES:
                    continue  # never took off (failed, or ordered home on the ground)
                st.return_reason = st.return_reason or {"range_cut": "battery"}.get(ev.reason.value, ev.reason.value)
                c.vehicles[ev.uav_id].set_stage(Stage.RETURN, f"going home ({ev.reason.value})")
            for uid in list(flying):
                x, y, _, stage = record.poses[uid]
                if uid not in self.targets or self.plan.cell_of(*self.targets[uid]) != (x, y):
                    self._expect(uid, (x, y))  # a vehicle reads a cell again only after leaving it
                self.targets[uid] = self.plan.cell_lat_lon(x, y)
                self._steer(uid)
                if stage is PlanStage.LANDED:
                    flying.discard(uid)
                    at_airport.add(uid)
            c.loop_latency_s.append(time.monotonic() - start)
            for vehicle in c.vehicles.values():
                vehicle.update_stage(time.monotonic())
        if c.interrupted:
            await c.bring_everyone_home()
            return
        await asyncio.gather(*landing_tasks)
        end = time.monotonic() + 300.0
        while not c.finished(time.monotonic()) and time.monotonic() < end and not c.interrupted:
            for vehicle in c.vehicles.values():
                vehicle.update_stage(time.monotonic())
            await asyncio.sleep(c.options.tick_s)
        if c.interrupted:
            await c.bring_everyone_home()
        self._fold_readings()
