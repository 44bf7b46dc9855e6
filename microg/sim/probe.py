"""Single kernels of the step at a world's current state, without stepping: for tests and tools.

The step runs its kernels fused in one compiled call (``pipeline``); these run one of them over
every object of a world's ``Data`` (in place, as the step would), so a test can check what
contact detection, the impulse phase or the contact forces do at a state it set up by hand.
They take worlds of boxes and spheres (the kernels get no mesh objects, ``contact``).
"""

from __future__ import annotations

import numpy as np

from .bodies import SceneError
from .contact import apart, detect, hand_reach, out_of_reach, sweep
from .impulse import apply_impulses as _apply_impulses
from .penetration import friction_cone, penetration_forces
from .soft_hand import soft_hand_forces
from .state import OBJECT_COUNT, unpack, unpack_params
from .vec import entry, rotation


@entry
def _detect(params, ints, reals, flags, counts, anchored):
    n = ints[OBJECT_COUNT]
    p, s = unpack_params(params, ints, n), unpack(reals, flags, counts, n)
    for o in range(n):
        detect(p, s, o, rotation(s.orientation[o]), anchored, None)


@entry
def _find(params, ints, reals, flags, counts, anchored, swept, broad_phase):
    n = ints[OBJECT_COUNT]
    p, s = unpack_params(params, ints, n), unpack(reals, flags, counts, n)
    reach = hand_reach(s)
    skipped = np.zeros(n, dtype=np.bool_)
    for o in range(n):
        rot = rotation(s.orientation[o])
        if broad_phase and out_of_reach(p, s, o, reach):
            skipped[o] = True
            apart(s, o)
            continue
        if swept:
            sweep(p, s, o, rot, None)
        detect(p, s, o, rot, anchored, None)
    return skipped


@entry
def _impulses(params, ints, reals, flags, counts, springs):
    n = ints[OBJECT_COUNT]
    p, s = unpack_params(params, ints, n), unpack(reals, flags, counts, n)
    for o in range(n):
        _apply_impulses(p, s, o, rotation(s.orientation[o]), springs, p.dt)


@entry
def _forces(params, ints, reals, flags, counts, cone, penetration, soft_hand, friction, under_phalanx, h):
    n = ints[OBJECT_COUNT]
    p, s = unpack_params(params, ints, n), unpack(reals, flags, counts, n)
    wrenches = np.zeros((n, 6))
    stiffness, damping = np.zeros((6, 6)), np.zeros((6, 6))
    for o in range(n):
        rot = rotation(s.orientation[o])
        if cone:
            friction_cone(p, s, o, rot, None)
        if penetration:
            penetration_forces(p, s, o, rot, friction, wrenches[o], stiffness, h, None, under_phalanx)
        if soft_hand:
            soft_hand_forces(p, s, o, rot, friction, wrenches[o], stiffness, damping, h)
    return wrenches


def _analytic(model) -> None:
    if model.scene.has_meshes:
        raise SceneError("microg.sim.probe works on boxes and spheres; this world has mesh objects")


def detect_contacts(model, data) -> None:
    """Start, keep or end every phalanx-object contact at the current poses (Eqs. 2-8)."""
    _analytic(model)
    _detect(model.params, model.ints, data.reals, data.flags, data.counts, "soft_hand" not in model.effects)


def find_contacts(model, data, broad_phase: bool = True) -> np.ndarray:
    """The step's contact search at the current state, in place: continuous collision (when the
    model has it) and Eqs. 2-8 for every object, those out of every phalanx's reach left out as
    the step leaves them out (``contact.out_of_reach``) unless ``broad_phase`` is False. Returns
    (N,) which objects the broad phase left out."""
    _analytic(model)
    return _find(model.params, model.ints, data.reals, data.flags, data.counts, "soft_hand" not in model.effects,
                 "continuous_collision" in model.effects, broad_phase)


def apply_impulses(model, data) -> None:
    """The impulse phase (Eqs. 9-15) for the contacts marked as onsets."""
    _analytic(model)
    _impulses(model.params, model.ints, data.reals, data.flags, data.counts, "penetration" in model.effects)


def contact_forces(model, data) -> np.ndarray:
    """(N, 6) the force and torque on each object from its contacts, as the model's effects name
    them (friction cone, penetration springs or the soft hand), before the velocity update."""
    _analytic(model)
    effects = model.effects
    return _forces(model.params, model.ints, data.reals, data.flags, data.counts,
                   {"friction", "penetration"} <= effects, "penetration" in effects, "soft_hand" in effects,
                   "friction" in effects, "impulse" not in effects, model.dt)
