"""An in-silico study cut after the phases a calibration asks about."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from microg.insilico.studies import protocol_through, simulate_trials
from microg.insilico.summaries import Statistic
from microg.study.protocol import load_protocol, protocol_from_resolved

TINY = Path(__file__).resolve().parents[1] / "study" / "protocols" / "tiny.toml"


def test_a_study_cut_after_the_phases_asked_about_plays_them_as_the_whole_study_does():
    """Numbers about the first phase's interaction model need neither the second phase nor the
    questionnaire; the phases kept are played to the last bit as in the whole protocol (a
    simulated participant does not know what comes later)."""
    protocol = load_protocol(TINY)
    first, second = protocol.phases
    asked = [Statistic("time_s", "mean", (("interaction", first.interaction),))]
    cut = protocol_through(protocol, asked)
    assert [p.name for p in cut.phases] == [first.name]
    assert second.name not in [p.name for p in cut.timeline] and not any(p.instruments for p in cut.timeline)
    assert protocol_through(protocol, asked + [Statistic("time_s", "mean", (("phase", second.name),))]) is protocol
    assert protocol_through(protocol, [Statistic("attempts", "slope", (("group", "B"),))]) is protocol
    resolved = dict(protocol.resolved)  # the timeline plays the second phase first: nothing can be cut
    timeline = list(resolved["timeline"])
    i, j = (next(k for k, entry in enumerate(timeline) if entry.get("phase") == p.name) for p in (first, second))
    timeline[i], timeline[j] = timeline[j], timeline[i]
    swapped = protocol_from_resolved(dict(resolved, timeline=timeline), "swapped")
    assert protocol_through(swapped, asked) is swapped

    whole = simulate_trials(protocol, 2, 11)
    part = simulate_trials(cut, 2, 11)
    kept = whole[whole["phase"] != second.name].reset_index(drop=True)
    assert len(part) == len(kept) and kept["completed"].any()
    pd.testing.assert_frame_equal(part.drop(columns=["study"]), kept.drop(columns=["study"]), check_exact=True)
