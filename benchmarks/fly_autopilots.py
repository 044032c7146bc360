"""Flights of `gcs fly` on real ArduPilot and PX4 SITL, measured: time to ready, length flown,
landing distance from the airport, battery at landing against the reserve, the return
trigger's margin when it fired (metres of charge above the way home) and the energy profile's
prediction against what the vehicle used.

    .venv/bin/python benchmarks/fly_autopilots.py [--speedup 10] [--px4-speedup 5] [--runs 1]
                                                  [--only ardupilot|px4]

Scenarios: one ArduCopter on a 600 m square (30 m cells), one ArduPlane on a 2 km square
(100 m cells, NAVL1_PERIOD 10, landing approach of 400 m), two ArduCopters on one UDP port
where the second one's current sensor reads 1.65 times what it draws (BATT_AMP_PERVLT 28, as if
it lifted a heavy payload: its stock profile underprices it and the trigger must learn); one
PX4 copter (SIH) on the copters' square, and a mixed fleet of an ArduCopter and a PX4 copter
whose battery lasts 300 s (SIM_BAT_DRAIN), both at the PX4 speed-up. Needs the SITLs of the
peers folder (../shared/peers or $GCS_PEERS_DIR)."""

from __future__ import annotations

import argparse
import math
import re
import subprocess
import sys
import tempfile
from contextlib import ExitStack
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gcs.plans.plan_folder import load_plan_dir  # noqa: E402
from gcs.recording.flight import FLIGHT_TIME  # noqa: E402
from gcs.recording.plan import read_recording  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl, free_udp_port, require_ardupilot  # noqa: E402
from tests.peers.px4 import STEADY_BATTERY, Px4Sitl, require_px4  # noqa: E402
from tests.peers.site import COPTERS, PLANE, Site  # noqa: E402

_STAMP = re.compile(r"^\[\s*([\d.]+)s\] UAV (\d+): (.*)$")


def _fly(plan: Path, links: int | list[str], *extra: str) -> str:
    """`gcs fly` over `links` (a port number: the station listens there)."""
    links = [f"udpin:127.0.0.1:{links}"] if isinstance(links, int) else links
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "fly", "--plan", str(plan),
                           *(a for link in links for a in ("--connect", link)),
                           "--rrd", str(plan / "flight.rrd"), *extra],
                          capture_output=True, text=True, timeout=1800)
    if done.returncode != 0:
        raise SystemExit(f"gcs fly failed ({done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr}")
    return done.stdout


def _rows(name: str, plan_dir: Path, out: str, speedup: float) -> list[str]:
    plan = load_plan_dir(plan_dir)
    rec = read_recording(plan_dir / "flight.rrd", FLIGHT_TIME)
    events: dict[int, dict[str, float]] = {}
    texts: dict[int, dict[str, str]] = {}
    for line in out.splitlines():
        m = _STAMP.match(line)
        if not m:
            continue
        t, uid, text = float(m.group(1)), int(m.group(2)), m.group(3)
        for key in ("ready", "search", "landed", "return - going home", "energy"):
            if text.startswith(key):
                events.setdefault(uid, {}).setdefault(key, t)
                texts.setdefault(uid, {})[key] = text
        if "the way home is" in text:
            texts.setdefault(uid, {})["trigger"] = text
    rows = []
    for uid, task in plan.uavs.items():
        _, positions = rec.column(f"geo/uav/{uid}", "GeoPoints:positions")
        points = [plan.local_m(*p[0]) for p in positions]
        flown = sum(math.dist(a, b) for a, b in zip(points, points[1:]))
        landed = math.dist(points[-1], plan.local_m(*task.airport_lat_lon))
        e, t = events.get(uid, {}), texts.get(uid, {})
        battery = re.search(r"battery (\d+)%", t.get("landed", ""))
        trigger = re.search(r"pays for (\d+) m above .*; the way home is (\d+) m", t.get("trigger", ""))
        energy = re.search(r"energy: used .* \(([+-][\d.]+)%\)", t.get("energy", ""))
        margin = f"{float(trigger.group(1)) - float(trigger.group(2)):.1f}" if trigger else "-"
        ready_vt = e.get("ready", math.nan) * speedup
        rows.append(f"| {name} | {uid} | {e.get('ready', math.nan):.1f} s ({ready_vt:.0f} s vehicle) | "
                    f"{(e.get('landed', math.nan) - e.get('search', math.nan)) * speedup:.0f} s | {flown:.0f} m | "
                    f"{landed:.1f} m | {battery.group(1) if battery else '-'} % | "
                    f"{'battery' if 'return - going home' in e else 'plan'} | {margin} | "
                    f"{energy.group(1) + ' %' if energy else '-'} |")
    return rows


