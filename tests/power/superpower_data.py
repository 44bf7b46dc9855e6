"""The effects the Superpower checks use (tests/power/r/nonspherical.toml), read by microg.power and
written as the tables tests/power/r/superpower.R reads."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from microg.paths import protocol_file
from microg.power import design_from_protocol, read_effects
from microg.study.protocol import load_protocol

R_DIR = Path(__file__).parent / "r"
EXPECTED = R_DIR / "expected"
NONSPHERICAL = R_DIR / "nonspherical.toml"


def paper_design():
    return design_from_protocol(load_protocol(protocol_file("paper")))


def export_effects(path: str | Path, folder: str | Path) -> None:
    """effects.csv (group, level, mean) and covariance.csv (group, a, b, value), in the design's order."""
    effects = read_effects(path, paper_design())
    d = effects.design
    means = [(g, level, effects.means[i, j]) for i, g in enumerate(d.groups) for j, level in enumerate(d.levels)]
    pairs = [(g, a, b, effects.covariances[i, j, m]) for i, g in enumerate(d.groups)
             for j, a in enumerate(d.levels) for m, b in enumerate(d.levels)]  # fmt: skip
    pd.DataFrame(means, columns=["group", "level", "mean"]).to_csv(Path(folder) / "effects.csv", index=False)
    pd.DataFrame(pairs, columns=["group", "a", "b", "value"]).to_csv(Path(folder) / "covariance.csv", index=False)
