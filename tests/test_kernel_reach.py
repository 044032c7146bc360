"""The JIT-off pass's choice of tests (`tests.kernel_reach.covering_tests`)."""

from __future__ import annotations

from tests.kernel_reach import covering_tests


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
