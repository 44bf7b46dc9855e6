"""Numbers as journals print them, and the schema the analysis reads."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from microg import schema
from microg.analysis import analyse_study, check_trials
from microg.analysis.apa import (
    bounded,
    degrees,
    f_test,
    interval,
    number,
    p_cell,
    p_value,
    t_test,
)

P_VALUES = [(7.141e-08, "< .001"), (0.0009999, "< .001"), (0.001, "= .001"), (0.0234, "= .023"), (0.05, "= .050"),
            (0.9994, "= .999"), (0.99951, "> .999"), (1.0, "> .999")]  # fmt: skip


@pytest.mark.parametrize("p, text", P_VALUES)
def test_p_values(p, text):
    assert p_value(p) == text
    assert p_cell(p) == text.removeprefix("= ")


def test_rounding_noise_and_signs():
    assert number(-2.22e-16) == "0.00" and number(-0.004) == "0.00" and number(-0.006) == "-0.01"
    assert (
        bounded(0.6612) == ".66" and bounded(-0.2175) == "-.22" and bounded(1.0) == "1.00" and bounded(-1e-17) == ".00"
    )
    assert number(np.nan) == "" and p_value(np.nan) == "" and interval(np.nan, 1.0) == ""


def test_test_statistics():
    assert degrees(28) == "28" and degrees(31.5712) == "31.57"
    assert f_test(55.2817, 1.1275, 31.5712, 3e-9) == "F(1.13, 31.57) = 55.28, p < .001"
    assert t_test(-8.1, 27.0, 0.0123) == "t(27) = -8.10, p = .012"
    assert interval(-4.5219, -1.9) == "[-4.52, -1.90]" and interval(0.47, 0.758, bounded) == "[.47, .76]"


def test_the_analysis_reads_the_schema_names():
    """The defaults of the analysis are columns of the one schema (microg/schema.py)."""
    trial_names = set(schema.TRIAL_COLUMNS)
    defaults = {name: p.default for name, p in inspect.signature(analyse_study).parameters.items()
                if isinstance(p.default, str)}  # fmt: skip
    for role in ("subject", "group", "within", "interaction_column", "completed", "phase", "label"):
        assert defaults[role] in trial_names, role
    assert {defaults["item"], defaults["rating"], defaults["label"]} <= set(schema.QUESTIONNAIRE_COLUMNS)
    measures = inspect.signature(check_trials).parameters["dv"].default
    assert set(measures) <= trial_names
    assert all(column.description and column.dtype for column in (*schema.TRIALS, *schema.QUESTIONNAIRE))
    assert schema.TRIAL_DTYPES["time_s"] == "float64" and schema.TRIAL_DTYPES["attempts"] == "Int64"
