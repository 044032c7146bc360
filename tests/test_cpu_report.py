"""`--cpu-report`: the tests that took the most CPU, and the totals."""

from __future__ import annotations

from tests.cpu_report import CpuUse, report_lines


def test_the_report_lists_the_most_cpu_first_with_cores_and_ends_with_the_totals():
    tests = [CpuUse("a", wall_s=10.0, cpu_s=5.0), CpuUse("b", wall_s=2.0, cpu_s=3.0), CpuUse("c", 1.0, 0.0)]
    lines = report_lines(tests, top=2)
    assert [line.split()[-1] for line in lines[:2]] == ["a", "b"]
    assert "0.50 cores" in lines[0] and "1.50 cores" in lines[1]
    assert lines[-1].split()[:4] == ["8.0", "CPU-s", "13.0", "s"] and lines[-1].endswith("all 3 tests")
    assert report_lines([]) == []
