"""Planes use their range: every UAV of a `gcs plan --vehicle plane` plan flies at least 97 % of
its range in metres (issue 37), on the issue's meadow and on seeded random fields."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gcs.plans.options import AreaOptions, SearchOptions
from gcs.plans.planning import build_area_search
from planner.area_grid import units_m
from planner.dtscs import ClosedSearch


def _field(folder: Path, name: str, width_m: float, height_m: float, airports: list[tuple[float, float, int, float]],
           lat0: float = 47.0, lon0: float = 8.0) -> Path:
    """An area file: a width x height rectangle of 50 m cells, airports (east, north, heading deg, range m)."""
    def lonlat(e: float, n: float) -> list[float]:
        return [lon0 + e / (111320 * math.cos(math.radians(lat0))), lat0 + n / 110540]

    ring = [lonlat(0, 0), lonlat(width_m, 0), lonlat(width_m, height_m), lonlat(0, height_m), lonlat(0, 0)]
    features = [{"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [ring]},
                 "properties": {"role": "area", "name": "field"}}]
    for i, (e, n, heading, range_m) in enumerate(airports):
        features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": lonlat(e, n)},
                         "properties": {"role": "airport", "name": f"a{i + 1}", "heading": heading,
                                        "range_m": range_m}})
    path = folder / f"{name}.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "name": name, "properties": {"cell_size_m": 50.0},
                                "features": features}))
    return path


def _random_field(folder: Path, seed: int) -> Path:
    rng = np.random.default_rng(seed)
    w, h = (float(v) for v in rng.uniform(800, 1600, 2))
    airports = [(float(rng.uniform(0.05, 0.95) * w), float(rng.uniform(0.05, 0.95) * h), int(rng.integers(8)) * 45,
                 float(rng.uniform(1.5, 3.0) * max(w, h))) for _ in range(int(rng.integers(2, 4)))]
    lat0, lon0 = 46.5 + float(rng.uniform(-1, 1)), 7.5 + float(rng.uniform(-1, 1))
    return _field(folder, f"field{seed}", w, h, airports, lat0, lon0)


def _shares(path: Path, improve: bool | None = None) -> list[float]:
    setup = build_area_search(path, AreaOptions(vehicle="plane"), SearchOptions(improve=improve))
    search: ClosedSearch = setup.search
    for _ in search.run():
        pass
    cell = setup.area.grid.cell_size_m
    return [(units_m(u.spent, cell) + setup.overheads_m[u.uav_id]) / setup.ranges_m[u.uav_id]
            for u in search.plan().uavs]


def test_the_issues_meadow_flies_its_range(tmp_path):
    meadow = _field(tmp_path, "meadow", 1500, 1200, [(100, 100, 45, 2500), (1400, 150, 315, 2500),
                                                    (750, 1100, 180, 2500)])
    assert min(_shares(meadow, improve=False)) < 0.92  # DTSCS alone: a UAV comes home with range it cannot use
    assert min(_shares(meadow)) >= 0.97


@pytest.mark.parametrize("seed", [2, 6, 9])
def test_random_plane_fields_fly_their_range(tmp_path, seed):
    assert min(_shares(_random_field(tmp_path, seed))) >= 0.97
