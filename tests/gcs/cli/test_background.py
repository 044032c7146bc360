"""The background helper (`gcs.background`): jobs and remote objects in a forked process, in
order; failures raised in the parent; objects closed when the parent dies; the same results
inline where it cannot fork. The plan recording made through it equals the one made in process."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest

from gcs.background import Background

# The recording's and the planner's modules are imported by the checks that use them: each check
# runs in a fresh interpreter, and the others need not pay for importing Rerun and numba.


def pid_and(value):
    return os.getpid(), value


def fail(message):
    raise ValueError(message)


class Journal:
    """Writes every call to a file, `closed` last when closed."""

    def __init__(self, path):
        self.path = Path(path)
        self.path.write_text("")

    def note(self, text):
        if text == "bad":
            raise KeyError(text)
        with self.path.open("a") as f:
            f.write(text + "\n")

    def close(self):
        self.note("closed")


def in_fresh_process(check: str, tmp_path: Path, *args: str) -> None:
    """Run `check(tmp_path, *args)` of this module in a new interpreter: the helper forks only
    from a process without other threads, which a test process may not be."""
    script = textwrap.dedent(f"""
        import sys
        from pathlib import Path
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        import test_background
        test_background.{check}(Path(sys.argv[1]), *sys.argv[2:])
    """)
    run = subprocess.run([sys.executable, "-c", script, str(tmp_path), *args], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr


def check_jobs_run_in_a_forked_process_in_order(tmp_path: Path) -> None:
    with Background() as helper:
        jobs = [helper.submit(pid_and, k) for k in range(5)]
        results = helper.results()
    pids = {pid for pid, _ in results}
    assert len(pids) == 1 and os.getpid() not in pids
    assert [results[j][1] for j in jobs] == [0, 1, 2, 3, 4]


def test_jobs_run_in_a_forked_process_in_order(tmp_path):
    in_fresh_process("check_jobs_run_in_a_forked_process_in_order", tmp_path)


def check_warm_up_runs_in_the_helper_before_the_jobs(tmp_path: Path) -> None:
    flag = tmp_path / "warm"
    with Background(lambda: flag.write_text(str(os.getpid()))) as helper:
        job = helper.submit(pid_and, None)
        pid, _ = helper.results()[job]
    assert flag.read_text() == str(pid) != str(os.getpid())


def test_warm_up_runs_in_the_helper_before_the_jobs(tmp_path):
    in_fresh_process("check_warm_up_runs_in_the_helper_before_the_jobs", tmp_path)


def check_calls_on_a_remote_object_are_made_in_order(tmp_path: Path) -> None:
    path = tmp_path / "journal"
    with Background() as helper:
        journal = helper.create(Journal, path)
        for word in ("one", "two", "three"):
            journal.call("note", word)
        journal.call("close")
        job = helper.submit(pid_and, None)
        pid, _ = helper.results()[job]
    assert pid != os.getpid()
    assert path.read_text().split() == ["one", "two", "three", "closed"]


def test_calls_on_a_remote_object_are_made_in_order(tmp_path):
    in_fresh_process("check_calls_on_a_remote_object_are_made_in_order", tmp_path)


def check_failures_are_raised_in_the_parent(tmp_path: Path) -> None:
    with Background() as helper:
        helper.submit(fail, "job went wrong")
        with pytest.raises(ValueError, match="job went wrong"):
            helper.results()
    with Background() as helper:
        journal = helper.create(Journal, tmp_path / "journal")
        journal.call("note", "bad")
        journal.call("note", "after")  # the object lives on
        with pytest.raises(KeyError, match="bad"):
            helper.results()
    assert (tmp_path / "journal").read_text().split() == ["after"]


def test_failures_are_raised_in_the_parent(tmp_path):
    in_fresh_process("check_failures_are_raised_in_the_parent", tmp_path)


def check_a_method_of_a_remote_object_runs_as_a_job(tmp_path: Path) -> None:
    with Background() as helper:
        first = helper.create(Journal, tmp_path / "first")
        first.call("note", "one")
        job = first.submit("note", "two")
        other = helper.submit(pid_and, "x")
        results = helper.results()
    assert results[job] is None and results[other][1] == "x"
    assert (tmp_path / "first").read_text().split() == ["one", "two"]
    with Background() as helper:  # after a failed call, the job fails with that failure
        journal = helper.create(Journal, tmp_path / "second")
        journal.call("note", "bad")
        journal.submit("note", "after")
        with pytest.raises(KeyError, match="bad"):
            helper.results()
    assert (tmp_path / "second").read_text() == ""


def test_a_method_of_a_remote_object_runs_as_a_job(tmp_path):
    in_fresh_process("check_a_method_of_a_remote_object_runs_as_a_job", tmp_path)


def test_without_fork_the_same_happens_in_the_caller(tmp_path):
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        with Background() as helper:
            journal = helper.create(Journal, tmp_path / "journal")
            journal.call("note", "one")
            job = helper.submit(pid_and, "x")
            assert (tmp_path / "journal").read_text() == "one\n"  # done at once
            assert helper.results()[job] == (os.getpid(), "x")
            method = journal.submit("note", "two")
            assert (tmp_path / "journal").read_text().split() == ["one", "two"]
            assert helper.results()[method] is None
            helper.submit(fail, "inline too")
            with pytest.raises(ValueError, match="inline too"):
                helper.results()
        assert (tmp_path / "journal").read_text().split() == ["one", "two", "closed"]
    finally:
        stop.set()
        other.join()


def test_a_killed_parent_leaves_the_helper_to_close_its_objects(tmp_path):
    path = tmp_path / "journal"
    script = textwrap.dedent(f"""
        import os, signal, sys, time
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_background import Journal
        from gcs.background import Background
        helper = Background(lambda: time.sleep(0.5))  # still warming up when the parent dies
        journal = helper.create(Journal, {str(path)!r})
        journal.call("note", "one")
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert run.returncode == -signal.SIGKILL
    for _ in range(200):
        if path.exists() and path.read_text().split() == ["one", "closed"]:
            break
        threading.Event().wait(0.05)
    assert path.read_text().split() == ["one", "closed"]


