"""What one vehicle's flight does before it flies (`prepare`): connect, then check and set what
it needs (ready to fly: `wait_ready`; its home at the plan's airport: `home_matches`; its battery
and energy profile: `battery_setup`; the parameters its autopilot needs:
`set_params_before_arming`), and upload its mission; just before arming, its charge reported
(`battery_report`) and paying for its plan (`charge_covers_plan`). Each says what it finds, and a check that
fails leaves the vehicle FAILED with a note naming why."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from gcs.autopilots import Autopilot
from gcs.autopilots.capacity import fence_capacity
from gcs.autopilots.mission_transfer import MissionTransferError, MissionType, upload_verified
from gcs.flight.events import MissionUploaded
from gcs.flight.vehicle_track import distance_m
from gcs.links import CommandError, mavlink
from gcs.missions.fence import Fence, FenceCapacity
from gcs.missions.fence_fit import FenceDoesNotFit, fit_fence
from gcs.plans.plan_folder import fence_wire
from gcs.plans.vehicle_file import stock_profile
from gcs.telemetry.status import Stage

if TYPE_CHECKING:
    from gcs.flight.vehicle_flight import VehicleFlight

__all__ = ["BATTERY_REPORT_WAIT_S", "battery_report", "battery_setup", "charge_covers_plan", "home_matches", "prepare",
           "set_params_before_arming", "upload_fence", "wait_ready", "wait_until"]

#: How long a vehicle that has sent no battery report yet is given for one before its charge is
#: checked, once asked for it (MAV_CMD_REQUEST_MESSAGE). A vehicle booted before the station is
#: ready at once, and its upload takes a tenth of a second: its first BATTERY_STATUS can come
#: after that (ArduCopter SITL, one run of four), and the check was then skipped.
BATTERY_REPORT_WAIT_S = 3.0


async def prepare(vehicle: VehicleFlight, mission: bool = True) -> bool:
    """Connect, ask for the telemetry, wait until the vehicle is ready to fly (GPS fix, the
    estimator's position, a home), check its home is the plan's airport, upload and verify
    (unless `mission` is False). False (and stage FAILED with a clear note) when anything
    cannot be done."""
    opts, st, task, uid = vehicle.options, vehicle.status, vehicle.task, vehicle.uid
    vehicle.set_stage(Stage.CONNECTING)
    if not await wait_until(lambda: st.autopilot is not None, opts.connect_timeout_s):
        links = ", ".join(link.name for link in vehicle.station.links)
        vehicle.set_stage(Stage.FAILED, f"no HEARTBEAT from system id {uid} within {opts.connect_timeout_s:g} s "
                                        f"on {links}")
        return False
    link = vehicle.link
    if link.signing is None and uid in link.signing_systems:
        vehicle.set_stage(Stage.FAILED, f"vehicle {uid} signs its MAVLink messages and will refuse ours: give the "
                                        "station its key (--signing-key or --signing-passphrase)")
        return False
    vehicle.set_stage(Stage.PREPARING, f"{st.autopilot.value} autopilot")
    await vehicle.commands.request_streams()
    if not await wait_ready(vehicle) or not home_matches(vehicle):
        return False
    await battery_setup(vehicle)
    await set_params_before_arming(vehicle)
    if not mission:
        return True
    vehicle.set_stage(Stage.UPLOADING)
    autopilot = st.autopilot
    try:
        items = task.mission_wire(autopilot)
    except ValueError as exc:
        vehicle.set_stage(Stage.FAILED, f"mission not uploaded: {exc}")
        return False
    try:
        report = await upload_verified(link, uid, items, autopilot, timeout_s=opts.transfer_timeout_s,
                                       fixed_wing=st.fixed_wing)
    except MissionTransferError as exc:
        vehicle.set_stage(Stage.FAILED, f"mission {exc}")
        return False
    vehicle.upload_reports = reports = {"mission": report}
    vehicle.station.emit(MissionUploaded(uid, "search"))
    extra = []
    if opts.fence and task.fence:
        fenced = await upload_fence(vehicle)
        if fenced is None:
            return False
        extra.append(f"{fenced} fence")
    rally = task.rally_wire()
    if opts.fence and rally:
        try:
            reports["rally"] = await upload_verified(link, uid, rally, autopilot, MissionType.RALLY,
                                                     timeout_s=opts.transfer_timeout_s)
            extra.append(f"{len(rally)} rally")
        except MissionTransferError as exc:
            vehicle.say(f"warning: {exc}; flying without it")
    vehicle.say(f"mission verified: {report.items} items{' + ' + ', '.join(extra) if extra else ''} in "
                f"{report.elapsed_s:.2f} s ({report.resends} re-sends"
                f"{', legacy MISSION_REQUEST used' if report.legacy_requests else ''})")
    return True


async def upload_fence(vehicle: VehicleFlight) -> int | None:
    """Upload and verify the plan's geofence, fitted first to what the vehicle's autopilot is
    known to hold and, if it refuses it for want of room, to what it says it holds (the inclusion
    grows; the no-fly zones are kept). The fence items uploaded; None, the vehicle FAILED, when
    it cannot be had: no vehicle is launched without its fence but by the operator's --no-fence."""
    st, task, opts = vehicle.status, vehicle.task, vehicle.options
    fixed_wing = bool(st.fixed_wing)
    rings = task.fence
    known = fence_capacity(st.autopilot.value, fixed_wing) if st.autopilot else None
    try:
        if known is not None:
            rings = _fitted(vehicle, rings, known)
        for attempt in (1, 2):
            items = fence_wire(rings)
            try:
                vehicle.upload_reports["fence"] = await upload_verified(
                    vehicle.link, vehicle.uid, items, st.autopilot, MissionType.FENCE,
                    timeout_s=opts.transfer_timeout_s)
                return len(items)
            except MissionTransferError as exc:
                answered = _answered_capacity(exc, st.autopilot, fixed_wing)
                if attempt == 2 or answered is None or answered.holds([len(r) for _, r in rings]):
                    raise
                rings = _fitted(vehicle, rings, answered)
    except (MissionTransferError, FenceDoesNotFit) as exc:
        vehicle.set_stage(Stage.FAILED, f"fence not uploaded: {exc}; not launched without it (--no-fence flies "
                                        "without a geofence)")
    return None


def _fitted(vehicle: VehicleFlight, rings: list[tuple[bool, list[tuple[float, float]]]],
            capacity: FenceCapacity) -> list[tuple[bool, list[tuple[float, float]]]]:
    """`rings` (inclusion flag, open ring) fitted to `capacity`, said when simplified."""
    closed = [(inclusion, ring + ring[:1]) for inclusion, ring in rings]
    fence = Fence([r for inclusion, r in closed if inclusion], [r for inclusion, r in closed if not inclusion])
    fitted = fit_fence(fence, capacity)
    if fitted.simplified:
        vehicle.say(f"{fitted.describe()}, to fit its {capacity.describe()}")
    return [(True, r[:-1]) for r in fitted.fence.inclusion] + [(False, r[:-1]) for r in fitted.fence.exclusion]


def _answered_capacity(exc: MissionTransferError, autopilot: Autopilot, fixed_wing: bool) -> FenceCapacity | None:
    """What a vehicle that refused a fence says it holds: ArduPilot's "Only N items are
    supported", else the autopilot's known capacity when it refused for want of room."""
    if exc.capacity:
        return FenceCapacity.ardupilot(exc.capacity) if autopilot is Autopilot.ARDUPILOT \
            else FenceCapacity(exc.capacity)
    if exc.result in (mavlink.MAV_MISSION_NO_SPACE, mavlink.MAV_MISSION_ERROR):
        return fence_capacity(autopilot.value, fixed_wing)
    return None


MAX_REASONS = 4  # the autopilot's distinct reasons a failed wait repeats


async def wait_until(predicate: Callable[[], bool], timeout_s: float) -> bool:
    """Poll `predicate` (every 20 ms) until it holds: True; False after `timeout_s`."""
    end = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > end:
            return False
        await asyncio.sleep(0.02)
    return True


async def wait_ready(vehicle: VehicleFlight) -> bool:
    """Until `VehicleStatus.waiting_for` is empty, showing what is missing (and the autopilot's
    own words) whenever that changes; FAILED after `ready_timeout_s`, naming every reason the
    autopilot gave while it waited (PX4 takes turns between its failing checks), latest last."""
    st, timeout_s = vehicle.status, vehicle.options.ready_timeout_s
    end = time.monotonic() + timeout_s
    shown: tuple = ()
    reasons: dict[str, None] = {}
    while missing := st.waiting_for():
        if st.last_text:
            reasons.pop(st.last_text, None)
            reasons[st.last_text] = None
        now = (tuple(missing), st.last_text)
        if now != shown:
            shown = now
            said = f" - autopilot: {st.last_text}" if st.last_text else ""
            vehicle.set_stage(Stage.PREPARING, f"waiting for {', '.join(missing)}{said}")
            vehicle.say(f"waiting for {', '.join(missing)}{said}")
        if time.monotonic() > end:
            autopilot = f" ({'; '.join(list(reasons)[-MAX_REASONS:])})" if reasons else ""
            vehicle.set_stage(Stage.FAILED, f"not ready after {timeout_s:g} s: no {', '.join(missing)}{autopilot}")
            return False
        await asyncio.sleep(0.05)
    vehicle.say("ready: " + ", ".join(part for part in (
        f"GPS fix {st.gps_fix_type}" + (f" ({st.satellites} satellites)" if st.satellites else "")
        if st.gps_fix_type is not None else "", "EKF position" if st.ekf_position_ok else "",
        "home set" if st.home else "") if part))
    return True


def home_matches(vehicle: VehicleFlight) -> bool:
    """The vehicle's home (HOME_POSITION, else its position) must be the plan's airport, within
    a cell; refused, naming both, unless the operator allowed the offset (`check_home`)."""
    st, task, plan, uid = vehicle.status, vehicle.task, vehicle.plan, vehicle.uid
    here = st.home[:2] if st.home else (st.lat_deg, st.lon_deg)
    away = distance_m(plan, here, task.airport_lat_lon)
    if away <= plan.cell_size_m:
        return True
    what = (f"vehicle {uid}'s home {here[0]:.7f}, {here[1]:.7f} is {away:.0f} m from UAV {uid}'s airport "
            f"{task.name!r} at {task.airport_lat_lon[0]:.7f}, {task.airport_lat_lon[1]:.7f} (more than a cell, "
            f"{plan.cell_size_m:g} m)")
    if not vehicle.options.check_home:
        vehicle.say(f"warning: {what}; flying anyway (--allow-home-offset)")
        return True
    vehicle.set_stage(Stage.FAILED, f"{what}: is system id {uid} the right vehicle? (--allow-home-offset flies anyway)")
    return False


async def battery_setup(vehicle: VehicleFlight) -> None:
    """Before the flight: the vehicle's stock profile for its autopilot and airframe (unless
    one was given), the pack capacity its autopilot counts with, and its board's unique id
    (AUTOPILOT_VERSION, the key of its learned profile)."""
    st, energy = vehicle.status, vehicle.energy
    autopilot = (st.autopilot or Autopilot.GENERIC).value
    airframe = "plane" if st.fixed_wing else "copter"
    energy.autopilot = autopilot
    if vehicle.uid not in vehicle.options.profiles:
        energy.set_profile(stock_profile(autopilot, airframe))
    name = (st.autopilot or Autopilot.GENERIC).capacity_param()
    if name is not None:
        capacity = await vehicle.commands.get_param(name)
        if capacity is not None and capacity > 0:
            energy.fuel.set_capacity(capacity)
    try:
        await vehicle.commands.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                                       retries=2)
    except CommandError:
        pass  # keyed by its system id


