"""Flights of `gcs fly` on real ArduPilot SITL, measured: time to ready, length flown, landing
distance from the airport, battery at landing against the reserve, and the return trigger's
margin when it fired.

    .venv/bin/python benchmarks/fly_ardupilot.py [--speedup 10] [--runs 1]

Scenarios: one ArduCopter on a 600 m square (30 m cells), one ArduPlane on a 2 km square
(100 m cells, NAVL1_PERIOD 10, landing approach of 400 m), and two ArduCopters on one UDP port
where the second one's battery has 2000 mAh instead of 3300 (it drains 1.65 times as fast).
Needs the ArduPilot SITL of the peers folder (../shared/peers/ardupilot or $GCS_PEERS_DIR)."""

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

from gcs.fleet import load_plan_dir  # noqa: E402
from gcs.flight_recording import FLIGHT_TIME  # noqa: E402
from gcs.recording import read_recording  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl, free_udp_port, require_ardupilot  # noqa: E402
from tests.peers.site import COPTERS, PLANE, Site  # noqa: E402

_STAMP = re.compile(r"^\[\s*([\d.]+)s\] UAV (\d+): (.*)$")


def _fly(plan: Path, port: int, speedup: float, *extra: str) -> str:
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "fly", "--plan", str(plan), "--connect",
                           f"udpin:127.0.0.1:{port}", "--rrd", str(plan / "flight.rrd"), *extra],
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
        for key in ("ready", "search", "landed", "return - going home"):
            if text.startswith(key):
                events.setdefault(uid, {}).setdefault(key, t)
                texts.setdefault(uid, {})[key] = text
        if "the way home needs" in text:
            texts.setdefault(uid, {})["trigger"] = text
    rows = []
    for uid, task in plan.uavs.items():
        _, positions = rec.column(f"geo/uav/{uid}", "GeoPoints:positions")
        points = [plan.local_m(*p[0]) for p in positions]
        flown = sum(math.dist(a, b) for a, b in zip(points, points[1:]))
        landed = math.dist(points[-1], plan.local_m(*task.airport_lat_lon))
        e, t = events.get(uid, {}), texts.get(uid, {})
        battery = re.search(r"battery (\d+)%", t.get("landed", ""))
        trigger = re.search(r"covers ([\d.]+) steps, the way home needs ([\d.]+)", t.get("trigger", ""))
        margin = f"{float(trigger.group(1)) - float(trigger.group(2)):.1f}" if trigger else "-"
        ready_vt = e.get("ready", math.nan) * speedup
        rows.append(f"| {name} | {uid} | {e.get('ready', math.nan):.1f} s ({ready_vt:.0f} s vehicle) | "
                    f"{(e.get('landed', math.nan) - e.get('search', math.nan)) * speedup:.0f} s | {flown:.0f} m | "
                    f"{landed:.1f} m | {battery.group(1) if battery else '-'} % | "
                    f"{'battery' if 'return - going home' in e else 'plan'} | {margin} |")
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--speedup", type=float, default=10.0)
    parser.add_argument("--runs", type=int, default=1)
    args = parser.parse_args()
    require_ardupilot()
    rows = []
    for run in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            copter = Site(COPTERS.airports[:1]).plan(root / "copter")
            with ArduPilotSitl("copter", home=COPTERS.home(0), speedup=args.speedup) as sitl:
                rows += _rows("copter", copter, _fly(copter, sitl.gcs_port, args.speedup, "--cruise-speed", "5"),
                              args.speedup)
            plane = PLANE.plan(root / "plane", "--vehicle", "plane", "--approach-m", "400")
            with ArduPilotSitl("plane", home=PLANE.home(0), speedup=args.speedup, params={"NAVL1_PERIOD": 10}) as sitl:
                rows += _rows("plane", plane, _fly(plane, sitl.gcs_port, args.speedup, "--cruise-speed", "22"),
                              args.speedup)
            pair = COPTERS.plan(root / "pair")
            port = free_udp_port()
            with ExitStack() as stack:
                stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(0), sysid=1, gcs_port=port,
                                                  speedup=args.speedup))
                stack.enter_context(ArduPilotSitl("copter", home=COPTERS.home(1), sysid=2, gcs_port=port,
                                                  speedup=args.speedup, params={"BATT_CAPACITY": 2000}))
                rows += _rows("2 copters, UAV 2 2000 mAh", pair, _fly(pair, port, args.speedup, "--cruise-speed", "5"),
                              args.speedup)
    print(f"ArduPilot 4.7 SITL, SPEEDUP {args.speedup:g}, reserve 30 %")
    print("| scenario | UAV | ready after the station started (wall) | flight (vehicle time) | flown | landed from airport | battery at landing "
          "| returned by | trigger margin (steps) |")
    print("|---|---:|---|---:|---:|---:|---:|---|---:|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