def _ardupilot_rows(root: Path, speedup: float) -> list[str]:
    rows = []
    copter = Site(COPTERS.airports[:1]).plan(root / "copter")
    with ArduPilotSitl("copter", home=COPTERS.home(0), speedup=speedup) as sitl:
        rows += _rows("ArduCopter", copter, _fly(copter, sitl.gcs_port), speedup)
    plane = PLANE.plan(root / "plane", "--vehicle", "plane", "--approach-m", "400")
    with ArduPilotSitl("plane", home=PLANE.home(0), speedup=speedup, params={"NAVL1_PERIOD": 10}) as sitl:
        rows += _rows("ArduPlane", plane, _fly(plane, sitl.gcs_port), speedup)
    pair = COPTERS.plan(root / "pair")
    port = free_udp_port()
    with ExitStack() as stack:
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port, speedup=speedup))
        stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=port, speedup=speedup,
                                          params={"BATT_AMP_PERVLT": 17.0 * 1.65}))
        rows += _rows("2 ArduCopters, UAV 2 draws 1.65x its profile", pair, _fly(pair, port), speedup)
    return rows


def _px4_rows(root: Path, speedup: float) -> list[str]:
    rows = []
    copter = Site(COPTERS.airports[:1]).plan(root / "px4")
    with Px4Sitl(home=COPTERS.home(0)[:3], speedup=speedup, params=STEADY_BATTERY) as px4:
        rows += _rows("PX4 copter", copter, _fly(copter, [px4.gcs_connection]), speedup)
    mixed = COPTERS.plan(root / "mixed")
    port = free_udp_port()
    with ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port, speedup=speedup), \
            Px4Sitl(home=COPTERS.home(1)[:3], sysid=2, speedup=speedup,
                    params={"SIM_BAT_DRAIN": 300.0, "SIM_BAT_MIN_PCT": 0.0}) as px4:
        rows += _rows("ArduCopter + PX4 (UAV 2, 300 s battery)", mixed,
                      _fly(mixed, [f"udpin:127.0.0.1:{port}", px4.gcs_connection]), speedup)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--speedup", type=float, default=10.0, help="ArduPilot-only scenarios")
    parser.add_argument("--px4-speedup", type=float, default=5.0, help="scenarios with PX4 (SIH keeps up to about 5)")
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--only", choices=("ardupilot", "px4"))
    args = parser.parse_args()
    require_ardupilot()
    if args.only != "ardupilot":
        require_px4()
    rows = []
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            if args.only != "px4":
                rows += _ardupilot_rows(Path(tmp), args.speedup)
            if args.only != "ardupilot":
                rows += _px4_rows(Path(tmp), args.px4_speedup)
    print(f"ArduPilot 4.7 SITL at SPEEDUP {args.speedup:g}, PX4 1.15.3 SIH at {args.px4_speedup:g} (and the mixed "
          "fleet's ArduCopter with it); reserve 30 %")
    print("| scenario | UAV | ready after the station started (wall) | flight (vehicle time) | flown "
          "| landed from airport | battery at landing | returned by | trigger margin (m) | energy predicted vs used |")
    print("|---|---:|---|---:|---:|---:|---:|---|---:|---:|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
