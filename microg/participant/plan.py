"""The pick-and-place plan a simulated participant carries out: plain data the study engine fills in.

The task (paper, section 4.3): pick the object from its start, carry it to places 1, 2 and 3 and
hold it at each for ``hold_s`` (a place counts while the object's centre is within
``place_radius`` of it), then release it. Positions are in the world (Leap device) frame, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from microg.sim.hand import SIDES

Point = tuple[float, float, float]


def _point(where: str, value) -> Point:
    try:
        point = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{where} = {value!r}: must be three numbers (m)") from None
    if len(point) != 3 or not all(math.isfinite(v) for v in point):
        raise ValueError(f"{where} = {value!r}: must be three finite numbers (m)")
    return point


@dataclass(frozen=True)
class PickPlacePlan:
    """What the participant is asked to do.

    ``release_position``: where to carry the object after the third hold before letting go;
    None releases it at the third place. ``hand_start``: where the hand waits at the start;
    None puts it 10 cm above and 12 cm nearer the user than the object.
    """

    object_name: str
    places: tuple[Point, Point, Point]
    hold_s: float = 3.0
    place_radius: float = 0.03
    release_position: Point | None = None
    hand_start: Point | None = None
    side: str = "right"

    def __post_init__(self) -> None:
        if not isinstance(self.object_name, str) or not self.object_name:
            raise ValueError(f"PickPlacePlan.object_name = {self.object_name!r}: must name an object in the world")
        places = tuple(self.places)
        if len(places) != 3:
            raise ValueError(f"PickPlacePlan.places has {len(places)} places: the task has exactly 3")
        object.__setattr__(self, "places", tuple(_point(f"PickPlacePlan.places[{i}]", p) for i, p in enumerate(places)))
        for name in ("hold_s", "place_radius"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"PickPlacePlan.{name} = {value!r}: must be a positive number")
        for name in ("release_position", "hand_start"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _point(f"PickPlacePlan.{name}", getattr(self, name)))
        if self.side not in SIDES:
            raise ValueError(f"PickPlacePlan.side = {self.side!r}: must be one of {SIDES}")


@dataclass(frozen=True)
class TaskDisplay:
    """What the participant sees of the task besides the scene: the place marks and their timer,
    as the paper's system shows them ("the mark is highlighted and the timer is triggered").

    ``stage`` is one of manipulation, maintenance, release, completed, timeout; ``place`` is the
    index of the current place (3 once all are done); ``lit`` whether it is highlighted.
    """

    stage: str = "manipulation"
    place: int = 0
    lit: bool = False
    timer_s: float = 0.0
