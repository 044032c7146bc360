"""Where a simulated autopilot steers: the `Goal` it gives its airframe in each mode, its way
through the mission (items started, reached, jumped over, completed), its RTL and its landings
(an ArduCopter onto the point, ArduPlane's glide down the runway axis). docs/sim.md lists each
measured behaviour.

`Guidance` is a mixin of `SimVehicle`: it reads and writes the same mode, setpoints, mission index
and outgoing messages as the vehicle's commands do, and the px4 profile overrides its steps, so
a separate object would reach into all of that. What needs only the airframe is plain functions.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import WireItem
from sim.autopilot import telemetry
from sim.autopilot.ardupilot import MISSION_TEXT_NAMES
from sim.autopilot.modes import Mode
from sim.physics.airframe import Airframe, Goal
from sim.physics.kinematics import corner_fraction

if TYPE_CHECKING:
    from planner.georef import LocalFrame
    from sim.autopilot.mission_protocol import MissionProtocol
    from sim.autopilot.vehicle import MAVMessage, VehicleConfig

#: the mission items the vehicle flies (the others are done, or skipped, as they come up)
NAV_COMMANDS = frozenset(
    {
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_LOITER_UNLIM,
        mavlink.MAV_CMD_NAV_LOITER_TIME,
        mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH,
        mavlink.MAV_CMD_NAV_LAND,
        mavlink.MAV_CMD_NAV_TAKEOFF,
    }
)

# ArduPlane SITL (plane.parm) climbs 10 m/s at full throttle in its take-off (docs/energy.md)
_PLANE_TAKEOFF_CLIMB_M_S = 10.0

def climb_point(airframe: Airframe) -> tuple[float, float] | None:
    """Where a take-off climbs: copters vertically (None), planes straight ahead."""
    if airframe.limits.can_hover:
        return None
    far, kin = 10_000.0, airframe.kin
    return (kin.east_m + far * math.sin(kin.heading_rad), kin.north_m + far * math.cos(kin.heading_rad))


def hold_or(airframe: Airframe, target: tuple[float, float] | None) -> tuple[float, float] | None:
    """A plane near its target circles (target None) instead of chasing it."""
    if target is None or airframe.limits.can_hover:
        return target
    if math.dist(target, airframe.position_en) < airframe.limits.turn_radius_m:
        return None
    return target


def glide_goal(airframe: Airframe, land_from: tuple[float, float, float], target: tuple[float, float]) -> Goal:
    """ArduPlane's landing: along the runway axis (from `land_from`, the approach's east, north
    and the altitude the glide began at, to the NAV_LAND point), gliding from that altitude to the
    ground just short of the point (flight §3: touchdowns 5-14 m short, within 0.5 m of the axis)."""
    here = airframe.position_en
    x0, y0, alt0 = land_from
    total = math.hypot(target[0] - x0, target[1] - y0)
    if total < 1.0:  # no axis: straight ahead, down
        return Goal(climb_point(airframe), -1.0, landing=True)
    ux, uy = (target[0] - x0) / total, (target[1] - y0) / total
    along = (here[0] - x0) * ux + (here[1] - y0) * uy
    left = total - along
    glide_alt = alt0 * min(max(left / total, 0.0), 1.0)
    look = along + 2.0 * airframe.limits.turn_radius_m  # pursue a point ahead on the axis
    aim = (x0 + ux * look, y0 + uy * look)
    if left <= airframe.limits.turn_radius_m:  # over the runway: on down to the ground
        return Goal(aim, glide_alt - 0.3, landing=True)
    return Goal(aim, glide_alt, landing=True)


class Guidance:
    """The steering half of `SimVehicle`. The vehicle calls, each step, `_goal()` (what the
    airframe flies toward; None: nothing) and in AUTO, once the airframe has moved,
    `_check_reached()`; on touching down on a mission's item, `_reach(seq)`; from its commands,
    `_restart_mission()`, `_set_seq(seq)`, `_start_or_resume()` and `_announce_item()`.
    `Px4Vehicle` overrides `_goal`, `_rtl_goal`, `_nav_goal` and `_finished_text` (PX4's RTL is
    in `sim.autopilot.px4_vehicle`), and extends the three that move the mission index."""

    # what the vehicle provides: its profile, body and mission, its mode and the setpoints its
    # commands give (the take-off altitude, GUIDED's target, the RTL altitude, a speed), and
    # `statustext`, `_alt_rel`, `_rtl_alt_setting_m`
    config: VehicleConfig
    ardupilot: bool
    copter: bool
    airframe: Airframe
    frame: LocalFrame
    mission: MissionProtocol
    home_en: tuple[float, float]
    time_s: float
    mode: Mode
    landed: bool
    landing: bool
    _takeoff_alt_m: float | None
    _target_en: tuple[float, float] | None
    _target_alt_m: float
    _rtl_alt_m: float
    _speed_m_s: float | None
    _auto_armed: bool
    _pending: list[MAVMessage]

    def _init_guidance(self) -> None:
        """Guidance's own state: where in the mission the vehicle is and what it has done there."""
        self.mission_seq = 0  # ArduPilot: 0 until a mission starts (item 0 is home)
        self.mission_complete = False
        self.reached: list[int] = []
        self._jumps_done: dict[int, int] = {}
        self._hold_until_s: float | None = None
        self._nav_item: WireItem | None = None  # ArduPlane finishes the nav item it started
        self._land_from: tuple[float, float, float] | None = None  # plane: where its glide began
        self._passing: tuple[WireItem, float] | None = None  # a waypoint and what is kept past it
        self._points_en: dict[tuple[int, int], tuple[float, float]] = {}  # mission points (degE7) in the frame

    @property
    def _takeoff_climb_m_s(self) -> float | None:
        """ArduPlane takes off at full throttle, climbing twice as fast as its TECS climbs in
        flight (SITL: 60 m in 6 s; docs/energy.md); others at their usual rate (None)."""
        return _PLANE_TAKEOFF_CLIMB_M_S if self.ardupilot and not self.copter else None

    # ---- the goal of each mode -----------------------------------------------------------

    def _goal(self) -> Goal | None:
        here = self.airframe.position_en
        if self._takeoff_alt_m is not None and self.mode in (Mode.GUIDED, Mode.TAKEOFF):
            if self.airframe.kin.alt_m >= self._takeoff_alt_m - 0.5:
                self._takeoff_alt_m = None
                if self.mode == Mode.TAKEOFF:
                    self.mode = Mode.LOITER
                if self._target_en is None:  # no reposition arrived during the climb
                    self._target_en, self._target_alt_m = here, self.airframe.kin.alt_m
            else:
                return Goal(climb_point(self.airframe), self._takeoff_alt_m, climb_rate_m_s=self._takeoff_climb_m_s)
        if self.ardupilot and self.copter and self.mode == Mode.LOITER:
            # SITL has no RC: LOITER's throttle is at its minimum and the copter sinks and lands
            return None if self.landed else Goal(None, -1.0, landing=True)
        if self.mode in (Mode.GUIDED, Mode.LOITER, Mode.TAKEOFF):
            if self.landed:
                return None
            return Goal(hold_or(self.airframe, self._target_en), self._target_alt_m)
        if self.mode == Mode.LAND:
            return Goal(None if self.airframe.limits.can_hover else hold_or(self.airframe, None), -1.0, landing=True)
        if self.mode == Mode.RTL:
            return self._rtl_goal()
        if self.mode == Mode.AUTO:
            if self.ardupilot and self.copter and self.landed and not self._auto_armed:
                return None  # AUTO entered by DO_SET_MODE on the ground: no take-off (flight §2)
            return self._auto_goal()
        return None if self.landed else Goal(None, self.airframe.kin.alt_m)

    def _rtl_goal(self) -> Goal:
        dist = math.dist(self.home_en, self.airframe.position_en)
        radius = self.config.acceptance_radius_m
        if self.ardupilot and not self.copter:
            return Goal(hold_or(self.airframe, self.home_en), self._rtl_alt_m)  # ArduPlane circles home (flight §3)
        if self.landing or dist <= radius:
            return Goal(self._touchdown_point(self.home_en), -1.0, landing=True)
        if self.airframe.limits.can_hover and self.airframe.kin.alt_m < self._rtl_alt_m - 0.5:
            return Goal(None, self._rtl_alt_m)
        return Goal(self.home_en, self._rtl_alt_m)

    def _touchdown_point(self, target: tuple[float, float]) -> tuple[float, float] | None:
        """Where a vertical landing goes down: an ArduCopter onto the point itself (0.03 m from
        it, flight §2), the px4 profile where it stands; a plane circles down."""
        if not self.airframe.limits.can_hover:
            return hold_or(self.airframe, None)
        return target if self.ardupilot else None

    # ---- the mission ---------------------------------------------------------------------

    def _auto_goal(self) -> Goal | None:
        items = self.mission.items()
        for _ in range(len(items) + 1):
            if self.mission_seq >= len(items):
                if not self.mission_complete:
                    self.mission_complete = True
                    self.statustext(self._finished_text)
                    self._pending.append(telemetry.mission_current(self))
                return None if self.landed else Goal(hold_or(self.airframe, None), self.airframe.kin.alt_m)
            item = items[self.mission_seq]
            if self.ardupilot and not self.copter and self._nav_item is not None \
                    and self._nav_item.seq == self.mission_seq:
                item = self._nav_item  # ArduPlane flies the nav item it started, whatever replaced it
            if item.command == mavlink.MAV_CMD_DO_JUMP:
                self._do_jump(item)
                continue
            if item.command == mavlink.MAV_CMD_DO_CHANGE_SPEED and item.param2 > 0:
                self._speed_m_s = item.param2
            if item.command not in NAV_COMMANDS:
                self._advance()
                continue
            self._nav_item = item
            return self._nav_goal(item)
        return None

    _finished_text = "Mission complete"

    def _do_jump(self, item: WireItem) -> None:
        done = self._jumps_done.get(item.seq, 0)
        if item.param2 < 0 or done < item.param2:
            self._jumps_done[item.seq] = done + 1
            self.mission_seq = int(item.param1)
        else:
            self._advance()
        self._pending.append(telemetry.mission_current(self))

    def _item_en(self, item: WireItem) -> tuple[float, float]:
        """Where an item's point is in the local frame (0, 0: here); each point converted once,
        not on every step it is flown toward."""
        if item.x == 0 and item.y == 0:
            return self.airframe.position_en
        key = (item.x, item.y)
        en = self._points_en.get(key)
        if en is None:
            en = self._points_en[key] = self.frame.geodetic2en(item.x / 1e7, item.y / 1e7)
        return en

    def _nav_goal(self, item: WireItem) -> Goal:
        cmd = item.command
        alt = self._alt_rel(item.z, item.frame)
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            return Goal(climb_point(self.airframe), alt, climb_rate_m_s=self._takeoff_climb_m_s)
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            if not self.landing and self._rtl_alt_m <= 0.0:
                self._rtl_alt_m = max(self.airframe.kin.alt_m, self._rtl_alt_setting_m)
            return self._rtl_goal()
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            target = self._item_en(item)
            if self.ardupilot and not self.copter:
                if self._land_from is None:  # the glide starts here, on the axis from the approach
                    here = self.airframe.position_en
                    self._land_from = (*self._previous_nav_en(here), self.airframe.kin.alt_m)
                return glide_goal(self.airframe, self._land_from, target)
            if self.landing or math.dist(target, self.airframe.position_en) <= self._radius(item):
                return Goal(self._touchdown_point(target), -1.0, landing=True)
            return Goal(target, self.airframe.kin.alt_m)
        return Goal(self._item_en(item), alt, pass_fraction=self._pass_fraction(item))

    def _pass_fraction(self, item: WireItem) -> float:
        """What an accelerating copter keeps of its speed past waypoint `item`: as its turn onto
        the next waypoint allows (`corner_fraction`); 0 (it stops) before anything else, or at a
        waypoint it holds at (param1). Worked out once per item flown to."""
        if self.airframe.limits.accel_m_s2 is None:
            return 0.0
        if self._passing is not None and self._passing[0] is item:
            return self._passing[1]
        fraction = 0.0
        items = self.mission.items()
        after = next((it for it in items[self.mission_seq + 1:] if it.command in NAV_COMMANDS), None)
        if item.command == mavlink.MAV_CMD_NAV_WAYPOINT and item.param1 <= 0 and after is not None \
                and after.command == mavlink.MAV_CMD_NAV_WAYPOINT and (after.x, after.y) != (0, 0):
            here = self._item_en(item)
            start = self._previous_nav_en(self.airframe.position_en)
            end = self._item_en(after)
            leg = math.atan2(here[0] - start[0], here[1] - start[1])
            fraction = corner_fraction(math.atan2(end[0] - here[0], end[1] - here[1]) - leg)
        self._passing = (item, fraction)
        return fraction

    def _previous_nav_en(self, fallback: tuple[float, float]) -> tuple[float, float]:
        """Where the nav item before the current one is (the approach before NAV_LAND)."""
        items = self.mission.items()
        for it in reversed(items[self._first_seq:self.mission_seq]):
            if it.command in NAV_COMMANDS and it.command != mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH \
                    and (it.x, it.y) != (0, 0):
                return self.frame.geodetic2en(it.x / 1e7, it.y / 1e7)
        return fallback

    def _radius(self, item: WireItem) -> float:
        """An item's acceptance radius: a waypoint's own (param2) or the vehicle's, never less
        than a plane's turn radius."""
        radius = item.param2 if item.command == mavlink.MAV_CMD_NAV_WAYPOINT and item.param2 > 0 \
            else self.config.acceptance_radius_m
        if not self.airframe.limits.can_hover:
            radius = max(radius, self.airframe.limits.turn_radius_m)
        return radius

    def _check_reached(self) -> None:
        items = self.mission.items()
        if self.mission_seq >= len(items):
            return
        item = self._nav_item if self._nav_item is not None and self._nav_item.seq == self.mission_seq \
            else items[self.mission_seq]
        cmd = item.command
        here = self.airframe.position_en
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            if self.airframe.kin.alt_m >= self._alt_rel(item.z, item.frame) - 0.5:
                self._reach(item.seq)
            return
        if cmd not in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME, mavlink.MAV_CMD_NAV_LOITER_UNLIM):
            return
        if self._hold_until_s is not None:
            if self.time_s >= self._hold_until_s:
                self._hold_until_s = None
                self._advance()
            return
        close = math.dist(self._item_en(item), here) <= self._radius(item)
        if self.airframe.limits.can_hover:
            close = close and abs(self.airframe.kin.alt_m - self._alt_rel(item.z, item.frame)) <= 1.0
        if not close:
            return
        if cmd == mavlink.MAV_CMD_NAV_LOITER_UNLIM:
            return
        self._report_reached(item.seq)
        hold_s = item.param1 if self.airframe.limits.can_hover or cmd == mavlink.MAV_CMD_NAV_LOITER_TIME else 0.0
        if hold_s > 0:
            self._hold_until_s = self.time_s + hold_s
        else:
            self._advance()

    def _report_reached(self, seq: int) -> None:
        """MISSION_ITEM_REACHED; ArduPlane reports the waypoint before a DO_LAND_START with the
        DO_LAND_START's number (flight §3)."""
        reported = seq
        items = self.mission.items()
        if self.ardupilot and not self.copter and seq + 1 < len(items) \
                and items[seq + 1].command == mavlink.MAV_CMD_DO_LAND_START:
            reported = seq + 1
        self._pending.append(mavlink.MAVLink_mission_item_reached_message(reported))
        self.reached.append(reported)
        if self.ardupilot:
            self.statustext(f"Reached command #{seq}" if self.copter else f"Reached waypoint #{seq}")

    def _reach(self, seq: int) -> None:
        self._report_reached(seq)
        self._advance()

    # ---- the mission index ---------------------------------------------------------------

    @property
    def _first_seq(self) -> int:
        return 1 if self.ardupilot else 0

    def _advance(self) -> None:
        self.mission_seq += 1
        self._rtl_alt_m = 0.0
        self._nav_item = None
        self._pending.append(telemetry.mission_current(self))
        if self.ardupilot:
            self._announce_item()

    def _announce_item(self) -> None:
        """ArduPilot's "Mission: N Takeoff" as each item starts."""
        items = self.mission.items()
        if self._first_seq <= self.mission_seq < len(items):
            cmd = items[self.mission_seq].command
            self.statustext(f"Mission: {self.mission_seq} {MISSION_TEXT_NAMES.get(cmd, cmd)}")

    def _restart_mission(self) -> None:
        self.mission_seq = self._first_seq
        self.mission_complete = False
        self._jumps_done.clear()
        self._hold_until_s = None
        self._nav_item = None

    def _set_seq(self, seq: int) -> bool:
        if not self._first_seq <= seq < len(self.mission.items()):
            return False
        self.mission_seq = seq
        self.mission_complete = False
        self._hold_until_s = None
        self._nav_item = None
        self._pending.append(telemetry.mission_current(self))
        return True

    def _start_or_resume(self) -> None:
        """AUTO starts the mission where it stands (MIS_RESTART 0: a re-uploaded mission
        resumes at the current index), from its first item if it never ran or completed."""
        if self.mission_complete or self.mission_seq < self._first_seq:
            self._restart_mission()
        if self.ardupilot:
            self._announce_item()
        self._pending.append(telemetry.mission_current(self))