async def set_params_before_arming(vehicle: VehicleFlight) -> None:
    """The parameters its autopilot needs changed for this flight (`param_changes_before_arming`);
    one not confirmed is said, not fatal."""
    st = vehicle.status
    assert st.autopilot is not None
    for name, value in st.autopilot.param_changes_before_arming(st.fixed_wing,
                                                                vehicle.task.approach is not None).items():
        if await vehicle.commands.set_param(name, value):
            vehicle.say(f"{name} set to {value:g}: RTL lands on the runway through the mission's landing sequence"
                        if name == "RTL_AUTOLAND" else f"{name} set to {value:g}")
        else:
            vehicle.say(f"warning: {name} not confirmed; the autopilot may refuse to arm")


async def battery_report(vehicle: VehicleFlight) -> None:
    """When the vehicle has reported no charge yet, ask for its BATTERY_STATUS and wait for it
    up to `BATTERY_REPORT_WAIT_S` (a request the autopilot does not answer still waits: its
    stream may bring it)."""
    fuel = vehicle.energy.fuel
    if fuel.remaining_mah is not None:
        return
    try:
        await vehicle.commands.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
                                       retries=1)
    except CommandError:
        pass
    await wait_until(lambda: fuel.remaining_mah is not None, BATTERY_REPORT_WAIT_S)


