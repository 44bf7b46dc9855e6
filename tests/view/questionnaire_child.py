"""Run (``run``) or resume (``resume``) P01's session of the study in argv[1] with the participant's page
on port argv[3]: tasks played by the scripted pinch, the questionnaires answered on the page
(``DisplayRater``, rejected answers logged as ``microg session run`` logs them). It prints ``url
<address>`` once the page is served. The page test kills this process with SIGKILL in the middle of
a questionnaire and resumes the session with a second one."""

from __future__ import annotations

import sys

from microg.cli.session import _rejected_logger
from microg.study.session import EventLog, Outputs, SimulationClock, Unattended, resume_session, run_session
from microg.study.store import open_study
from microg.view.display import DisplayOperator, DisplayRater, ParticipantDisplay

from tests.study.conftest import scripted_inputs


def main(study_dir: str, mode: str, port: int) -> None:
    store = open_study(study_dir)
    session = store.session_of("P01") or store.create_session("P01", input_spec="scripted", simulated=True, clock="simulation")
    store.lock_session(session.id)
    clock = SimulationClock(store.last_time(session.id))
    with ParticipantDisplay(store.protocol, port=port) as display:
        print(f"url {display.url}", flush=True)
        options = dict(clock=clock, operator=DisplayOperator(display, Unattended()),
                       rater=DisplayRater(display, _rejected_logger(EventLog(store, session.id, clock))),
                       outputs=Outputs(sinks=(display,)))
        go = resume_session if mode == "resume" else run_session
        print(f"status {go(store, session.id, scripted_inputs(), **options)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
