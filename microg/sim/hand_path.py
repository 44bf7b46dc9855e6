"""The tracked hand inside the physics: each frame's phalanges and their path over the steps.

A frame gives each side's palm and joints (``points``: (2, 26, 3), palm first, then the 25 joints
digit-major) and bone widths; the compiled frame intake ``take_hands`` decides which sides start a
new track, which slots are phalanges (known ends, length at least ``MIN_PHALANX_LENGTH``, positive
width) and where each phalanx goes. Between frames ``move_hand`` moves the phalanges linearly from
the last frame to this one, a physics step at a time.

A side starts a new track when the hand appears, comes with another track id, or jumped: the jump
rule (``microg.skeleton.is_jump``: its palm or some joint moved the scene's ``jump_distance`` or
more since the last frame), the function the tracking guard asks, decided per hand as the guard
decides it. A hand that moved that far in one frame did not get there by moving, so all its
phalanges start afresh, even one whose own bone moved less (a hand found again turned about that
finger): none gets velocity from the move, and one found inside an object is a ghost there. In a
session the guard has already given such a hand a new track id; the world asks again for the
callers of ``microg.sim.step`` that pass no guard (a scripted scene, a re-simulation of an edited
recording): taken for motion, a jump into an object sweeps the phalanx into it at the jump's
speed (11 m/s for 10 cm at 110 Hz), and the object leaves at up to twice that.

A phalanx whose track starts here (new track, or newly valid) has no velocity yet and no contact
(a god-object anchored by the track before would press with a depth this hand never pressed), and
stays ``fresh`` until a physics step has looked at it: an overlap found then makes it a ghost.
"""

from __future__ import annotations

import math


from microg.skeleton import BONES_PER_HAND, MIN_PHALANX_LENGTH, N_BONES, SLOTS, is_jump
from .vec import add, cell, kernel, norm, row, scale, set_cell, set_row, sub

NAN3 = (math.nan, math.nan, math.nan)


@kernel
def new_tracks(p, s, present, track, points):
    """Per side: does its track start this frame (it appears, comes with another track id, or
    jumped: ``is_jump`` with the scene's ``jump_distance``)? Remembers each side's track and
    points for the next frame."""
    left = right = False
    for side in range(2):
        if not present[side]:
            s.present[side] = False
            continue
        starts = (not s.present[side] or track[side] != s.track_id[side]
                  or is_jump(points[side], s.last_points[side], p.jump_distance))
        if side == 0:
            left = starts
        else:
            right = starts
        s.present[side] = True
        s.track_id[side] = track[side]
        for i in range(points.shape[1]):
            set_cell(s.last_points, side, i, cell(points, side, i))
    return left, right


@kernel
def take_hands(p, s, present, track, points, widths, interval):
    """Set each phalanx's path for the coming steps from this frame's (filtered) joints."""
    starts = new_tracks(p, s, present, track, points)
    for k in range(SLOTS):
        side, bone = divmod(k, BONES_PER_HAND)
        digit, b = divmod(bone, N_BONES)
        set_row(s.hand_from, k, row(s.hand_to, k))
        if not present[side]:
            s.valid[k] = False
            set_row(s.hand_to, k, NAN3)
        else:
            first = cell(points, side, 1 + digit * (N_BONES + 1) + b)
            second = cell(points, side, 2 + digit * (N_BONES + 1) + b)
            length, width = norm(sub(second, first)), widths[side, digit, b]
            valid = math.isfinite(length) and length >= MIN_PHALANX_LENGTH and width > 0
            set_row(s.hand_to, k, scale(0.5, add(second, first)))
            s.radius[k] = width / 2 if valid else 0.0
            restart = valid and (starts[side] or not s.valid[k])
            s.valid[k] = valid
            if restart:
                set_row(s.hand_from, k, row(s.hand_to, k))
                set_row(s.hand_position, k, row(s.hand_to, k))
                for o in range(s.active.shape[1]):
                    s.active[k, o] = False
                    s.ghost[k, o] = False
            s.fresh[k] = valid and (restart or s.fresh[k])
            if valid and not restart and interval > 0:
                moved = sub(row(s.hand_to, k), row(s.hand_from, k))
                set_row(s.hand_velocity, k, (moved[0] / interval, moved[1] / interval, moved[2] / interval))
                continue
        set_row(s.hand_velocity, k, (0.0, 0.0, 0.0))


@kernel
def move_hand(s, previous_frame_time, frame_time, time, h):
    """Place the phalanges for the end of this step, on the line from the last frame to this one;
    a new step starts with no contact onsets."""
    interval = frame_time - previous_frame_time
    alpha = 1.0 if interval <= 0 else min(1.0, (time + h - previous_frame_time) / interval)
    previous, position, start, end = s.hand_previous, s.hand_position, s.hand_from, s.hand_to
    s.onset[:, :] = False  # one fill (row by row, it was a call to memset per slot)
    for k in range(SLOTS):
        set_row(previous, k, row(position, k))
        first = row(start, k)
        set_row(position, k, add(first, scale(alpha, sub(row(end, k), first))))
