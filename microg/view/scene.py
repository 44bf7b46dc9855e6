"""What one logged frame looks like: plain geometry that the browser view and the picture export
both draw, so the two show the same thing.

A hand is drawn as 20 capsules, one per bone of the Leap skeleton (bone ``b`` of digit ``d`` runs
from joint ``b`` to joint ``b + 1``, radius ``width / 2``, the phalanx sphere's radius). The
*tracked* hand is the skeleton as the source delivered it; the *rendered* (god-object) hand moves
each bone so that its centre is the logged rendered phalanx centre: out of contact the two agree,
in contact the rendered phalanx stays on the object's surface while the tracked one may sink in
(paper, section 3.3, Fig. 6). Phalanges whose ``touching`` bit is set are drawn in the highlight
colour (the paper's highlighted hand avatar, Fig. 1).

Places are rings of the protocol's ``place_radius`` around each place: grey until they are the
current target, white while the object is on its way there, yellow while lit (the object is held
inside and the place's timer runs), green once done (Fig. 9). Only a pick-and-place has places; the
zone a send's object must reach (its target) or a handover's (its place) is two crossed rings of
its radius about its centre, in its own colour.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from microg.skeleton import SIDES, side_slots
from microg.study.protocol import Protocol
from microg.task import KINDS, PICK_AND_PLACE

HAND_MODES = ("rendered", "tracked", "both")
"""Which hands to draw: the rendered (god-object) hand, the tracked one, or both (tracked faint)."""
PLACE_STATES = ("pending", "next", "lit", "done")

PALETTE = {
    "rendered": (70, 125, 235),      # the rendered hand: blue
    "highlight": (235, 40, 180),     # a phalanx in contact: magenta
    "tracked": (150, 160, 175),      # the tracked hand: grey (faint when both are shown)
    "object": (205, 120, 45),        # light hardwood
    "table": (200, 200, 196),
    "pending": (150, 150, 150),      # a place not yet the target
    "next": (245, 245, 245),         # the current target, not reached
    "lit": (255, 215, 0),            # the object held in the target: its timer runs
    "done": (40, 185, 70),           # held there for hold_s
    "target": (40, 190, 230),        # a send's target zone: cyan
}
"""Colours (RGB 0-255), chosen to be told apart by hue, in a picture as in a screenshot."""
TRACKED_OPACITY = 0.35
"""Opacity of the tracked hand when both hands are shown."""
TRACKED_THINNER = 0.8
"""With both hands shown, the tracked bones are drawn this much thinner, so they show only where
they leave the rendered hand (into the object)."""


@dataclass(frozen=True)
class Capsules:
    """Line segments with a radius; rows of NaN are not drawn (an untracked bone or hand)."""

    start: np.ndarray
    """(K, 3) one end (m)."""
    end: np.ndarray
    """(K, 3) the other end (m)."""
    radius: np.ndarray
    """(K,) radius (m)."""

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (self.start + self.end)

    @property
    def drawn(self) -> np.ndarray:
        """(K,) True where the capsule is known and has a positive radius."""
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.start).all(1) & np.isfinite(self.end).all(1) & (self.radius > 0)


@dataclass(frozen=True)
class HandValues:
    """One side's hand in a logged frame (``microg.study.framelog.FRAME``), in float64."""

    joints: np.ndarray
    """(5, 5, 3)"""
    widths: np.ndarray
    """(5, 4)"""
    palm_position: np.ndarray
    palm_orientation: np.ndarray
    rendered: np.ndarray
    """(20, 3) rendered (god-object) phalanx centres; NaN where untracked."""


def hand_values(frame: np.ndarray, side: int) -> HandValues:
    """Side ``side``'s hand in a logged frame record (all NaN for an untracked hand)."""
    return HandValues(*(frame[field][side].astype(np.float64) for field in
                        ("joints", "widths", "palm_position", "palm_orientation", "rendered")))


