"""The tracking guard: each kind of bad tracking has its defined behaviour and its count."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from microg.skeleton import HandFrame, displacement
from microg.hands import GuardConfig, Tracking
from microg.hands.source import HandSource
from tests.hands.synthetic import RATE, Guarded, ListSource, run_guard, sweep, with_joints, with_nan

PERIOD = 1 / RATE


def moved(frame: HandFrame, offset) -> HandFrame:
    return HandFrame(frame.timestamp, tuple(h.moved(np.asarray(offset, dtype=float)) for h in frame.hands))


def same_hand(a, b, track_id) -> bool:
    """``a`` is ``b`` renumbered to ``track_id`` (positions to rounding)."""
    return (a.side == b.side and a.track_id == track_id and np.allclose(a.joints, b.joints, atol=1e-12)
            and np.allclose(a.palm_position, b.palm_position, atol=1e-12) and np.array_equal(a.widths, b.widths))


def test_clean_stream_passes_unchanged_but_for_the_guards_track_number():
    frames = sweep((0, 0.2, 0), (0.3, 0, 0), 20)
    out, counts = run_guard(frames)
    assert [f.timestamp for f in out] == [f.timestamp for f in frames]
    assert all(o.hands[0] == replace(f.hands[0], track_id=1) for o, f in zip(out, frames))
    assert counts.frames_in == counts.frames_out == 20
    assert counts.new_tracks == 1
    assert sum(counts.as_dict().values()) == 20 + 20 + 1


def test_nan_palm_drops_the_hand_and_the_next_good_hand_is_a_new_track():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 10)
    frames[4] = HandFrame(frames[4].timestamp, (with_nan(frames[4].hands[0], palm=True),))
    out, counts = run_guard(frames)
    assert len(out) == 10
    assert out[4].hands == ()
    assert out[3].hands[0].track_id == 1 and out[5].hands[0].track_id == 2
    assert counts.hands_incomplete == 1 and counts.new_tracks == 2


def test_nan_in_a_delivered_joint_drops_the_hand():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 6)
    frames[3] = HandFrame(frames[3].timestamp, (with_nan(frames[3].hands[0], joint=(1, 4)),))
    out, counts = run_guard(frames)
    assert out[3].hands == ()
    assert counts.hands_incomplete == 1


def test_joints_the_source_never_delivers_may_stay_unknown():
    """A LeapJS recording has no metacarpal bases: its hands pass whole."""
    def leapjs_like(frame):
        joints = frame.hands[0].joints.copy()
        joints[1:, 0] = np.nan
        return HandFrame(frame.timestamp, (with_joints(frame.hands[0], joints),))

    frames = [leapjs_like(f) for f in sweep((0, 0.2, 0), (0.1, 0, 0), 6)]
    out, counts = run_guard(frames)
    assert all(len(f.hands) == 1 for f in out)
    assert counts.hands_incomplete == 0
    assert np.isnan(out[-1].hands[0].joints[1:, 0]).all()


def test_a_hand_that_disappears_and_returns_starts_a_new_track():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 8)
    frames[3] = HandFrame(frames[3].timestamp)
    out, counts = run_guard(frames)
    assert [len(f.hands) for f in out] == [1, 1, 1, 0, 1, 1, 1, 1]
    assert {f.hands[0].track_id for f in out[4:]} == {2}
    assert counts.hands_incomplete == 0 and counts.new_tracks == 2


def test_duplicate_and_out_of_order_frames_are_dropped_and_counted():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 10)
    stream = frames[:5] + [frames[4], frames[2]] + frames[5:]
    out, counts = run_guard(stream)
    assert [f.timestamp for f in out] == [f.timestamp for f in frames]
    assert counts.duplicate_timestamps == 1 and counts.out_of_order == 1
    assert counts.frames_in == 12 and counts.frames_out == 10


def test_a_clock_that_goes_back_is_re_anchored_after_a_run_of_stale_frames():
    config = GuardConfig(resync_after=5)
    before = sweep((0, 0.2, 0), (0.1, 0, 0), 20, t0=100.0)
    after = sweep((0.02, 0.2, 0), (0.1, 0, 0), 20, t0=0.0)
    out, counts = run_guard(before + after, config)
    times = np.array([f.timestamp for f in out])
    assert (np.diff(times) > 0).all()
    assert counts.out_of_order == 4 and counts.clock_resyncs == 1
    assert len(out) == 20 + 16
    # after re-anchoring, the source's spacing is kept and the frame comes one period after the last
    assert times[20] == pytest.approx(times[19] + PERIOD)
    assert np.diff(times[20:]) == pytest.approx(np.full(15, PERIOD))
    assert out[20].hands[0].track_id != out[19].hands[0].track_id


def test_a_clock_jump_far_ahead_is_re_anchored_and_then_the_true_clock_again():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 30)
    frames[10] = HandFrame(1e6, frames[10].hands)
    out, counts = run_guard(frames, GuardConfig(resync_after=3, max_gap=5.0))
    times = np.array([f.timestamp for f in out])
    assert (np.diff(times) > 0).all()
    assert times[-1] - times[0] < 1.0  # the world never integrates the bogus million seconds
    assert counts.clock_resyncs == 2 and counts.out_of_order == 2


def test_a_one_frame_glitch_is_bridged_and_never_reaches_the_world():
    true = sweep((0, 0.2, 0), (0.1, 0, 0), 10)
    frames = list(true)
    frames[5] = moved(frames[5], (0.15, 0, 0))
    config = GuardConfig(confirm_frames=3)
    guarded = Guarded(ListSource(frames), config)
    out = [guarded.next_frame() for _ in range(5)]
    assert guarded.guard.waiting == 0  # nothing waits before the glitch
    out.append(guarded.next_frame())  # reads the glitch, waits, then the next frame decides it
    assert len(guarded.source.frames) == 3  # it read exactly one frame past the glitch
    out += [guarded.next_frame() for _ in range(4)]
    assert guarded.next_frame() is None
    # on the line from before to after the glitch: for this steady sweep, where the hand really was
    assert all(same_hand(o.hands[0], t.hands[0], 1) for o, t in zip(out, true))
    counts = guarded.guard.counts
    assert (counts.jumps, counts.jumps_rejected, counts.jumps_accepted, counts.bridged_hands) == (1, 1, 0, 1)


def test_a_hand_that_stays_at_the_new_place_becomes_a_new_track_from_where_it_arrived():
    config = GuardConfig(confirm_frames=3)
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 12)
    frames[5:] = [moved(f, (0, 0.12, 0)) for f in frames[5:]]
    out, counts = run_guard(frames, config)
    assert [f.timestamp for f in out] == [f.timestamp for f in frames]
    assert all(same_hand(o.hands[0], f.hands[0], 1) for o, f in zip(out[:5], frames[:5]))
    assert all(same_hand(o.hands[0], f.hands[0], 2) for o, f in zip(out[5:], frames[5:]))
    assert (counts.jumps, counts.jumps_accepted, counts.bridged_hands) == (1, 1, 0)


def test_a_hand_that_keeps_jumping_is_marked_lost():
    config = GuardConfig(confirm_frames=3, max_hold=4)
    frames = sweep((0, 0.2, 0), (0.0, 0, 0), 12)
    frames[3:9] = [moved(f, (0.3 * (i % 2) + 0.15, 0.2 * (i % 3), 0)) for i, f in enumerate(frames[3:9])]
    out, counts = run_guard(frames, config)
    assert [f.timestamp for f in out] == [f.timestamp for f in frames]
    assert counts.jumps_lost == 1
    assert [len(f.hands) for f in out[:8]] == [1, 1, 1, 0, 0, 0, 0, 0]


def test_fingers_that_jump_while_the_palm_stays_are_caught_too():
    true = sweep((0, 0.2, 0), (0.05, 0, 0), 8)
    frames = list(true)
    joints = frames[4].hands[0].joints.copy()
    joints[1, 2:] += (0.0, 0.11, 0.0)
    frames[4] = HandFrame(frames[4].timestamp, (with_joints(frames[4].hands[0], joints),))
    assert np.linalg.norm(frames[4].hands[0].palm_position - frames[3].hands[0].palm_position) < 0.001
    out, counts = run_guard(frames)
    assert same_hand(out[4].hands[0], true[4].hands[0], 1)
    assert counts.jumps_rejected == 1


def test_just_under_the_jump_distance_passes():
    frames = sweep((0, 0.2, 0), (0.0, 0, 0), 4)
    frames[2] = moved(frames[2], (0.099, 0, 0))
    out, counts = run_guard(frames)
    assert out[2].hands[0].palm_position[0] == pytest.approx(0.099)
    assert counts.jumps == 0


def test_a_new_source_id_is_a_new_track_at_once_wherever_it_is():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 4) + sweep((0.3, 0.2, 0), (0.1, 0, 0), 4, t0=4 * PERIOD, track_id=8)
    out, counts = run_guard(frames)
    assert [f.hands[0].track_id for f in out] == [1, 1, 1, 1, 2, 2, 2, 2]
    assert counts.jumps == 0 and counts.new_tracks == 2


def test_dropped_frames_are_counted_and_the_arrived_frames_pass_as_they_are():
    true = sweep((0, 0.2, 0), (0.1, 0, 0), 30)
    kept = true[:10] + true[12:20] + true[23:]
    out, counts = run_guard(kept)
    assert [f.timestamp for f in out] == [f.timestamp for f in kept]
    assert all(same_hand(o.hands[0], k.hands[0], 1) for o, k in zip(out, kept))
    assert (counts.gaps, counts.bridged_hands, counts.new_tracks) == (2, 0, 1)


def test_hand_tracking_shows_the_observation_to_its_source_and_closes_it():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 2)
    source = ListSource(frames)
    tracked = Tracking(source)
    assert isinstance(tracked, HandSource)
    observation = object()
    tracked.next_frame(observation)
    assert source.observations == [observation]
    tracked.close()
    assert source.closed and tracked.description == "list"


def test_frames_still_waiting_when_the_source_ends_are_passed_without_the_undecided_hand():
    frames = sweep((0, 0.2, 0), (0.1, 0, 0), 6)
    frames[5] = moved(frames[5], (0.2, 0, 0))
    out, counts = run_guard(frames)
    assert len(out) == 6 and out[5].hands == ()
    assert counts.frames_out == 6


def _corrupt(frames, actions, rng):
    """Apply one corruption per frame, as drawn: keep, drop, duplicate, swap, NaN, glitch, relocate."""
    stream, offset = [], np.zeros(3)
    for frame, action in zip(frames, actions):
        if action == "relocate":
            offset = offset + rng.uniform(-0.3, 0.3, 3)
        frame = moved(frame, offset)
        if action == "drop":
            continue
        if action == "nan":
            joint = (int(rng.integers(5)), int(rng.integers(1, 5)))
            frame = HandFrame(frame.timestamp, (with_nan(frame.hands[0], palm=rng.random() < 0.5, joint=joint),))
        if action == "glitch":
            frame = moved(frame, rng.uniform(-0.3, 0.3, 3))
        stream.append(frame)
        if action == "duplicate":
            stream.append(frame)
        if action == "swap" and len(stream) >= 2:
            stream[-1], stream[-2] = stream[-2], stream[-1]
    return stream


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["keep"] * 4 + ["drop", "duplicate", "swap", "nan", "glitch", "relocate"]),
                min_size=5, max_size=60), st.integers(0, 2 ** 32 - 1))
def test_whatever_the_corruption_the_output_is_ordered_complete_and_jump_free(actions, seed):
    rng = np.random.default_rng(seed)
    frames = sweep((0, 0.2, 0), (0.2, 0, 0), len(actions))
    stream = _corrupt(frames, actions, rng)
    config = GuardConfig()
    out, counts = run_guard(stream, config)
    times = np.array([f.timestamp for f in out])
    assert (np.diff(times) > 0).all()
    assert counts.frames_in == len(stream)
    assert counts.frames_out == len(out)
    assert counts.frames_out == counts.frames_in - counts.duplicate_timestamps - counts.out_of_order
    for before, after in zip(out, out[1:]):
        for hand in after.hands:
            assert np.isfinite(hand.palm_position).all()
            previous = before.hand(hand.side)
            if previous is not None and previous.track_id == hand.track_id:
                assert displacement(hand.points, previous.points) < config.jump_distance
