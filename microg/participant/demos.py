"""The paper's demonstrations (section 4.2, Fig. 8) as scripted scenes, run with any interaction model.

    result = run_demo("ball-catch", "impulse_penetration")
    result.summary()        # grasped at the end, attempts, peak speed, deepest penetration

Each demo is one shipped object, a scripted hand and the world around them (zero g, or Earth's
gravity and a table). The hand is a ``probe_hand``: only the phalanges that do the work are
tracked, and they move along minimum-jerk paths (``motion.minimum_jerk``), so a demo shows one
interaction at a time and its outcome can be checked against the physics:

- ``ball-grasp``: thumb, index, middle and ring close round a floating ball and carry it.
- ``cube-grasp``: thumb against index and middle on a floating cube, carried.
- ``ball-catch``: a ball thrown at the still, open hand bounces off the middle fingertip, and
  thumb and index, closing behind it once it has passed between them, hold it.
- ``flat-grasp``: the flat cuboid held across its 1.5 cm, thumb below, index and middle above
  (with ``pinch``, the two objects of the paper's Fig. 7).
- ``pinch``: the long bar pinched across its 2.5 cm between thumb and index, carried.
- ``lift``: under Earth gravity, thumb, index and middle lift the cube off the table and hold it.
- ``nudge``: a fingertip taps a floating cube above its centre and pulls back; the cube drifts
  and turns with what the impulse gave it.
- ``pinch-carry``: thumb and index carry an object and let go (``microg sim demo``'s original).

The same script runs under every interaction model (a grasp under gravity squeezes as deep as the
model's static friction needs), so the models can be compared side by side (``microg sim
gallery``) as the paper compares its own with CLAP (Fig. 7). ``tests/participant/test_demos.py``
holds each demo to a physical criterion under the paper's model (``docs/demos.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from microg.paths import object_file
from microg.skeleton import N_BONES, N_DIGITS, SIDES, Hand, HandFrame, side_slots
from microg.sim import (PlacedObject, Scene, SceneError, TableParameters, World, compose_scene, grasped, highlighted,
                        load_object, make_world, rendered_phalanges, step)
from .motion import minimum_jerk
from .scripted import grip_and_carry, pinch_and_carry, probe_hand

EARTH_GRAVITY = 9.81
"""m/s^2, downward (-y): the paper's evaluation under Earth gravity."""
START = (0.0, 0.2, 0.0)
"""Where each demo's object starts (m): 20 cm above the tracker, as in the protocols."""
FINGER_WIDTH = 0.016
"""Width (m) of every scripted phalanx: a 16 mm fingertip, the middle of the Leap's range."""
SQUEEZE = 0.005
"""How far (m) a grasping phalanx presses into the object in zero g: enough for the penetration
springs (gamma = 100 N/m) to carry it without slipping."""
PAPER_GAMMA = 100.0
"""gamma of Eq. 16 (N/m): the paper's value, every demo scene's penetration stiffness."""
WEIGHT_MARGIN = 1.6
"""Under gravity a grasp squeezes this many times the depth at which static friction just holds
the weight."""
GRASP_SETTLE_S = 0.1
"""A grasp counts as a hold once it lasts this long (s): the paper protocol's ``grasp_settle_s``."""
DROP_GRACE_S = 0.25
"""A hold ends once the grasp is gone this long (s): the paper protocol's ``drop_grace_s``."""


