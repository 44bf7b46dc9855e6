"""``microg bench accuracy --quick`` still runs end to end (keeps the benchmark code from rotting).

No timing is asserted: only that every metric was measured, finite, with a Pareto front, and the
chart was drawn. (Named ``test_hard*`` to sit with the hard suite it accompanies; not marked hard.)
"""

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from microg.cli import main

pytestmark = pytest.mark.slow


def test_quick_accuracy_benchmark_writes_every_metric_and_the_chart(tmp_path):
    result = CliRunner().invoke(main, ["bench", "accuracy", "--quick", "--out", str(tmp_path),
                                       "--figures", str(tmp_path)])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(tmp_path / "accuracy.csv")
    expected = {"restitution_error", "max_penetration", "L_drift", "E_drift", "omega_error", "slip", "lag",
                "tracking_rms"}
    assert set(table["metric"]) == expected
    assert np.isfinite(table["cost_us_per_s"]).all() and (table["cost_us_per_s"] > 0).all()
    assert table.groupby("metric")["pareto"].any().all()
    assert set(table["angular_integrator"]) == {"midpoint", "semi_implicit_euler", "explicit_euler"}
    # the conserving integrator keeps |L| where the Euler variants do not (independent: conservation)
    drift = table[table["metric"] == "L_drift"].groupby("angular_integrator")["error"].max()
    assert drift["midpoint"] < 1e-9 < drift["explicit_euler"]
    assert (tmp_path / "bench-accuracy.png").stat().st_size > 10_000
