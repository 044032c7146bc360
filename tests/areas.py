"""The area the simulated flights fly: the paper's (missions/paper.geojson), its four airports'
range cut to `FLIGHT_RANGE_M`, 1400 m of the paper's 3700: a flight of its four UAVs at speed-up
30 takes about 12 s of wall time (a station's decisions and a vehicle's stages are the same as on
the whole range; there is less search between them). It was 1850 m until the simulated copter
braked for its corners as ArduCopter does (docs/sim.md), which made each flight 3 s longer."""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAPER_AREA = ROOT / "missions" / "paper.geojson"
FLIGHT_RANGE_M = 1400.0


def paper_area_with_range(folder: Path, range_m: float = FLIGHT_RANGE_M) -> Path:
    """The paper area written into `folder` as paper.geojson, every airport's range `range_m`."""
    area = json.loads(PAPER_AREA.read_text())
    for feature in area["features"]:
        if feature["properties"].get("role") == "airport":
            feature["properties"]["range_m"] = range_m
    path = folder / "paper.geojson"
    path.write_text(json.dumps(area))
    return path