@dataclass(frozen=True, eq=False)
class Demo:
    """A scripted scene: the object and its start, the world around it, the hand's path over time."""

    name: str
    description: str
    placed: PlacedObject
    path: Callable[[float], Mapping[str, np.ndarray]]
    """The scripted phalanges' centres (m) at a time (s): what ``probe_hand`` takes."""
    duration: float
    """Seconds of simulated time."""
    moments: tuple[tuple[str, float], ...]
    """The key moments (label, time in s) a picture of the demo shows, like the panels of Fig. 7."""
    hold: tuple[float, float] | None = None
    """The window (s) in which the script holds the object (a hold lost inside it is a drop); None
    for a demo that does not grasp."""
    gravity: float = 0.0
    """Downward gravity (m/s^2)."""
    table: TableParameters | None = None
    squeeze: float | None = None
    """How far (m) the grasping phalanges press past the surface; None for a demo without a grasp script."""

    def scene(self, interaction: str) -> Scene:
        """The demo's scene under the interaction model ``interaction``."""
        return compose_scene([self.placed], interaction, gravity=(0.0, -self.gravity, 0.0), table=self.table)

    def frame_times(self, rate: float) -> np.ndarray:
        """The hand frames' timestamps (s) at ``rate`` (Hz), from 0 to the end."""
        return np.arange(0.0, self.duration + 1e-9, 1.0 / rate)


@dataclass(frozen=True, eq=False)
class DemoRun:
    """A demo as it ran: the object's state and the hand's at every hand frame (F frames)."""

    demo: Demo
    interaction: str
    t: np.ndarray
    """(F,) frame times (s)."""
    position: np.ndarray
    """(F, 3) object centre (m)."""
    orientation: np.ndarray
    """(F, 4) object orientation (w, x, y, z)."""
    velocity: np.ndarray
    """(F, 3) m/s."""
    angular_velocity: np.ndarray
    """(F, 3) rad/s, world frame."""
    joints: np.ndarray
    """(F, 2, 5, 5, 3) the tracked hands' joints as the script delivered them, left first; NaN where
    untracked (the whole left hand, and the right hand's bones the script does not move)."""
    widths: np.ndarray
    """(F, 2, 5, 4) their bone widths."""
    hand_velocity: np.ndarray
    """(F, 3) the mean velocity of the tracked phalanges, as the physics takes it from the frames."""
    rendered: np.ndarray
    """(F, 40, 3) rendered (god-object) phalanx centres, slot order; NaN where untracked."""
    touching: np.ndarray
    """(F, 40) phalanges in contact with the object (the highlighted hand)."""
    grasped: np.ndarray
    """(F,) held between the thumb and an opposing digit (``microg.sim.grasped``)."""
    digits: np.ndarray
    """(F,) how many digits touch the object."""
    depth: np.ndarray
    """(F,) the deepest any tracked phalanx is inside the object (m); 0 without contact."""

    def index_at(self, t: float) -> int:
        """The last frame at or before ``t`` (s)."""
        return max(0, int(np.searchsorted(self.t, t + 1e-9, side="right")) - 1)

    def window(self, start: float, end: float) -> np.ndarray:
        """(F,) True for the frames from ``start`` to ``end`` (s)."""
        return (self.t >= start - 1e-9) & (self.t <= end + 1e-9)

    @property
    def attempts(self) -> int:
        """Holds lost before the script lets go (``count_attempts``: the protocol's rule)."""
        if self.demo.hold is None:
            return 0
        return count_attempts(self.t, self.grasped, self.demo.hold[1])

    def summary(self) -> dict[str, object]:
        """One row of ``gallery.csv``: held at the end, attempts, peak object speed, deepest penetration."""
        return {"demo": self.demo.name, "interaction": self.interaction, "grasped": bool(self.grasped[-1]),
                "attempts": self.attempts,
                "peak_object_speed_m_s": float(np.linalg.norm(self.velocity, axis=1).max()),
                "deepest_penetration_mm": float(self.depth.max() * 1e3)}


