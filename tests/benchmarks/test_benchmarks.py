"""Every script in benchmarks/ runs, so that none can break silently again (issue 37: the bound
crashed for months on ranges in metres, and `benchmarks/areas.py` on a renamed function).

Each benchmark is loaded from its file in this process and its argument parser run (`--help`:
its imports, its options, its docstring). The ones that plan run on a tiny input as well, through
their own `main`; the ones that fly SITL, a fleet of simulated vehicles, a broker or whole `gcs`
processes for minutes stop at their parser here (`SMOKE` says what each covers). A new script
without a line in `SMOKE` fails `test_every_benchmark_has_a_smoke_test`."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"

#: benchmark -> what its smoke test here covers.
SMOKE = {
    "areas.py": "imported by the runs below; a seeded random area built (ranges in metres)",
    "bench_area.py": "parser (plans the large area at up to 64 UAVs for minutes)",
    "bench_bus.py": "parser (starts Mosquitto and a subscriber process)",
    "bench_fleet.py": "parser (flies 64 simulated vehicles for 5 minutes)",
    "bench_fly.py": "parser (a fleet of simulated vehicles in real time)",
    "bench_logging.py": "parser (whole gcs plan processes)",
    "bench_online.py": "parser (gcs fly processes over seeds)",
    "bench_optimisers.py": "parser (every optimiser over seeds for minutes)",
    "bench_planner.py": "parser (cold-start processes)",
    "bench_improve.py": "parser (the improvement planner over the missions and random areas); `--copters --smoke` "
                        "run (one random area of stock ArduCopters, their paths priced by metres and by time)",
    "bench_return_trigger.py": "parser (its learned fuel gauge alone takes some 9 CPU-s to build)",
    "bench_sim.py": "parser (simulated fleets in real time)",
    "bench_startup.py": "parser (fresh gcs processes)",
    "bench_success.py": "parser (five options over 100 paper seeds and the missions); its bound row on planner.bound",
    "camera_cells.py": "run: `--smoke` (hiker at 50 m cells with a camera, judged by its swath on 25 m cells)",
    "bench_upload_sitl.py": "parser (ArduCopter and PX4 SITL)",
    "fly_approach.py": "parser (ArduPlane SITL)",
    "fly_autopilots.py": "parser (ArduPilot and PX4 SITL)",
    "fly_wind.py": "parser (SITL in wind)",
    "lean_wind.py": "parser (ArduCopter SITL in steady winds)",
    "measure_energy.py": "parser; its tables made from the recorded energy_sitl.json",
    "path_time_fit.py": "imported (a grid search of some minutes, no options)",
    "sarenv_bench.py": "tests/benchmarks/test_sarenv_bench.py (SAREnv from the peers folder)",
    "sim_corners.py": "imported (ArduCopter SITL beside the simulator, no options)",
    "stress_safety.py": "run: one seed's crowded plans against the safety invariants",
    "success_bound.py": "run: `figures --smoke` (the paper at range 12 and a tiny area, plan against bound) and "
                        "`gap --smoke` (a tiny area's exact optimum between the plan and the bound)",
}

NO_PARSER = {"path_time_fit.py", "areas.py", "sarenv_bench.py", "sim_corners.py"}

#: The scripts there are (an entry of SMOKE may name one still being written in another branch).
SCRIPTS = {p.name for p in BENCHMARKS.glob("*.py") if p.name != "__init__.py"}


def load(name: str) -> ModuleType:
    """benchmarks/`name` as the module `benchmarks.<stem>` (their own imports name it so)."""
    module_name = f"benchmarks.{Path(name).stem}"
    if module_name in sys.modules:
        return sys.modules[module_name]
    spec = importlib.util.spec_from_file_location(module_name, BENCHMARKS / name)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


def run_main(module: ModuleType, monkeypatch: pytest.MonkeyPatch, *args: str) -> None:
    monkeypatch.setattr(sys, "argv", [module.__file__, *args])
    result = module.main()
    assert result in (None, 0)


def test_every_benchmark_has_a_smoke_test() -> None:
    assert sorted(SCRIPTS - set(SMOKE)) == [], "add a line to SMOKE (and a test here) for each"


@pytest.mark.parametrize("name", sorted(SCRIPTS & set(SMOKE) - NO_PARSER))
def test_a_benchmark_parses_its_arguments(name: str, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    module = load(name)
    with pytest.raises(SystemExit) as done:
        run_main(module, monkeypatch, "--help")
    assert done.value.code == 0
    assert "usage:" in capsys.readouterr().out


@pytest.mark.parametrize("name", sorted(SCRIPTS & NO_PARSER - {"sarenv_bench.py"}))
def test_a_benchmark_without_options_imports(name: str) -> None:
    module = load(name)
    assert callable(getattr(module, "main", None) or module.random_area)


def test_random_areas_are_built_in_metres() -> None:
    scenario = load("areas.py").random_area(1)
    assert scenario.unit_m is not None and not scenario.move_costs.unit_steps
    assert all(u.range_units > 10 * scenario.move_costs.straight for u in scenario.uavs)


def test_success_bound_figures_and_gap(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    module = load("success_bound.py")
    run_main(module, monkeypatch, "figures", "--smoke")
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| paper") or line.startswith("| tiny")]
    assert len(rows) == 2 and all(re.search(r"\*\*\d+\.\d%\*\*", row) for row in rows)
    run_main(module, monkeypatch, "gap", "--smoke")
    out = capsys.readouterr().out
    assert re.search(r"LP bound over optimum: mean \+\d+\.\d%.*\(1 of 1 solved\)", out)


def test_bench_improve_prices_copters_by_metres_and_by_time(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    run_main(load("bench_improve.py"), monkeypatch, "--copters", "--smoke")
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| 1 random areas")]
    assert len(rows) == 1
    cells = rows[0].strip("| ").split(" | ")
    dtscs, metres, timed = (float(c) for c in cells[3:6])
    assert min(metres, timed) >= dtscs > 0


def test_stress_safety_one_seed(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    run_main(load("stress_safety.py"), monkeypatch, "--seeds", "1")
    out = capsys.readouterr().out
    assert re.findall(r": 0 unsafe of \d+ plans", out) and "unsafe of 0 plans" not in out


def test_energy_tables_from_the_recorded_flights() -> None:
    import json

    module = load("measure_energy.py")
    for flight in json.loads((BENCHMARKS / "energy_sitl.json").read_text())["flights"]:
        assert flight["flight"] in module.table(flight)
        assert module.markdown(flight).count("\n|") == len(flight["phases"]) + 2   # the header, its rule, the phases


def test_camera_cells_judges_a_plan_by_what_its_swath_sees(monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    run_main(load("camera_cells.py"), monkeypatch, "--smoke")
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| hiker")]
    assert len(rows) == 1
    cells = rows[0].strip("| ").split(" | ")
    assert cells[1] == "50.00 (50)" and cells[2] == "0"  # a 41 m swath over 50 m cells: the cell below
    share, least, greatest, km2 = (float(c) for c in cells[5:9])
    assert least == share == greatest  # one seed
    # three UAVs of 5.5 km under swaths of 41-58 m can see at most 0.83 km2, and see the likely ground first
    assert 0.2 < km2 < 0.83 and share > 5 * km2 / 13.8  # 13.8 km2 of the area are searchable
