"""Run P01's session of the study in argv[1] with a scripted pinch, in lockstep with the test that
started it: before handing over each frame it prints ``frame <task> <n>`` (n frames made so far)
and waits for a line on its standard input. The crash test kills this process with SIGKILL while
it waits, so what was committed then is known exactly, however busy the machine is."""

from __future__ import annotations

import sys

from microg.study.inputs import ScriptedInputs
from microg.study.session import SimulationClock, run_session
from microg.study.store import open_study

from tests.study.scripted import ScriptedPinch, pinch_keyframes


class Reporting(ScriptedPinch):
    def __init__(self, keys, task):
        super().__init__(keys)
        self.task = task

    def next_frame(self, observation=None):
        frame = super().next_frame(observation)
        if frame is not None:
            print(f"frame {self.task} {self.index}", flush=True)
            sys.stdin.readline()
        return frame


def main(study_dir: str) -> None:
    store = open_study(study_dir)
    session = store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.lock_session(session.id)
    made = []

    def make(plan, seed):
        made.append(Reporting(pinch_keyframes(plan), len(made)))
        return made[-1]

    run_session(store, session.id, ScriptedInputs(make), clock=SimulationClock())
    print("done", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
