"""A `gcs plan --area` folder as a flight reads it back (`load_plan_dir`): what each UAV is to fly
(`FleetPlan`, `UavTask`), validated against the plan schema, with the mission items each
vehicle gets.

UAV ids are matched to vehicles by MAVLink system id: the plan's UAV N is the vehicle whose
HEARTBEAT comes from system id N, on whichever connection it is heard."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gcs.autopilots import Autopilot
from gcs.autopilots.mission_transfer import MissionType, WireItem
from gcs.errors import UserError
from gcs.links import mavlink
from gcs.missions.items import (
    AltitudeReference,
    LandingApproach,
    MissionItem,
    UavMission,
    Vehicle,
    landing_items,
    mission_items,
    waypoint_items,
)
from planner.georef import Grid, LocalFrame
from planner.motion import STEPS, MoveCosts, OrientationConstraint, constraint_by_name
from planner.return_exact import UNREACHABLE, follow_table, return_table

__all__ = ["FleetPlan", "Pose", "UavTask", "load_plan_dir"]

MAVMessage = mavlink.MAVLink_message


@dataclass(frozen=True)
class Pose:
    """A trajectory step: 0-based cell, heading 0..7, planner stage, cell centre lat/lon."""

    step: int
    x: int
    y: int
    heading: int
    stage: str
    lat_deg: float
    lon_deg: float


@dataclass
class UavTask:
    """One UAV's part of the plan."""

    uav_id: int
    name: str
    vehicle: Vehicle
    altitude_m: float
    airport_lat_lon: tuple[float, float]
    airport_cell: tuple[int, int]
    start_heading: int
    range_units: int
    waypoints: list[tuple[float, float]]
    trajectory: list[Pose]
    fence: list[tuple[bool, list[tuple[float, float]]]] = field(default_factory=list)
    rally: list[tuple[float, float, float]] = field(default_factory=list)
    altitude_reference: AltitudeReference = AltitudeReference.HOME
    elevation_m: float | None = None
    approach: LandingApproach | None = None

    @property
    def mission(self) -> UavMission:
        lat, lon = self.airport_lat_lon
        return UavMission(self.uav_id, self.name, self.vehicle, lat, lon, self.altitude_m, list(self.waypoints),
                          self.elevation_m or 0.0, self.altitude_reference, self.approach)

    def mission_wire(self, autopilot: Autopilot) -> list[WireItem]:
        """The mission as wire items; ArduPilot gets the airport as its home placeholder (item 0)."""
        return self._wire(autopilot, mission_items(self.mission))

    def return_wire(self, autopilot: Autopilot, leg: list[tuple[float, float]]) -> list[WireItem]:
        """A mission that flies `leg` (lat, lon) at the UAV's altitude and lands as the plan does."""
        mission = self.mission
        return self._wire(autopilot, waypoint_items(mission, leg) + landing_items(mission))

    def _wire(self, autopilot: Autopilot, items: list[MissionItem]) -> list[WireItem]:
        wire = [autopilot.adapt_item(WireItem.at(0, it.frame, it.command, it.lat_deg, it.lon_deg, it.alt_m, it.params))
                for it in items]
        if autopilot.home_item(MissionType.MISSION):
            lat, lon = self.airport_lat_lon
            wire.insert(0, WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon,
                                       self.elevation_m or 0.0))
        return wire

    def fence_wire(self) -> list[WireItem]:
        """Polygon fence vertices (param1 = vertex count), MAV_MISSION_TYPE_FENCE."""
        return fence_wire(self.fence)

    def rally_wire(self) -> list[WireItem]:
        return [WireItem.at(0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_RALLY_POINT, lat, lon, alt,
                            mission_type=MissionType.RALLY) for lat, lon, alt in self.rally]