def count_attempts(t: np.ndarray, grasped: np.ndarray, until: float) -> int:
    """Holds lost before ``until``, by the protocol's rule.

    A hold begins once the grasp has lasted ``GRASP_SETTLE_S`` and ends once it has been gone
    ``DROP_GRACE_S``: shorter breaks are the flicker of contacts, not a drop.

    Parameters
    ----------
    t
        (F,) frame times (s).
    grasped
        (F,) whether the object is grasped at each frame.
    until
        A hold whose grasp went at or after this time (s) was let go on purpose, not dropped.

    Returns
    -------
    int
        The number of attempts (drops).
    """
    attempts, held, since = 0, False, None
    for time, now in zip(t, grasped):
        if bool(now) == held:
            since = None
            continue
        since = time if since is None else since
        if time - since >= (DROP_GRACE_S if held else GRASP_SETTLE_S) - 1e-9:
            if held and since < until:
                attempts += 1
            held, since = not held, None
    return attempts


def _shipped(name: str, position: Sequence[float] = START, **state) -> PlacedObject:
    return PlacedObject(load_object(object_file(name)), tuple(float(x) for x in position), **state)


def _hold_depth(placed: PlacedObject, gravity: float, interaction: str) -> float:
    """How deep a grasp squeezes: ``SQUEEZE``, or under gravity deep enough that static friction
    holds the weight with ``WEIGHT_MARGIN`` (Eq. 19: thumb and the fingers opposing it share m g
    when 2 mu gamma depth >= m g). The soft hand has no static friction to size it by and squeezes
    ``SQUEEZE``."""
    spec = placed.spec
    if not gravity or interaction == "soft_hand":
        return SQUEEZE
    needed = spec.mass * gravity / (2 * spec.material.static_friction * PAPER_GAMMA)
    return max(SQUEEZE, WEIGHT_MARGIN * needed)


def _box_contact(half_extents: np.ndarray, normal: Sequence[float], along: Sequence[float] = (0.0, 0.0, 0.0)):
    """A contact on the box face with outward ``normal`` (a unit axis): the point ``along`` from the
    face's centre, and the normal."""
    normal = np.asarray(normal, dtype=float)
    return np.asarray(along, dtype=float) + normal * half_extents, normal


def _sphere_contact(radius: float, azimuth_deg: float):
    """A contact on a sphere's horizontal equator, ``azimuth_deg`` from +x toward +z: the point and
    the outward normal."""
    angle = np.radians(azimuth_deg)
    normal = np.array([np.cos(angle), 0.0, np.sin(angle)])
    return radius * normal, normal


APPROACH, CLOSE, SETTLE, CARRY, HOLD = 0.5, 0.5, 0.3, 1.0, 1.0
"""A grasp demo's timeline (s): come down open, close, settle, carry, hold (``grip_and_carry``)."""


def _grip_demo(name: str, description: str, placed: PlacedObject, contacts, carry: Sequence[float],
               depth: float = SQUEEZE, gravity: float = 0.0, table: TableParameters | None = None) -> Demo:
    """A grasp that comes down and closes on ``contacts``, carries the object by ``carry`` and holds
    it: held from the moment the hand has closed to the end."""
    path, end = grip_and_carry(placed.position, contacts, carry, depth, APPROACH, CLOSE, SETTLE, CARRY, HOLD,
                               release=False, width=FINGER_WIDTH)
    closed = APPROACH + CLOSE
    moments = (("start", 0.0), ("closed", closed), ("carrying", closed + SETTLE + CARRY / 2),
               ("carried", closed + SETTLE + CARRY), ("end", end))
    return Demo(name, description, placed, path, end, moments, hold=(closed, end), gravity=gravity, table=table,
                squeeze=depth)


