"""The report of a study of several task kinds: each kind analysed apart with its own measures, a
proportion for the yes/no ``flipped``, a note where the design allows no ANOVA, and a study that
asks no questionnaire.

Data: make_study(seed=11) with its stage1 tasks made catches and its stage2 tasks stops of a spin,
their own measures drawn from a seeded generator."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from markupsafe import escape

from microg.analysis import AnalysisInputError, analyse_study, kinds_present
from microg.analysis.report import NO_QUESTIONNAIRE, write_report
from microg.study.export import kind_infos
from tests.analysis.study_data import make_study


@pytest.fixture(scope="module")
def kinds_trials() -> pd.DataFrame:
    trials, _ = make_study(11)
    rng = np.random.default_rng(3)
    kind = trials["phase"].map({"training": "pick_and_place", "stage1": "catch", "stage2": "stop_spin"})
    done = trials["completed"].astype(bool)
    catch, stop = done & (kind == "catch"), kind == "stop_spin"
    flips = rng.random(len(trials)) < 0.4
    return trials.assign(
        task_kind=kind,
        time_to_catch_s=(trials["time_s"] * 0.8).where(catch),
        time_to_rest_s=(trials["time_s"] * 0.7).where(done & stop),
        flipped=pd.Series(flips, dtype="boolean").where(stop.to_numpy()),
    )


KINDS = kind_infos()
"""The kinds as the export describes them to the report (the study's registry)."""


def test_the_report_reads_each_kinds_measures_as_the_export_writes_them():
    from microg.study.export import measure_declarations

    written = [column.name for column in measure_declarations()]
    assert written == [m.name for info in KINDS.values() for m in info.measures]
    assert {m.name for m in KINDS["stop_spin"].measures if m.proportion} == {"flipped"}


def test_each_kind_is_analysed_apart_with_its_own_measures(kinds_trials):
    assert kinds_present(kinds_trials) == ("catch", "stop_spin")
    catch = analyse_study(kinds_trials, kind="catch", kinds=KINDS)
    assert catch.measures == ("time_s", "attempts", "time_to_catch_s")
    assert catch.interactions == ("impulse_penetration",)
    assert ("impulse_penetration", "time_to_catch_s") in catch.analysed()
    stop = analyse_study(kinds_trials, kind="stop_spin", kinds=KINDS)
    assert ("soft_hand", "time_to_rest_s") in stop.analysed()
    assert ("soft_hand", "flipped") in stop.analysed()
    assert "flipped" not in set(stop.trial_models["measure"])  # a yes/no per task has no linear model


def test_flipped_is_the_proportion_of_every_task_with_a_value(kinds_trials):
    stop = analyse_study(kinds_trials, kind="stop_spin", kinds=KINDS)
    rows = kinds_trials[(kinds_trials["task_kind"] == "stop_spin") & kinds_trials["flipped"].notna()]
    expected = rows.groupby(["participant", "object"])["flipped"].mean().astype(float)
    cells = stop.table("cells", "soft_hand", "flipped").set_index(["participant", "object"])["value"]
    pd.testing.assert_series_equal(cells.sort_index(), expected.sort_index(), check_names=False)
    assert not rows["completed"].all()  # a stop of a spin that timed out counts too


def test_a_kind_of_one_group_is_described_with_a_note_not_an_error(kinds_trials):
    beginners = kinds_trials[kinds_trials["group"] == "B"]
    catch = analyse_study(beginners, kind="catch", kinds=KINDS)
    assert catch.analysed() == []
    assert any(note.startswith("No time_to_catch_s ANOVA") and "1 group(s)" in note for note in catch.warnings)
    described = catch.description.query("measure == 'time_to_catch_s'")
    assert list(described["group"]) == ["B"] * 3
    expected = beginners[beginners["task_kind"] == "catch"].groupby(["participant", "object"])["time_to_catch_s"]
    means = expected.mean().groupby("object").mean()
    np.testing.assert_allclose(described.set_index("object")["mean"], means)


def test_the_report_has_each_kind_and_says_there_is_no_questionnaire(kinds_trials, tmp_path):
    empty = pd.DataFrame(columns=["participant", "group", "interaction", "item", "rating"])
    write_report(kinds_trials, empty, tmp_path, kinds=KINDS)
    markdown = (tmp_path / "report.md").read_text()
    for text in ("### Catch", "### Stop of a spin", "Catch: Time to catch (s), impulse_penetration",
                 "Stop of a spin: Flipped (proportion of tasks), soft_hand", "time to rest (s)", NO_QUESTIONNAIRE):
        assert text in markdown, text
    assert str(escape(NO_QUESTIONNAIRE)) in (tmp_path / "report.html").read_text()
    for kind, measure in (("catch", "time_to_catch_s"), ("stop_spin", "flipped")):
        assert (tmp_path / kind / f"anova_{measure}.csv").exists()
        assert measure in set(pd.read_csv(tmp_path / kind / "description.csv")["measure"])
    assert not (tmp_path / "anova_time.csv").exists()  # no pick-and-place task is analysed


def _as_kind(trials, kind, **measures):
    """The stop-of-a-spin rows of ``trials`` as tasks of ``kind``, with ``measures`` (values for every
    row, kept on those rows only)."""
    rows = trials["task_kind"] == "stop_spin"
    return trials.assign(task_kind=trials["task_kind"].where(~rows, kind),
                         **{name: pd.Series(values).where(rows) for name, values in measures.items()})


def test_a_sends_release_speed_error_may_be_negative_and_is_analysed(kinds_trials):
    rng, n = np.random.default_rng(5), len(kinds_trials)
    trials = _as_kind(kinds_trials, "send", send_error_m=rng.uniform(0.0, 0.05, n),
                      release_speed_error=rng.normal(-0.02, 0.03, n))
    send = analyse_study(trials, kind="send", kinds=KINDS)
    assert send.measures == ("time_s", "attempts", "send_error_m", "release_speed_error")
    assert ("soft_hand", "release_speed_error") in send.analysed()
    assert (send.table("cells", "soft_hand", "release_speed_error")["value"] < 0).any()
    with pytest.raises(AnalysisInputError, match="is negative"):
        analyse_study(trials.assign(time_s=-trials["time_s"]), kind="send", kinds=KINDS)  # other measures stay non-negative


def test_a_handovers_transfer_time_may_be_negative_and_is_analysed(kinds_trials):
    """A toss within the drop grace has a negative transfer time (the first hand let go first)."""
    rng, n = np.random.default_rng(6), len(kinds_trials)
    trials = _as_kind(kinds_trials, "handover", transfer_time_s=rng.normal(0.1, 0.2, n),
                      both_held_s=rng.uniform(0.2, 1.0, n))
    handover = analyse_study(trials, kind="handover", kinds=KINDS)
    assert (handover.table("cells", "soft_hand", "transfer_time_s")["value"] < 0).any()
    with pytest.raises(AnalysisInputError, match="is negative"):
        analyse_study(trials.assign(both_held_s=-trials["both_held_s"]), kind="handover", kinds=KINDS)
