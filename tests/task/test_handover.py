"""The handover on scripted observations: a hand-over done right, a drop, the wrong hand first."""

from __future__ import annotations

import numpy as np
import pytest

from microg.task.observation import Observation
from microg.task.kinds.handover import HandoverRules
from microg.task.rules import TaskRules
from microg.task import COMPLETED, KINDS, TIMEOUT

KIND = KINDS["handover"]
PASS, PLACE, TAKE = "pass", "place", "take"

RATE = 100.0
SETTLE, GRACE, HOLD = 0.1, 0.25, 1.0
START, PLACE_AT = (0.0, 0.2, 0.0), (0.1, 0.2, 0.0)
RULES = TaskRules(start=START, start_orientation=(1.0, 0.0, 0.0, 0.0), places=((0.0, 0.3, 0.0),),
                  place_radius=0.02, hold_s=3.0, timeout_s=8.0, grasp_settle_s=SETTLE, drop_grace_s=GRACE,
                  workspace_min=(-1.0, -1.0, -1.0), workspace_max=(1.0, 1.0, 1.0), kind="handover",
                  tables=(("handover", HandoverRules(first_hand="right", place=PLACE_AT, radius=0.03, hold_s=HOLD)),))


def play(script, seconds: float = RULES.timeout_s + 0.5):
    """Feed ``script(t) -> (left holds, right holds, position)`` at RATE; the final state and events."""
    state, events = KIND.start(), []
    for k in range(round(seconds * RATE)):
        t = k / RATE
        left, right, position = script(t)
        observation = Observation(t, left or right, position, grasped_by=np.array([left, right]))
        state, new = KIND.advance(state, observation, RULES)
        events += new
        if state.finished:
            break
    return state, events


RIGHT_TAKES, LEFT_TAKES, RIGHT_LETS_GO, IN_PLACE = 0.5, 2.0, 2.6, 3.0


def handed_over(t):
    """The right hand takes the object, the left takes it too, the right lets go, and the left carries
    it into the place zone and holds it there."""
    right = RIGHT_TAKES <= t < RIGHT_LETS_GO
    left = t >= LEFT_TAKES
    return left, right, PLACE_AT if t >= IN_PLACE else START


def test_a_handover_done_right_completes_with_its_transfer_and_both_held_times():
    state, events = play(handed_over)
    assert state.stage == COMPLETED and state.attempts == 0
    # the transfer: from the left hand's grasp to the right hand's letting go (holds date from the grasp)
    assert state.transfer_time == pytest.approx(RIGHT_LETS_GO - LEFT_TAKES, abs=1e-9)
    # both held: from the left hold's confirmation (settled) to the right hold's end (its grace)
    assert state.both_held == pytest.approx((RIGHT_LETS_GO + GRACE) - (LEFT_TAKES + SETTLE), abs=1e-9)
    # completed once held alone in the place for HOLD
    assert state.completion_time == pytest.approx(IN_PLACE + HOLD, abs=1e-9)
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [TAKE, PASS, PLACE]
    assert KIND.measured(state.record) == {"transfer_time_s": state.transfer_time, "both_held_s": state.both_held}
    assert [e.data["hand"] for e in events if e.kind == "hold"] == ["right", "left"]


def test_letting_go_before_the_other_hand_holds_it_is_a_drop_and_back_to_taking():
    def dropped(t):
        return False, RIGHT_TAKES <= t < 1.5, START

    state, events = play(dropped)
    assert state.stage == TIMEOUT and state.attempts == 1 and state.transfer_time is None
    drop = next(e for e in events if e.kind == "drop")
    assert drop.t == pytest.approx(1.5 + GRACE, abs=1e-9) and drop.data["stage"] == PASS
    assert [e.data["stage"] for e in events if e.kind == "stage"] == [TAKE, PASS, TAKE]


def test_the_other_hand_first_is_no_handover():
    """Taken by the left hand (not the protocol's first hand) and held in the place: never passed."""
    state, _ = play(lambda t: (t >= RIGHT_TAKES, False, PLACE_AT))
    assert state.stage == TIMEOUT and state.transfer_time is None and state.both_held == 0.0


def test_held_in_the_place_by_both_hands_does_not_count_until_the_first_lets_go():
    """After the pass, the right hand takes it again in the place: the hold there restarts once the
    left hand holds it alone again."""
    again = 3.3

    def regrasped(t):
        left, right, position = handed_over(t)
        return left, right or again <= t < again + 0.2, position

    state, _ = play(regrasped)
    assert state.stage == COMPLETED
    # the right hand's second hold settles at again + SETTLE and ends at again + 0.2 + GRACE
    assert state.completion_time == pytest.approx(again + 0.2 + GRACE + HOLD, abs=1e-9)


def test_two_hands_hand_the_cube_over_in_the_physics_and_the_measures_follow_their_grasps():
    """The transfer time runs from the left hand's first grasp to the right hand's letting go, and
    both hands held it from the left hold's settling to the right hold's end, by the grasps the
    physics reports for each hand; the cube ends held in the zone."""
    from pathlib import Path

    from microg.study.inputs import participant_plan
    from microg.study.protocol import load_protocol
    from microg.study.session import task_world
    from microg.study.store import PlannedTask
    from microg.task import Lanes, play
    from tests.study.scripted import RATE as HANDS_RATE, TwoPinches

    frame_s = 1 / HANDS_RATE
    protocol = load_protocol(Path(__file__).parents[1] / "study" / "protocols" / "handover.toml")
    task = PlannedTask(0, "passing", "impulse_penetration", "cube", "C", 1)
    plan, world = participant_plan(protocol, task), task_world(protocol, task)
    handover = protocol.task.handover
    source = TwoPinches(np.asarray(plan.start), np.asarray(handover.place), float(plan.object.half_extents[0]))
    lanes = Lanes(KIND, world, 1, guard=protocol.guard, window=protocol.filter_window)
    lanes.load(0, world, plan.rules)
    after = np.concatenate([moments.records for moments in play(lanes, source)])["after"]
    state = lanes.state(0)
    t = after["t"]
    left, right = after["grasped_by"].astype(bool).T
    assert state.stage == COMPLETED and state.attempts == 0
    took = t[np.argmax(left)]
    let_go = t[np.flatnonzero(right)[-1] + 1]
    assert state.transfer_time == pytest.approx(let_go - took, abs=1e-9)
    assert state.both_held == pytest.approx((let_go + plan.rules.drop_grace_s) - (took + plan.rules.grasp_settle_s),
                                            abs=frame_s + 1e-9)
    held = round(handover.hold_s / frame_s)
    assert left[-held:].all() and not right[-held:].any()
    assert np.linalg.norm(after["position"][-1] - np.asarray(handover.place)) <= handover.radius


def test_a_toss_within_the_drop_grace_is_a_handover_with_a_negative_transfer_time():
    """The right hand lets go 0.1 s before the left takes the object (less than the drop grace): the
    holds' grace joins them, no drop, and the transfer time is -0.1 s."""
    gap = 0.1

    def tossed(t):
        right = RIGHT_TAKES <= t < LEFT_TAKES - gap
        left = t >= LEFT_TAKES
        return left, right, PLACE_AT if t >= IN_PLACE else START

    state, events = play(tossed)
    assert state.stage == COMPLETED and state.attempts == 0
    assert state.transfer_time == pytest.approx(-gap, abs=1e-9)