@dataclass
class FleetPlan:
    """A plan folder: the UAVs' tasks, the grid on the Earth, the OC and the true targets."""

    folder: Path
    uavs: dict[int, UavTask]
    frame: LocalFrame
    grid: Grid
    no_fly: np.ndarray
    oc: OrientationConstraint
    targets: list[tuple[int, int]]
    raw: dict
    _tables: dict[int, np.ndarray] = field(default_factory=dict)

    @property
    def cell_size_m(self) -> float:
        return self.grid.cell_size_m

    @property
    def pc(self) -> float:
        """The Pc per look the plan was made with: plan.json's `search_theory.pc`, the one its
        figures were reckoned with (its camera's when it was made with one: every plan that names
        a camera records it), else its options' `pc` (0.9 for a plan that records none)."""
        recorded = (self.raw.get("search_theory") or {}).get("pc")
        if recorded is not None:
            return float(recorded)
        options = (self.raw.get("campaign") or {}).get("options") or {}
        return float(options.get("pc", 0.9))

    @property
    def pf(self) -> float:
        """The false-alarm probability per look the plan was made with (0.1 for one that records none)."""
        options = (self.raw.get("campaign") or {}).get("options") or {}
        return float(options.get("pf", 0.1))

    def cell_of(self, lat_deg: float, lon_deg: float) -> tuple[int, int] | None:
        east, north = self.frame.geodetic2local(lat_deg, lon_deg)
        try:
            return self.grid.cell_of(float(east), float(north))
        except ValueError:
            return None

    def local_m(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """One point in the plan's frame, by pyproj's single-point path (a fifth of the array
        path's time: the station converts every vehicle's every position)."""
        east, north = self.frame.geodetic2en(lat_deg, lon_deg)
        return float(east), float(north)

    def cell_lat_lon(self, x: int, y: int) -> tuple[float, float]:
        lat, lon = self.frame.local2geodetic(*self.grid.centre_m(x, y))
        return float(lat), float(lon)

    def raw_uav(self, uav_id: int) -> dict:
        """UAV `uav_id`'s entry of plan.json as written."""
        return next(u for u in self.raw["uavs"] if int(u["id"]) == uav_id)

    @property
    def move_costs(self) -> MoveCosts:
        """What the plan charged a step (its settings' `move_costs`; steps for older plans)."""
        costs = self.raw.get("settings", {}).get("move_costs")
        return STEPS if costs is None else MoveCosts(int(costs["straight"]), int(costs["diagonal"]))

    def return_table(self, uav_id: int) -> np.ndarray:
        """The lowest cost home from every (heading, x, y) to this UAV's airport under the plan's
        OC, charged as the plan charged (`planner.return_exact.return_table`), computed once."""
        if uav_id not in self._tables:
            self._tables[uav_id] = return_table(self.no_fly, self.uavs[uav_id].airport_cell, self.oc,
                                                self.move_costs)
        return self._tables[uav_id]

    def way_home(self, uav_id: int, pose: tuple[int, int, int]) -> list[tuple[int, int, int]]:
        """The poses after `pose` on this UAV's lowest-cost way home (the exact table's path under
        the OC, `planner.return_exact.follow_table`)."""
        return follow_table(self.return_table(uav_id), pose, self.oc.successors, self.no_fly, self.move_costs)

    def prepare_returns(self) -> None:
        """Compute every UAV's return table, and load the kernels that build and follow them, now:
        before a flight, not on its event loop, where a vehicle's first return check would hold
        every link for a second on a loaded station (ten seconds of a vehicle at SPEEDUP 10,
        whose telemetry the station then loses)."""
        for uav_id, task in self.uavs.items():
            if task.trajectory:
                p = task.trajectory[0]
                self.way_home(uav_id, (p.x, p.y, p.heading))

    def home_m(self, uav_id: int, pose: tuple[int, int, int]) -> float:
        """Metres of the lowest-cost way home from `pose` over the grid (inf when there is none)."""
        x, y, h = pose
        value = int(self.return_table(uav_id)[h, x, y])
        if value >= UNREACHABLE:
            return math.inf
        costs = self.move_costs
        return value * self.cell_size_m / costs.straight if not costs.unit_steps else value * self.cell_size_m


def _fail(folder: Path, what: str) -> UserError:
    return UserError(f"{folder}: {what}")


def load_plan_dir(folder: str | Path) -> FleetPlan:
    """Read a `gcs plan --area` output folder; UserError with one line on anything missing."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"plan folder {folder} does not exist "
                        f"(make one with: gcs plan --area AREA.geojson --out {folder})")
    path = folder / "plan.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise _fail(folder, "no plan.json in it (make one with gcs plan --area)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _fail(folder, f"plan.json is not readable JSON ({exc})") from None
    _check_schema(folder, data)
    try:
        grid_data = data["grid"]
        georef = grid_data.get("georef")
        if georef is None:
            raise _fail(folder, "plan.json has no geo-reference: plan over an area (gcs plan --area) to fly it")
        frame = LocalFrame(float(georef["origin"]["lat"]), float(georef["origin"]["lon"]))
        grid = Grid(float(georef["east0_m"]), float(georef["north0_m"]), float(georef["cell_size_m"]),
                    int(grid_data["nx"]), int(grid_data["ny"]))
        no_fly = np.zeros((grid.nx, grid.ny), dtype=bool)
        for x, y in grid_data["no_fly"]:
            no_fly[x - 1, y - 1] = True
        oc = constraint_by_name(data["settings"]["oc"])
        uavs = {}
        for u in data["uavs"]:
            uid = int(u["id"])
            if "waypoints" not in u:
                raise _fail(folder, f"UAV {uid} has no mission waypoints in plan.json")
            trajectory = [Pose(int(p["step"]), int(p["x"]) - 1, int(p["y"]) - 1, int(p["heading"]), str(p["stage"]),
                               float(p["lat"]), float(p["lon"])) for p in u["trajectory"]]
            task = UavTask(uid, str(u.get("name", f"UAV{uid}")), Vehicle(u.get("vehicle", "copter")),
                           float(u["altitude_m"]), tuple(u["airport_lat_lon"]),
                           (int(u["airport"][0]) - 1, int(u["airport"][1]) - 1), int(u["start_heading"]),
                           int(u["range"]), [tuple(w) for w in u["waypoints"]], trajectory,
                           altitude_reference=AltitudeReference(u.get("altitude_reference", "home")),
                           elevation_m=u.get("elevation_m"), approach=_approach(u.get("approach")))
            _read_qgc_plan(folder / f"uav{uid}.plan", task)
            uavs[uid] = task
        targets = [(int(t["x"]) - 1, int(t["y"]) - 1) for t in data.get("targets", [])]
    except UserError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise _fail(folder, f"plan.json is not a plan made by gcs plan --area ({type(exc).__name__}: {exc})") from None
    if not uavs:
        raise _fail(folder, "plan.json has no UAVs")
    return FleetPlan(folder, uavs, frame, grid, no_fly, oc, targets, data)


def _check_schema(folder: Path, data: object) -> None:
    """plan.json against gcs/schemas/plan.schema.json: UserError naming the first field that
    is missing or wrong (where it is, and what was expected)."""
    import jsonschema

    from gcs.plans.plan_file import plan_schema

    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(plan_schema()).iter_errors(data))
    if error is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
        raise _fail(folder, f"plan.json does not follow the plan schema: {where or 'the top level'}: {error.message}")


def _approach(data: dict | None) -> LandingApproach | None:
    if data is None:
        return None
    (lat, lon), alt = data["lat_lon"], data["alt_m"]
    return LandingApproach(float(lat), float(lon), float(alt))


def _read_qgc_plan(path: Path, task: UavTask) -> None:
    """Geofence polygons and rally points from the UAV's QGroundControl .plan, when present."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    for poly in doc.get("geoFence", {}).get("polygons", []):
        task.fence.append((bool(poly["inclusion"]), [(float(a), float(b)) for a, b in poly["polygon"]]))
    for lat, lon, alt in doc.get("rallyPoints", {}).get("points", []):
        task.rally.append((float(lat), float(lon), float(alt)))


# ---- live state ------------------------------------------------------------------------




def fence_wire(rings: list[tuple[bool, list[tuple[float, float]]]]) -> list[WireItem]:
    """Polygon fence vertices of (inclusion, open ring of (lat, lon)) pairs, param1 the vertex
    count, MAV_MISSION_TYPE_FENCE."""
    out = []
    for inclusion, ring in rings:
        cmd = (mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION if inclusion
               else mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
        out += [WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, cmd, lat, lon, 0.0, (len(ring), 0, 0, 0), MissionType.FENCE)
                for lat, lon in ring]
    return out
