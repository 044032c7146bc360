"""A station that survives its own restart (`gcs fly --resume`, docs/fly.md): the vehicles run in
`gcs sim`'s own process, the station in another that is SIGKILLed mid-flight; a new station takes
the flight over from the journal the first one left, and every vehicle lands at its airport with
nothing recorded lost. Plus the pure parts: what the restarted station does with a vehicle in each
state, where a vehicle is on its plan from MISSION_CURRENT, and the journal read back."""

from __future__ import annotations

import json
import math
import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from gcs.autopilots import Autopilot
from gcs.cli import main
from gcs.flight.journal import JOURNAL_FILE, FlightJournal, JournalError, VehicleRecord, read_journal
from gcs.flight.resume import Action, Found, decide
from gcs.flight.vehicle_track import PlanTrack
from gcs.plans.plan_folder import load_plan_dir
from gcs.telemetry.status import Stage
from tests.gcs.flight.resume_peers import SimProcess, flight_events, kill_when, readings, station, vehicle_state
from tests.gcs.flight.test_campaign import closed_form_posterior

#: The module's fixtures (a whole flight, a killed station) are flown once: every test here in one
#: worker (pytest-xdist's loadgroup), not each fixture once in each worker.
pytestmark = pytest.mark.xdist_group("resume")

SPEEDUP = 20.0
DRAIN = 5.0  # every battery drains 5x as fast: the return trigger sends them home on fuel, mid-search


def _metres(plan, a, b) -> float:
    ea, na = plan.local_m(*a)
    eb, nb = plan.local_m(*b)
    return math.hypot(ea - eb, na - nb)


# ---- what the restarted station does with each vehicle ----------------------------------------

MODES = ("AUTO", "GUIDED", "RTL", "LAND", "LOITER", "STABILIZE")
ON_BOARD = ("search", "return", "other", None)


def _records():
    for stage in (Stage.CONNECTING, Stage.ARMING, Stage.SEARCH, Stage.RETURN, Stage.RTL, Stage.LOST):
        for airborne_seen in (False, True):
            for reason in (None, "battery", "order"):
                for mission in (None, "search", "return"):
                    yield VehicleRecord(1, stage=stage, stage_before_loss=Stage.RETURN if stage is Stage.LOST else None,
                                        return_reason=reason, airborne_seen=airborne_seen, mission=mission)


def test_every_state_a_vehicle_can_be_found_in_ends_watched_to_the_ground_or_launched():
    """Every combination of journal and what the vehicle reports: a vehicle in the air is never
    launched, disarmed or left unwatched; one on the ground is launched only if it never flew
    and was not ordered home; one flying a list the station did not upload, or holding, is sent
    home on its planned return; one in its autopilot's RTL is left to it."""
    seen = set()
    for record in _records():
        for armed in (False, True):
            for airborne in (False, True):
                if airborne and not armed:
                    continue
                for mode in MODES:
                    for on_board in ON_BOARD:
                        d = decide(record, Found(armed, airborne, mode, on_board))
                        seen.add(d.action)
                        if airborne:
                            assert d.action in (Action.FOLLOW, Action.RTL, Action.SEND_HOME), (record, mode, d)
                            held = mode not in ("AUTO", "RTL", "LAND")
                            if held:
                                assert d.action is Action.SEND_HOME
                            if mode in ("RTL", "LAND"):
                                assert d.action is Action.RTL and d.stage is Stage.RTL and d.return_reason
                            if mode == "AUTO" and (on_board or record.mission) not in ("search", "return"):
                                assert d.action is Action.SEND_HOME
                        elif record.airborne_seen:
                            assert d.action in (Action.LANDED, Action.FOLLOW)  # landed, or landing still armed
                        elif armed:
                            assert d.action in (Action.FOLLOW, Action.RELAUNCH)
                        else:
                            want = Action.KEEP_ON_GROUND if record.return_reason else Action.LAUNCH
                            assert d.action is want
                        if d.action in (Action.FOLLOW, Action.SEND_HOME) and d.stage is Stage.RETURN:
                            assert d.return_reason is not None
                        if d.action is Action.SEND_HOME:
                            assert d.return_reason is not None and d.stage is Stage.SEARCH
    assert seen == set(Action)


