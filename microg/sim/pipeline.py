"""The physics step, compiled for a scene's effects: one compiled call per frame for a whole batch.

``specialise(effects)`` returns the compiled ``step`` of one world: it takes the hand frame
(``hand_path.take_hands``), then runs as many physics steps of ``dt`` as fit up to the frame's
timestamp; ``step_worlds`` runs it for each world of a batch. A step moves the hand, then runs for each object, with its rotation computed
once, the paper's sequence: contacts (Eqs. 2-8), impulses at the onsets (Eqs. 9-15), the friction
cone (Eqs. 19-20), the penetration springs (Eqs. 16-18), the compliant contacts, gravity, the
velocity update and the pose update. Objects never touch each other, so one object's step needs
nothing of another's. An object that no phalanx can reach this step (the box around the hand's
phalanges, now and a step ago, against the object's bounding sphere and its motion:
``contact.out_of_reach``) skips the contact search, which would find nothing there: the broad
phase, which changes no result (``tests/sim/test_broad_phase.py``).

The effects are compile-time constants of ``step`` (its closure): numba prunes the branches of
the effects a scene does not name before it types the function, so their kernels are not in the
machine code at all (``tests/sim/test_composition.py`` reads the compiled code to check it).
The mesh kernels (``mesh_contact``) are compiled in the same way only for a scene with a mesh object.
Each set of effects compiles once and is cached on disk (``microg.skeleton.cache``).

A step in which an object would turn more than ``MAX_TURN`` is cut into as many parts as that
takes (a hard impact can spin a light bar to hundreds of rad/s, which a contact linearised over a
whole step would no longer follow); almost always it is one. In the baselines, whose contact springs
take a bounce over several steps, a step is cut too where a spring on a light object would swing
through more than ``MAX_SWING`` of its oscillation in one (docs/physics.md, "The baselines at
coarse steps"); the paper's model takes a bounce by its impulse and is not cut for its springs.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .bodies import MESH
from .compiled import specialised
from .contact import apart, closest_surface_point, detect, hand_reach, out_of_reach, sweep
from .hand_path import move_hand, take_hands
from .impulse import apply_impulses, spring_onsets
from .integrate import add_gravity, rotate_constant, rotate_free, update_position, update_velocity
from .penetration import friction_cone, penetration_forces
from .soft_hand import soft_hand_forces
from .state import (CLOCK_DRIFT, CLOCK_FRAME, CLOCK_PREVIOUS_FRAME, CLOCK_START, CLOCK_TIME, COUNT_FRAMES, COUNT_STEPS,
                    OBJECT_COUNT, unpack, unpack_mesh, unpack_params)
from .table import table_contacts
from .vec import add, cell, kernel, mat_t_vec, norm, rotation, row, scale, sub

CONTACT_EFFECTS = frozenset({"impulse", "penetration", "soft_hand"})
MAX_TURN = 0.1
"""rad: the most an object may turn in one physics step; faster spins cut the step into parts."""
MAX_PARTS = 64
MAX_SWING = 1.0
"""rad: the most of its oscillation (w h) a contact spring of a baseline may swing through in one
physics step; stiffer contacts on lighter objects cut the step into parts."""


@kernel
def start_frame(s, t):
    """Note the frame's time; returns the interval since the frame before (0 for the first)."""
    if s.counter[COUNT_FRAMES] == 0:
        s.clock[CLOCK_START] = s.clock[CLOCK_TIME] = s.clock[CLOCK_PREVIOUS_FRAME] = t
    else:
        s.clock[CLOCK_PREVIOUS_FRAME] = s.clock[CLOCK_FRAME]
    s.clock[CLOCK_FRAME] = t
    s.counter[COUNT_FRAMES] += 1
    return s.clock[CLOCK_FRAME] - s.clock[CLOCK_PREVIOUS_FRAME]


