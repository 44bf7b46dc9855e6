"""The hand vocabulary every room shares: the ground floor of the pipeline, importing nothing of microg.

A tracked hand is the Leap Motion skeleton in SI units (``Hand``: a palm pose and 5 digits x 4
bones), a hand source delivers ``HandFrame``s (a timestamp and the hands seen), and the physics
knows each bone by its *slot* (``slot``, ``SLOTS``: left hand 0..19, right hand 20..39). The jump
rule (``is_jump``: a hand that moved ``jump_distance`` or more between two frames is a new track;
``JUMP_DISTANCE`` by default) is stated here and applied by the tracking guard
(``microg.hands.guard``) and by the physics' frame intake (``microg.sim.hand_path``); so is the
precision a hand enters with (``TRACKER_FLOAT``, ``at_tracker_precision``), applied by the hand
sources and the simulated participant.

Hands, the physics, the task, the simulated participant, the study and the view import it; it is
also where numba's cache is pointed at the user's cache directory (``cache``), first, since every
room with compiled code stands on this one.
"""

from .cache import use_user_cache

use_user_cache()

from .hand import (BONES, BONES_PER_HAND, DIGITS, HANDS, JUMP_DISTANCE, MAX_BONE_WIDTH, MAX_REACH,  # noqa: E402
                   MIN_PHALANX_LENGTH, N_BONES, N_DIGITS, POINTS, SIDES, SLOT_DIGIT, SLOTS, TRACKER_FLOAT, Hand,
                   HandFrame, TrackedFrame, at_tracker_precision, bone_centres, bone_lengths, displacement,
                   hand_frame, hand_jumped, hands_record, is_jump, jumped, phalanx_mask, side_slots, slot, slot_name)

__all__ = [
    "BONES", "BONES_PER_HAND", "DIGITS", "HANDS", "JUMP_DISTANCE", "MAX_BONE_WIDTH", "MAX_REACH",
    "MIN_PHALANX_LENGTH", "N_BONES", "N_DIGITS", "POINTS", "SIDES", "SLOTS", "SLOT_DIGIT", "TRACKER_FLOAT",
    "Hand", "HandFrame", "TrackedFrame", "at_tracker_precision", "bone_centres", "bone_lengths", "displacement",
    "hand_frame", "hand_jumped", "hands_record", "is_jump", "jumped", "phalanx_mask", "side_slots", "slot",
    "slot_name",
]