def test_a_vehicle_sent_home_that_still_flies_its_search_is_sent_home_again():
    record = VehicleRecord(2, stage=Stage.RETURN, return_reason="order", airborne_seen=True, mission="search")
    d = decide(record, Found(True, True, "AUTO", "search"))
    assert d.action is Action.SEND_HOME and d.return_reason == "order"
    d = decide(record, Found(True, True, "AUTO", "return"))
    assert (d.action, d.stage, d.return_reason) == (Action.FOLLOW, Stage.RETURN, "order")


def test_the_place_on_the_plan_comes_from_the_mission_item_flown_to(plan):
    """For every waypoint of every UAV's mission and every trajectory step between it and the one
    before, a vehicle at that step flying to that waypoint is placed at that step."""
    for autopilot in (Autopilot.ARDUPILOT, Autopilot.PX4):
        first = autopilot.first_mission_seq()
        for uid, task in plan.uavs.items():
            track = PlanTrack(plan, uid)
            points = [(p.lat_deg, p.lon_deg) for p in task.trajectory]
            steps = []
            for wp in task.waypoints:
                steps.append(next(i for i in range(steps[-1] if steps else 0, len(points))
                                  if _metres(plan, points[i], wp) < 1.0))
            for j, hi in enumerate(steps):
                lo = steps[j - 1] if j else 0
                for i in range(lo, hi + 1):
                    got = track.index_on_board(autopilot, first + 1 + j, *points[i], fallback=-1)
                    assert got == i, (uid, j, i, got)
            assert track.index_on_board(autopilot, first, *points[0], -1) == 0  # taking off
            assert track.index_on_board(autopilot, first + 1 + len(task.waypoints), *points[-1], -1) \
                == len(points) - 1  # landing


def test_a_current_item_the_vehicle_is_nowhere_near_does_not_move_its_place(plan):
    """A MISSION_CURRENT of an earlier mission (or a late one) names a waypoint far from where the
    vehicle is: its place stays what the walk along its track found (the fallback)."""
    for autopilot in (Autopilot.ARDUPILOT, Autopilot.PX4):
        first = autopilot.first_mission_seq()
        for uid, task in plan.uavs.items():
            track = PlanTrack(plan, uid)
            airport = task.trajectory[0].lat_deg, task.trajectory[0].lon_deg
            far = [j for j, wp in enumerate(task.waypoints[1:], 1) if _metres(plan, airport, wp) > 4 * track.off_track_m
                   and _metres(plan, airport, task.waypoints[j - 1]) > 4 * track.off_track_m]
            assert far, uid
            for j in far:
                assert track.index_on_board(autopilot, first + 1 + j, *airport, fallback=7) == 7, (uid, j)
            assert track.index_on_board(autopilot, first + 1 + far[0], *task.waypoints[far[0]], -1) > 0


# ---- the journal read back ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def finished(tmp_path_factory, flight_area) -> Path:
    """A whole flight of the paper area by `gcs fly --sim`: its journal ends."""
    out = tmp_path_factory.mktemp("finished") / "paper"
    assert main(["fly", "--area", str(flight_area), "--strategy", "exhaustive", "--sim",
                 "--speedup", "60", "--out", str(out), "--no-rrd"]) == 0
    return out


