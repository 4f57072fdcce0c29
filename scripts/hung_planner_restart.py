"""Does a sequence planner that hung in a pass, was killed and restarted, take the job up?

Each try runs the steady 60 mm job (seed 4, 22 s deadline) in lock-step, stops the sequence
planner (SIGSTOP) once pass 0's force trajectory is out, kills it once the plant has
reported the pass and starts it again; the restarted planner must take pass 0's result from
the plant's kept ones and end the job. Before a restart got a DDS participant id of its own
(``hex_control.ros.app.graph.RESTART_PARTICIPANT_IDS``) 4 of 5 tries stalled: the new
planner heard nothing from the graph. ``--same-id`` restarts it with the lowest free id, as
before. The stopped participant may leave its shared-memory port broken for the next process
to take its id: run this in a domain of its own, not beside the test suite.

    ROS_DOMAIN_ID=77 python scripts/hung_planner_restart.py --tries 5 [--same-id]
"""

from __future__ import annotations

import argparse
import signal
import tempfile
from pathlib import Path

from hex_control.ros.app import graph
from hex_control.ros.app.grind_job import JobSession

STEADY = {"bead_length_mm": 60.0, "bead_height_mm": 0.8, "specific_energy_cv": 0.0}


def one_try(directory: Path) -> str:
    """The job's end after the hang, kill and restart, or why it did not end."""
    with JobSession(directory, seed=4, plant_overrides=STEADY, record=False) as session:
        session.start_job(22.0, 4.7)
        session.spin_until(lambda: 0 in session.record.trajectories, 300.0, "pass 0's force trajectory")
        session.graph.processes["sequence_planner"].send_signal(signal.SIGSTOP)
        session.spin_until(lambda: 0 in session.record.results, 300.0, "pass 0's result")
        session.graph.kill("sequence_planner")
        session.graph.start("sequence_planner")
        try:
            outcome = session.wait_for_outcome(60.0)
        except TimeoutError:
            return "stalled: no job result 60 s after the restart"
    return f"{outcome['reason']} after {outcome['passes']} passes"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tries", type=int, default=5)
    parser.add_argument("--same-id", action="store_true", help="restart with the lowest free participant id")
    args = parser.parse_args()
    if args.same_id:
        graph.NodeGraph._restart_profile = lambda self, log_path: {}
    ended = 0
    for k in range(args.tries):
        said = one_try(Path(tempfile.mkdtemp(prefix="hung_planner_")))
        ended += not said.startswith("stalled")
        print(f"try {k + 1}: {said}", flush=True)
    print(f"{ended} of {args.tries} jobs ended")


if __name__ == "__main__":
    main()
