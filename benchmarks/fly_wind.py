"""Fleets of three on real ArduPilot SITL in a gusty wind, judged as their crew judges them (issue 38,
docs/energy.md "Wind truth"): the planned waypoints each vehicle passed, the battery it touched down
with (read on its own spare port), the energy its profile predicted against what it used, and the
wind the station said. SITL's turbulence (SIM_WIND_TURB) lowers ArduPlane's current by a fifth at
the same air speed, a thing no real plane does: the planes fly with and without it.

    .venv/bin/python benchmarks/fly_wind.py            # about 8 min: the table of docs/energy.md
    .venv/bin/python benchmarks/fly_wind.py --only 0,1 # some rows

Each row: `gcs fly --fit-charge` with stock profiles, no crew's wind (the copters read it from their
lean, the planes from ArduPlane's WIND), on the field of
`tests/peers/site.py` (1.5 x 1.2 km, 50 m cells, airports of 2500 m, the reserve 30 %)."""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.gcs.autopilots.fleets import RESERVE_PCT, Vehicle, fly_fleet  # noqa: E402
from tests.peers.site import FIELD_COPTERS, FIELD_PLANES  # noqa: E402

PLANES = [Vehicle(airframe="plane")] * 3
ROWS = [  # (label, fleet, site, plan arguments, SIM_WIND_SPD, SIM_WIND_DIR, SIM_WIND_TURB)
    ("ArduCopter x3", [Vehicle()] * 3, FIELD_COPTERS, (), 5.0, 250.0, 2.0),
    ("ArduCopter x3", [Vehicle()] * 3, FIELD_COPTERS, (), 8.0, 250.0, 2.0),
    ("ArduCopter x3", [Vehicle()] * 3, FIELD_COPTERS, (), 5.0, 70.0, 2.0),
    ("ArduCopter x3", [Vehicle()] * 3, FIELD_COPTERS, (), 8.0, 70.0, 2.0),
    ("ArduPlane x3", PLANES, FIELD_PLANES, ("--vehicle", "plane"), 8.0, 250.0, 2.0),
    ("ArduPlane x3", PLANES, FIELD_PLANES, ("--vehicle", "plane"), 8.0, 250.0, 0.0),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="row numbers, comma-separated (from 0)")
    args = parser.parse_args()
    rows = [ROWS[int(i)] for i in args.only.split(",")] if args.only else ROWS
    print("| fleet | SIM_WIND_SPD / DIR / TURB | UAV | waypoints passed | returned | touchdown % "
          "| energy predicted vs used | wind said last |")
    print("|---|---|---|---|---|---|---|---|")
    for label, fleet, site, plan_args, speed, source, turbulence in rows:
        wind = {"SIM_WIND_SPD": speed, "SIM_WIND_DIR": source, "SIM_WIND_TURB": turbulence}
        with tempfile.TemporaryDirectory() as tmp:
            flight = fly_fleet(Path(tmp), site, fleet, "--fit-charge", plan_args=plan_args, wind=wind)
        errors = flight.energy_errors()
        for uid, v in sorted(flight.verdicts.items()):
            said = re.findall(rf"UAV {uid}: wind ([\d.]+ ± [\d.]+ m/s from \d+ deg \([^)]*\))", flight.stdout)
            ok = v.flew_its_search or (v.touchdown_pct is not None
                                      and RESERVE_PCT - 5 <= v.touchdown_pct <= RESERVE_PCT + 12)
            error = errors.get(uid)
            print(f"| {label} | {speed:g} / {source:g} / {turbulence:g} | {uid} | {v.passed}/{v.planned} "
                  f"| {v.returned} "
                  f"| {v.touchdown_pct} {'' if ok else '(out of bounds)'} "
                  f"| {'-' if error is None else f'{error:+.1f} %'} | {said[-1] if said else 'none'} |", flush=True)


if __name__ == "__main__":
    main()
