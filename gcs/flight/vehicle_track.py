"""One vehicle's plan in metres (`PlanTrack`): its trajectory in the plan's local frame, the pose
a position has reached along it, the planned way home from each pose (the exact table's path
under the OC) and a plane's landing circuit. No I/O: a plan in, legs out."""

from __future__ import annotations

import functools
import math

import numpy as np

from gcs.autopilots import Autopilot
from gcs.plans.plan_folder import FleetPlan

__all__ = ["Legs", "PlanTrack", "distance_m"]

Legs = list[tuple[float, float]]


class PlanTrack:
    """The trajectory of UAV `uid` of `plan`, in metres (see the module docstring)."""

    def __init__(self, plan: FleetPlan, uid: int) -> None:
        self.plan = plan
        self.task = task = plan.uavs[uid]
        self.uid = uid
        self.track_m = np.array([plan.local_m(p.lat_deg, p.lon_deg) for p in task.trajectory])
        self.along_m = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(self.track_m, axis=0).T))])
        self._home_legs: dict[int, Legs] = {}

    def advance(self, index: int, lat_deg: float, lon_deg: float) -> int:
        """The pose reached from pose `index` at this position: on while the next pose is nearer."""
        track = self.track_m
        pos = np.array(self.plan.local_m(lat_deg, lon_deg))
        while index + 1 < len(track) and np.hypot(*(track[index + 1] - pos)) <= np.hypot(*(track[index] - pos)):
            index += 1
        return index

    @functools.cached_property
    def waypoint_steps(self) -> list[int]:
        """The trajectory step of each of the task's waypoints, in order, up to the first that is
        not on the trajectory."""
        steps, i = [], 0
        for lat, lon in self.task.waypoints:
            at = np.hypot(*(self.track_m[i:] - np.array(self.plan.local_m(lat, lon))).T)
            if not len(at) or at.min() > 1.0:
                break
            i += int(np.argmax(at <= 1.0))
            steps.append(i)
        return steps

    def index_on_board(self, autopilot: Autopilot, seq: int, lat_deg: float, lon_deg: float, fallback: int) -> int:
        """The step a vehicle flying its search mission is at, from its current item (`seq`,
        MISSION_CURRENT; the autopilot's first item is the take-off) and its position: between the
        waypoint before the one flown to and that one (past the last: on to the trajectory's end),
        the step nearest the position; before the first waypoint 0. `fallback` when the waypoint
        flown to is not on the trajectory, or when the position is more than `off_track_m` from
        every step between (a stale MISSION_CURRENT, of an earlier mission, must not move it on)."""
        waypoint = seq - autopilot.first_mission_seq() - 1
        if not len(self.track_m):
            return fallback
        if waypoint < 0:
            return 0
        steps, last = self.waypoint_steps, len(self.track_m) - 1
        if waypoint >= len(self.task.waypoints):
            lo, hi = (steps[-1] if steps and len(steps) == len(self.task.waypoints) else 0), last
        elif waypoint >= len(steps):
            return fallback
        else:
            lo, hi = (steps[waypoint - 1] if waypoint > 0 else 0), steps[waypoint]
        near = np.hypot(*(self.track_m[lo:hi + 1] - np.array(self.plan.local_m(lat_deg, lon_deg))).T)
        nearest = int(np.argmin(near))
        return lo + nearest if near[nearest] <= self.off_track_m else fallback

    @property
    def off_track_m(self) -> float:
        """How far from its trajectory a vehicle flying it may be seen: a cell and a half (a plane
        cuts its turns, a position is a few hundred milliseconds old)."""
        return 1.5 * self.plan.cell_size_m

    def flown_m(self, index: int) -> float:
        """Metres of the plan behind pose `index`: the trajectory's length up to it."""
        return float(self.along_m[min(index, len(self.along_m) - 1)])

    @property
    def length_m(self) -> float:
        return float(self.along_m[-1])

    def legs(self) -> Legs:
        """The trajectory's legs, pose to pose, in metres."""
        return [(float(e), float(n)) for e, n in np.diff(self.track_m, axis=0)]

    def look_ahead(self, index: int, lat_deg: float, lon_deg: float, steps: int) -> tuple[list[Legs], list[Legs]]:
        """For each of the next `steps` search poses after pose `index`: the legs from this position
        to it, and the planned way home from it; empty while the next pose is not a search pose
        (the plan's own return, or its end, is already the lowest-cost way home)."""
        start = index + 1
        ahead = self.task.trajectory[start: start + steps]
        steps_ahead: list[Legs] = []
        home: list[Legs] = []
        if not ahead or ahead[0].stage != "search":
            return steps_ahead, home
        here = np.array(self.plan.local_m(lat_deg, lon_deg))
        for j, p in enumerate(ahead):
            if p.stage != "search":
                break
            points = np.vstack([[here], self.track_m[start: start + j + 1]])
            steps_ahead.append([(float(e), float(n)) for e, n in np.diff(points, axis=0)])
            home.append(self.home_legs(start + j))
        return steps_ahead, home

    def home_legs(self, index: int) -> Legs:
        """The planned way home from pose `index` (the exact table's path under the OC), cell
        centre to cell centre, and on to the airport point: legs in metres, kept per pose."""
        legs = self._home_legs.get(index)
        if legs is None:
            plan = self.plan
            p = self.task.trajectory[index]
            pose = (p.x, p.y, p.heading)
            path = [pose] + plan.way_home(self.uid, pose)
            points = np.array([plan.grid.centre_m(x, y) for x, y, _ in path]
                              + [plan.local_m(*self.task.airport_lat_lon)])
            legs = [(float(e), float(n)) for e, n in np.diff(points, axis=0)]
            self._home_legs[index] = legs
        return legs

    def circuit_legs(self) -> Legs:
        """A plane flies out to its approach point and back before it lands (a copter lands where
        the way home ends): those legs, in metres."""
        task = self.task
        if task.approach is None:
            return []
        airport = np.array(self.plan.local_m(*task.airport_lat_lon))
        approach = np.array(self.plan.local_m(task.approach.lat_deg, task.approach.lon_deg))
        out = approach - airport
        return [(float(out[0]), float(out[1])), (float(-out[0]), float(-out[1]))]

    def return_leg(self, index: int) -> list[tuple[float, float]]:
        """Lat/lon turn points of the lowest-cost OC-respecting way home from the pose after pose
        `index` (the exact table's path), straight runs merged, ending at the airport cell."""
        plan, traj = self.plan, self.task.trajectory
        p = traj[min(index + 1, len(traj) - 1)]
        pose = (p.x, p.y, p.heading)
        path = [pose] + plan.way_home(self.uid, pose)
        keep = [path[0]] + [path[i] for i in range(1, len(path) - 1) if path[i + 1][2] != path[i][2]] + [path[-1]]
        return [plan.cell_lat_lon(x, y) for x, y, _ in keep] if len(path) > 1 else [plan.cell_lat_lon(pose[0], pose[1])]


def distance_m(plan: FleetPlan, a: tuple[float, float], b: tuple[float, float]) -> float:
    """Metres between lat/lon `a` and `b` in the plan's local frame."""
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)
