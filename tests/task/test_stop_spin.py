"""The stop of a spin on scripted observations: a spin slowed by a grip's steady torque, a free flip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from microg.task.observation import Observation
from microg.task.kinds.stop_spin import StopSpinRules
from microg.task.rules import TaskRules
from microg.task import COMPLETED, KINDS, TIMEOUT

KIND = KINDS["stop_spin"]
RESTING, SPINNING = "resting", "spinning"

RATE = 100.0
SPIN, REST_OMEGA, HOLD_S = 4.0, 0.3, 1.0
GRIP_AT, SLOWING = 0.5, 3.0
"""The hand grasps at GRIP_AT (s) and its steady torque slows the spin by SLOWING rad/s^2."""
RULES = TaskRules(start=(0.0, 0.2, 0.0), start_orientation=(1.0, 0.0, 0.0, 0.0), places=((0.0, 0.3, 0.0),),
                  place_radius=0.02, hold_s=3.0, timeout_s=5.0, grasp_settle_s=0.1, drop_grace_s=0.25,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0), kind="stop_spin",
                  tables=(("stop_spin", StopSpinRules(spin_axis=(0.0, 1.0, 0.0), spin_rate=SPIN, rest_omega=REST_OMEGA,
                                                             rest_speed=0.02, hold_s=HOLD_S)),))


def about_y(angle: float) -> np.ndarray:
    return np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])


def about_x(angle: float) -> np.ndarray:
    return np.array([math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0])


def play(observe, seconds: float = 6.0):
    """Feed ``observe(t) -> Observation`` at RATE for ``seconds``; the final state and the events."""
    state, events = KIND.start(), []
    for k in range(round(seconds * RATE)):
        state, new = KIND.advance(state, observe(k / RATE), RULES)
        events += new
    return state, events


def slowed(t: float, release: bool = False, drift: float = 0.0) -> Observation:
    """Spinning at SPIN about its own (and the world's) y axis, grasped at GRIP_AT and slowed by SLOWING
    to a stop; ``release``: let go at the stop, leaving it drifting at ``drift`` m/s."""
    omega = max(0.0, SPIN - SLOWING * max(0.0, t - GRIP_AT))
    stopped = omega == 0.0
    grasped = t >= GRIP_AT and not (release and stopped)
    return Observation(t, grasped, (0.0, 0.2, 0.0), about_y(SPIN * t), angular_velocity=np.array([0.0, omega, 0.0]),
                       velocity=np.array([drift if stopped else 0.0, 0.0, 0.0]))


def test_a_grip_that_slows_the_spin_brings_it_to_rest_when_the_slowing_says():
    state, events = play(slowed)
    # |omega| = SPIN - SLOWING (t - GRIP_AT) falls below REST_OMEGA after (SPIN - REST_OMEGA) / SLOWING
    due = GRIP_AT + (SPIN - REST_OMEGA) / SLOWING
    rest = math.floor(due * RATE + 1e-9) / RATE + 1 / RATE  # the first frame after it
    assert state.stage == COMPLETED and not state.flipped and state.attempts == 0
    assert state.time_to_rest == pytest.approx(rest, abs=1e-9)
    assert state.completion_time == pytest.approx(rest + HOLD_S, abs=1e-9)
    assert KIND.measured(state.record) == {"time_to_rest_s": state.time_to_rest, "flipped": False}
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [SPINNING, RESTING]


def test_a_stopped_object_let_go_at_rest_in_its_place_stays_stopped():
    state, _ = play(lambda t: slowed(t, release=True, drift=0.005))
    assert state.stage == COMPLETED and state.attempts == 1  # the release before the end is a drop


def test_a_stopped_object_let_go_drifting_is_not_at_rest_and_the_task_times_out():
    state, events = play(lambda t: slowed(t, release=True, drift=0.05))
    assert state.stage == TIMEOUT and state.time_to_rest is None
    assert KIND.measured(state.record)["time_to_rest_s"] is None
    assert [e.data["stage"] for e in events if e.kind == "stage"][-1] == SPINNING


FLIP_S = 2.0
"""The free object turns half a turn about its x axis in this time while its spin stays in the world."""


def flipping(t: float) -> Observation:
    """A free tumble: the spin stays SPIN about the world's y axis while the object turns over about
    x, so its own spin axis goes from +y to -y: the intermediate-axis flip."""
    turned = math.pi * min(t / FLIP_S, 1.0)
    return Observation(t, False, (0.0, 0.2, 0.0), about_x(turned), angular_velocity=np.array([0.0, SPIN, 0.0]))


def test_an_object_that_turns_over_flips_and_never_rests():
    state, events = play(flipping)
    assert state.stage == TIMEOUT and state.flipped and KIND.measured(state.record)["flipped"] is True
    # its own spin axis is R^T y: at an angle equal to the turn; past 90 degrees at FLIP_S / 2
    flip = next(e for e in events if e.kind == "flip")
    assert flip.t == pytest.approx(math.floor(FLIP_S / 2 * RATE + 1e-9) / RATE + 1 / RATE, abs=1e-9)


def test_a_grip_that_makes_the_spin_turn_back_is_no_flip():
    def braked(t):  # the grip overshoots: the spin reverses to -1 rad/s while held
        omega = SPIN if t < GRIP_AT else -1.0
        return Observation(t, t >= GRIP_AT, (0.0, 0.2, 0.0), about_y(0.0), angular_velocity=np.array([0.0, omega, 0.0]))

    state, _ = play(braked)
    assert not state.flipped


def test_a_spin_that_keeps_its_axis_has_not_flipped():
    state, _ = play(lambda t: Observation(t, False, (0.0, 0.2, 0.0), about_y(SPIN * t),
                                          angular_velocity=np.array([0.0, SPIN, 0.0])))
    assert state.stage == TIMEOUT and not state.flipped


@pytest.mark.parametrize("seen", ["touching", "velocity"])
def test_a_touch_that_knocks_the_spin_round_starts_a_new_free_spell_and_is_no_flip(seen):
    """Knocked at GRIP_AT, the object spins on about its own -y axis: turned over from the
    protocol's spin axis, but by the knock, not while it turned freely. The knock is seen as a
    phalanx touching it at the frame's end, or only by the push it gave (a touch over within the
    frame)."""
    def knocked(t):
        after = t > GRIP_AT
        touched = seen == "touching" and abs(t - GRIP_AT) < 0.5 / RATE
        return Observation(t, False, (0.0, 0.2, 0.0), about_x(math.pi if after else 0.0),
                           angular_velocity=np.array([0.0, SPIN, 0.0]), touching=np.array([touched] + [False] * 39),
                           velocity=np.array([0.0, 0.0, 0.01 if after and seen == "velocity" else 0.0]))

    state, events = play(knocked)
    assert state.stage == TIMEOUT and not state.flipped and not any(e.kind == "flip" for e in events)


FRAME_S = 1 / 90
"""The frame interval of the free tumbles below (s)."""


def free_tumble(name: str, seconds: float):
    """A stop of a spin of the skills protocol's ``name`` that nobody touches, in the physics: its
    final state, its events (with the physics' time of each frame, ``physics_t`` in its data) and
    the protocol."""
    import dataclasses

    from microg.paths import PROTOCOLS
    from microg.sim import snapshot, step
    from microg.skeleton import HandFrame
    from microg.study.protocol import load_protocol
    from microg.study.session import task_world
    from microg.study.store import PlannedTask
    from microg.task.observation import seen_in

    protocol = load_protocol(PROTOCOLS / "microgravity-skills.toml")
    rules = dataclasses.replace(protocol.rules("stopping"), timeout_s=seconds)
    world = task_world(protocol, PlannedTask(0, "stopping", "impulse_penetration", name,
                                             protocol.object(name).code, 1))
    state, events, k = KIND.start(), [], 0
    while not state.finished:
        k += 1
        world = step(world, HandFrame.made(k * FRAME_S, ()))
        state, new = KIND.advance(state, seen_in(snapshot(world)), rules)
        events += [e._replace(data={**e.data, "physics_t": world.time}) for e in new]
    return state, events, protocol


def euler_flip_time(protocol, name: str) -> float:
    """When the free body's own spin axis first turns 90 degrees from where it started, by Euler's
    equations for a box's principal moments (I dw/dt = (I w) x w), integrated to 1e-10."""
    from scipy.integrate import solve_ivp

    spec = protocol.object(name).spec
    x, y, z = spec.size
    inertia = spec.mass / 12 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])
    spin = protocol.task.stop_spin
    w0 = spin.spin_rate * np.asarray(spin.spin_axis)

    def crossed(t, w):
        return float(w @ w0)

    crossed.terminal, crossed.direction = True, -1
    solution = solve_ivp(lambda t, w: np.cross(inertia * w, w) / inertia, (0.0, 60.0), w0, events=crossed,
                         rtol=1e-10, atol=1e-12)
    return float(solution.t_events[0][0]) if len(solution.t_events[0]) else math.inf


def test_a_free_flat_cuboid_spun_near_its_intermediate_axis_flips_when_eulers_equations_say():
    """The flip is seen at the first frame past Euler's time, or the next one: the physics moves in
    whole steps of its own (here 1/99 s), so a frame may show the object a step behind its clock."""
    state, events, protocol = free_tumble("flat_cuboid", 6.0)
    due = euler_flip_time(protocol, "flat_cuboid")
    assert due < 6.0 and state.stage == TIMEOUT and state.flipped
    flip = next(e.data["physics_t"] for e in events if e.kind == "flip")
    assert due < flip <= due + 2 * FRAME_S


def test_a_free_cube_keeps_its_spin_axis_and_does_not_flip():
    state, _, protocol = free_tumble("cube", 6.0)
    assert euler_flip_time(protocol, "cube") == math.inf and not state.flipped
