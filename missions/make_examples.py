"""Regenerate the example area files of this folder (`python missions/make_examples.py`).

Each example is drawn in local metres around a real place and converted to WGS84 lon/lat with the
same projection `gcs plan --area` uses, so grid cells line up with the shapes drawn here."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from planner.georef import LocalFrame
from planner.scenario import PAPER_KEY, PAPER_KNOWN, PAPER_NO_FLY, PAPER_SIZE, PAPER_UAVS, paper_scenario

HERE = Path(__file__).parent


def _lonlat(frame: LocalFrame, points_m) -> list[list[float]]:
    pts = np.asarray(points_m, dtype=float)
    lat, lon = frame.local2geodetic(pts[:, 0], pts[:, 1])
    return [[round(float(a), 9), round(float(b), 9)] for a, b in zip(np.atleast_1d(lon), np.atleast_1d(lat))]


def _ring(frame: LocalFrame, points_m, ccw: bool = True) -> list[list[float]]:
    pts = list(points_m)
    twice_area = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, pts[1:] + pts[:1]))
    if (twice_area > 0) != ccw:
        pts = pts[::-1]
    coords = _lonlat(frame, pts)
    return coords + [coords[0]]


def _polygon(frame, outer, holes=(), **props) -> dict:
    rings = [_ring(frame, outer, True)] + [_ring(frame, h, False) for h in holes]
    return {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": rings}, "properties": props}


def _point(frame, east, north, **props) -> dict:
    return {"type": "Feature", "geometry": {"type": "Point", "coordinates": _lonlat(frame, [(east, north)])[0]},
            "properties": props}


def _circle(cx, cy, r, n=24):
    return [(cx + r * math.cos(2 * math.pi * k / n), cy + r * math.sin(2 * math.pi * k / n)) for k in range(n)]


def _rotated_rect(cx, cy, length, width, bearing_deg):
    a = math.radians(90 - bearing_deg)
    ux, uy = math.cos(a), math.sin(a)
    vx, vy = -uy, ux
    hl, hw = length / 2, width / 2
    return [(cx + sx * hl * ux + sy * hw * vx, cy + sx * hl * uy + sy * hw * vy)
            for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def _collection(name: str, cell_size_m: float, description: str, features: list[dict]) -> dict:
    return {"type": "FeatureCollection", "name": name,
            "properties": {"cell_size_m": cell_size_m, "description": description}, "features": features}


def paper_example() -> dict:
    """Section 6.1 on real ground: 50x50 cells of 20 m centred on ArduPilot's SITL home (CMAC,
    Canberra). Boxes are the paper's 1-based inclusive cell ranges; the ten targets are those of
    `paper_scenario(seed=0)`, so `gcs plan --area missions/paper.geojson` flies the same cells as
    `gcs plan --scenario paper --seed 0`. Range 3700 m = 130 steps of 20*sqrt(2) m."""
    cell = 20.0
    frame = LocalFrame(-35.363261, 149.165230)
    half = PAPER_SIZE * cell / 2

    def box(x0, x1, y0, y1):
        return [(-half + (x0 - 1) * cell, -half + (y0 - 1) * cell), (-half + x1 * cell, -half + (y0 - 1) * cell),
                (-half + x1 * cell, -half + y1 * cell), (-half + (x0 - 1) * cell, -half + y1 * cell)]

    def centre(x, y):
        return -half + (x - 0.5) * cell, -half + (y - 0.5) * cell

    feats = [_polygon(frame, box(1, PAPER_SIZE, 1, PAPER_SIZE), role="area", name="paper region")]
    feats += [_polygon(frame, box(*b), role="no_fly", name=f"no-fly {i + 1}") for i, b in enumerate(PAPER_NO_FLY)]
    feats.append(_polygon(frame, box(*PAPER_KNOWN), role="prior", name="known region", tep=0.0, eu=0.0))
    feats += [_polygon(frame, box(*b), role="prior", name=f"key region {i + 1}", tep=0.9, eu=0.9)
              for i, b in enumerate(PAPER_KEY)]
    compass = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
    for i, (x, y, h) in enumerate(PAPER_UAVS):
        feats.append(_point(frame, *centre(x, y), role="airport", name=f"UAV{i + 1}", heading=compass[h],
                            range_m=3700))
    for k, (tx, ty) in enumerate(paper_scenario(seed=0).targets):
        feats.append(_point(frame, *centre(tx + 1, ty + 1), role="target", name=f"target {k + 1}"))
    return _collection("paper", cell, "Section 6.1 of the paper on real coordinates (CMAC, Canberra)", feats)


def irregular_example() -> dict:
    """A river-valley search area near Zurich (PX4 SITL home): an irregular outline with two
    lakes as holes, a hospital heliport zone, a power-line corridor, a zone crossing the edge."""
    frame = LocalFrame(47.397742, 8.545594)
    outline = [(-1900, -1300), (-1200, -1450), (-300, -1350), (400, -1500), (1250, -1380), (1850, -1000),
               (1950, -300), (1700, 250), (1900, 900), (1500, 1350), (700, 1250), (100, 1450), (-600, 1300),
               (-1300, 1400), (-1850, 900), (-1700, 300), (-1950, -350), (-1650, -800)]
    lakes = [[(-900, -200), (-500, -350), (-250, -100), (-450, 200), (-850, 150)],
             [(700, 300), (1000, 250), (1150, 500), (900, 700), (650, 550)]]
    feats = [_polygon(frame, outline, lakes, role="area", name="valley")]
    feats.append(_polygon(frame, _circle(300, -600, 260), role="no_fly", name="heliport"))
    feats.append(_polygon(frame, _rotated_rect(-300, 700, 2600, 40, 65), role="no_fly", name="power line"))
    feats.append(_polygon(frame, [(1500, -1200), (2100, -1200), (2100, -500), (1500, -700)], role="no_fly",
                          name="quarry"))
    feats.append(_polygon(frame, [(-1800, -900), (1800, -1100), (1800, -800), (-1800, -600)], role="prior",
                          name="river", tep=0.85, eu=0.8))
    feats.append(_polygon(frame, [(-1700, 500), (-800, 500), (-800, 1200), (-1700, 1200)], role="prior",
                          name="searched yesterday", tep=0.05, eu=0.1))
    feats.append(_point(frame, -1500, -1000, role="airport", name="west field", heading=45, endurance_s=600))
    feats.append(_point(frame, 1300, -1150, role="airport", name="south road", heading="N", range_m=7000))
    feats.append(_point(frame, 1300, 1000, role="airport", name="north farm", heading=225, altitude_m=100))
    feats.append(_point(frame, -1400, 1000, role="airport", name="hill hut", heading="SE"))
    for k, (e, n) in enumerate([(-1000, -850), (200, -950), (1300, -300), (-200, 1000), (1200, 900), (-1500, 0)]):
        feats.append(_point(frame, e, n, role="target", name=f"target {k + 1}"))
    return _collection("irregular", 30.0, "Irregular valley with lakes (holes) and three no-fly zones", feats)


def large_example() -> dict:
    """A 10 km x 10 km wildland search (400x400 cells of 25 m) with 8 UAVs."""
    frame = LocalFrame(-33.9, 150.3)
    outline = [(5000 * 0.92 * math.cos(t) * (1 + 0.08 * math.sin(3 * t)),
                5000 * 0.92 * math.sin(t) * (1 + 0.08 * math.cos(2 * t))) for t in np.linspace(0, 2 * math.pi, 40,
                                                                                               endpoint=False)]
    outline = np.array(outline)
    outline[:, 0] *= 5000 / np.abs(outline[:, 0]).max()
    outline[:, 1] *= 5000 / np.abs(outline[:, 1]).max()
    feats = [_polygon(frame, [tuple(p) for p in outline], [_circle(-1500, 1800, 700, 20)], role="area",
                      name="wildland")]
    feats.append(_polygon(frame, _circle(1800, -1500, 900, 28), role="no_fly", name="township"))
    feats.append(_polygon(frame, _rotated_rect(0, 600, 7000, 80, 80), role="no_fly", name="transmission line"))
    feats.append(_polygon(frame, [(-4200, -3000), (-2800, -3200), (-2600, -2000), (-3900, -1800)], role="no_fly",
                          name="restricted range"))
    feats.append(_polygon(frame, [(-3500, -1000), (3500, -1200), (3500, 0), (-3500, -300)], role="prior",
                          name="creek", tep=0.8, eu=0.8))
    feats.append(_polygon(frame, _circle(2500, 2500, 1200, 20), role="prior", name="last seen", tep=0.95, eu=0.9))
    spots = [(-4300, 0, "E"), (4300, -300, "W"), (0, 4300, "S"), (200, -4300, "N"),
             (-3000, 3000, "SE"), (3000, 3200, "SW"), (-2600, -3900, "NE"), (3200, -3100, "NW")]
    for i, (e, n, h) in enumerate(spots):
        feats.append(_point(frame, e, n, role="airport", name=f"team {i + 1}", heading=h, endurance_s=2400))
    rng = np.random.default_rng(3)
    for k, (e, n) in enumerate(rng.uniform(-3500, 3500, size=(12, 2))):
        feats.append(_point(frame, float(e), float(n), role="target", name=f"target {k + 1}"))
    return _collection("large", 25.0, "10 km wildland search, 400x400 cells, 8 UAVs", feats)


def _line(frame, points_m, **props) -> dict:
    return {"type": "Feature", "geometry": {"type": "LineString", "coordinates": _lonlat(frame, points_m)},
            "properties": props}


def hiker_example() -> dict:
    """A hiker missing in the mountains above Grindelwald (Bernese Oberland): a 4 x 3.6 km area
    around the initial planning point, the trailhead car park from which the crew launches all
    three UAVs; the prior comes from the IPP alone (Koester's hiker, mountainous, temperate),
    weighted by the trail, the stream and the hut subjects are found near. The village is a
    no-fly zone."""
    frame = LocalFrame(46.6300, 8.0600)
    outline = [(-2000, -1800), (2000, -1800), (2000, 1800), (-2000, 1800)]
    car_park = (-400, -1100)
    trail = [car_park, (-250, -600), (100, -200), (300, 400), (700, 900), (1300, 1300), (1900, 1700)]
    stream = [(-1950, 200), (-1200, 300), (-500, 150), (200, 600), (900, 500), (1950, 800)]
    feats = [_polygon(frame, outline, role="area", name="Oberland search area")]
    feats.append(_polygon(frame, _circle(700, -1500, 450, 20), role="no_fly", name="village"))
    feats.append(_point(frame, *car_park, role="ipp", name="trailhead (last seen)", subject="hiker",
                        terrain="mountainous", climate="temperate"))
    feats.append(_line(frame, trail, role="feature", kind="trail", name="hut trail"))
    feats.append(_line(frame, stream, role="feature", kind="drainage", name="stream"))
    feats.append(_point(frame, 700, 900, role="feature", kind="structure", name="hut"))
    for i in range(3):
        feats.append(_point(frame, *car_park, role="airport", name=f"car park {i + 1}", heading="N", range_m=5500))
    feats.append(_point(frame, 380, 520, role="target", name="hiker"))
    return _collection("hiker", 50.0, "A hiker missing in the mountains: the prior from the IPP alone, three UAVs "
                       "launched from the trailhead", feats)


def main() -> None:
    for name, make in (("paper", paper_example), ("irregular", irregular_example), ("large", large_example),
                       ("hiker", hiker_example)):
        (HERE / f"{name}.geojson").write_text(json.dumps(make(), indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
