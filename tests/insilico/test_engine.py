"""An in-silico study played batched in compiled code against the same study run by the session runner."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from microg.insilico.studies import play_sessions, simulate_trials, sized_protocol
from microg.paths import protocol_file
from microg.study import Participant, SimulationClock, create_study, open_inputs, run_session, trials_table
from microg.study.protocol import load_protocol

PROTOCOLS = Path(__file__).resolve().parents[1] / "study" / "protocols"


def study_trials(folder: Path, protocol, seed: int, batched: bool) -> pd.DataFrame:
    """The trials table of a study of ``protocol`` (its groups as sized), its sessions run by the
    session runner (every frame logged) or played batched (nothing logged)."""
    rng = np.random.default_rng(seed)
    with create_study(folder, protocol, seed) as store:
        for number in range(protocol.total_participants):
            store.add_participant(Participant(f"S{number + 1:03d}", ("female", "male")[number % 2],
                                              int(rng.integers(18, 31)), ("right", "left")[number % 3 == 2], True))
        inputs = {record.participant.id: open_inputs("simulated", protocol.group(record.group))
                  for record in store.participants()}
        for _ in protocol.sessions:  # a training program's sessions in turn, on the simulated calendar
            for pid, source in inputs.items():
                store.create_session(pid, input_spec=source.spec, simulated=source.simulated, clock=source.clock)
            if batched:
                play_sessions(store, lambda session: inputs[session.participant_id])
            else:
                for pid, source in inputs.items():
                    run_session(store, store.session_of(pid).id, source, clock=SimulationClock())
        return trials_table(store).drop(columns=["study"])


@pytest.mark.slow
@pytest.mark.parametrize("protocol", [PROTOCOLS / "tiny.toml", protocol_file("paper"), PROTOCOLS / "kinds-simulated.toml",
                                      PROTOCOLS / "send.toml", PROTOCOLS / "handover.toml", PROTOCOLS / "program-toy.toml"],
                         ids=["tiny", "paper", "kinds", "send", "handover", "program"])
def test_a_batched_in_silico_study_gives_the_trials_table_of_the_logged_sessions(tmp_path, protocol):
    """One frame path run two ways: the same seeds, the same table. Every task's status, completion
    time, attempts, its kind's measures, and its start and end on the session's clock, to the last
    bit (a left-handed participant among them), for every kind of task; and a training program's
    sessions, whose phases trained to a criterion plan each task from the runs before it (the task's
    place in the phase, its staircase difficulty, when the criterion was met)."""
    sized = sized_protocol(load_protocol(protocol), 2)
    logged = study_trials(tmp_path / "logged", sized, 7, batched=False)
    batched = study_trials(tmp_path / "batched", sized, 7, batched=True)
    assert logged["completed"].any()
    pd.testing.assert_frame_equal(batched, logged, check_exact=True)


@pytest.mark.slow
def test_a_study_shared_out_to_worker_processes_gives_the_table_of_one_process():
    """Tasks dealt out to two forked workers (after the compiled code is loaded in this process, which
    they inherit) come back to the same table as when one process plays them all."""
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    one = simulate_trials(protocol, 2, 11, workers=1)
    two = simulate_trials(protocol, 2, 11, workers=2)
    assert len(one) > 4 and one["completed"].any()
    pd.testing.assert_frame_equal(two.drop(columns=["study"]), one.drop(columns=["study"]), check_exact=True)
