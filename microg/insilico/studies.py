"""Whole simulated studies, kept as their trials table (``simulate_trials``)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from microg.participant import Population
from microg.study.protocol import Protocol, protocol_from_resolved


def sized_protocol(protocol: Protocol, n_per_group: int) -> Protocol:
    """The protocol with every group of ``n_per_group`` participants."""
    resolved = dict(protocol.resolved)
    resolved["groups"] = [dict(group, size=n_per_group) for group in resolved["groups"]]
    resolved["participants"] = dict(resolved["participants"], total=n_per_group * len(resolved["groups"]))
    return protocol_from_resolved(resolved, f"{protocol.where} (resized to {n_per_group} per group)")


def simulate_trials(protocol: Protocol, n_per_group: int, seed: int, *,
                    population: Population | None = None) -> pd.DataFrame:
    """The trials table of one whole simulated study with ``n_per_group`` participants per group;
    every group's participants are drawn from ``population`` when given, else from each group's
    ``simulated_profile``. The same seed gives the same table."""
    from microg.study import Participant, SimulationClock, create_study, open_inputs, run_session, trials_table
    from microg.study.inputs import SimulatedInputs

    sized = sized_protocol(protocol, n_per_group)
    rng = np.random.default_rng(seed)
    youngest, oldest = sized.age_range or (18, 60)
    with tempfile.TemporaryDirectory(prefix="microg-insilico-") as folder, \
            create_study(Path(folder) / "study", sized, seed) as store:
        for number in range(sized.total_participants):
            store.add_participant(Participant(f"S{number + 1:03d}", ("female", "male")[number % 2],
                                              int(rng.integers(youngest, oldest + 1)), "right", True))
        for record in store.participants():
            inputs = (open_inputs("simulated", sized.group(record.group)) if population is None
                      else SimulatedInputs(f"simulated:{population.where}", population))
            session = store.create_session(record.participant.id, inputs.spec, inputs.simulated, inputs.clock)
            run_session(store, session.id, inputs, clock=SimulationClock())
        return trials_table(store)