def charge_covers_plan(vehicle: VehicleFlight) -> bool:
    """Before arming: does the charge the vehicle reports now pay for its plan (launch, the
    mission path, the landing) and leave the reserve, at its profile's prices? When it does
    not, the vehicle stays on the ground (FAILED, naming both figures), or with `fit_charge`
    flies its plan until its battery calls it home (the fuel-based return trigger, which prices
    the way home from where it is in the wind it reads), never when its charge cannot pay for
    its shortest way: out to its first pose and home from there. A metre is priced in the wind
    known. A charge not reported (`battery_report`) is not checked, and said.

    No range in metres is set: a cut priced at the plan's average cost of a metre, corners
    included, turned a copter home with its battery well above the reserve where its plan was
    cheaper than that average (ArduCopter SITL: 42 % at a 30 % reserve), while the battery
    itself says what is left."""
    st, fuel, options = vehicle.status, vehicle.energy.fuel, vehicle.options
    path_m = float(vehicle.plan.raw_uav(vehicle.uid).get("length_m", vehicle.track.length_m))
    track = vehicle.track
    charge = vehicle.energy.plan_charge(path_m, track)
    if charge is None:
        vehicle.say(f"warning: no battery report in {BATTERY_REPORT_WAIT_S:g} s, asked for; its charge is not checked "
                    "against its plan")
        return True
    have, need, per_m = charge.have_mah, charge.need_mah, charge.mah_per_m
    pct = f"{st.battery_pct:.0f}%" if st.battery_pct is not None else "charge"
    wind = "" if fuel.wind_m_s is None else " in the wind"
    if charge.enough:
        vehicle.say(f"charge {pct} ({have:.0f} of {fuel.capacity_mah:.0f} mAh) pays for its {path_m:.0f} m plan"
                    f"{wind}: {need:.0f} mAh with the {options.reserve_pct:g}% reserve")
        return True
    covers_m = charge.covers_m
    what = (f"charge {pct} = {have:.0f} mAh pays for {covers_m:.0f} m of its plan's {path_m:.0f} m{wind} (the plan "
            f"needs {need:.0f} mAh with the {options.reserve_pct:g}% reserve of a {fuel.capacity_mah:.0f} mAh "
            f"pack)")
    if not options.fit_charge:
        vehicle.set_stage(Stage.FAILED, f"not armed: {what}; charge it, or fly its plan until its battery calls it "
                                        "home (--fit-charge)")
        return False
    mission_m = covers_m - max(0.0, path_m - track.length_m)
    if len(vehicle.task.trajectory) > 1:
        home = fuel.way_cost(track.home_legs(1))
        shortest_m = track.flown_m(1) + home.metres
        if mission_m * per_m < track.flown_m(1) * per_m + home.mah:
            vehicle.set_stage(Stage.FAILED, f"not armed: {what}, less than its shortest way out and home "
                                            f"({shortest_m:.0f} m{wind})")
            return False
    vehicle.say(f"{what}: flying its plan until its battery calls it home (--fit-charge)")
    return True

