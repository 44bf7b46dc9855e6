"""Property-based hard cases: random contacts, poses, masses and time steps.

A hand that holds still does no work, so whatever the object runs into, its kinetic energy (plus
what the paper's springs hold, gamma delta^2 / 2 each) can only stay or fall; and nothing is NaN.
The first property allows what a contact found up to one step late may store; the second asks, at
every step from 1/60 s down, for no more than 1 % growth, of the paper's model (contacts are taken
as at their time of impact, ``microg.sim.impulse``) and of both baselines (their steps are cut by
their contacts' frequency, ``microg.sim.pipeline``).
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
    """Energy stored in the active contact springs: gamma delta^2 / 2 each (Eq. 16), or the soft
    hand's k delta^2 / 2. A contact whose phalanx has left its face's plane (delta <= 0) presses
    nothing and holds nothing (``penetration_forces``)."""
    data, model = world.data, world.model
    stiffness = model.soft_stiffness if "soft_hand" in model.effects else model.penetration_stiffness
    return 0.5 * stiffness * float((np.where(data.active, np.maximum(data.depth, 0.0), 0.0) ** 2).sum())


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


def still_hand_energy(size, mass, restitution, quaternion, velocity, spin, tips, rate, substeps,
                      interaction) -> tuple[float, float, bool]:
    """A drifting box against still fingertips (each waits where the box will be after its own
    delay, give or take 6 cm) for 0.3 s: its energy at the start, the most it has at the end of any
    frame (kinetic plus the contact springs'), and whether a contact was made; asserts that nothing
    becomes NaN."""
    spec = ObjectSpec("box", "box", size, mass, Material(restitution, 0.8, 0.5))
    q = tuple(quat_normalize(np.asarray(quaternion, dtype=float)))
    world = world_of([PlacedObject(spec, (0.0, 0.0, 0.0), q, velocity, spin)], interaction=interaction,
                     tracking_rate=rate, substeps=substeps)
    hand = probe_hand({name: np.asarray(velocity) * delay + offset for name, (delay, *offset) in zip(TIPS, tips)})
    start = highest = kinetic_energy(world)[0]
    touched = False
    for t in np.arange(0.0, 0.3, 1.0 / rate):
        world = step(world, HandFrame(float(t), (hand,)))
        touched |= bool(world.data.impulse.any() or world.data.active.any())
        assert np.isfinite(world.data.velocity).all() and np.isfinite(world.data.position).all()
        highest = max(highest, kinetic_energy(world)[0] + spring_energy(world))
    return start, highest, touched


@pytest.mark.parametrize("interaction", [
    "impulse_penetration", "soft_hand", "penetration_only"])
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
        interaction, size, log_mass, restitution, quaternion, velocity, spin, tips, rate, substeps):
    # Each model at one physics step per frame at 60-120 Hz (dt from 1/60 s), or a few substeps,
    # masses 1 g to 10 kg spread evenly in log (the light ones are the hard ones). The paper's model:
    # a 2.5 g object gained 10 % at 1/79 s and a 15 g one 85 % at 1/64 s when a contact found late
    # kept its spring's energy. The baselines, before they were mended (docs/physics.md, "The
    # baselines at coarse steps"): in a scan of 800 such boxes, 12 (penetration-only) and 33 (soft
    # hand) of some 700 touched gained more than 1 %, up to 421 % (1.4 g) and 964 % (1.2 g).
    start, highest, touched = still_hand_energy(size, 10.0 ** log_mass, restitution, quaternion, velocity, spin, tips,
                                                rate, substeps, interaction)
    assert highest <= start * 1.01 + 1e-12
    event("contact" if touched else "no contact")


@pytest.mark.parametrize("interaction, mass, size, restitution, quaternion, velocity, spin, tips, before", [
    pytest.param("penetration_only", 0.0096, (0.106, 0.149, 0.128), 0.38, (-0.77, -0.62, 0.11, 0.05), (-0.19, 0.84, -0.2),
     (-5.75, 2.0, 1.6), [(0.149, -0.059, -0.002, -0.038), (0.074, 0.032, 0.056, 0.045), (0.074, -0.009, 0.043, 0.041)],
     0.19, id="penetration_only 9.6 g"),
    pytest.param("soft_hand", 0.0025, (0.165, 0.054, 0.113), 0.35, (0.81, -0.32, -0.33, 0.36), (-0.02, 0.45, -0.69),
     (-7.0, 4.7, -2.2), [(0.074, -0.031, 0.044, -0.017), (0.045, -0.034, 0.032, -0.028), (0.148, 0.040, 0.013, 0.030)],
     17.7, id="soft_hand 2.5 g"),
])
def test_the_baselines_energy_at_coarse_dt(interaction, mass, size, restitution, quaternion, velocity, spin, tips,
                                           before):
    # The corners: one step per frame at 72 Hz, a light box (9.6 g, 2.5 g) drifting and
    # spinning into three still fingertips. Before the baselines were mended (docs/physics.md, "The
    # baselines at coarse steps") it gained ``before`` (+19 %, +1765 %: most of it in the soft hand's
    # springs, its contacts found a step late and deep); the paper's model gains nothing here either.
    for model in (interaction, "impulse_penetration"):
        start, highest, touched = still_hand_energy(size, mass, restitution, quaternion, velocity, spin, tips, 72.0, 1,
                                                    model)
        assert touched and highest <= start * 1.01, (model, highest / start - 1, before)


def test_a_light_cube_turning_under_one_still_tip_at_60_hz_gains_nothing_with_the_penetration_only_baseline():
    # Found by the property test's search outside its repeatable examples: a 10 g cube turning at
    # 2 rad/s under one still fingertip seemed to gain 58 % at 1/60 s with the penetration-only
    # baseline. Its kinetic energy never grew: the measure counted the spring of a contact whose
    # phalanx had left its face's plane (depth < 0, pressing nothing) as held energy.
    start, highest, touched = still_hand_energy((0.01171875,) * 3, 0.01, 0.5, (1.0, 0.0, 0.5, 0.0), (0.0, 0.0, 0.0),
                                                (0.0, 0.0, 2.0), [(0.25, 0.01953125, 0.0, 0.0)], 60.0, 1,
                                                "penetration_only")
    assert touched and highest <= start * 1.01, highest / start - 1