def test_a_journal_holds_the_whole_flight_and_its_end(finished):
    state = read_journal(finished)
    record = json.loads((finished / "sortie.json").read_text())
    assert state.ended is not None and state.ended["landed"] == [1, 2, 3, 4] and state.start.sim
    assert sum(readings(state).values()) == record["readings"]["count"]
    plan = load_plan_dir(finished)
    for uid, v in state.vehicles.items():
        assert v.stage is Stage.LANDED and v.airborne_seen and v.mission == "search"
        assert v.battery_samples and v.track_index > 0.9 * len(plan.uavs[uid].trajectory)
        # the track goes out and comes back: its points (one a fifth of a cell apart at most as often
        # as the station samples, so fewer on a loaded machine) reach cells away from the airport,
        # and the last is over it
        home = np.array(plan.local_m(*plan.uavs[uid].airport_lat_lon))
        away = [float(np.hypot(*(np.array(plan.local_m(lat, lon)) - home))) for lat, lon in v.track]
        assert len(v.track) >= 8 and max(away) > 4 * plan.cell_size_m and away[-1] < plan.cell_size_m, (uid, away)
        lines = [line.text for _, line in state.events if line.uav_id == uid]
        assert sum(text.startswith("take-off") for text in lines) == 1
        assert [text for text in lines if not text.startswith("detection")][-1].startswith("landed")
    _only_recovered_readings_follow_the_landing(finished / JOURNAL_FILE)


def _only_recovered_readings_follow_the_landing(journal: Path) -> None:
    """A reading may reach the station after its vehicle landed only as one asked for again
    (lost on the link in flight): its index is below one the station already had."""
    records = [json.loads(line) for line in journal.read_text().splitlines()]
    for uid in {r["uav"] for r in records if r.get("uav") is not None}:
        mine = [r for r in records if r.get("uav") == uid]
        landed = max(i for i, r in enumerate(mine) if r["k"] == "event" and r["text"].startswith("landed"))
        before = [r["index"] for r in mine[:landed] if r["k"] == "reading"]
        after = [r["index"] for r in mine[landed:] if r["k"] == "reading"]
        assert all(index < max(before) and index not in before for index in after), (uid, after)


def test_a_torn_last_line_is_skipped_and_a_damaged_journal_refused(finished, tmp_path):
    folder = tmp_path / "f"
    shutil.copytree(finished, folder)
    data = (folder / JOURNAL_FILE).read_bytes()
    (folder / JOURNAL_FILE).write_bytes(data[:-20])  # a power cut inside the last line
    state = read_journal(folder)
    assert state.torn_lines == 1 and state.ended is None
    plan = load_plan_dir(folder)
    journal = FlightJournal.reopen(plan, state, ["udpin:127.0.0.1:0"], None)
    journal._open()  # as a restarted station does: the torn line goes, the resume line follows
    journal.close()
    again = read_journal(folder)
    assert again.torn_lines == 0 and again.resumed_t and again.last_t >= state.last_t
    assert sum(readings(again).values()) == sum(readings(state).values())
    lines = data.split(b"\n")
    lines[5] = lines[5][:10]
    (folder / JOURNAL_FILE).write_bytes(b"\n".join(lines))
    with pytest.raises(JournalError, match="line 6 is not JSON"):
        read_journal(folder)


# ---- killed mid-flight and taken over ---------------------------------------------------------

def _searching(state) -> bool:
    counts = readings(state)
    return len(counts) == 4 and min(counts.values()) >= 9


def _preparing(state) -> bool:
    """Every vehicle heard, none armed yet, one or more making ready or uploading (the four pass
    PREPARING together in a few hundredths of a second: a poll of the journal can miss that)."""
    stages = [v.stage for v in state.vehicles.values()]
    return len(stages) == 4 and set(stages) <= {Stage.CONNECTING, Stage.PREPARING, Stage.UPLOADING} \
        and bool(set(stages) & {Stage.PREPARING, Stage.UPLOADING})


def _returning(state) -> bool:
    return any(v.stage is Stage.RETURN for v in state.vehicles.values())


