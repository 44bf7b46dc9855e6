"""The columns of the exported tables, in one place: the export writes them, the analysis reads them.

Each table is a tuple of :class:`Column` (name, pandas dtype, one-line description; unit, allowed
values or range, where its values come from) in the order the export writes them: the export's
``codebook.csv`` and ``dataset_description.json`` are made from them (``microg.study.codebook``).
``TRIAL_COLUMNS`` / ``QUESTIONNAIRE_COLUMNS`` / ``ANSWER_COLUMNS`` are the names in that order,
``TRIAL_DTYPES`` / ``QUESTIONNAIRE_DTYPES`` / ``ANSWER_DTYPES`` map each name to its dtype. The
questionnaire table holds the paper's kind of 0-10 items (the Likert analysis reads it); the answers
table holds every answer to every instrument, and ``SCORES`` their scores
(``microg.analysis.scoring``). Columns marked optional may be absent from a table; readers must not
require them.
"""

from __future__ import annotations

from typing import NamedTuple


class Column(NamedTuple):
    """One column of an exported table: what the export writes, the analysis reads and the
    codebook (``microg.study.codebook``) describes."""

    name: str
    dtype: str
    description: str
    optional: bool = False
    unit: str = ""
    """Its unit, for a number that has one: s, min, ms, m, m/s, rad/s, years; empty for none."""
    values: tuple[str, ...] = ()
    """The values it may take, when the code fixes them."""
    minimum: float | None = None
    maximum: float | None = None
    levels: str = ""
    """The study's own list its values come from, filled in from the protocol at each export:
    groups, phases, interactions, objects, object_names, instruments, kinds, stages
    (``microg.study.codebook``)."""
    source: str = ""
    """Where its values come from (one of the sources below, or a sentence naming one)."""


STUDY = "the study (microg study init)"
PROTOCOL = "the protocol"
ENROLMENT = "the participant's enrolment (microg participant add; withdraw)"
ASSIGNMENT = "the assignment at enrolment (groups balanced by the protocol's balance)"
SESSION_LOG = "the session log"
TASK_RULES = "the task kind's rules over the run's frames (the run's measures event in the session log)"
"""Where a task kind's own measures come from."""
ANSWER = "the answer as given: by the participant (page or terminal) or by the rating model"
SCORING = "computed from the answers by the instrument's key (microg.analysis.scoring)"
FRAME_LOG = "the frame log"
MERGE = "the station's study, at microg study merge"

SESSION_CLOCK = ("in seconds since the session started on the session's clock (the wall clock in a live session, "
                 "carried on across a resume; simulated time, advancing with the frames, otherwise)")
RATING_RANGE = (0, 10)
"""The paper's kind of item: a rating from 0 to 10."""
REPORT_FILE = "report.html"
"""The report ``microg report`` writes into its folder (``microg.analysis.report``), which the dashboard links to."""


class KindMeasure(NamedTuple):
    """One of a task kind's own measures, a column of the trials table after the fixed ``TRIALS``, as
    a report reads it: its column, how a reader sees it ("time to catch (s)"), and whether it is yes
    or no per task (``proportion``: a participant's cell is the share of its tasks with yes) or may be
    negative (``signed``: a difference from the right value)."""

    name: str
    label: str
    proportion: bool = False
    signed: bool = False


class KindInfo(NamedTuple):
    """A task kind as the tables and the report know it (the study's registry of kinds, passed in:
    the analysis reads tables only): its name, how a reader calls it, what its ``attempts`` count, and
    its own measures."""

    name: str
    title: str
    attempts: str
    measures: tuple[KindMeasure, ...] = ()


PICK_AND_PLACE = KindInfo("pick_and_place", "Pick and place", "drops")
"""The paper's task kind: time and attempts, no measures of its own."""
STATUSES = ("completed", "timeout", "aborted", "skipped", "unfinished", "not_run")
"""How a planned task ended (its last run): unfinished when cut off, not_run when never started."""
ANSWERED_BY = ("participant", "model")
"""Who answered an item: the participant, or the rating model for a simulated participant."""
GENDERS = ("female", "male", "diverse", "undisclosed")
HANDEDNESS = ("left", "right", "ambidextrous")

