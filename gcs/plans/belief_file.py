"""The campaign files of a plan folder (docs/campaigns.md): `belief.json`, the belief a sortie
is planned from, and the schema of `sortie.json`, the record a flown sortie leaves
(`gcs.flight.sortie.SortieLog` writes it, `gcs plan --continue` reads it); and the file hash
that ties them to plan.json and the area file."""

from __future__ import annotations

import hashlib
import json
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from planner.campaign import Belief
from planner.environment import SearchMap

__all__ = ["BELIEF_FILE", "SCHEMA_VERSION", "SORTIE_FILE", "belief_from_dict", "belief_to_dict", "file_sha256",
           "validate_belief_dict", "validate_sortie_dict"]

BELIEF_FILE = "belief.json"
SORTIE_FILE = "sortie.json"
SCHEMA_VERSION = 1


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@lru_cache(maxsize=1)
def sortie_schema() -> dict:
    return json.loads(resources.files("gcs").joinpath("schemas/sortie.schema.json").read_text())


def validate_sortie_dict(data: dict) -> None:
    """Raise jsonschema.ValidationError when `data` is not a sortie record."""
    import jsonschema  # ~0.1 s to import: only where a record is checked, never while a plan is made

    jsonschema.validate(data, sortie_schema())


def validate_belief_dict(data: dict) -> None:
    """Raise jsonschema.ValidationError when `data` is not a belief map (belief.json)."""
    import jsonschema

    schema = sortie_schema()
    jsonschema.validate(data, {"$ref": "#/$defs/belief", "$defs": schema["$defs"]})


def belief_to_dict(belief: Belief, source: str) -> dict:
    """`belief.json`: the belief a sortie is planned from (and a sortie record's posterior):
    TEP, EU, the campaign's first prior `p0` and `looks`, the campaign's readings per cell so
    far, and `found_targets` ([x, y, sortie], 1-based) an exercise's targets earlier sorties found
    (when any). `source` says where it came from: `prior`, `flight` (a flown sortie's readings),
    `predicted` (a planned sortie that reports nothing, `planner.campaign.predicted_after`)."""
    m = belief.search_map
    return {"schema_version": SCHEMA_VERSION, "sortie": belief.sortie, "source": source, "nx": m.shape[0],
            "ny": m.shape[1], "tep": m.tep.tolist(), "eu": m.eu.tolist(), "p0": belief.p0.tolist(),
            "looks": belief.looks.tolist(),
            **({"found_targets": [[int(x) + 1, int(y) + 1, int(k)] for x, y, k in belief.found]}
               if len(belief.found) else {})}


def belief_from_dict(data: dict, no_fly: np.ndarray) -> Belief:
    """The `Belief` of a `belief.json` (or a sortie record's posterior); ValueError when it is not one."""
    try:
        tep, eu, p0, looks = (np.asarray(data[k], dtype=float) for k in ("tep", "eu", "p0", "looks"))
        sortie = int(data["sortie"])
        found = np.asarray(data.get("found_targets", []), dtype=float).reshape(-1, 3)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"not a belief map ({type(exc).__name__}: {exc})") from None
    if not all(np.all(np.isfinite(a)) for a in (tep, eu, p0)):
        raise ValueError("TEP, EU and P0 must be numbers")
    if not np.all(np.isfinite(looks)) or np.any(looks != np.round(looks)):
        raise ValueError("looks must be whole numbers")
    if tep.shape != no_fly.shape:
        raise ValueError(f"the belief is a {'x'.join(map(str, tep.shape))} grid, the plan's {no_fly.shape[0]}x"
                         f"{no_fly.shape[1]}")
    if np.any(found != np.round(found)) or np.any(found < 1) or np.any(found[:, 0] > tep.shape[0]) \
            or np.any(found[:, 1] > tep.shape[1]):
        raise ValueError("found_targets must be [x, y, sortie] of cells in the grid, counted from 1")
    found_cells = found.astype(np.int64) - np.array([1, 1, 0], dtype=np.int64)
    return Belief(SearchMap(tep, eu, no_fly), p0, looks.astype(np.int64), sortie, found_cells)
