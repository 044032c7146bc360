"""The options of a plan, as small typed objects: how the closed search runs (`SearchOptions`),
how a real area becomes a grid and missions (`AreaOptions`), and where a plan's recording goes
and whether progress is shown (`OutputOptions`). Each option's default is written here once;
`gcs plan` and `gcs fly` take theirs from these classes (`gcs.cli.plan_options`).

    from gcs.plans.make import plan_area
    from gcs.plans.options import AreaOptions, SearchOptions

    plan_area("missions/paper.geojson", AreaOptions(cell_size_m=40), SearchOptions(seed=3), "runs/mine")

Values are checked where they are used (`gcs.plans.planning`), with the error naming the option.
A plan folder's plan.json records the planning options (`campaign.options`) under these field
names: `options_record` writes them, `options_from_record` reads them back."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from gcs.errors import UserError
from gcs.missions.items import Vehicle
from gcs.plans.plan_bound import DEFAULT_BOUND_TIME_S

#: The grid cell side of an area whose file gives none (`AreaOptions.cell_size_m` None).
DEFAULT_CELL_SIZE_M = 50.0

#: The planner's default largest grid, `planner.area_grid.MAX_CELLS`, spelt out so that the options
#: (and with them the command line's parsers) load without the planner and numba; a test checks
#: that the two agree.
MAX_CELLS = 1_000_000


def _as_declared(options: Any) -> None:
    """Whole numbers given for float fields become floats (`margin_m=5` is 5.0, as `--margin 5`
    is), so that the files a plan writes do not depend on how a number was spelt."""
    for f in fields(options):
        value = getattr(options, f.name)
        if f.type in ("float", "float | None") and isinstance(value, int) and not isinstance(value, bool):
            object.__setattr__(options, f.name, float(value))


@dataclass(frozen=True)
class SearchOptions:
    """How the closed search (DTSCS) runs, for a built-in scenario and a real area alike.

    `np_steps` is Np (steps of look-ahead), `oc` the orientation constraint (`"3"`, `"4"`, `"5"`,
    `"8"`), `strategy` one of `planner.search.STRATEGIES`, `return_planner` one of
    `planner.dtscs.RETURN_PLANNERS`, `reserve` the steps of range every range check keeps back,
    `range_aware_search` prunes search moves by range (eq. 8) instead of the paper's switch.
    `improve` re-solves windows of the finished plan (`planner.improve`); None: on for an area,
    off for a built-in scenario.
    `horizon_value` adds the value of where each path ends to J1; None: on for an area, off for a
    built-in scenario (the paper's J1). `pc`, `pf` and `footprint` describe the sensor; over an area,
    `camera_fov_deg` (with `camera_pixels` and `camera_pd`) derives the footprint and Pc from a
    camera at the UAVs' altitude instead (`planner.camera`). `range_steps`
    is every UAV's range in steps in a built-in scenario (an area's ranges come from its airports
    and `AreaOptions`). `seed` seeds the targets, the sensor draws and the optimisers."""

    seed: int = 0
    np_steps: int = 5
    oc: str = "3"
    range_steps: int = 130
    strategy: str = "cpio"
    return_planner: str = "exact"
    reserve: int = 0
    range_aware_search: bool = False
    horizon_value: bool | None = None
    improve: bool | None = None
    pc: float = 0.9
    pf: float = 0.1
    footprint: int = 0
    camera_fov_deg: float | None = None
    camera_pixels: int | None = None
    camera_pd: float = 1.0

    def __post_init__(self) -> None:
        _as_declared(self)


@dataclass(frozen=True)
class AreaOptions:
    """How an area file becomes a grid, ranges and missions (docs/areas.md).

    `cell_size_m` None takes the file's `cell_size_m`, else `DEFAULT_CELL_SIZE_M`. An airport that
    gives neither `range_m` nor `endurance_s` gets `range_m`, else `endurance_s * speed_m_s`; with
    `vehicles` (a vehicles.json, `gcs.plans.vehicle_file`) each UAV whose vehicle is in it gets the
    range its energy profile pays for at its altitude, `reserve_pct` of the pack kept back.
    UAVs fly one altitude layer each from `altitude_m` up in `altitude_step_m` steps, never above
    `ceiling_m`, above their airport (or, with `terrain_follow`, the ground below). A plane takes
    off along its runway and lands on an approach of `approach_m` from `approach_alt_m`. The area
    shrinks and the no-fly zones grow by `margin_m`; cells outside every prior region get
    `default_tep` and `default_eu`; grids of more than `max_cells` cells are refused."""

    cell_size_m: float | None = None
    speed_m_s: float = 12.0
    range_m: float | None = None
    endurance_s: float = 900.0
    altitude_m: float = 50.0
    altitude_step_m: float = 10.0
    ceiling_m: float = 120.0
    terrain_follow: bool = False
    vehicle: Vehicle = Vehicle.COPTER  # or its name, "copter" / "plane"
    approach_m: float = 500.0
    approach_alt_m: float = 30.0
    margin_m: float = 0.0
    default_tep: float = 0.5
    default_eu: float = 0.5
    max_cells: int = MAX_CELLS
    vehicles: str | None = None
    reserve_pct: float = 30.0

    def __post_init__(self) -> None:
        _as_declared(self)
        object.__setattr__(self, "vehicle", Vehicle(self.vehicle))  # "plane" is Vehicle.PLANE


@dataclass(frozen=True)
class OutputOptions:
    """What planning shows and records, not how it plans: `rrd` the Rerun recording's path (None:
    beside the plan), none when `record` is False; `rerun_connect` also streams it to a running
    viewer at that address; `progress` False shows no progress bar; `bound_time_s` > 0 gives
    the upper bound on expected finds that many seconds (`gcs.plans.plan_bound`; 0: none), as
    `gcs plan` does by default."""

    rrd: str | Path | None = None
    record: bool = True
    rerun_connect: str | None = None
    progress: bool = True
    bound_time_s: float = DEFAULT_BOUND_TIME_S

    def recording_path(self, default: Path) -> Path | None:
        """Where the Rerun recording goes: `rrd`, else `default`; None when nothing is recorded.
        UserError unless it names a .rrd file."""
        if not self.record:
            return None
        rrd = Path(self.rrd) if self.rrd else default
        if rrd.suffix != ".rrd":
            raise UserError(f"--rrd must name a .rrd file, got {rrd}")
        return rrd


def options_record(area: AreaOptions, search: SearchOptions) -> dict[str, Any]:
    """The planning options as plan.json's `campaign.options` holds them: one key per field,
    sorted (a continued sortie is planned with them again)."""
    record = {**asdict(search), **asdict(area), "vehicle": area.vehicle.value}
    return dict(sorted(record.items()))


def options_from_record(record: dict[str, Any]) -> tuple[AreaOptions, SearchOptions]:
    """The options `options_record` wrote (or an older plan folder's: keys that are no option
    are ignored, missing ones take their defaults)."""
    def known(cls: type) -> dict[str, Any]:
        return {f.name: record[f.name] for f in fields(cls) if f.name in record}

    return AreaOptions(**known(AreaOptions)), SearchOptions(**known(SearchOptions))