TRIALS = (
    Column("study", "string", "the study's name", source=STUDY),
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("group", "string", "the participant's group code", levels="groups", source=ASSIGNMENT),
    Column("gender", "string", "the participant's gender as enrolled", values=GENDERS, source=ENROLMENT),
    Column("age", "Int64", "the participant's age", unit="years", minimum=0, source=ENROLMENT),
    Column("handedness", "string", "the participant's dominant hand", values=HANDEDNESS, source=ENROLMENT),
    Column("mr_experience", "bool", "whether the participant had used mixed reality before", source=ENROLMENT),
    Column("phase", "string", "the protocol phase the task belongs to, e.g. training, stage1, stage2", levels="phases",
           source=PROTOCOL),
    Column("interaction", "string", "code of the interaction model the task ran with, e.g. soft_hand",
           levels="interactions", source=PROTOCOL),
    Column("object", "string", "the object's code in the protocol, e.g. C, F, L", levels="objects", source=PROTOCOL),
    Column("order_position", "Int64", "position of the task's object in its phase's object order (the participant's "
           "order for a phase of tasks, the protocol's for training), from 1", minimum=1,
           source="the participant's object order, drawn at enrolment (the protocol's order)"),
    Column("completed", "bool", "whether the task was completed", source=SESSION_LOG),
    Column("time_s", "float64", "completion time, from the task's first frame to its completion, by the frames' "
           "timestamps; empty unless completed", unit="s", minimum=0, source=SESSION_LOG),
    Column("attempts", "Int64", "number of attempts (what the task's kind counts as one: a pick-and-place's drops); "
           "empty unless the task's last run completed, timed out or was aborted", minimum=0, source=SESSION_LOG),
    Column("started_at", "float64", f"when the task's last run started, {SESSION_CLOCK}; empty unless that run ended",
           unit="s", minimum=0, source=SESSION_LOG),
    Column("ended_at", "float64", f"when the task's last run ended, {SESSION_CLOCK}; empty unless it ended", unit="s",
           minimum=0, source=SESSION_LOG),
    Column("status", "string", "how the task's last run ended: unfinished (cut off), not_run (never started)",
           values=STATUSES, source=SESSION_LOG),
    Column("simulated", "bool", "whether a simulated participant did the task", source=SESSION_LOG),
    Column("object_name", "string", "the object's name, e.g. cube", levels="object_names", source=PROTOCOL),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True, source=PROTOCOL),
    Column("added_latency_ms", "float64", "display latency the task's phase adds to the participant's page "
           "(the protocol's added_latency_ms); 0 for none", optional=True, unit="ms", minimum=0, source=PROTOCOL),
    Column("runs", "Int64", "how many times the task was run", minimum=0, source=SESSION_LOG),
    Column("withdrawn", "bool", "whether the participant withdrew from the study", source=ENROLMENT),
    Column("session", "string", "the session the task ran in: a training program's session by its name in the "
           "protocol's [[sessions]], else main (the one session)", levels="sessions", source=PROTOCOL),
    Column("task_index", "Int64", "index of the task within its session, from 0 (a phase trained to a criterion "
           "keeps max_tasks indexes, so indexes may skip)", minimum=0, source=SESSION_LOG),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True, source=MERGE),
    Column("task_kind", "string", "the task's kind", optional=True, levels="kinds", source=PROTOCOL),
    Column("session_id", "Int64", "id of the session in the study's log", minimum=1, source=SESSION_LOG),
    Column("session_index", "Int64", "the session's place among the participant's sessions, from 1", minimum=1,
           source=SESSION_LOG),
    Column("session_date", "string", "the day the session ran (ISO 8601 date; on the simulated calendar for a "
           "simulated participant: each session on the earliest day it may run)", source=SESSION_LOG),
    Column("task_in_phase", "Int64", "the task's place in its phase, from 1", minimum=1, source=SESSION_LOG),
    Column("criterion_met", "boolean", "in a phase trained to a criterion (the protocol's until): whether the "
           "criterion was met at this task (true on that one task only); empty in other phases", optional=True,
           source=SESSION_LOG),
    Column("difficulty", "float64", "the value of the phase's staircase parameter the task ran with; empty without "
           "a staircase", optional=True, source=PROTOCOL),
)
"""The trials table's columns every study has; each task kind's own measures follow them
(``microg.study.export.trial_declarations``)."""

