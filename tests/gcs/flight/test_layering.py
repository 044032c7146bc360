"""The flight's public surface for the modules beside the controller (online mode, resume, the
journal, the recorder, the bus feed), the terminal's live table given from outside, and the
direction of the imports: display, bus, recording and TAK depend on the flight, never the reverse."""

from __future__ import annotations

import ast
import asyncio
import time
from pathlib import Path

from gcs.display.status_table import CLEAR_SCREEN, LiveTable
from gcs.flight.controller import FlightController
from gcs.flight.events import StageChanged
from gcs.telemetry.status import Stage
from tests.gcs.flight.conftest import fast_options

ROOT = Path(__file__).resolve().parents[3]
WATCHING_THE_FLIGHT = ("gcs.display", "gcs.bus", "gcs.recording", "gcs.tak", "gcs.cli")


def _imports(path: Path) -> list[tuple[str, str | None]]:
    """(module imported, enclosing function or None) for every import outside TYPE_CHECKING."""
    tree = ast.parse(path.read_text())
    found = []

    def walk(node, function, guarded):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            guarded = True
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            function = node.name
        if not guarded and isinstance(node, ast.ImportFrom) and node.module:
            found.append((node.module, function))
        if not guarded and isinstance(node, ast.Import):
            found.extend((alias.name, function) for alias in node.names)
        for child in ast.iter_child_nodes(node):
            walk(child, function, guarded)

    walk(tree, None, False)
    return found


def test_the_flight_imports_nothing_that_watches_it():
    wrong = [f"{path.relative_to(ROOT)}: {module}" for path in sorted((ROOT / "gcs" / "flight").glob("*.py"))
             for module, function in _imports(path)
             if module.startswith(WATCHING_THE_FLIGHT)]
    assert not wrong, wrong


def test_tak_imports_no_command_line_and_pytak_stays_in_gcs_tak():
    """TAK watches the flight and the bus; only the command line chooses it, and only gcs/tak loads pytak."""
    wrong = [f"{path.relative_to(ROOT)}: {module}" for path in sorted((ROOT / "gcs" / "tak").glob("*.py"))
             for module, _ in _imports(path) if module.startswith("gcs.cli")]
    wrong += [f"{path.relative_to(ROOT)}: {module}" for path in sorted((ROOT / "gcs").rglob("*.py"))
              if path.parent.name != "tak" for module, _ in _imports(path)
              if module.split(".")[0] in ("pytak", "takproto")]
    assert not wrong, wrong


def test_telemetry_imports_neither_the_flight_nor_what_watches_it():
    wrong = [f"{path.relative_to(ROOT)}: {module}" for path in sorted((ROOT / "gcs" / "telemetry").glob("*.py"))
             for module, _ in _imports(path) if module.startswith(("gcs.flight", *WATCHING_THE_FLIGHT))]
    assert not wrong, wrong


def test_the_controllers_public_surface_for_the_modules_beside_it(plan):
    controller = FlightController(plan, [], fast_options(lost_giveup_s=5.0), out=lambda line: None)
    stages = []
    controller.subscribe(lambda event, now: stages.append(event) if isinstance(event, StageChanged) else None)
    assert not controller.interrupted
    controller.order_return(1)
    controller.order_return(2, "mqtt")
    assert controller.take_orders() == [(1, "order"), (2, "mqtt")]
    assert controller.take_orders() == []

    now = time.monotonic()
    three, four = controller.vehicles[3], controller.vehicles[4]
    for stage in (Stage.PREPARING, Stage.UPLOADING, Stage.ARMING, Stage.SEARCH):
        three.set_stage(stage, "flying" if stage is Stage.SEARCH else "")
    three.mark_lost("no telemetry", now)
    assert controller.status[3].stage is Stage.LOST and not controller.finished(now + 1.0)
    controller.status[3].last_heard_s = now + 1.0
    three.update_stage(now + 1.0)  # heard again: back to the stage it was lost in
    assert controller.status[3].stage is Stage.SEARCH and controller.status[3].note == "link back"
    four.mark_lost("did not answer", now, before=Stage.CONNECTING)
    controller.status[4].last_heard_s = now + 1.0
    four.update_stage(now + 1.0)
    assert controller.status[4].stage is Stage.CONNECTING
    assert [(e.uav_id, e.after) for e in stages] == [(3, Stage.PREPARING), (3, Stage.UPLOADING), (3, Stage.ARMING),
                                                     (3, Stage.SEARCH), (3, Stage.LOST), (3, Stage.SEARCH),
                                                     (4, Stage.LOST), (4, Stage.CONNECTING)]

    controller.status[1].stage = Stage.SEARCH
    controller.status[1].mode_name = "RTL"
    controller.vehicles[1].claim()  # commanded by another task: its RTL is not the autopilot's own return
    controller.vehicles[1].update_stage(now)
    assert controller.status[1].stage is Stage.SEARCH
    controller.vehicles[1].release()
    controller.vehicles[1].update_stage(now)
    assert controller.status[1].stage is Stage.RTL and controller.status[1].return_reason == "autopilot"

    assert asyncio.run(controller.wait_until(lambda: True, 0.0))
    assert not asyncio.run(controller.wait_until(lambda: False, 0.05))
    controller.interrupt()
    assert controller.interrupted


def test_the_live_table_shows_the_controllers_lines_under_the_table(plan):
    written: list[str] = []
    table = LiveTable(every_s=0.02, lines=3, write=written.append)
    controller = FlightController(plan, [], fast_options(), out=table.line)
    controller.say(None, "before the flight")
    assert written[-1].endswith("before the flight\n")  # not drawn yet: printed as it comes

    async def flight():
        async with table.attach(controller):
            await asyncio.sleep(0.05)
            controller.say(2, "during the flight")
            await asyncio.sleep(0.05)

    written.clear()
    asyncio.run(flight())
    assert written and all(text.startswith(CLEAR_SCREEN) for text in written)  # only redraws
    assert not any("during the flight" in text for text in written[:1])
    last = written[-1]  # the final state, drawn as the flight ends
    assert "UAV stage" in last and last.rstrip().endswith("UAV 2: during the flight")
    assert "before the flight" in last
    written.clear()
    controller.say(None, "after the flight")
    assert written == [f"{table.recent[-1]}\n"] and table.recent[-1].endswith("after the flight")
