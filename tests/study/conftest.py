"""Shared set-up for the study tests: small studies and scripted participants."""

from __future__ import annotations

from pathlib import Path

import pytest

from microg.study.assignment import Participant
from microg.study.inputs import ScriptedInputs
from microg.study.protocol import load_protocol
from microg.study.questionnaire import TerminalRater
from microg.study.store import create_study

from .scripted import ScriptedPinch, pinch_keyframes

PROTOCOLS = Path(__file__).parent / "protocols"


def scripted_inputs(**script) -> ScriptedInputs:
    """Every task played by a scripted pinch (keyword arguments go to ``pinch_keyframes``);
    the sources it made are kept in ``.made``."""
    made = []

    def make(plan, seed):
        made.append(ScriptedPinch(pinch_keyframes(plan, **script)))
        return made[-1]

    inputs = ScriptedInputs(make)
    inputs.made = made
    return inputs


def answers(*lines) -> TerminalRater:
    """A rater that gives ``lines`` as a participant's typed answers."""
    feed = iter(lines)
    return TerminalRater(read=lambda prompt: next(feed), write=lambda text: None)


@pytest.fixture
def make_study(tmp_path):
    """``make_study(protocol_name, gender=...)``: a study with one participant P01; returns (store, record)."""
    stores = []

    def make(protocol: str = "tiny", gender: str = "female", seed: int = 1):
        store = create_study(tmp_path / f"study-{len(stores)}", load_protocol(PROTOCOLS / f"{protocol}.toml"), seed)
        stores.append(store)
        return store, store.add_participant(Participant("P01", gender, 24, "right", True))

    yield make
    for store in stores:
        store.close()