def tracked_bones(hand: HandValues) -> Capsules:
    """The 20 bones of the tracked skeleton, digit-major (the physics' slot order)."""
    return Capsules(hand.joints[:, :-1].reshape(-1, 3), hand.joints[:, 1:].reshape(-1, 3),
                    0.5 * hand.widths.reshape(-1))


def rendered_bones(hand: HandValues) -> Capsules:
    """The tracked bones, each moved so its centre is the rendered phalanx centre. A bone that is
    no phalanx (the thumb's zero-length metacarpal, an untracked bone) has no rendered centre and
    is not drawn."""
    tracked = tracked_bones(hand)
    shift = hand.rendered - tracked.centre
    return Capsules(tracked.start + shift, tracked.end + shift, tracked.radius)


def both_sides(capsules: list[Capsules]) -> Capsules:
    """The left and right hands' capsules as one set of 40, in slot order."""
    return Capsules(*(np.concatenate([getattr(c, f) for c in capsules]) for f in ("start", "end", "radius")))


def world_scene(t: float, *, object_position, object_orientation, joints: np.ndarray, widths: np.ndarray,
                rendered: np.ndarray, touching: np.ndarray, held: bool) -> FrameScene:
    """What a world shows that no study logged (a scripted demo): the object, the tracked hand as its
    source delivered it (``joints`` (2, 5, 5, 3) and ``widths`` (2, 5, 4), left first; NaN where
    untracked), the rendered phalanx centres (40, 3) and the phalanges in contact (40,), in slot
    order. There is no task: no places, no task timer, no attempts."""
    hands = [HandValues(joints[side], widths[side], np.full(3, np.nan), np.full(4, np.nan),
                        rendered[side_slots(side)]) for side in range(len(SIDES))]
    return FrameScene(t=t, stage="", place=0, place_lit=False, place_timer=0.0, held=held, attempts=0,
                      object_position=np.asarray(object_position, dtype=np.float64),
                      object_orientation=np.asarray(object_orientation, dtype=np.float64),
                      tracked=both_sides([tracked_bones(h) for h in hands]),
                      rendered=both_sides([rendered_bones(h) for h in hands]),
                      touching=np.asarray(touching, dtype=bool), places=())


def place_states(current: int, lit: bool, n_places: int) -> tuple[str, ...]:
    """The state of each place marker when ``current`` places are done (the index of the target)
    and the target is ``lit`` or not."""
    return tuple("done" if k < current else ("lit" if lit else "next") if k == current else "pending"
                 for k in range(n_places))


def bone_colours(touching: np.ndarray, base: str) -> np.ndarray:
    """(40, 3) uint8: the highlight colour where a phalanx touches, ``base`` elsewhere."""
    colours = np.tile(np.array(PALETTE[base], dtype=np.uint8), (len(touching), 1))
    colours[touching] = PALETTE["highlight"]
    return colours