PROGRESSION = (
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("group", "string", "the participant's group code", levels="groups", source=ASSIGNMENT),
    Column("session", "string", "the session (as in trials)", levels="sessions", source=PROTOCOL),
    Column("session_index", "Int64", "the session's place among the participant's sessions, from 1", minimum=1,
           source=SESSION_LOG),
    Column("phase", "string", "the phase of tasks", levels="phases", source=PROTOCOL),
    Column("tasks", "Int64", "tasks the phase ran (ended: completed, timed out, aborted or skipped)", minimum=0,
           source=SESSION_LOG),
    Column("criterion_met", "boolean", "whether the phase met its criterion (the protocol's until); empty for a "
           "phase without one", optional=True, source=SESSION_LOG),
    Column("tasks_to_criterion", "Int64", "the task at which the criterion was met (its task_in_phase); empty when "
           "it was not met (max_tasks reached: censored) or the phase has none", optional=True, minimum=1,
           source=SESSION_LOG),
    Column("minutes", "float64", "the phase's duration, from its start to its end on the session's clock; empty "
           "for a phase not ended", optional=True, unit="min", minimum=0, source=SESSION_LOG),
    Column("final_difficulty", "float64", "the staircase's value of the phase's last task; empty without a "
           "staircase", optional=True, source=PROTOCOL),
)
"""``progression``: one row per participant, session and phase of tasks: how far training went."""

QUESTIONNAIRE = (
    Column("study", "string", "the study's name", source=STUDY),
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("group", "string", "the participant's group code", levels="groups",
           source=ASSIGNMENT),
    Column("interaction", "string", "code of the interaction model the rating is about", levels="interactions",
           source=PROTOCOL),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True, source=PROTOCOL),
    Column("item", "string", "the questionnaire item, e.g. naturalness", source="the instrument (its item ids)"),
    Column("rating", "Int64", "the rating on the item's 0-10 scale", minimum=RATING_RANGE[0], maximum=RATING_RANGE[1],
           source=ANSWER),
    Column("source", "string", "who gave the rating", values=ANSWERED_BY, source=ANSWER),
    Column("simulated", "bool", "whether the rating comes from the rating model", source=SESSION_LOG),
    Column("withdrawn", "bool", "whether the participant withdrew from the study", source=ENROLMENT),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True, source=MERGE),
)

ANSWERS = (
    Column("study", "string", "the study's name", source=STUDY),
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("group", "string", "the participant's group code", levels="groups",
           source=ASSIGNMENT),
    Column("instrument", "string", "the instrument's id: ssq, ipq, tlx, sus, paper or a study's own",
           levels="instruments", source=PROTOCOL),
    Column("administration", "string", "when it was asked, e.g. pre, post, after, end (the timeline phase's "
           "administration)", source=PROTOCOL),
    Column("interaction", "string", "code of the interaction model it is about; empty for none",
           levels="interactions", source=PROTOCOL),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True, source=PROTOCOL),
    Column("item", "string", "the item's id, e.g. ssq08, SP2, pair_mental_effort, sus10",
           source="the instrument (instruments/ID.toml)"),
    Column("value", "string", "the answer: a number on the item's scale, or the choice made (the item's scale "
           "and anchors: instruments/ID.toml)", source=ANSWER),
    Column("source", "string", "who answered", values=ANSWERED_BY, source=ANSWER),
    Column("response_time_s", "float64", "time from showing the item to the answer; empty for the model", unit="s",
           minimum=0, source=SESSION_LOG),
    Column("t", "float64", f"when the answer was committed, {SESSION_CLOCK}", unit="s", minimum=0,
           source=SESSION_LOG),
    Column("simulated", "bool", "whether the answer comes from the rating model", source=SESSION_LOG),
    Column("withdrawn", "bool", "whether the participant withdrew from the study", source=ENROLMENT),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True, source=MERGE),
)

SCORES = (
    Column("participant", "string", "participant id, e.g. P01", source=ENROLMENT),
    Column("instrument", "string", "the instrument's id", levels="instruments", source=PROTOCOL),
    Column("administration", "string", "when it was asked (as in the answers table); empty for one asked once",
           source=PROTOCOL),
    Column("interaction", "string", "code of the interaction model it is about; empty for none",
           levels="interactions", source=PROTOCOL),
    Column("scale", "string", "the scale's name in the instrument's key, e.g. nausea, spatial, tlx, sus",
           source="the instrument's key (instruments/ID.toml)"),
    Column("score", "float64", "the scale's score by the instrument's published key (its range: the key's); empty "
           "where an item it needs was not answered", source=SCORING),
)

TRIAL_COLUMNS = tuple(column.name for column in TRIALS)
QUESTIONNAIRE_COLUMNS = tuple(column.name for column in QUESTIONNAIRE)
ANSWER_COLUMNS = tuple(column.name for column in ANSWERS)
SCORE_COLUMNS = tuple(column.name for column in SCORES)
TRIAL_DTYPES = {column.name: column.dtype for column in TRIALS}
QUESTIONNAIRE_DTYPES = {column.name: column.dtype for column in QUESTIONNAIRE}
ANSWER_DTYPES = {column.name: column.dtype for column in ANSWERS}
