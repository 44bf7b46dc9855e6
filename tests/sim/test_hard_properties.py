"""Property-based hard cases: random contacts, poses, masses and time steps.

A hand that holds still does no work, so whatever the object runs into, its kinetic energy (plus
what the paper's springs hold, gamma delta^2 / 2 each) can only stay or fall; and nothing is NaN.
The first property allows what a contact found up to one step late may store; the second asks, at
every step from 1/60 s down, for no more than 1 % growth (contacts are taken as at their time of
impact, ``microg.sim.impulse``).
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from microg.skeleton import HandFrame
from microg.sim import Material, ObjectSpec, PlacedObject, kinetic_energy, step
from microg.sim.rotation import quat_normalize
from microg.participant.scripted import probe_hand
from tests.physics import world_of

pytestmark = pytest.mark.hard

TIPS = ("thumb.distal", "index.distal", "middle.distal", "ring.distal", "pinky.distal")


def spring_energy(world) -> float:
    """Energy stored in the active penetration springs: gamma delta^2 / 2 each (Eq. 16)."""
    data = world.data
    return 0.5 * world.model.penetration_stiffness * float((np.where(data.active, data.depth, 0.0) ** 2).sum())


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    size=st.tuples(*[st.floats(0.01, 0.2)] * 3),
    mass=st.floats(0.001, 10.0),
    restitution=st.floats(0.05, 0.95),
    quaternion=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
    velocity=st.tuples(*[st.floats(-1, 1)] * 3),
    spin=st.tuples(*[st.floats(-10, 10)] * 3),
    tips=st.lists(st.tuples(st.floats(0.02, 0.25), *[st.floats(-0.06, 0.06)] * 3), min_size=1, max_size=5),
    rate=st.sampled_from([60.0, 90.0, 110.0]),
    substeps=st.integers(1, 8),
    interaction=st.sampled_from(["impulse_penetration", "penetration_only"]),
)
def test_a_still_hand_never_adds_energy_and_nothing_becomes_nan(size, mass, restitution, quaternion, velocity, spin,
                                                                 tips, rate, substeps, interaction):
    # Physics steps of 1/240 s or finer (the default is 1/440 s). Coarser steps find an impact up
    # to v dt late: at 1/180 s a 1 kg bar hitting a fingertip at 0.9 m/s leaves 0.7 % faster than
    # it came, and at 1/60 s a 1 m/s impact on a 1.5 cm bar is found past its far side. The
    # benchmarks chart what such steps cost in accuracy.
    assume(rate * substeps >= 240)
    spec = ObjectSpec("box", "box", size, mass, Material(restitution, 0.8, 0.5))
    q = tuple(quat_normalize(np.asarray(quaternion, dtype=float)))
    world = world_of([PlacedObject(spec, (0.0, 0.0, 0.0), q, velocity, spin)], interaction=interaction,
                     tracking_rate=rate, substeps=substeps)
    # each tip waits where the drifting object will be after its own delay, give or take 6 cm
    hand = probe_hand({name: np.asarray(velocity) * delay + offset for name, (delay, *offset) in zip(TIPS, tips)})
    start = kinetic_energy(world)[0]
    # A contact is found up to one step late, so its spring may start up to v h deep, v the fastest a
    # point of the object moves: each can store gamma (v h)^2 / 2 that no motion paid for.
    fastest = np.linalg.norm(velocity) + np.linalg.norm(spin) * np.linalg.norm(size) / 2
    onset = len(tips) * 0.5 * world.model.penetration_stiffness * (fastest * world.model.dt) ** 2
    touched = False
    for t in np.arange(0.0, 0.3, 1.0 / rate):
        world = step(world, HandFrame(float(t), (hand,)))
        touched |= bool(world.data.active.any())
        assert np.isfinite(world.data.velocity).all() and np.isfinite(world.data.angular_velocity).all()
        assert np.isfinite(world.data.position).all() and np.isfinite(world.data.orientation).all()
        assert kinetic_energy(world)[0] + spring_energy(world) <= start * (1 + 1e-9) + onset + 1e-12
    event("contact" if touched else "no contact")


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    size=st.tuples(*[st.floats(0.01, 0.2)] * 3),
    log_mass=st.floats(-3.0, 1.0),
    restitution=st.floats(0.05, 0.95),
    quaternion=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
    velocity=st.tuples(*[st.floats(-1, 1)] * 3),
    spin=st.tuples(*[st.floats(-10, 10)] * 3),
    tips=st.lists(st.tuples(st.floats(0.02, 0.25), *[st.floats(-0.06, 0.06)] * 3), min_size=1, max_size=5),
    rate=st.floats(60.0, 120.0),
    substeps=st.sampled_from([1, 1, 1, 2, 4, 8]),
)
def test_at_any_step_from_one_sixtieth_down_a_still_hand_adds_at_most_one_percent(
        size, log_mass, restitution, quaternion, velocity, spin, tips, rate, substeps):
    # The paper's model at one physics step per frame at 60-120 Hz (dt from 1/60 s), or a few
    # substeps, masses 1 g to 10 kg spread evenly in log (the light ones are the hard ones): a 2.5 g
    # object gained 10 % at 1/79 s and a 15 g one 85 % at 1/64 s when a contact found late kept its
    # spring's energy. (The penetration-only baseline is left to the first property: see docs/physics.md.)
    spec = ObjectSpec("box", "box", size, 10.0 ** log_mass, Material(restitution, 0.8, 0.5))
    q = tuple(quat_normalize(np.asarray(quaternion, dtype=float)))
    world = world_of([PlacedObject(spec, (0.0, 0.0, 0.0), q, velocity, spin)], interaction="impulse_penetration",
                     tracking_rate=rate, substeps=substeps)
    hand = probe_hand({name: np.asarray(velocity) * delay + offset for name, (delay, *offset) in zip(TIPS, tips)})
    start = kinetic_energy(world)[0]
    touched = False
    for t in np.arange(0.0, 0.3, 1.0 / rate):
        world = step(world, HandFrame(float(t), (hand,)))
        touched |= bool(world.data.impulse.any() or world.data.active.any())
        assert np.isfinite(world.data.velocity).all() and np.isfinite(world.data.position).all()
        assert kinetic_energy(world)[0] + spring_energy(world) <= start * 1.01 + 1e-12
    event("contact" if touched else "no contact")
