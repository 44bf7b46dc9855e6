"""Run P01's session of the study in argv[1] with a slow scripted pinch, printing each frame it
hands over (``frame <task> <n>``). The crash test kills this process with SIGKILL mid-task."""

from __future__ import annotations

import sys

from microg.study.inputs import ScriptedInputs
from microg.study.session import SimulationClock, run_session
from microg.study.store import open_study

from tests.study.scripted import ScriptedPinch, pinch_keyframes


class Reporting(ScriptedPinch):
    def __init__(self, keys, task):
        super().__init__(keys, pace=0.002)
        self.task = task

    def next_frame(self, world=None):
        frame = super().next_frame(world)
        if frame is not None:
            print(f"frame {self.task} {self.index}", flush=True)
        return frame


def main(study_dir: str) -> None:
    store = open_study(study_dir)
    session = store.create_session("P01", "scripted", True, "simulation")
    store.lock_session(session.id)
    made = []

    def make(plan, seed):
        made.append(Reporting(pinch_keyframes(plan), len(made)))
        return made[-1]

    run_session(store, session.id, ScriptedInputs(make), clock=SimulationClock(), progress=False)
    print("done", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