def z_to_direction(direction: np.ndarray) -> np.ndarray:
    """(K, 4) unit quaternions (w, x, y, z) turning the z axis onto each (K, 3) direction; the
    identity for a zero or unknown direction."""
    d = np.asarray(direction, dtype=np.float64)
    length = np.linalg.norm(d, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(length > 1e-12, d / length, [0.0, 0.0, 1.0])
    unit = np.where(np.isfinite(unit), unit, [0.0, 0.0, 1.0])
    # half-way quaternion: (1 + z.u, z x u), normalised; opposite to z: a half turn about x
    q = np.column_stack([1.0 + unit[:, 2], -unit[:, 1], unit[:, 0], np.zeros(len(unit))])
    opposite = q[:, 0] < 1e-9
    q[opposite] = (0.0, 1.0, 0.0, 0.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@dataclass(frozen=True)
class FrameScene:
    """Everything drawn for one frame of a task run."""

    t: float
    """Seconds since the run's first frame (the task timer)."""
    stage: str
    place: int
    """The current place's index (= places done)."""
    place_lit: bool
    place_timer: float
    held: bool
    attempts: int
    """Attempts so far (what the task's kind counts)."""
    object_position: np.ndarray
    object_orientation: np.ndarray
    """(w, x, y, z)"""
    tracked: Capsules
    """(40) slot order: left hand 0-19, right hand 20-39."""
    rendered: Capsules
    touching: np.ndarray
    """(40,) bool"""
    places: tuple[str, ...]
    """State of each place marker (``PLACE_STATES``)."""


def hud_lines(scene: FrameScene, layout: TaskLayout) -> list[str]:
    """The heads-up display: stage, task timer, place and its timer (a pick-and-place's), whether
    the object is held, attempts (by what the task's kind counts)."""
    n_places = len(layout.places)
    holding = "holding" if scene.held else "not holding"
    if not n_places:
        place = holding
    elif scene.place_lit:
        place = f"place {scene.place + 1} lit: {scene.place_timer:.1f} / {layout.hold_s:g} s · {holding}"
    elif scene.place < n_places:
        place = f"place {scene.place + 1} of {n_places}: not reached · {holding}"
    else:
        place = f"all {n_places} places done · {holding}"
    return [f"{scene.stage} · {scene.t:.1f} s", place, f"attempts ({KINDS[layout.kind].attempts}): {scene.attempts}"]


@dataclass(frozen=True)
class TaskLayout:
    """What stays put during a task: the object's shape, its kind's marks (a pick-and-place's places,
    a send's target zone), the table, and what a view frames."""

    shape: str
    """``box``, ``sphere`` or ``mesh``."""
    size: np.ndarray
    """Box: edge lengths; sphere: (diameter,) * 3; mesh: its extent along the body axes (m)."""
    start: np.ndarray
    places: np.ndarray
    """(P, 3)"""
    place_radius: float
    hold_s: float
    table_height: float | None
    table_centre: np.ndarray
    """Centre of the table top (m)."""
    table_size: np.ndarray
    """Edge lengths of the table slab (m)."""
    surface: tuple[np.ndarray, np.ndarray] | None = None
    """A mesh object's surface in its body frame: vertices (V, 3) and triangles (F, 3)."""
    kind: str = PICK_AND_PLACE
    """The task's kind (``microg.task.KINDS``): only a kind whose view shows places has ``places``."""
    target: np.ndarray | None = None
    """The centre (m) of the zone the object must reach: a send's target, a handover's place; None
    for the other kinds."""
    target_radius: float = 0.0
    workspace: np.ndarray | None = None
    """(P, 3) what a view frames (None: the start and the places): the start, the protocol's places,
    the sides of its send's target zone and its handover's place zone, and the start of its catch's
    path, so that the view stays put from one task to the next."""


TABLE_MARGIN = 0.12
TABLE_DEPTH = 0.30
TABLE_THICKNESS = 0.02
DEMO_TABLE_HALF_WIDTH = 0.20
"""Half the width (m) of the table drawn under a scene without a task."""
CAMERA_MARGIN = 0.05
"""Space (m) the default camera leaves around the start and the places."""
CATCH_PATH_VIEWED = 0.2
"""How much (m) of a launch path from the start a view frames: where the hand meets the object."""
RING_TUBE = 0.003
"""Radius of a place ring's tube (m)."""


def task_layout(protocol: Protocol, object_name: str, phase: str | None = None) -> TaskLayout:
    """The layout of a task with ``object_name`` in ``phase`` (None: a pick-and-place): its start
    pose and its kind's marks (the protocol's places, or a send's or a handover's zone), with a
    table under the start and the places when the protocol has one."""
    spec, task = protocol.object(object_name).spec, protocol.task
    kind = KINDS[protocol.kind(phase) if phase is not None else PICK_AND_PLACE]
    start = np.asarray(protocol.start_pose(object_name)[0], dtype=np.float64)
    places = np.asarray(task.places, dtype=np.float64)
    given = [k for k in KINDS.values() if k.table is None or getattr(task, k.name) is not None]  # kinds it can run
    zones = {k.name: k.view.zone(task) for k in given if k.view.zone is not None}
    sides = [np.asarray(centre) + offset for centre, radius in zones.values()
             for offset in radius * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])]
    path = [start + CATCH_PATH_VIEWED * np.asarray(k.view.path(task)) for k in given if k.view.path is not None]
    workspace = np.vstack([start, places, *sides, *path])
    xs = np.concatenate([[start[0]], places[:, 0]])
    height = protocol.table_height
    centre = np.array([0.5 * (xs.min() + xs.max()), height if height is not None else np.nan, start[2]])
    size = np.array([xs.max() - xs.min() + 2 * TABLE_MARGIN, TABLE_THICKNESS, TABLE_DEPTH])
    zone = zones.get(kind.name)
    return TaskLayout(spec.shape, np.asarray(spec.size, dtype=np.float64), start,
                      places if kind.view.places else np.empty((0, 3)), task.place_radius, task.hold_s, height,
                      centre, size, surface_of(spec), kind.name,
                      None if zone is None else np.asarray(zone[0], dtype=float), 0.0 if zone is None else zone[1],
                      workspace)


