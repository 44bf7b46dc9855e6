"""One trainee's page of a training program: their learning curve against the criterion and the band
of their group, their sessions and phases with the tasks to criterion, and what is due next.

``trainee_summary`` is the page's table (tidy in, tidy out); ``write_trainee_page`` writes the page,
a self-contained HTML file with its figure and table beside it.
"""

from __future__ import annotations

import base64
from pathlib import Path

import jinja2
import pandas as pd

from microg.analysis.figures import plot_trainee, save_figure
from microg.analysis.tables import AnalysisInputError
from microg.analysis.training import PRACTICE, add_practice, cohort_band

TRAINEE_COLUMNS = ("session", "session_date", "phase", "tasks", "completed", "median_time_s", "criterion_met",
                   "tasks_to_criterion")
PAGE = jinja2.Template("""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{{ title }}</title>
<style>body{font-family:system-ui,sans-serif;max-width:56rem;margin:2rem auto;padding:0 1rem;color:#222}
table{border-collapse:collapse}td,th{padding:.2rem .6rem;border-bottom:1px solid #ddd;text-align:left}
.next{font-size:1.1rem;background:#eef4fb;padding:.6rem 1rem;border-radius:.3rem}img{max-width:100%}</style>
</head><body>
<h1>{{ title }}</h1>
{% if next %}<p class="next">Next: {{ next }}</p>{% endif %}
{% if simulated %}<p><em>Simulated data: these tasks come from a simulated participant (a motor model), not a
person.</em></p>{% endif %}
<figure><img alt="learning curve" src="data:image/png;base64,{{ figure }}">
<figcaption>Completion time of each completed {{ kind }}task against the tasks done so far (all sessions), one colour
per session; the grey band is {{ group }}'s 10-90 % range and median at that practice{% if criterion %}, the
dashed line the training criterion's time limit ({{ criterion }} s){% endif %}.</figcaption></figure>
<h2>Sessions</h2>
{{ table }}
</body></html>
""")


def trainee_summary(trials: pd.DataFrame, participant: str, subject: str = "participant") -> pd.DataFrame:
    """The trainee's sessions and phases in order: when, tasks done and completed, the median time of
    the completed ones, and for a phase with a criterion whether and at which task it was met.

    Parameters
    ----------
    trials : pandas.DataFrame
        The exported trials (columns session, session_index, session_date, phase, task_in_phase,
        completed, time_s, attempts, criterion_met).
    participant : str
        The trainee's id in ``subject``.

    Returns
    -------
    pandas.DataFrame
        Columns ``session, session_date, phase, tasks, completed, median_time_s, criterion_met,
        tasks_to_criterion``.

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.trainee import trainee_summary
    >>> trials = pd.DataFrame({"participant": "T1", "session": ["pre", "t1", "t1"], "session_index": [1, 2, 2],
    ...     "session_date": ["2026-01-01", "2026-01-02", "2026-01-02"], "phase": ["test", "train", "train"],
    ...     "task_in_phase": [1, 1, 2], "completed": True, "time_s": [50.0, 40.0, 30.0], "attempts": 0,
    ...     "criterion_met": [None, False, True]})
    >>> trainee_summary(trials, "T1")[["session", "tasks", "median_time_s", "tasks_to_criterion"]]
      session  tasks  median_time_s  tasks_to_criterion
    0     pre      1           50.0                <NA>
    1      t1      2           35.0                   2
    """
    mine = trials[trials[subject] == participant]
    if mine.empty:
        raise AnalysisInputError(f"trials table: {subject} {participant!r}: no such participant (participants: "
                                 f"{', '.join(map(str, trials[subject].unique()))})")
    rows = []
    for (_, session, date, phase), part in mine.groupby(["session_index", "session", "session_date", "phase"],
                                                        sort=True):
        trained = part["criterion_met"].notna().any()
        met = part.loc[part["criterion_met"].fillna(False).astype(bool), "task_in_phase"]
        done = part[part["completed"].astype(bool)]
        rows.append((session, date, phase, int(part["attempts"].notna().sum()), len(done),
                     done["time_s"].median() if len(done) else None, bool(len(met)) if trained else None,
                     int(met.min()) if len(met) else None))
    table = pd.DataFrame(rows, columns=list(TRAINEE_COLUMNS))
    return table.astype({"tasks": "Int64", "completed": "Int64", "median_time_s": "float64",
                         "criterion_met": "boolean", "tasks_to_criterion": "Int64"})


def write_trainee_page(trials: pd.DataFrame, participant: str, out_dir: str | Path, *, next_session: str = "",
                       criterion_s: float | None = None, subject: str = "participant",
                       group: str = "group") -> Path:
    """Write ``OUT/trainee-ID.html`` (self-contained), with ``trainee-ID.csv`` (``trainee_summary``) and
    the figure as PNG and SVG beside it; ``next_session``: what is due next, as said to the trainee;
    ``criterion_s``: the training criterion's time limit, drawn as a line. Returns the page's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = trainee_summary(trials, participant, subject)
    practised = add_practice(trials, subject=subject)
    if "task_kind" in practised.columns:  # the curve of the kind the trainee did most (other kinds' times differ)
        kind = practised.loc[practised[subject] == participant, "task_kind"].mode().iloc[0]
        practised = practised[practised["task_kind"] == kind]
    mine = practised[practised[subject] == participant]
    their_group = mine[group].iloc[0]
    done = practised[practised[group] == their_group]
    band = cohort_band(done.assign(time_s=done["time_s"].where(done["completed"].astype(bool))), group=group)
    fig = plot_trainee(mine.assign(time_s=mine["time_s"].where(mine["completed"].astype(bool))), band,
                       practice=PRACTICE, criterion=criterion_s, ylabel="completion time (s)")
    png, _ = save_figure(fig, out / f"trainee-{participant}")
    summary.to_csv(out / f"trainee-{participant}.csv", index=False)
    page = out / f"trainee-{participant}.html"
    page.write_text(PAGE.render(
        title=f"Training progress of {participant} (group {their_group})", next=next_session,
        simulated=bool(mine.get("simulated", pd.Series(dtype=bool)).any()), group=f"group {their_group}",
        criterion=None if criterion_s is None else f"{criterion_s:g}",
        kind=f"{kind} " if "task_kind" in practised.columns else "",
        figure=base64.b64encode(png.read_bytes()).decode("ascii"),
        table=summary.to_html(index=False, na_rep="", border=0)), encoding="utf-8")
    return page
