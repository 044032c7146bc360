"""How much an autopilot holds of a fence and a mission, as it answers when it is full, so a
plan is fitted before it reaches the vehicle (docs/autopilots.md, "Capacities").

Measured on the SITLs in `../shared/peers/` (tests/gcs/autopilots/test_sim_matches_sitl.py,
test_sim_matches_px4.py): ArduCopter holds 70 fence items, packed in 560 bytes (one polygon of
69 vertices), ArduPlane 84 (83); PX4 64 fence items (its dataman's fence points). Missions:
ArduCopter 650 items, ArduPlane 655 (home counted), PX4 65534. ArduPilot's storage is the
board's: a vehicle that holds fewer says so ("Only N items are supported") and the station
fits the fence to that (`gcs.flight.preflight`). Our simulated autopilots hold what this table
says (`sim.autopilot.ardupilot.CAPACITY`, `sim.autopilot.px4.CAPACITY`), and the SITL comparisons
hold both to the real ones."""

from __future__ import annotations

from gcs.missions.fence import FenceCapacity

__all__ = ["ARDUCOPTER_FENCE", "ARDUPLANE_FENCE", "PX4_FENCE", "fleet_fence_capacity", "fleet_mission_capacity",
           "mission_capacity"]

ARDUCOPTER_FENCE = FenceCapacity.ardupilot(70, "ArduCopter")
ARDUPLANE_FENCE = FenceCapacity.ardupilot(84, "ArduPlane")
PX4_FENCE = FenceCapacity(64, None, "PX4")

_MISSION_ITEMS = {("ardupilot", False): 650, ("ardupilot", True): 655, ("px4", False): 65534, ("px4", True): 65534}
_NAMES = {("ardupilot", False): "ArduCopter", ("ardupilot", True): "ArduPlane", ("px4", False): "PX4",
          ("px4", True): "PX4"}


def fence_capacity(autopilot: str, fixed_wing: bool) -> FenceCapacity | None:
    """What `autopilot` ("ardupilot", "px4") holds of a fence; None for one we do not know."""
    if autopilot == "ardupilot":
        return ARDUPLANE_FENCE if fixed_wing else ARDUCOPTER_FENCE
    return PX4_FENCE if autopilot == "px4" else None


def fleet_fence_capacity(fixed_wing: bool) -> FenceCapacity:
    """What every autopilot we fly holds of a copter's (or a plane's) fence: a plan's fences fit it."""
    return (ARDUPLANE_FENCE if fixed_wing else ARDUCOPTER_FENCE).within(PX4_FENCE)


def mission_capacity(autopilot: str, fixed_wing: bool) -> int:
    """Mission items `autopilot` ("ardupilot", "px4") holds (ArduPilot's count includes home)."""
    return _MISSION_ITEMS[(autopilot, fixed_wing)]


def fleet_mission_capacity(fixed_wing: bool) -> tuple[int, str]:
    """The fewest mission items an autopilot we fly holds, and whose that is."""
    return min((items, _NAMES[key]) for key, items in _MISSION_ITEMS.items() if key[1] == fixed_wing)
