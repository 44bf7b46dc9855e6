"""The broad phase: an object that no phalanx can reach this step skips the contact search, and
that must change nothing. Checked against the search itself (``probe.find_contacts`` with and
without it) on random objects, motions and phalanges placed around the edge of its reach."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from microg.skeleton import slot
from microg.sim import Material, ObjectSpec, PlacedObject
from microg.sim.probe import find_contacts
from microg.sim.rotation import quat_normalize
from microg.sim.state import CLOCK_DRIFT
from tests.physics import placed, world_of

SLOTS_USED = [slot("right", digit, bone) for digit in range(5) for bone in range(4)][:6]


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def searched(world, data, broad_phase):
    """The state after the contact search, and which objects it left out."""
    data = data.copy()
    skipped = find_contacts(world.model, data, broad_phase)
    return data, skipped


def assert_same_state(a, b):
    assert a.reals.tobytes() == b.reals.tobytes()
    assert a.flags.tobytes() == b.flags.tobytes()
    assert a.counts.tobytes() == b.counts.tobytes()


phalanx = st.fixed_dictionaries({
    "direction": st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
    "reach": st.floats(0.8, 2.0),           # the centre's distance in object radii + phalanx radius
    "moved": st.tuples(*[st.floats(-0.02, 0.02)] * 3),  # where it was a step ago, from where it is
    "radius": st.floats(0.002, 0.012),
    "valid": st.sampled_from([True, True, True, False]),
    "fresh": st.booleans(),
    "ghost": st.sampled_from([False, False, True]),
})


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    sphere=st.booleans(),
    size=st.tuples(*[st.floats(0.01, 0.2)] * 3),
    quaternion=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: np.linalg.norm(q) > 0.1),
    heading=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
    speed=st.floats(-3, 1),                 # log10 m/s
    axis=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1),
    rate=st.floats(-2, 2.2),                # log10 rad/s
    drift=st.floats(0.0, 1 / 60),
    phalanges=st.lists(phalanx, min_size=1, max_size=4),
    interaction=st.sampled_from(["impulse_penetration", "penetration_only", "soft_hand"]),
)
def test_leaving_out_what_no_phalanx_reaches_changes_nothing(sphere, size, quaternion, heading, speed, axis, rate,
                                                             drift, phalanges, interaction):
    velocity, spin = tuple(10 ** speed * unit(heading)), tuple(10 ** rate * unit(axis))
    size = (size[0],) * 3 if sphere else size
    spec = ObjectSpec("thing", "sphere" if sphere else "box", size, 0.1, Material())
    centre = np.array([0.0, 0.2, 0.0])
    thing = PlacedObject(spec, tuple(centre), orientation=tuple(quat_normalize(np.array(quaternion))),
                         velocity=velocity, angular_velocity=spin)
    world = world_of([thing], interaction=interaction)
    data = world.data.copy()
    data.reals[CLOCK_DRIFT] = drift
    bound = size[0] / 2 if sphere else np.linalg.norm(size) / 2
    for k, ph in zip(SLOTS_USED, phalanges):
        now = centre + ph["reach"] * (bound + ph["radius"]) * unit(ph["direction"])
        data.hand_position[k], data.hand_previous[k] = now, now + np.array(ph["moved"])
        data.radius[k], data.valid[k], data.fresh[k] = ph["radius"], ph["valid"], ph["fresh"]
        data.ghost[k, 0] = ph["ghost"]
    without, _ = searched(world, data, broad_phase=False)
    with_it, skipped = searched(world, data, broad_phase=True)
    event("left out" if skipped[0] else "searched")
    if skipped[0]:
        event("left out, a phalanx within 1.5 times its reach" if any(
            ph["valid"] and ph["reach"] < 1.5 for ph in phalanges) else "left out, all farther")
    assert_same_state(without, with_it)


def still_phalanx(data, k, now, before=None, radius=0.004):
    data.hand_position[k] = now
    data.hand_previous[k] = now if before is None else before
    data.radius[k], data.valid[k] = radius, True


def assert_found_and_searched(world, data, k):
    """The search finds contact (k, 0) starting (its onset), and the broad phase does not leave
    the object out."""
    found, skipped = searched(world, data, broad_phase=True)
    assert not skipped[0]
    assert found.onset[k, 0]
    assert_same_state(found, searched(world, data, broad_phase=False)[0])


K = SLOTS_USED[0]


def test_a_bar_turning_past_a_still_fingertip_is_searched():
    # The sweep follows the phalanx's path in the object's frame: a bar that turned 1 rad in the
    # last step puts a still fingertip's path on a chord, nearer its centre than the fingertip is,
    # here across the end of its box: a contact starts though the fingertip is farther from the
    # centre than the bar's corners plus sqrt(3) times its radius.
    bar = placed("long_cuboid", angular_velocity=(0.0, 0.0, 100.0))
    world = world_of([bar])
    data = world.data.copy()
    h, rho = 0.01, 0.002
    data.reals[CLOCK_DRIFT] = h
    half = 0.5 * np.array(bar.spec.size)
    distance = 0.99 * (half[0] + rho) / math.cos(0.5)  # the chord's middle just inside the box's end
    assert distance > np.linalg.norm(half) + math.sqrt(3) * rho
    still_phalanx(data, K, np.array(bar.position) + distance * np.array([math.cos(0.5), -math.sin(0.5), 0.0]),
                  radius=rho)
    assert_found_and_searched(world, data, K)


def test_a_cube_flying_through_a_still_fingertip_in_one_step_is_searched():
    # 9 m/s for 1/60 s: the cube passed the fingertip, now 9 cm behind its centre.
    cube = placed("cube", velocity=(9.0, 0.0, 0.0))
    world = world_of([cube])
    data = world.data.copy()
    data.reals[CLOCK_DRIFT] = 1 / 60
    still_phalanx(data, K, np.array(cube.position) - (0.09, 0.0, 0.0))
    assert_found_and_searched(world, data, K)


def test_a_fingertip_cutting_a_box_corner_is_searched():
    # The slab test grows the box by rho along each axis, so its corner reaches sqrt(3) rho past
    # the box's own: a path across that corner starts a contact from farther than |half| + rho.
    world = world_of([placed("cube")])
    data = world.data.copy()
    rho = 0.01
    centre = np.array([0.0, 0.2, 0.0])
    before, now = centre + (0.042, 0.037, 0.039), centre + (0.037, 0.042, 0.039)
    assert min(np.linalg.norm(before - centre), np.linalg.norm(now - centre)) > np.linalg.norm((0.03,) * 3) + rho
    still_phalanx(data, K, now, before, radius=rho)
    assert_found_and_searched(world, data, K)


def test_the_paper_scene_searches_only_the_held_cube():
    # The live benchmark scene: the hand holds the cube; the flat and long cuboids float 25 cm away.
    from microg.bench import ours
    from microg.bench.scenarios import HOLD
    from microg.sim import step
    config = ours.Config(110.0, 4, "midpoint", 1)
    world = ours.live_world(config, HOLD)
    for frame in ours.live_frames(config, 0.5, HOLD):
        world = step(world, frame)
    assert world.data.active[:, 0].sum() > 0
    data = world.data.copy()
    skipped = find_contacts(world.model, data)
    assert skipped.tolist() == [False, True, True]
    assert_same_state(data, searched(world, world.data, broad_phase=False)[0])


@pytest.mark.parametrize("interaction", ["impulse_penetration", "soft_hand"])
def test_an_object_in_contact_is_always_searched(interaction):
    # A contact must be kept or ended by the search, even when its phalanx jumped far away.
    world = world_of([placed("cube")], interaction=interaction)
    data = world.data.copy()
    k = SLOTS_USED[0]
    data.valid[k], data.radius[k] = True, 0.008
    data.hand_position[k] = data.hand_previous[k] = (0.0, 0.2 + 0.03 + 0.004, 0.0)
    find_contacts(world.model, data)
    assert data.active[k, 0]
    data.hand_position[k] = data.hand_previous[k] = (0.0, 1.2, 0.0)
    skipped = find_contacts(world.model, data.copy())
    assert not skipped[0]