def _kill_and_resume(plan_dir: Path, tmp_path: Path, kill_at, capsys, away_s: float = 0.5):
    """Fly `plan_dir` (a copy) on `gcs sim` from a station process, SIGKILL it when its journal
    says `kill_at`, wait `away_s`, take the flight over with `gcs fly --resume` here."""
    import time

    folder = tmp_path / "paper"
    shutil.copytree(plan_dir, folder)
    plan = load_plan_dir(folder)
    with SimProcess(plan, speedup=SPEEDUP, drain=DRAIN) as sim:
        first = station(folder, sim.connections)
        before = kill_when(first, folder, kill_at)
        time.sleep(away_s)
        capsys.readouterr()
        started = time.monotonic()
        code = main(["fly", "--resume", str(folder)])
        took = time.monotonic() - started
        out = capsys.readouterr().out
        ends = {uid: vehicle_state(conn) for uid, conn in zip(sorted(plan.uavs), sim.connections)}
    after = read_journal(folder)
    print(f"station killed at flight second {before.last_t:.1f}; the vehicles flew "
          f"{after.resumed_t[0] - before.last_t:.1f} s without it; the resumed station ran {took:.1f} s")
    return plan, folder, before, after, code, out, ends


def _assert_landed_at_airports(plan, ends, after, out):
    landed = {}
    for uid, (lat, lon, armed) in ends.items():
        landed[uid] = _metres(plan, (lat, lon), plan.uavs[uid].airport_lat_lon)
        assert landed[uid] < 5.0 and not armed, f"UAV {uid} ends {landed[uid]:.1f} m from its airport\n{out}"
    print("landed from their airports (m, as the vehicles report):",
          ", ".join(f"UAV {uid} {m:.1f}" for uid, m in landed.items()))
    assert after.ended is not None and after.ended["landed"] == sorted(plan.uavs), out
    assert "4/4 landed" in out


def test_a_station_killed_mid_search_is_taken_over_and_nothing_recorded_is_lost(plan_dir, tmp_path, capsys):
    plan, folder, before, after, code, out, ends = _kill_and_resume(plan_dir, tmp_path, _searching, capsys,
                                                                    away_s=1.5)
    assert code == 0, out
    _assert_landed_at_airports(plan, ends, after, out)
    for uid in plan.uavs:
        assert f"UAV {uid}: reattached: flying its search (mode AUTO" in out, out  # ci68: all four late, 5.6 s
    # the fuel-based returns carried on after the restart, from the learned consumption
    resumed_at = after.resumed_t[0]
    returns = [(t, line) for t, line in after.events if "return triggered (reason: battery)" in line.text]
    assert returns and all(t > resumed_at for t, _ in returns), returns
    assert not [line for _, line in after.events if "): rtl" in line.text]  # no autopilot failsafe RTL
    # the event log, in the journal and in the segments of one recording (what the killed station
    # had not flushed yet comes from the journal, at its own times): each take-off and landing
    # once, the take-offs before the kill, the landings after the restart
    ids, logs = flight_events(folder, 2)
    assert len(set(ids)) == 1 and len(logs[1]) > 5
    recorded = [(t, line) for log in logs for t, line in log]
    journal = [(t, line.line) for t, line in after.events]
    for uid in plan.uavs:
        for lines in (recorded, journal):
            take_offs = [t for t, line in lines if line.startswith(f"UAV {uid}: take-off")]
            landings = [t for t, line in lines if line.startswith(f"UAV {uid}: landed")]
            assert len(take_offs) == 1 and take_offs[0] < before.last_t
            assert len(landings) == 1 and landings[0] > resumed_at
    assert all(t0 <= t1 for (t0, _), (t1, _) in zip(logs[1], logs[1][1:]))
    if logs[0]:  # the backlog starts after what the first segment holds
        assert max(t for t, _ in logs[0]) < min(t for t, _ in logs[1])
    in_recording, in_journal = Counter(line for _, line in recorded), Counter(line for _, line in journal)
    assert not in_journal - in_recording  # every line of the journal's log is in the recording, once
    assert all(line.startswith("station restarted") or "planned return begins" in line
               for line in in_recording - in_journal)  # and the recorder's own lines
    # readings: those from before the kill kept, those taken while it was away asked for again
    record = json.loads((folder / "sortie.json").read_text())
    assert record["finished"] is True
    log = {(r[0], r[1]): r for r in record["reading_log"]}
    for uid, v in before.vehicles.items():
        assert {(uid, d.index) for d in v.readings} <= set(log)
        indices = sorted(i for u, i in log if u == uid)
        assert indices == list(range(len(indices))), f"UAV {uid} lost readings"
    hits_before = {(uid, d.index) for uid, v in before.vehicles.items() for d in v.readings if d.hit}
    detections = json.loads((folder / "detections.geojson").read_text())["features"]
    assert hits_before and hits_before <= {(f["properties"]["uav"], f["properties"]["index"]) for f in detections}
    # the posterior is the plan's belief with every reading of both halves folded in
    prior = json.loads((folder / "belief.json").read_text())
    cells = [((r[2] - 1, r[3] - 1), bool(r[4])) for r in record["reading_log"] if r[2] is not None]
    tep, eu, _, _ = closed_form_posterior(np.asarray(prior["tep"]), np.asarray(prior["eu"]), cells,
                                          record["sensor"]["pc"], record["sensor"]["pf"])
    assert np.allclose(record["belief"]["tep"], tep, atol=1e-9) and np.allclose(record["belief"]["eu"], eu)
    tracks = json.loads((folder / "tracks.geojson").read_text())["features"]
    for feature in tracks:
        uid = feature["properties"]["uav"]
        assert feature["geometry"]["coordinates"][:len(before.vehicles[uid].track)] == \
            [[lon, lat] for lat, lon in before.vehicles[uid].track]


