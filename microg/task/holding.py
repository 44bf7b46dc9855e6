"""Holding, as every kind of task but the compiled pick-and-place judges it (``stages``' rule).

The object is held once the physics reports it grasped for ``grasp_settle_s`` without a break; a
hold ends once it is not grasped for ``drop_grace_s`` without a break (shorter breaks are the
flicker of contacts). A hold is taken to have begun when the grasp began, and to have ended when
the grasp went.
"""

from __future__ import annotations

from typing import NamedTuple

from .rules import TaskRules
from .stages import COMPLETED, FINAL

EPS = 1e-9
"""s: times that differ by less are equal (frame times are sums of float intervals)."""


class Holding(NamedTuple):
    held: bool = False
    grasp_since: float | None = None
    loose_since: float | None = None


class Change(NamedTuple):
    """What a frame did to the hold: when it began or ended (None: it did not)."""

    began: float | None = None
    ended: float | None = None


def hold(holding: Holding, t: float, grasped: bool, rules: TaskRules) -> tuple[Holding, Change]:
    """The hold after a frame at ``t`` in which the object was ``grasped`` (or not)."""
    if grasped:
        if holding.held:
            return Holding(True), Change()
        since = t if holding.grasp_since is None else holding.grasp_since
        if t - since >= rules.grasp_settle_s - EPS:
            return Holding(True), Change(began=since)
        return Holding(False, since), Change()
    if not holding.held:
        return Holding(), Change()
    since = t if holding.loose_since is None else holding.loose_since
    if t - since >= rules.drop_grace_s - EPS:
        return Holding(), Change(ended=since)
    return Holding(True, None, since), Change()


class Placeless:
    """What the session and the frame log read of a task's state, for a kind without places (the
    catch, the stop of a spin, the send): mixed into each kind's NamedTuple of fields, which has
    ``stage``, ``started``, ``ended`` and ``holding``."""

    __slots__ = ()
    place = 0
    """No places: what the frame log keeps of a place stays 0."""
    lit_since = None

    @property
    def held(self) -> bool:
        return self.holding.held

    @property
    def finished(self) -> bool:
        return self.stage in FINAL

    @property
    def completion_time(self) -> float | None:
        return self.ended - self.started if self.stage == COMPLETED else None

    def place_timer(self, t: float) -> float:
        """0: no places."""
        return 0.0
