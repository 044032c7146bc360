"""The JIT-off pass's choice of tests (`tests.kernel_reach.covering_tests`) and the record it
chooses from (`tests/kernel_tests.json`)."""

from __future__ import annotations

from tests.kernel_reach import RECORD, covering_tests, read_record, stale_tests, write_record


def test_every_test_runs_in_its_quickest_case_and_every_kernel_in_its_quickest_tests():
    records = {
        "t.py::plan[pso]": {"kernels": ["reward", "pso"], "seconds": 45.0},
        "t.py::plan[ga]": {"kernels": ["reward", "ga"], "seconds": 40.0},
        "t.py::plan[lawnmower]": {"kernels": ["reward"], "seconds": 9.0},
        "t.py::pso_unit[1]": {"kernels": ["pso"], "seconds": 0.1},
        "t.py::pso_unit[2]": {"kernels": ["pso"], "seconds": 0.2},
        "t.py::table": {"kernels": ["table"], "seconds": 5.0},
        "t.py::no_kernel[1]": {"kernels": [], "seconds": 0.0},
    }
    assert covering_tests(records, cover=1) == {
        "t.py::plan[lawnmower]",  # plan's quickest case, and reward's quickest test
        "t.py::pso_unit[1]",
        "t.py::table",
        "t.py::plan[ga]",  # the only test that reaches ga
    }
    assert covering_tests(records, cover=2) == covering_tests(records, cover=1) | {"t.py::pso_unit[2]",
                                                                                  "t.py::plan[ga]"}


def test_a_test_reaching_no_kernel_is_left_out():
    assert covering_tests({"t.py::plain": {"kernels": [], "seconds": 0.0}}) == set()


def test_a_test_reaching_other_kernels_than_recorded_is_stale_and_a_new_one_reaching_none_is_not():
    recorded = {"t.py::a": {"kernels": ["k1", "k2"], "seconds": 1.0}, "t.py::b": {"kernels": ["k1"], "seconds": 1.0}}
    seen = {"t.py::a": {"kernels": ["k2", "k1"], "seconds": 3.0},  # the same kernels, another order and time
            "t.py::b": {"kernels": ["k1", "k3"], "seconds": 1.0},
            "t.py::new": {"kernels": ["k1"], "seconds": 0.1},
            "t.py::plain": {"kernels": [], "seconds": 0.1}}
    assert stale_tests(recorded, seen) == ["t.py::b: reaches ['k1', 'k3'], recorded ['k1']",
                                           "t.py::new: reaches ['k1'], recorded none"]
    assert stale_tests(recorded, {"t.py::a": {"kernels": [], "seconds": 0.1}}) == [
        "t.py::a: reaches no kernel, recorded ['k1', 'k2']"]


def test_the_record_is_written_whole_and_read_back(tmp_path):
    path = tmp_path / "kernel_tests.json"
    assert read_record(path) == {}
    records = {"t.py::b[1]": {"kernels": ["k"], "seconds": 0.5}, "t.py::a": {"kernels": ["k", "j"], "seconds": 2.0}}
    write_record(records, path)
    assert read_record(path) == records
    assert path.read_text().splitlines()[1].startswith('"t.py::a"')  # a test a line, sorted: diffs stay small
    assert list(tmp_path.iterdir()) == [path]


def test_the_committed_record_names_planner_tests_that_reach_kernels():
    record = read_record(RECORD)
    assert len(record) > 100
    assert all(test.startswith("tests/planner/") and r["kernels"] for test, r in record.items())
    assert len(covering_tests(record)) < len(record) / 2