@kernel
def steps_due(s, h):
    """How many physics steps of h fit between the first frame and this one."""
    return math.floor((s.clock[CLOCK_FRAME] - s.clock[CLOCK_START]) / h + 1e-9)


@kernel
def parts_of_step(p, s, h, stiffness):
    """Into how many parts this step is cut so that no object turns more than ``MAX_TURN`` in one,
    and, for contact springs of ``stiffness`` (N/m; 0: not cut for them), none swings through more
    than ``MAX_SWING`` of its oscillation."""
    fastest, stiffest = 0.0, 0.0
    for o in range(s.angular_velocity.shape[0]):
        w = s.angular_velocity[o]
        fastest = max(fastest, w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        if stiffness > 0.0:
            stiffest = max(stiffest, stiffness * contact_compliance(p, s, o, h))
    return min(MAX_PARTS, max(1, math.ceil(math.sqrt(fastest) * h / MAX_TURN),
                              math.ceil(math.sqrt(stiffest) * h / MAX_SWING)))


@kernel
def arm_compliance(p, o, r, margin):
    """An upper bound on n^T K n (Eq. 12) in any direction n for a contact at body-frame offset r
    (give or take ``margin``) on object o: 1/m plus the trace of [r]x^T I^-1 [r]x, the sum over the
    principal axes of (distance of r from the axis)^2 / I."""
    total = 1.0 / p.mass[o]
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        off_axis = math.sqrt(r[j] * r[j] + r[k] * r[k]) + margin
        total += off_axis * off_axis / p.inertia[o, i]
    return total


@kernel
def contact_compliance(p, s, o, h):
    """An upper bound on the sum of n^T K n over the contacts object o has, or may start within a
    step of h (a phalanx within reach of its surface): times a spring's stiffness,
    the square of the fastest oscillation they can set up. A contact's arm is its god-object
    phalanx's centre; a phalanx not in contact counts when the step could close its gap to the
    object's surface (a mesh's: its bounding sphere), taken anywhere within its radius of its centre."""
    rot = rotation(s.orientation[o])
    bound = norm(row(p.half_size, o)) * (2.0 if p.shape[o] == MESH else 1.0)  # a mesh's centre is anywhere in its box
    reach = h * (norm(row(s.velocity, o)) + norm(row(s.angular_velocity, o)) * bound)
    total = 0.0
    for k in range(s.active.shape[0]):
        if not s.valid[k] or s.ghost[k, o]:
            continue
        if s.active[k, o]:
            total += arm_compliance(p, o, add(cell(s.anchor, k, o), scale(s.radius[k], cell(s.normal, k, o))), 0.0)
            continue
        local = mat_t_vec(rot, sub(row(s.hand_position, k), row(s.position, o)))
        gap = norm(local) - bound if p.shape[o] == MESH else closest_surface_point(p.shape[o], row(p.half_size, o),
                                                                                    local)[2]
        if gap - s.radius[k] <= reach + h * norm(row(s.hand_velocity, k)):
            total += arm_compliance(p, o, local, s.radius[k])
    return total


@kernel
def end_part(s, h):
    for k in range(s.fresh.shape[0]):
        s.fresh[k] = False
    s.clock[CLOCK_TIME] += h
    s.clock[CLOCK_DRIFT] = h


@kernel
def end_step(s, h):
    s.counter[COUNT_STEPS] += 1
    s.clock[CLOCK_TIME] = s.clock[CLOCK_START] + s.counter[COUNT_STEPS] * h


@lru_cache(maxsize=None)
def specialise(effects: frozenset[str], meshes: bool = False):
    """The compiled ``step(params, ints, reals, flags, counts, frame)`` of one world to one hand
    frame (a ``microg.skeleton.HANDS`` record) for exactly these effects (module docstring), and
    for mesh objects when ``meshes``: only then are the mesh kernels compiled in (the contact
    kernels get None for the meshes otherwise, see ``contact``). A kernel: compiled into its
    callers (the frame path, ``step_worlds``)."""
    contacts = bool(effects & CONTACT_EFFECTS)
    swept = "continuous_collision" in effects
    anchored = "soft_hand" not in effects
    impulse = "impulse" in effects
    friction = "friction" in effects
    cone = friction and "penetration" in effects
    penetration = "penetration" in effects
    soft_hand = "soft_hand" in effects
    gravity = "gravity" in effects
    table = "table" in effects
    gyroscopic = "gyroscopic" in effects

    @kernel
    def step(params, ints, reals, flags, counts, frame):
        n = ints[OBJECT_COUNT]
        p = unpack_params(params, ints, n)
        mesh = unpack_mesh(params, ints, n) if meshes else None
        # the contact springs a step is cut for: a model's without the impulse phase (the baselines)
        springs = p.soft_stiffness if soft_hand else p.penetration_stiffness if penetration and not impulse else 0.0
        wrench, stiffness, damping = np.zeros(6), np.zeros((6, 6)), np.zeros((6, 6))
        s = unpack(reals, flags, counts, n)
        interval = start_frame(s, frame.t)
        take_hands(p, s, frame.present, frame.track_id, frame.points, frame.widths, interval)  # phalanges (3.2)
        due = steps_due(s, p.dt)
        while s.counter[COUNT_STEPS] < due:
            parts = parts_of_step(p, s, p.dt, springs)
            h = p.dt / parts
            for _ in range(parts):
                move_hand(s, s.clock[CLOCK_PREVIOUS_FRAME], s.clock[CLOCK_FRAME], s.clock[CLOCK_TIME], h)
                if contacts:
                    reach = hand_reach(s)
                for o in range(n):
                    rot = rotation(s.orientation[o])
                    if contacts:
                        if out_of_reach(p, s, o, reach):                     # broad phase
                            apart(s, o)
                        else:
                            if swept:
                                sweep(p, s, o, rot, mesh)                    # continuous collision
                            detect(p, s, o, rot, anchored, mesh)             # contacts, Eqs. 2-8
                    if impulse:
                        if apply_impulses(p, s, o, rot, penetration, h):     # impulse phase, Eqs. 9-15
                            rot = rotation(s.orientation[o])
                    elif penetration:
                        if spring_onsets(p, s, o, rot, h):
                            rot = rotation(s.orientation[o])
                    if cone:
                        friction_cone(p, s, o, rot, mesh)                    # friction cone, Eqs. 19-20
                    if penetration:
                        penetration_forces(p, s, o, rot, friction, wrench, stiffness, h, mesh,
                                           not impulse)                      # penetration phase, Eqs. 16-18
                    if soft_hand:
                        soft_hand_forces(p, s, o, rot, friction, wrench, stiffness, damping, h)
                    if gravity:
                        add_gravity(p, o, wrench)
                    if table:
                        table_contacts(p, s, o, rot, wrench, stiffness, damping, h, mesh)
                    update_velocity(p, s, o, rot, wrench, stiffness, damping, h)
                    update_position(s, o, h)
                    if gyroscopic:
                        rotate_free(p, s, o, h)
                    else:
                        rotate_constant(s, o, h)
                end_part(s, h)
            end_step(s, p.dt)

    return step


_STEP_WORLDS = """
def {name}(params, ints, reals, flags, counts, frames):
    for world in range(reals.shape[0]):
        {step}(params, ints, reals[world], flags[world], counts[world], frames[world])
"""


@lru_cache(maxsize=None)
def step_worlds(effects: frozenset[str], meshes: bool = False):
    """The compiled ``step_worlds(params, ints, reals, flags, counts, frames)``: ``specialise``'s step
    for each world of a batch (buffers with a leading world axis, one ``HANDS`` record each)."""
    key = "_".join(sorted(effects)) + ("_meshes" if meshes else "")
    return specialised(_STEP_WORLDS, f"step_worlds_{key}", {"step": specialise(effects, meshes)}, __file__, globals())
