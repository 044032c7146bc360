"""One layer of GeoJSON features written in another GIS format by GDAL (pyogrio), as text: what
the KML (`gcs.missions.kml`) and GPX (`gcs.missions.gpx`) writers share. GDAL and pyogrio are
imported on the first call (about 0.2 s)."""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Layer:
    """Features (GeoJSON dicts) to write as one layer: `names` are the features' names (KML
    `<name>`, GPX `<name>`), `columns` further per-feature values written under their key,
    `fields` the properties kept as attributes (in this order; absent ones are left empty)."""

    name: str
    features: Sequence[dict]
    names: Sequence[str]
    fields: Sequence[str]
    columns: dict[str, Sequence[Any]] = field(default_factory=dict)


def _column(values: Sequence[Any]):
    """A numpy column GDAL types as the values are: whole numbers, reals (None as null) or text."""
    import numpy as np

    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present) and len(present) == len(values):
        return np.array(values, dtype=np.int32)
    if present and all(isinstance(v, int) and not isinstance(v, bool) and abs(v) < 2**31 for v in present) \
            and len(present) == len(values):
        return np.array(values, dtype=np.int32)  # (LIBKML declares 64-bit integers as text)
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)
    return np.array([None if v is None else v if isinstance(v, str) else json.dumps(v) for v in values],
                    dtype=object)


def layer_text(layer: Layer, driver: str, geometry_type: str, *, dataset_options: dict[str, str] | None = None,
               layer_options: dict[str, str] | None = None) -> str:
    """The layer written by GDAL's `driver` (WGS84), as the text of the file it makes."""
    import numpy as np
    import shapely
    from pyogrio.raw import write
    from shapely.geometry import shape

    geometry = np.array([None if f.get("geometry") is None else shapely.to_wkb(shape(f["geometry"]))
                         for f in layer.features], dtype=object)
    names, columns = ["name"], [_column(list(layer.names))]
    for key in layer.fields:
        names.append(key)
        columns.append(_column([(f.get("properties") or {}).get(key) for f in layer.features]))
    for key, values in layer.columns.items():
        names.append(key)
        columns.append(_column(list(values)))
    buffer = io.BytesIO()
    write(buffer, geometry, columns, names, layer=layer.name, driver=driver, geometry_type=geometry_type,
          crs="EPSG:4326", dataset_options=dataset_options or {}, layer_options=layer_options or {})
    return buffer.getvalue().decode("utf-8")
