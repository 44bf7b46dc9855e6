"""The study engine (paper, section 4.3): protocols, participants, sessions, the log store, export.

    from microg.study import load_protocol, create_study, Participant
    store = create_study("studies/s1", load_protocol("protocols/paper.toml"), seed=1)
    store.add_participant(Participant("P01", "female", 24, "right", True))

The command line (``microg study init``, ``microg participant add``, ``microg session run``,
``microg session resume``, ``microg export``) wraps the same functions; see docs/study.md.
"""

from .assignment import Participant, ParticipantError, assign_group, assign_order, balanced_latin_square, paper_sample
from .export import answers_table, export_study, questionnaire_table, read_answers, read_tables, run_frames, \
    run_hand_frames, scores_table, trials_table
from .inputs import InputError, ScriptedInputs, open_inputs, participant_plan
from .protocol import Protocol, ProtocolError, load_protocol
from .questionnaire import Question, RatingError, TerminalRater, parse_answer, questions
from .session import Outputs, SimulationClock, WallClock, resume_session, run_session, run_task, task_world
from .store import Store, StoreError, create_study, open_study, plan_tasks

__all__ = [
    "InputError", "Outputs", "Participant", "ParticipantError", "Protocol", "ProtocolError", "Question",
    "RatingError", "ScriptedInputs", "SimulationClock", "Store", "StoreError", "TerminalRater",
    "WallClock", "answers_table", "assign_group", "assign_order", "balanced_latin_square", "create_study",
    "export_study", "load_protocol", "open_inputs", "open_study", "paper_sample", "parse_answer", "participant_plan",
    "plan_tasks", "questionnaire_table", "questions", "read_answers", "read_tables", "resume_session", "run_frames",
    "run_hand_frames", "run_session", "run_task", "scores_table",
    "task_world", "trials_table",
]