def columns(path: Path) -> dict[str, str]:
    from gcs.recording.plan import read_recording

    tables = read_recording(path)
    return {f"{entity} {name}": str(table.column(name).to_pylist())
            for entity, table in tables.temporal.items() for name in table.column_names if "log_time" not in name}


def check_the_recording_made_in_the_helper_equals_the_one_made_here(tmp_path: Path, cells_per_map: str) -> None:
    import gcs.recording.plan_rules
    from gcs.recording.background import BackgroundPlanRecorder
    from gcs.recording.plan import PlanRecorder, read_recording
    from planner.dtscs import ClosedSearch, MissionConfig
    from planner.scenario import paper_scenario

    if cells_per_map != "default":
        gcs.recording.plan_rules.MAP_CELLS_EVERY_STEP = int(cells_per_map)
    scenario = paper_scenario(2, range_steps=50)

    def record(make):
        search = ClosedSearch(scenario, MissionConfig(np_steps=2), seed=2)
        with make() as rec:
            for step in search.run():
                rec.log_step(step)
            rec.log_plan(search.plan())
        return search.step_index

    here, there = tmp_path / "here.rrd", tmp_path / "there.rrd"
    steps = record(lambda: PlanRecorder(here, None, scenario, name="paper"))
    with Background() as helper:
        record(lambda: BackgroundPlanRecorder(helper, there, scenario, name="paper"))
        helper.results()
    map_steps = read_recording(there).column("maps/tep", "Image:buffer")[0]
    assert map_steps == sorted({*range(0, steps + 1, 3 if cells_per_map == "1000" else 1), steps})
    assert columns(here) == columns(there)


@pytest.mark.parametrize("cells_per_map", ["default", "1000"])
def test_the_recording_made_in_the_helper_equals_the_one_made_here(tmp_path, cells_per_map):
    """With maps every step (the default, `gcs.recording.plan_rules.MAP_CELLS_EVERY_STEP`) and
    (on the 50 x 50 paper grid, 1000 cells a map) every 3rd step: the helper's recording holds
    the same rows, the last step's maps included."""
    in_fresh_process("check_the_recording_made_in_the_helper_equals_the_one_made_here", tmp_path, str(cells_per_map))


def check_ctrl_c_keeps_the_background_recording_up_to_the_last_step(tmp_path: Path) -> None:
    from gcs.recording.background import BackgroundPlanRecorder
    from gcs.recording.plan import read_recording
    from planner.dtscs import ClosedSearch, MissionConfig
    from planner.scenario import paper_scenario

    scenario = paper_scenario(2, range_steps=50)
    search = ClosedSearch(scenario, MissionConfig(np_steps=2), seed=2)
    rrd = tmp_path / "cut.rrd"
    with Background() as helper:
        with pytest.raises(KeyboardInterrupt):
            with BackgroundPlanRecorder(helper, rrd, scenario) as rec:
                for step in search.run():
                    rec.log_step(step)
                    if step.step == 12:
                        raise KeyboardInterrupt
    _, texts = read_recording(rrd).column("events", "TextLog:text")
    assert texts[-1] == ["run interrupted after step 12 (Ctrl-C)"]
    assert read_recording(rrd).column("maps/tep", "Image:buffer")[0][-1] == 12


def test_ctrl_c_keeps_the_background_recording_up_to_the_last_step(tmp_path):
    in_fresh_process("check_ctrl_c_keeps_the_background_recording_up_to_the_last_step", tmp_path)