def surface_of(spec) -> tuple[np.ndarray, np.ndarray] | None:
    """A mesh object's surface to draw (None for a box or a sphere)."""
    return None if spec.mesh is None else (spec.mesh.vertices, spec.mesh.faces)


def object_layout(spec, start, table_height: float | None = None) -> TaskLayout:
    """The layout of a scene without a task (a scripted demo): one object that starts at ``start``,
    no places, and a table of the task's depth and 40 cm wide under it when ``table_height`` is given."""
    start = np.asarray(start, dtype=np.float64)
    centre = np.array([start[0], table_height if table_height is not None else np.nan, start[2]])
    return TaskLayout(spec.shape, np.asarray(spec.size, dtype=np.float64), start, np.empty((0, 3)), 0.0, 0.0,
                      table_height, centre, np.array([2 * DEMO_TABLE_HALF_WIDTH, TABLE_THICKNESS, TABLE_DEPTH]),
                      surface_of(spec))


@dataclass(frozen=True)
class Camera:
    """A pinhole camera looking at ``target`` from ``eye``, y up; ``fov_deg`` is the vertical field."""

    eye: np.ndarray
    target: np.ndarray
    fov_deg: float = 40.0


def default_camera(layout: TaskLayout, aspect: float = 4 / 3, fov_deg: float = 40.0) -> Camera:
    """The participant's side of the scene, a little from above (y up, +z toward the participant),
    just far enough back that the layout's workspace (the start and every place, and a send's
    target), with a margin, fill a view of ``aspect`` (width / height)."""
    points = np.vstack([layout.start, layout.places]) if layout.workspace is None else layout.workspace
    return framing_camera(points, layout.place_radius + CAMERA_MARGIN, aspect, fov_deg)


def framing_camera(points, margin: float, aspect: float = 4 / 3, fov_deg: float = 40.0) -> Camera:
    """The participant's side of the scene, a little from above (y up, +z toward the participant),
    just far enough back that ``points`` (P, 3), with ``margin`` (m) round them, fill a view of
    ``aspect`` (width / height)."""
    points = np.asarray(points, dtype=np.float64)
    target = 0.5 * (points.min(axis=0) + points.max(axis=0))
    half = 0.5 * (points.max(axis=0) - points.min(axis=0)) + margin
    tangent = np.tan(np.radians(fov_deg) / 2)
    direction = np.array([0.0, 0.7, 1.0]) / np.linalg.norm([0.0, 0.7, 1.0])
    distance = max(half[1] / tangent, half[0] / (tangent * aspect)) + half[2]
    return Camera(target + distance * direction, target, fov_deg)


def ring_mesh(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of a place marker: a thin ring of ``radius`` around the origin, facing z
    (toward the participant)."""
    import trimesh

    ring = trimesh.creation.torus(major_radius=radius, minor_radius=RING_TUBE, major_sections=48, minor_sections=8)
    return np.asarray(ring.vertices), np.asarray(ring.faces)
