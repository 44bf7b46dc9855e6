"""The columns of the exported tables, in one place: the export writes them, the analysis reads them.

Each table is a tuple of :class:`Column` (name, pandas dtype, one-line description) in the order the
export writes them. ``TRIAL_COLUMNS`` / ``QUESTIONNAIRE_COLUMNS`` / ``ANSWER_COLUMNS`` are the names
in that order, ``TRIAL_DTYPES`` / ``QUESTIONNAIRE_DTYPES`` / ``ANSWER_DTYPES`` map each name to its
dtype. The questionnaire table holds the paper's kind of 0-10 items (the Likert analysis reads it);
the answers table holds every answer to every instrument, and ``scores.csv`` their scores
(``microg.analysis.scoring``). Columns marked optional
may be absent from a table; readers must not require them.
"""

from __future__ import annotations

from typing import NamedTuple


class Column(NamedTuple):
    """One column of an exported table."""

    name: str
    dtype: str
    description: str
    optional: bool = False


TRIALS = (
    Column("study", "string", "the study's name"),
    Column("participant", "string", "participant id, e.g. P01"),
    Column("group", "string", "the participant's group code, e.g. V (trained first) or B (beginners)"),
    Column("gender", "string", "the participant's gender as enrolled"),
    Column("age", "Int64", "the participant's age in years"),
    Column("handedness", "string", "left or right"),
    Column("mr_experience", "bool", "whether the participant had used mixed reality before"),
    Column("phase", "string", "the protocol phase the task belongs to, e.g. training, stage1, stage2"),
    Column("interaction", "string", "code of the interaction model the task ran with, e.g. soft_hand"),
    Column("object", "string", "the object's code in the protocol, e.g. C, F, L"),
    Column("order_position", "Int64", "position of the task in the participant's object order"),
    Column("completed", "bool", "whether the task was completed"),
    Column("time_s", "float64", "completion time in seconds; empty unless completed"),
    Column("attempts", "Int64", "number of drops; empty for a task that never ran"),
    Column("started_at", "float64", "session-clock seconds when the task's last run started"),
    Column("ended_at", "float64", "session-clock seconds when the task's last run ended"),
    Column("status", "string", "completed, timeout, aborted, skipped, unfinished or not_run"),
    Column("simulated", "bool", "whether a simulated participant did the task"),
    Column("object_name", "string", "the object's name, e.g. cube"),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True),
    Column("added_latency_ms", "float64", "display latency the task's phase adds to the participant's page (ms, "
           "the protocol's added_latency_ms); 0 for none", optional=True),
    Column("runs", "Int64", "how many times the task was run"),
    Column("withdrawn", "bool", "whether the participant withdrew from the study"),
    Column("session", "Int64", "id of the session in the study's log"),
    Column("task_index", "Int64", "index of the task within its session"),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True),
    Column("task_kind", "string", "the task's kind: pick_and_place, catch, stop_spin, send or handover", optional=True),
    Column("time_to_catch_s", "float64", "a catch's seconds from its first frame to the grasp that caught the "
           "object; empty unless a catch was completed", optional=True),
    Column("time_to_rest_s", "float64", "a stop of a spin's seconds from its first frame to the rest that "
           "completed it; empty unless a stop of a spin was completed", optional=True),
    Column("flipped", "boolean", "whether a stop of a spin's object turned over its spin axis (the "
           "intermediate-axis flip); empty for other kinds and for tasks not finished", optional=True),
    Column("send_error_m", "float64", "a send's closest approach to the target's centre of the drift's straight "
           "line (m; the last send's, for a task that ended without an arrival); empty for other kinds and before a "
           "first send", optional=True),
    Column("release_speed_error", "float64", "a send's release speed minus the speed that reaches the target in "
           "arrival_s (m/s; negative: too slow); empty for other kinds and before a first send", optional=True),
    Column("transfer_time_s", "float64", "a handover's seconds from the second hand's hold beginning to the first "
           "hand letting go (the last handover's; negative: the first let go that long before the second took "
           "it, within drop_grace_s); empty for other kinds and before a handover", optional=True),
    Column("both_held_s", "float64", "a handover's seconds during which both hands held the object; empty for "
           "other kinds", optional=True),
)

QUESTIONNAIRE = (
    Column("study", "string", "the study's name"),
    Column("participant", "string", "participant id, e.g. P01"),
    Column("group", "string", "the participant's group code"),
    Column("interaction", "string", "code of the interaction model the rating is about"),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True),
    Column("item", "string", "the questionnaire item, e.g. naturalness"),
    Column("rating", "Int64", "the rating on the 0-10 scale"),
    Column("source", "string", "who gave the rating: participant or model"),
    Column("simulated", "bool", "whether the rating comes from the rating model"),
    Column("withdrawn", "bool", "whether the participant withdrew from the study"),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True),
)

ANSWERS = (
    Column("study", "string", "the study's name"),
    Column("participant", "string", "participant id, e.g. P01"),
    Column("group", "string", "the participant's group code"),
    Column("instrument", "string", "the instrument's id: ssq, ipq, tlx, sus, paper or a study's own"),
    Column("administration", "string", "when it was asked, e.g. pre, post, after, end"),
    Column("interaction", "string", "code of the interaction model it is about; empty for none"),
    Column("interaction_label", "string", "the protocol's label for that interaction model, e.g. System 1",
           optional=True),
    Column("item", "string", "the item's id, e.g. ssq08, SP2, pair_mental_effort, sus10"),
    Column("value", "string", "the answer: a number on the item's scale, or the choice made"),
    Column("source", "string", "who answered: participant or model"),
    Column("response_time_s", "float64", "seconds from showing the item to the answer; empty for the model"),
    Column("t", "float64", "session-clock seconds when the answer was committed"),
    Column("simulated", "bool", "whether the answer comes from the rating model"),
    Column("withdrawn", "bool", "whether the participant withdrew from the study"),
    Column("station", "string", "the station that ran the session (microg study merge); empty for a session run "
           "in the study itself", optional=True),
)

TRIAL_COLUMNS = tuple(column.name for column in TRIALS)
QUESTIONNAIRE_COLUMNS = tuple(column.name for column in QUESTIONNAIRE)
ANSWER_COLUMNS = tuple(column.name for column in ANSWERS)
TRIAL_DTYPES = {column.name: column.dtype for column in TRIALS}
QUESTIONNAIRE_DTYPES = {column.name: column.dtype for column in QUESTIONNAIRE}
ANSWER_DTYPES = {column.name: column.dtype for column in ANSWERS}

KIND_MEASURES = {"pick_and_place": (), "catch": ("time_to_catch_s",), "stop_spin": ("time_to_rest_s", "flipped"),
                 "send": ("send_error_m", "release_speed_error"), "handover": ("transfer_time_s", "both_held_s")}
"""Each task kind's own measures in the trials table (``task_kind``), besides every task's ``time_s``
and ``attempts``: the analysis reads a kind's tasks with them (``microg.task.kinds.MEASURES`` names
the same columns for the export)."""
KIND_ATTEMPTS = {"pick_and_place": "drops", "catch": "touches that did not hold", "stop_spin": "drops",
                 "send": "misses", "handover": "drops"}
"""What a task kind's ``attempts`` count (``microg.task``'s rules)."""
PROPORTIONS = ("flipped",)
"""Measures that are yes or no per task: a participant's cell is the proportion of its tasks with yes."""
SIGNED = ("release_speed_error", "transfer_time_s")
"""Measures that may be negative: a difference from the right value; a handover whose first hand let
go before the other's grasp began (within ``drop_grace_s``: the object floated free between them)."""
