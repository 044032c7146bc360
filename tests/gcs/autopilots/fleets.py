"""Fleets on real autopilots judged as their crew judges them (issue 23): each vehicle's planned
search really flown and the battery it touched down with, read by an independent recorder on the
vehicle's own spare port (`tests.peers.recorder`), not from the station's log.

A vehicle does its job when it passes at least 90 % of its planned waypoints, or comes home by
fuel and touches down within [reserve - 5, reserve + 10] %: what it did not search, it left for
lack of charge, and it spent that charge on the search."""

from __future__ import annotations

import json
import math
import re
import time
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

from tests.gcs.autopilots.flights import fly
from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.ports import free_udp_port
from tests.peers.process import cpu_share
from tests.peers.px4 import Px4Sitl
from tests.peers.recorder import Flown, SpareRecorder, waypoints_passed
from tests.peers.site import Site

RESERVE_PCT = 30.0
#: ArduPilot SITL's wind with gusts (issue 23: a steady 8 m/s wind with turbulence 2)
WIND = {"SIM_WIND_SPD": 8.0, "SIM_WIND_DIR": 250.0, "SIM_WIND_TURB": 2.0}


@dataclass(frozen=True)
class Vehicle:
    """One vehicle of a fleet: `autopilot` "ardupilot" or "px4", its airframe, parameters."""

    autopilot: str = "ardupilot"
    airframe: str = "copter"
    params: dict = field(default_factory=dict)


@dataclass
class Verdict:
    uav: int
    planned: int
    passed: int
    returned: str
    touchdown_pct: float | None
    landed_m: float | None

    @property
    def flew_its_search(self) -> bool:
        return self.passed >= 0.9 * self.planned

    @property
    def spent_its_battery(self) -> bool:
        return self.touchdown_pct is not None and RESERVE_PCT - 5 <= self.touchdown_pct <= RESERVE_PCT + 10

    def __str__(self) -> str:
        return (f"UAV {self.uav}: {self.passed}/{self.planned} waypoints, returned by {self.returned}, touched down "
                f"with {self.touchdown_pct}%, {self.landed_m} m from its airport")


@dataclass
class FleetFlight:
    plan_dir: Path
    stdout: str
    returncode: int
    flown: dict[int, Flown]
    verdicts: dict[int, Verdict]

    def energy_errors(self) -> dict[int, float]:
        """Each vehicle's predicted-against-used error, as `gcs fly` reported it (%)."""
        return {int(m.group(1)): float(m.group(2)) for m in
                re.finditer(r"UAV (\d+): energy: used .* \(([+-][\d.]+)%\)", self.stdout)}


def fly_fleet(tmp_path: Path, site: Site, vehicles: list[Vehicle], *gcs_args: str, plan_args: tuple[str, ...] = (),
              speedup: float = 10.0, plan_dir: Path | None = None, wind: bool | dict[str, float] = False,
              inject: tuple[int, float, dict[str, float]] | None = None) -> FleetFlight:
    """Plan `site` (unless `plan_dir` is given), start one SITL per airport (ArduPilot instances
    push to one UDP port, PX4 ones are reached on their own), record each on its spare port, fly
    it with `gcs fly` and judge every vehicle. `inject` (uav, metres, params): set those
    parameters of an ArduPilot vehicle once it is that far from where it took off (a fault:
    SIM_GPS1_ENABLE 0 fails its GPS), over its SERIAL0, which nobody else uses. `wind`: True for
    WIND, or ArduPilot's SIM_WIND_* parameters."""
    plan_dir = plan_dir or site.plan(tmp_path / "field", *plan_args)
    plan = json.loads((plan_dir / "plan.json").read_text())
    port = free_udp_port()
    connections = [f"udpin:127.0.0.1:{port}"]
    recorders: dict[int, SpareRecorder] = {}
    serial0: dict[int, str] = {}
    with ExitStack() as stack:
        stack.enter_context(cpu_share(heavy=sum(v.autopilot == "px4" for v in vehicles) >= 2))
        for i, v in enumerate(vehicles):
            sysid = i + 1
            if v.autopilot == "px4":
                lat, lon, alt, _hdg = site.home(i)
                px4 = stack.enter_context(Px4Sitl(v.airframe, home=(lat, lon, alt), sysid=sysid, speedup=speedup,
                                                  params=dict(v.params)))
                connections.append(px4.gcs_connection)
                spare = f"udpin:127.0.0.1:{14030 + px4.instance}"  # its payload link: the API one sets its params
            else:
                params = {**(WIND if wind is True else wind or {}), **v.params}
                sitl = stack.enter_context(ArduPilotSitl(v.airframe, home=site.home(i), sysid=sysid, gcs_port=port,
                                                         speedup=speedup, params=params))
                spare = f"tcp:127.0.0.1:{sitl.tcp_port_2}"
                serial0[sysid] = sitl.tcp_connection
            recorders[sysid] = stack.enter_context(SpareRecorder(spare, sysid))
        if inject is not None:
            uav, away_m, params = inject
            _injector(serial0[uav], uav, recorders[uav], away_m, params)
        done = fly(plan_dir, connections, "--no-rrd", *gcs_args, timeout=900)
        flown = {uid: r.stop() for uid, r in recorders.items()}
    assert done.stdout.strip(), f"gcs fly said nothing, exit {done.returncode}: {done.stderr[-3000:]}"
    verdicts = {}
    for u in plan["uavs"]:
        uid = u["id"]
        f = flown[uid]
        within = plan["grid"]["georef"]["cell_size_m"] * (1.2 if u.get("vehicle") == "plane" else 0.6)
        going = re.search(rf"UAV {uid}: return - going home \((\w+)\)", done.stdout)
        landed = re.search(rf"UAV {uid}: landed(?: away)? - .*?([\d.]+) m from its airport", done.stdout)
        returned = going.group(1) if going else "plan"
        landed_m = float(landed.group(1)) if landed else None
        verdicts[uid] = Verdict(uid, len(u["waypoints"]), waypoints_passed(f.positions, u["waypoints"], within),
                                returned, f.touchdown_pct, landed_m)
    for v in verdicts.values():  # the figures docs/energy.md quotes (pytest -s shows them)
        print(v)
    return FleetFlight(plan_dir, done.stdout, done.returncode, flown, verdicts)


def _injector(connection: str, uav: int, recorder: SpareRecorder, away_m: float, params: dict[str, float]):
    """A thread that sets `params` on vehicle `uav` once its recorder has seen it `away_m` from
    where it took off (vehicle positions, not wall time: a loaded machine's SITL falls behind its
    speed-up). Started with the flight; it gives up when the flight ends."""
    import threading

    from pymavlink import mavutil

    from planner.georef import LocalFrame

    def inject() -> None:
        while not recorder.stopped:
            positions = list(recorder.flown.positions)
            if positions:
                frame = LocalFrame(*positions[0][:2])
                east, north = frame.geodetic2local(*positions[-1][:2])
                if math.hypot(float(east), float(north)) >= away_m:
                    break
            time.sleep(0.1)
        else:
            return
        conn = mavutil.mavlink_connection(connection, source_system=253, source_component=190)
        try:
            for name, value in params.items():
                for _ in range(20):
                    conn.mav.param_set_send(uav, 1, name.encode(), value, 9)
                    msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                    if msg is not None and msg.param_id.rstrip("\x00") == name and abs(msg.param_value - value) < 1e-6:
                        break
        finally:
            conn.close()

    thread = threading.Thread(target=inject, daemon=True, name=f"inject-{uav}")
    thread.start()
    return thread
