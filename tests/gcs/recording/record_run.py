"""A recorded paper-scenario search in its own process, to be interrupted by the tests.

Usage: python record_run.py OUT.rrd FLUSH_INTERVAL_S PAUSE_S. Prints `step K` once step K has
been logged (and flushed, with a flush interval of 0), then pauses PAUSE_S seconds."""

import sys
import time

from gcs.recording.plan import PlanRecorder
from planner.dtscs import ClosedSearch, MissionConfig
from planner.scenario import paper_scenario


def main() -> None:
    out, flush_interval_s, pause_s = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    scenario = paper_scenario(5, range_steps=130)
    search = ClosedSearch(scenario, MissionConfig(), seed=5)
    with PlanRecorder(out, None, scenario, flush_interval_s=flush_interval_s) as rec:
        for record in search.run():
            rec.log_step(record)
            print(f"step {record.step}", flush=True)
            time.sleep(pause_s)
        rec.log_plan(search.plan())


if __name__ == "__main__":
    main()