@pytest.mark.parametrize("kill_at", [_preparing, _returning], ids=["while-preparing", "while-returning"])
def test_resume_after_a_kill_lands_every_vehicle(plan_dir, tmp_path, capsys, kill_at):
    """Killed before any vehicle took off, its vehicles are prepared and launched again;
    killed the moment the first battery return is decided (its leg half uploaded, or flying),
    that vehicle is sent home or followed home; every vehicle lands at its airport."""
    plan, folder, before, after, code, out, ends = _kill_and_resume(plan_dir, tmp_path, kill_at, capsys)
    assert code == 0, out
    _assert_landed_at_airports(plan, ends, after, out)
    if kill_at is _preparing:
        assert not any(v.airborne_seen for v in before.vehicles.values())
        for uid in plan.uavs:
            assert f"UAV {uid}: search - mission started" in out
    else:
        returning = [uid for uid, v in before.vehicles.items() if v.stage is Stage.RETURN]
        for uid in returning:
            assert f"UAV {uid}: reattached" in out
            assert after.vehicles[uid].return_reason == "battery"


# ---- bad input --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def killed(plan_dir, tmp_path_factory) -> Path:
    """A flight whose station was SIGKILLed mid-search and whose vehicles are gone since."""
    folder = tmp_path_factory.mktemp("killed") / "paper"
    shutil.copytree(plan_dir, folder)
    with SimProcess(load_plan_dir(folder), speedup=SPEEDUP) as sim:
        kill_when(station(folder, sim.connections), folder, lambda s: len(s.vehicles) == 4 and
                  min(readings(s).values()) >= 3)
    return folder


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def _copy(folder: Path, tmp_path: Path) -> Path:
    out = tmp_path / folder.name
    shutil.copytree(folder, out)
    return out


def _edit_start(folder: Path, **changes) -> None:
    path = folder / JOURNAL_FILE
    lines = path.read_text().splitlines()
    start = json.loads(lines[0]) | changes
    path.write_text("\n".join([json.dumps(start), *lines[1:]]) + "\n")


