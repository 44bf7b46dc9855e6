"""Two run sets of the same tasks side by side: a study and its re-simulation under another model.

The same participants did the same tasks with the same hand motion (``microg session resimulate``):
per phase and object, how the tasks ended in each; per phase and measure, the paired comparison
(participant means over the objects completed in both, as the paper's Table 1 compares interaction models).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd

from .paired import compare_interactions
from .report import markdown_table
from .tables import read_trials

RUN_SET = "run_set"


def compare_run_sets(first: pd.DataFrame, second: pd.DataFrame, labels: tuple[str, str] = ("original", "re-simulated"),
                     measures: tuple[str, ...] = ("time_s", "attempts"), subject: str = "participant",
                     phase: str = "phase", within: str = "object", status: str = "status") -> dict[str, pd.DataFrame]:
    """Outcomes and paired tests of two run sets of the same tasks.

    Parameters
    ----------
    first, second : pandas.DataFrame
        Trials tables (one row per task) of the two run sets.
    labels : tuple of str
        Their names in the output; differences are second - first.
    measures, subject, phase, within, status : str
        Columns: the measures compared, the participant, the phase of the study (training, a
        block), the within factor (object) and how the task ended.

    Returns
    -------
    dict of pandas.DataFrame
        ``outcomes``: per phase, object and run set, how many tasks ended each way; ``tests``: per
        phase and measure, one row of :func:`microg.analysis.compare_interactions` (second against first).

    Examples
    --------
    >>> import pandas as pd
    >>> from microg.analysis.compare import compare_run_sets
    >>> a = pd.DataFrame({"participant": list("ppqqrr"), "phase": "s1", "object": list("CFCFCF"),
    ...                   "status": "completed", "time_s": [10., 12, 11, 13, 9, 14], "attempts": 0})
    >>> b = a.assign(time_s=a.time_s + [1., 2, 1, 3, 2, 2])
    >>> compare_run_sets(a, b, measures=("time_s",))["tests"][["phase", "n", "mean_diff"]]
      phase  n  mean_diff
    0    s1  3   1.833333
    """
    both = pd.concat([first.assign(**{RUN_SET: labels[0]}), second.assign(**{RUN_SET: labels[1]})],
                     ignore_index=True)
    outcomes = (both.groupby([phase, within, RUN_SET, status]).size().unstack(status, fill_value=0)
                .reset_index().rename(columns={phase: "phase"}))
    rows = []
    for name, part in both.groupby(phase, sort=False):
        for dv in measures:
            cells = part.dropna(subset=[dv]).groupby([subject, RUN_SET, within], as_index=False)[dv].mean()
            kept = cells.groupby([subject, within])[RUN_SET].transform("nunique") == 2
            cells = cells[kept]
            if cells[subject].nunique() < 2:
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                row = compare_interactions(cells, dv, labels[1], labels[0], within, subject, RUN_SET)
            rows.append(row.assign(phase=name))
    tests = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=["phase", "measure", "n"])
    tests = tests[["phase"] + [c for c in tests.columns if c != "phase"]]
    return {"outcomes": outcomes, "tests": tests}


def write_comparison(first, second, out_dir: str | Path, labels: tuple[str, str] = ("original", "re-simulated"),
                     **columns) -> Path:
    """``compare_run_sets`` of two trials tables (files or DataFrames) as comparison.md and CSVs."""
    first = first if isinstance(first, pd.DataFrame) else read_trials(first)
    second = second if isinstance(second, pd.DataFrame) else read_trials(second)
    result = compare_run_sets(first, second, labels, **columns)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    result["outcomes"].to_csv(out / "comparison_outcomes.csv", index=False)
    result["tests"].to_csv(out / "comparison_tests.csv", index=False)
    listed = ("phase", "measure", "n", "mean_baseline", "sd_baseline", "mean_interaction", "sd_interaction",
              "mean_diff", "diff_ci_low", "diff_ci_high", "p_t", "p_wilcoxon")
    shown = result["tests"][[c for c in listed if c in result["tests"].columns]].rename(columns={
        "mean_baseline": f"mean {labels[0]}", "sd_baseline": f"SD {labels[0]}",
        "mean_interaction": f"mean {labels[1]}", "sd_interaction": f"SD {labels[1]}", "mean_diff": "difference",
        "diff_ci_low": "95% CI low", "diff_ci_high": "95% CI high", "p_t": "p (paired t)",
        "p_wilcoxon": "p (Wilcoxon)"})
    text = "\n".join([
        f"# {labels[0]} and {labels[1]}, side by side", "",
        f"The same participants' tasks with the same hand motion. Differences are {labels[1]} - {labels[0]}, "
        "per participant over the objects completed in both run sets; a task that one run set did not "
        "complete drops out of its measures (the outcomes table counts them).", "",
        "## How the tasks ended", "", markdown_table(result["outcomes"]), "",
        "## Paired comparison", "", markdown_table(shown.round(3)) if len(shown) else
        "No measure was completed by at least two participants in both run sets.", ""])
    path = out / "comparison.md"
    path.write_text(text, encoding="utf-8")
    return path