def _thumb_against_two(half_extents: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The thumb on a box's -x face, index and middle side by side (3 cm apart) on its +x face."""
    return {"thumb.distal": _box_contact(half_extents, (-1, 0, 0)),
            "index.distal": _box_contact(half_extents, (1, 0, 0), (0, 0, 0.015)),
            "middle.distal": _box_contact(half_extents, (1, 0, 0), (0, 0, -0.015))}


def _ball_grasp(interaction: str) -> Demo:
    ball = _shipped("ball")
    r = ball.spec.half_extents[0]
    contacts = {"thumb.distal": _sphere_contact(r, 180.0), "index.distal": _sphere_contact(r, 40.0),
                "middle.distal": _sphere_contact(r, 0.0), "ring.distal": _sphere_contact(r, -40.0)}
    return _grip_demo("ball-grasp", "thumb, index, middle and ring close round a floating ball and carry it "
                      "10 cm sideways and 5 cm up", ball, contacts, (0.10, 0.05, 0.0))


def _cube_grasp(interaction: str) -> Demo:
    cube = _shipped("cube")
    contacts = _thumb_against_two(cube.spec.half_extents)
    return _grip_demo("cube-grasp", "the thumb against index and middle on a floating cube, carried 10 cm "
                      "sideways and 5 cm up", cube, contacts, (0.10, 0.05, 0.0))


def _pinch(interaction: str) -> Demo:
    bar = _shipped("long_cuboid")
    half = bar.spec.half_extents
    contacts = {"thumb.distal": _box_contact(half, (0, 0, -1)), "index.distal": _box_contact(half, (0, 0, 1))}
    return _grip_demo("pinch", "the long bar pinched across its 2.5 cm between thumb and index, carried 10 cm "
                      "sideways and 5 cm up", bar, contacts, (0.10, 0.05, 0.0))


def _flat_grasp(interaction: str) -> Demo:
    plate = _shipped("flat_cuboid")
    half = plate.spec.half_extents
    contacts = {"thumb.distal": _box_contact(half, (0, -1, 0)),
                "index.distal": _box_contact(half, (0, 1, 0), (0.015, 0, 0)),
                "middle.distal": _box_contact(half, (0, 1, 0), (-0.015, 0, 0))}
    return _grip_demo("flat-grasp", "the flat cuboid held across its 1.5 cm, the thumb below, index and middle "
                      "above, carried 10 cm sideways and 5 cm up", plate, contacts, (0.10, 0.05, 0.0))


def _lift(interaction: str) -> Demo:
    cube = _shipped("cube")
    half = cube.spec.half_extents
    contacts = _thumb_against_two(cube.spec.half_extents)
    return _grip_demo("lift", "under Earth gravity, thumb, index and middle lift the cube 10 cm off the table "
                      "and hold it", cube, contacts, (0.0, 0.10, 0.0),
                      depth=_hold_depth(cube, EARTH_GRAVITY, interaction), gravity=EARTH_GRAVITY,
                      table=TableParameters(height=START[1] - half[1]))


NUDGE_SPEED = 0.2
"""m/s: the fingertip's speed when it taps the cube."""
NUDGE_HEIGHT = 0.015
"""m: how far above the cube's centre the fingertip taps it (so the tap also turns it)."""
NUDGE_FOLLOW = 0.02
"""s: the fingertip keeps its speed this long after it touches (two hand frames, so the frames
that carry the touch show the tap's full speed), then brakes."""
NUDGE_BRAKE = 0.05
"""s: the fingertip stops in this time with constant deceleration, then draws back 5 cm."""
NUDGE_GAP = 0.03
"""m: the fingertip starts this far from the cube's face."""


def _nudge(interaction: str) -> Demo:
    cube = _shipped("cube")
    start = np.array(START) + (-(cube.spec.half_extents[0] + FINGER_WIDTH / 2 + NUDGE_GAP), NUDGE_HEIGHT, 0.0)
    touch = NUDGE_GAP / NUDGE_SPEED
    brake = touch + NUDGE_FOLLOW
    stopped = brake + NUDGE_BRAKE
    reach = start[0] + NUDGE_SPEED * (brake + NUDGE_BRAKE / 2)

    def path(t: float) -> dict[str, np.ndarray]:
        if t <= brake:
            x = start[0] + NUDGE_SPEED * t
        elif t <= stopped:
            x = reach - NUDGE_SPEED * (stopped - t) ** 2 / (2 * NUDGE_BRAKE)
        else:
            x = reach - 0.05 * minimum_jerk((t - stopped) / 0.5)
        return {"index.distal": np.array([x, start[1], start[2]])}

    end = 2.0
    return Demo("nudge", f"a fingertip taps a floating cube {NUDGE_HEIGHT * 100:g} cm above its centre at "
                f"{NUDGE_SPEED:g} m/s and draws back; the cube drifts and turns", cube, path, end,
                (("start", 0.0), ("tap", touch), ("drawn back", stopped + 0.5), ("end", end)))


THROW_SPEED = 0.3
"""m/s: how fast the ball is thrown at the hand."""
ARRIVAL = 0.5
"""s: when the thrown ball reaches the middle fingertip."""
GATE = 0.01
"""m: how far in front of the middle fingertip's catch point the thumb and index close, so that
closed they hold the ball against the middle finger."""
CATCH_CLEARANCE = 0.01
"""m: the gap the open thumb and index leave on each side of the ball flying between them."""
GATE_CLOSE = 0.12
"""s: how long the thumb and index take to close."""


def _ball_catch(interaction: str) -> Demo:
    """The ball flies along -x at ``THROW_SPEED`` between the open thumb (+z) and index (-z) onto the
    middle fingertip; thumb and index close behind it once its centre has passed between them."""
    ball_radius = load_object(object_file("ball")).half_extents[0]
    reach = ball_radius + FINGER_WIDTH / 2
    catch_point = np.array(START)
    ball = _shipped("ball", catch_point + (THROW_SPEED * ARRIVAL, 0.0, 0.0), velocity=(-THROW_SPEED, 0.0, 0.0))
    closed = np.sqrt((reach - SQUEEZE) ** 2 - GATE ** 2)
    opened = reach + CATCH_CLEARANCE
    closing = ARRIVAL - GATE / THROW_SPEED

    def path(t: float) -> dict[str, np.ndarray]:
        z = opened + (closed - opened) * minimum_jerk((t - closing) / GATE_CLOSE)
        return {"thumb.distal": catch_point + (GATE, 0.0, z), "index.distal": catch_point + (GATE, 0.0, -z),
                "middle.distal": catch_point - (reach, 0.0, 0.0)}

    end = 3.0
    return Demo("ball-catch", f"a ball thrown at {THROW_SPEED:g} m/s at the still, open hand bounces off the middle "
                "fingertip, and thumb and index close behind it and hold it", ball, path, end,
                (("start", 0.0), ("arriving", closing), ("bounced", ARRIVAL + 0.05), ("caught", closing + GATE_CLOSE),
                 ("end", end)), hold=(closing + GATE_CLOSE, end), squeeze=SQUEEZE)


PINCH_CARRY_TIMES = {"approach": 0.5, "close": 0.5, "hold": 0.3, "move": 1.5}
"""pinch-carry's timeline (s): ``pinch_and_carry``'s."""


def _pinch_carry(interaction: str, gravity: float = 0.0, object_name: str = "cube") -> Demo:
    """``microg sim demo``'s original: thumb and index pinch an object's sides, carry it 15 cm sideways
    and 10 cm up and let go; under gravity the object starts on a table."""
    placed = _shipped(object_name)
    depth = _hold_depth(placed, gravity, interaction)
    path, released = pinch_and_carry(placed.position, placed.spec.half_extents[0], carry=(0.15, 0.10, 0.0),
                                     depth=depth, width=FINGER_WIDTH, **PINCH_CARRY_TIMES)
    times = PINCH_CARRY_TIMES
    closed = times["approach"] + times["close"]
    carried = closed + times["hold"] + times["move"]
    opens = carried + times["hold"]
    end = released + 1.0
    moments = (("start", 0.0), ("closed", closed), ("carrying", closed + times["hold"] + times["move"] / 2),
               ("carried", carried), ("let go", released), ("end", end))
    table = TableParameters(height=START[1] - placed.spec.half_extents[1]) if gravity else None
    return Demo("pinch-carry", f"thumb and index pinch the {object_name}, carry it 15 cm sideways and 10 cm up and "
                "let go", placed, path, end, moments, hold=(closed, opens), gravity=gravity, table=table, squeeze=depth)


DEMOS: dict[str, Callable[..., Demo]] = {"ball-grasp": _ball_grasp, "cube-grasp": _cube_grasp, "flat-grasp": _flat_grasp,
                                         "ball-catch": _ball_catch, "pinch": _pinch, "lift": _lift, "nudge": _nudge,
                                         "pinch-carry": _pinch_carry}
"""Every demo by name, each built for an interaction model: the same script for every model, except
that a grasp under gravity squeezes as deep as the model's static friction needs (``_hold_depth``)."""


def make_demo(name: str, interaction: str = "impulse_penetration", **options) -> Demo:
    """The demo called ``name``, scripted for ``interaction``.

    Parameters
    ----------
    name
        A demo of ``DEMOS``.
    interaction
        The interaction model it will run under (a grasp under gravity squeezes as deep as the
        model's static friction needs).
    **options
        ``gravity`` (m/s^2) and ``object_name`` (a shipped object), for ``pinch-carry`` only.

    Returns
    -------
    Demo
        The scene's parts and the hand's script.

    Raises
    ------
    SceneError
        For an unknown demo, or options given to a demo that fixes its object and gravity.
    """
    if name not in DEMOS:
        raise SceneError(f"demo {name!r}: must be one of {list(DEMOS)}")
    if options and name != "pinch-carry":
        raise SceneError(f"demo {name!r} fixes its object and gravity; {sorted(options)[0]} is for pinch-carry only")
    return DEMOS[name](interaction, **options)


def run_demo(name: str, interaction: str = "impulse_penetration", **options) -> DemoRun:
    """Run demo ``name`` (``DEMOS``) under ``interaction`` and record every hand frame.

    Parameters
    ----------
    name
        A demo of ``DEMOS``.
    interaction
        An interaction model: ``impulse_penetration`` (the paper's), ``penetration_only`` or
        ``soft_hand``.
    **options
        ``gravity`` (m/s^2) and ``object_name`` (a shipped object), for ``pinch-carry`` only.

    Returns
    -------
    DemoRun
        The object's state, the tracked and rendered hand, contacts and grasp at every frame.
    """
    demo = make_demo(name, interaction, **options)
    world = make_world(demo.scene(interaction))
    times = demo.frame_times(world.model.scene.tracking_rate)
    frames = []
    for t in times:
        hand = probe_hand(demo.path(float(t)), width=FINGER_WIDTH)
        world = step(world, HandFrame(float(t), (hand,)))
        frames.append(_record(world, hand))
    columns = {key: np.array([frame[key] for frame in frames]) for key in frames[0]}
    return DemoRun(demo, interaction, times, **columns)


def _record(world: World, hand: Hand) -> dict[str, object]:
    """What a frame of the world shows of the demo's one object and the scripted right hand."""
    data = world.data
    right = side_slots(SIDES.index("right"))
    touching = data.active[:, 0]
    joints = np.full((len(SIDES),) + hand.joints.shape, np.nan)
    widths = np.full((len(SIDES),) + hand.widths.shape, np.nan)
    joints[SIDES.index(hand.side)], widths[SIDES.index(hand.side)] = hand.joints, hand.widths
    return {"position": data.position[0].copy(), "orientation": data.orientation[0].copy(),
            "velocity": data.velocity[0].copy(), "angular_velocity": data.angular_velocity[0].copy(),
            "joints": joints, "widths": widths,
            "hand_velocity": data.hand_velocity[right][data.valid[right]].mean(axis=0),
            "rendered": rendered_phalanges(world), "touching": highlighted(world), "grasped": bool(grasped(world)[0]),
            "digits": int(touching[right].reshape(N_DIGITS, N_BONES).any(axis=1).sum()),
            "depth": float(data.depth[:, 0][touching].max(initial=0.0))}