@pytest.mark.parametrize("case, message", [
    ("missing", "no such folder"),
    ("never flown", "no flight journal (flight-journal.jsonl)"),
    ("finished", "no flight in progress there: the flight started"),
    ("sim", "flew the built-in simulated fleet (--sim), which stopped with its station: nothing is flying"),
    ("plan changed", "plan.json changed since the flight started"),
    ("signed", "the flight's links were signed: give --signing-key or --signing-passphrase again"),
    ("damaged", "is not JSON (the journal is damaged)"),
    ("online", "an online flight (--online) cannot be taken over"),
])
def test_resume_refuses_a_folder_with_no_flight_to_take_over(killed, finished, plan_dir, tmp_path, capsys, case,
                                                             message):
    """One error line, exit 2, and the folder as it was: no line appended to the journal, no
    recording segment started."""
    folder = {"missing": tmp_path / "nowhere", "never flown": plan_dir, "finished": finished}.get(case)
    if folder is None:
        folder = _copy(killed, tmp_path)
        if case == "sim":
            _edit_start(folder, sim=True)
        elif case == "signed":
            _edit_start(folder, signed=True)
        elif case == "online":
            _edit_start(folder, online=True)
        elif case == "plan changed":
            (folder / "plan.json").write_text((folder / "plan.json").read_text().replace('"seed": 0', '"seed": 1'))
        elif case == "damaged":
            lines = (folder / JOURNAL_FILE).read_bytes().split(b"\n")
            (folder / JOURNAL_FILE).write_bytes(b"\n".join([lines[0], b"{oops", *lines[2:]]))
    before = sorted(p.name for p in folder.iterdir()) if folder.exists() else None
    journal = (folder / JOURNAL_FILE).read_bytes() if (folder / JOURNAL_FILE).exists() else None
    assert main(["fly", "--resume", str(folder)]) == 2
    assert message in _one_error_line(capsys)
    if before is not None:
        assert sorted(p.name for p in folder.iterdir()) == before
        assert ((folder / JOURNAL_FILE).read_bytes() if journal is not None else None) == journal


@pytest.mark.parametrize("extra, named", [(["--plan", "x"], "--plan"),
                                          (["--strategy", "pio", "--sim"], "--strategy, --sim"),
                                          (["--rrd", "other.rrd"], "--rrd")])
def test_resume_takes_no_option_that_belongs_to_the_flight_as_started(killed, capsys, extra, named):
    assert main(["fly", "--resume", str(killed), *extra]) == 2
    assert f"--resume flies the flight as it was started: leave out {named}" in _one_error_line(capsys)


def test_a_new_flight_over_one_in_progress_is_refused(killed, capsys):
    assert main(["fly", "--plan", str(killed), "--connect", "udpout:127.0.0.1:9"]) == 2
    line = _one_error_line(capsys)
    assert "never ended" in line and f"gcs fly --resume {killed}" in line


@pytest.mark.parametrize("command", [["upload", "--plan", "{f}", "--connect", "udpout:127.0.0.1:9"],
                                     ["plan", "--continue", "{f}"]])
def test_an_upload_or_the_next_sortie_over_a_flight_in_progress_is_refused(killed, capsys, command):
    before = sorted(p.name for p in killed.iterdir())
    assert main([part.format(f=killed) for part in command]) == 2
    line = _one_error_line(capsys)
    assert "never ended" in line and f"gcs fly --resume {killed}" in line
    assert sorted(p.name for p in killed.iterdir()) == before


def test_vehicles_that_do_not_answer_after_the_restart_are_named(killed):
    """The vehicles are gone: each is named lost with the links listened on, and the flight
    ends when they have been lost for `lost_giveup_s` (the summary shows none landed)."""
    import asyncio

    from gcs.display.status_table import render_summary
    from gcs.flight.fly import fly_async
    from gcs.flight.resume import Resumption
    from tests.gcs.flight.conftest import fast_options

    plan, state = load_plan_dir(killed), read_journal(killed)
    controller = asyncio.run(asyncio.wait_for(fly_async(
        plan, ["udpin:127.0.0.1:0"], fast_options(connect_timeout_s=0.5, lost_giveup_s=0.5),
        resume=Resumption(plan, state)), 30))
    for uid in plan.uavs:
        st = controller.status[uid]
        assert st.stage is Stage.LOST
        assert st.note.startswith(f"did not answer after the restart: no HEARTBEAT from system id {uid} within 0.5 s "
                                  "on udpin:127.0.0.1:0")
        assert len(st.detections) == len(state.vehicles[uid].readings)  # what the journal kept is still there
    assert "0/4 landed" in render_summary(controller)
