"""A small search site for flights on real autopilots: a square area in local metres around a
centre (by default ArduPilot SITL's home at Innsbruck), a no-fly box, a likely corner and
airports where the SITL vehicles are started; planned through `gcs plan --area`."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gcs.cli import main
from planner.georef import LocalFrame

CENTRE = (47.2771883, 11.4039709)
GROUND_AMSL_M = 584.0


@dataclass(frozen=True)
class Airport:
    name: str
    east_m: float
    north_m: float
    heading: str
    range_m: float


@dataclass(frozen=True)
class Site:
    """`half_m`: half the area's east-west side (`half_n_m` its north-south one, the same when
    None: a square); airports and targets in local metres."""

    airports: tuple[Airport, ...]
    half_m: float = 300.0
    half_n_m: float | None = None
    cell_m: float = 30.0
    no_fly: tuple[float, float, float, float] | None = (30.0, 30.0, 120.0, 120.0)
    centre: tuple[float, float] = CENTRE
    targets: tuple[tuple[float, float], ...] = ()
    outline_vertices: int | None = None  # a traced outline of so many vertices inside the square, not the square
    zone_vertices: int | None = None  # the no-fly box drawn as a round zone of so many vertices inside it

    @property
    def frame(self) -> LocalFrame:
        return LocalFrame(*self.centre)

    def lat_lon(self, east_m: float, north_m: float) -> tuple[float, float]:
        lat, lon = self.frame.local2geodetic(east_m, north_m)
        return float(lat), float(lon)

    def home(self, index: int) -> tuple[float, float, float, float]:
        """SITL `--home` of airport `index` (0-based): lat, lon, ground AMSL, heading degrees."""
        ap = self.airports[index]
        heading = {"N": 0, "NE": 45, "E": 90, "SE": 135, "S": 180, "SW": 225, "W": 270, "NW": 315}[ap.heading]
        return (*self.lat_lon(ap.east_m, ap.north_m), GROUND_AMSL_M, float(heading))

    def _ring(self, points: list[tuple[float, float]]) -> list[list[float]]:
        pts = np.asarray(points, dtype=float)
        lat, lon = self.frame.local2geodetic(pts[:, 0], pts[:, 1])
        coords = [[float(b), float(a)] for a, b in zip(lat, lon)]
        return coords + [coords[0]]

    def geojson(self) -> dict:
        h, v = self.half_m, self.half_m if self.half_n_m is None else self.half_n_m
        outline = [(-h, -v), (h, -v), (h, v), (-h, v)] if self.outline_vertices is None \
            else _traced(self.outline_vertices, (0.0, 0.0), h, v)
        features = [{"type": "Feature", "properties": {"role": "area", "name": "sitl square"},
                     "geometry": {"type": "Polygon", "coordinates": [self._ring(outline)]}},
                    {"type": "Feature", "properties": {"role": "prior", "tep": 0.9, "eu": 0.9},
                     "geometry": {"type": "Polygon",
                                  "coordinates": [self._ring([(-h, 0), (0, 0), (0, v), (-h, v)])]}}]
        if self.no_fly is not None:
            x0, y0, x1, y1 = self.no_fly
            zone = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)] if self.zone_vertices is None else _traced(
                self.zone_vertices, (0.5 * (x0 + x1), 0.5 * (y0 + y1)), 0.5 * (x1 - x0), 0.5 * (y1 - y0), 0.0)
            features.append({"type": "Feature", "properties": {"role": "no_fly", "name": "box"},
                             "geometry": {"type": "Polygon", "coordinates": [self._ring(zone)]}})
        for ap in self.airports:
            lat, lon = self.lat_lon(ap.east_m, ap.north_m)
            features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [lon, lat]},
                             "properties": {"role": "airport", "name": ap.name, "heading": ap.heading,
                                            "range_m": ap.range_m, "elevation_m": GROUND_AMSL_M}})
        for i, (east, north) in enumerate(self.targets):
            lat, lon = self.lat_lon(east, north)
            features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [lon, lat]},
                             "properties": {"role": "target", "name": f"target {i + 1}"}})
        return {"type": "FeatureCollection", "properties": {"cell_size_m": self.cell_m}, "features": features}

    def plan(self, folder: Path, *extra: str) -> Path:
        """Plan the site with `gcs plan --area` into `folder` (the `--area` default: DTSCS, then
        the whole-mission improvement); the plan folder. The improved plans fly the energy
        fleets since `--fit-charge` leaves the return to the battery: a range in metres priced
        at the plan's average cost of a metre turned the still-air fleet's UAV 3 home at 7 of 27
        waypoints, landing at 42 % (ci77-78 flew DTSCS's plans for that)."""
        folder.mkdir(parents=True, exist_ok=True)
        area = folder / "site.geojson"
        area.write_text(json.dumps(self.geojson()))
        out = folder / "plan"
        code = main(["plan", "--area", str(area), "--out", str(out), "--quiet", "--no-rrd", "--strategy", "exhaustive",
                     *extra])
        assert code == 0
        return out


def _traced(vertices: int, centre: tuple[float, float], half_e_m: float, half_n_m: float, wobble: float = 0.08
            ) -> list[tuple[float, float]]:
    """A boundary traced around `centre` as a GPS or a drawn circle gives it: `vertices` points on
    an ellipse of the half-sides, its radius wobbling by `wobble` (a star shape: always valid)."""
    angles = np.linspace(0.0, 2 * np.pi, vertices, endpoint=False)
    scale = 1.0 - wobble * (1 + np.sin(5 * angles)) / 2
    return [(centre[0] + half_e_m * r * np.cos(a), centre[1] + half_n_m * r * np.sin(a)) for a, r in zip(angles, scale)]


#: The sites the autopilot tests and benchmarks fly: two copter airports on a 600 m square of 30 m
#: cells (the copters' ranges fit a 3300 mAh ArduCopter SITL battery with the 30 % reserve), a
#: plane runway on a 2 km square of 100 m cells with room for its landing approach, and a 1.5 km
#: meadow whose runway starts on its south edge and lands northwards, into it: its landing
#: approach (500 m by default) lies wholly outside the area.
COPTERS = Site((Airport("west", -240.0, -30.0, "E", 1300.0), Airport("south", -30.0, -240.0, "N", 1300.0)))
PLANE = Site((Airport("runway", -500.0, -500.0, "N", 10000.0),), half_m=1000.0, cell_m=100.0,
             no_fly=(100.0, 100.0, 300.0, 300.0))
#: One PX4 copter at COPTERS' west airport with a 500 m range: PX4 flies missions at 5 m/s, so its
#: flight is about four minutes of vehicle time (a third of it the climb and the landing), about
#: 33 s of wall time at speed-up 8.
PX4_SOLO = Site((Airport("west", -240.0, -30.0, "E", 500.0),))
MEADOW = Site((Airport("edge", -400.0, -750.0, "N", 4000.0),), half_m=750.0, cell_m=100.0,
              no_fly=(100.0, 100.0, 300.0, 300.0))

#: The issue's field (a 1.5 km x 1.2 km meadow of 50 m cells, three airports of 2500 m): copters
#: start inside it; planes start from runways on its edges heading into it, their landing
#: approaches wholly outside the area (docs/energy.md flies both).
FIELD_COPTERS = Site((Airport("west", -450.0, 0.0, "E", 2500.0), Airport("south", 0.0, -350.0, "N", 2500.0),
                      Airport("east", 450.0, 100.0, "W", 2500.0)),
                     half_m=750.0, half_n_m=600.0, cell_m=50.0, no_fly=(-100.0, 150.0, 100.0, 350.0))
FIELD_PLANES = Site((Airport("west edge", -750.0, -200.0, "E", 2500.0),
                     Airport("south edge", 200.0, -600.0, "N", 2500.0),
                     Airport("east edge", 750.0, 200.0, "W", 2500.0)),
                    half_m=750.0, half_n_m=600.0, cell_m=50.0, no_fly=(-100.0, 150.0, 100.0, 350.0))
#: COPTERS' west airport in a traced outline of 96 vertices (the issue's wildland) with a round
#: no-fly zone of 28: 124 fence vertices, more than ArduCopter (69 in one polygon) or PX4 (64) holds.
WILDLAND = replace(COPTERS, airports=COPTERS.airports[:1], half_m=400.0, outline_vertices=96, zone_vertices=28)
PX4_WILDLAND = replace(WILDLAND, airports=PX4_SOLO.airports)

#: The field with 800 m airports instead of 2500, for the fleets whose test is not about spending
#: a whole battery (docs/tests.md, "Half-range fleets"): the mixed fleet, whose PX4 copters fly at
#: 5 m/s (at 2500 m 122-153 s of wall time, at 1250 m 68-79 s, at 800 m 60 s, while the other
#: worker waits for it: tests/peers/process.cpu_share), the range cut to the charge and the copter
#: that lands away (its GPS fails 150 m out: UAV 1's plan reaches 255 m from its airport)
FIELD_COPTERS_SHORT = replace(FIELD_COPTERS, airports=tuple(replace(a, range_m=800.0) for a in FIELD_COPTERS.airports))
