"""Mesh objects in a study: the shipped mallet protocol (protocols/mallet-microgravity.toml) runs a
task with the scripted pinch like the shipped cuboids, and a study keeps the mesh file with its
protocol, so it opens again where the file is gone."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from microg.paths import PROTOCOLS
from microg.study.protocol import load_protocol, protocol_from_resolved

from .test_session import one_task


def test_the_shipped_mallet_protocol_names_a_mesh_object():
    protocol = load_protocol(PROTOCOLS / "mallet-microgravity.toml")
    (mallet,) = protocol.objects
    assert mallet.spec.shape == "mesh" and len(mallet.spec.mesh.parts) >= 2  # a T: not convex
    assert mallet.spec.mass == pytest.approx(700.0 * mallet.spec.mesh.volume)


def test_a_scripted_pinch_carries_the_mallet_through_the_places(make_study):
    store, _ = make_study("quick-mallet")
    result, run_id, _ = one_task(store)
    assert result.status == "completed" and result.attempts == 0
    kinds = [e.kind for e in store.events(store.session_of("P01").id, run_id)]
    assert kinds.count("place_done") == len(store.protocol.task.places)


def test_a_study_keeps_the_mesh_with_its_protocol(tmp_path):
    folder = tmp_path / "protocols"
    shutil.copytree(PROTOCOLS, folder)
    protocol = load_protocol(folder / "mallet-microgravity.toml")
    shutil.rmtree(folder)
    again = protocol_from_resolved(protocol.resolved, "study.sqlite")
    original, kept = protocol.objects[0].spec, again.objects[0].spec
    assert np.array_equal(kept.mesh.vertices, original.mesh.vertices) and kept.mass == original.mass
