"""In-silico power: whole simulated studies through the physics, one Dask task each (a cut-down
protocol, 2 participants per group, 2 studies, every participant drawn from the population file
``--profile`` names), and the first study rerun here from its seed and that population and analysed
with the report's own functions gives the same p values."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.analysis import mixed_anova, posthoc, sphericity_correction
from microg.cli import main
from microg.power import design_from_protocol
from microg.insilico import simulate_trials
from microg.participant import read_population
from microg.paths import PROTOCOLS
from microg.study.protocol import load_protocol

QUICK = Path(__file__).parent / "quick.toml"
PROFILE = PROTOCOLS / "populations" / "literature.toml"
"""Not the protocol's own population (the default): the studies must come from this one."""


@pytest.mark.slow
@pytest.mark.timeout(3600)  # two whole studies on a shared 2-core machine; the test waits on the run, not a clock
def test_simulated_studies_on_a_local_cluster(tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["power", "--simulated", "--protocol", str(QUICK), "--n", "2", "--sims", "2",
                                       "--seed", "5", "--workers", "2", "--profile", str(PROFILE),
                                       "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"simulated studies of {PROFILE}" in result.output
    protocol = load_protocol(QUICK)
    design = design_from_protocol(protocol)
    rows = pd.read_csv(out / "simulations.csv")
    assert sorted(rows["sim"].unique()) == [0, 1] and len(rows) == 2 * len(design.tests)
    power = pd.read_csv(out / "power.csv")
    assert list(power["term"]) == list(design.tests) and set(power["power"]) <= {0.0, 0.5, 1.0}
    assert (power["method"] == "montecarlo").all()

    seed = int(np.random.SeedSequence(5, spawn_key=(2, 0)).generate_state(1)[0])
    trials = simulate_trials(protocol, 2, seed, population=read_population(PROFILE))
    assert trials["simulated"].all() and trials["participant"].nunique() == 4
    names = {o.code: o.name for o in protocol.objects}
    groups = {g.code: g.name for g in protocol.groups}
    stage1 = trials[(trials["phase"] == "stage1") & trials["completed"]]
    cells = pd.DataFrame({"participant": stage1["participant"], "group": stage1["group"].map(groups),
                          "object": stage1["object"].map(names), "value": stage1["time_s"].astype(float)})  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        anova = sphericity_correction(mixed_anova(cells, "value", "object", "group", "participant"))
        post = posthoc(cells, "value", "object", "group", "participant", within_by_group=True)
    first = rows[rows["sim"] == 0].set_index("term")["p"]
    assert np.allclose(first[list(design.terms)], anova["p"], atol=1e-9)
    assert np.isclose(first["cube - flat_cuboid"], post.loc[post["at"].isna(), "p_bonf"].iloc[0], atol=1e-9)

    again = CliRunner().invoke(main, ["power", "--simulated", "--protocol", str(QUICK), "--n", "2", "--sims", "3",
                                      "--seed", "5", "--resume", "--out", str(out)])  # fmt: skip
    assert again.exit_code == 1 and "literature.toml" in again.output  # not resumed with another population
    assert "resumes only with the same settings" in again.output
