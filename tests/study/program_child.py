"""Run the next session of P01 in the study in argv[1] with the simulated participant, and kill this
process with SIGKILL in the middle of the session's third task (once two of its task runs have
ended and the third has logged frames): the program test resumes what it left."""

from __future__ import annotations

import os
import signal
import sys

from microg.study.inputs import open_inputs
from microg.study.session import Outputs, SimulationClock, run_session
from microg.study.store import open_study


class KillInThirdTask:
    """A frame sink that kills the process once two runs of the session ended and a third is under way."""

    def __init__(self, store, session_id):
        self.store, self.session_id = store, session_id

    def take(self, moments) -> None:
        ended = self.store.db.execute("SELECT COUNT(*) FROM task_runs WHERE session_id = ? AND status != 'running'",
                                      (self.session_id,)).fetchone()[0]
        if ended >= 2:
            os.kill(os.getpid(), signal.SIGKILL)


def main(study_dir: str) -> None:
    store = open_study(study_dir)
    inputs = open_inputs("simulated", store.protocol.group(store.participant("P01").group))
    session = store.create_session("P01", input_spec=inputs.spec, simulated=True, clock="simulation")
    store.lock_session(session.id)
    print(f"started {session.name}", flush=True)
    run_session(store, session.id, inputs, clock=SimulationClock(),
                outputs=Outputs(sinks=(KillInThirdTask(store, session.id),)))


if __name__ == "__main__":
    main(sys.argv[1])
