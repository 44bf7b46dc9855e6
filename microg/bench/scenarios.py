"""The benchmark scenes as plain data, their scripted hands, and their independent answers.

Every engine (ours, MuJoCo, PyBullet) builds the same scenes from these numbers: the same boxes
(size, mass, inertia, restitution, friction), the same fingertip spheres following the same paths.
Nothing here imports an engine.

- ``IMPACT``: a fingertip hits the long bar's top face off-centre at 1 m/s. Answer: Newton's impact
  law, the bar takes the impulse j = (1 + e) u / (n^T K n) (paper, Eq. 14) and nothing more.
- ``TUMBLE``: the long bar spun near its intermediate axis drifts free for 60 s. Answer: |L| and
  the kinetic energy are conserved; the body-frame angular velocity follows Euler's equations,
  solved by ``solve_ivp`` (DOP853) at tolerances far below any engine's error.
- ``SHAKE``: thumb and index pinch the cube and shake it 4 cm at 2 Hz along the contact faces.
  Answer: static friction can carry the cube (2 mu gamma delta > m a_max), so the undisturbed
  trajectory keeps the cube where the grasp holds it: any lasting offset is slip. Tracking lag
  and tracking error are measured against the true (noise-free) hand path.
- ``LIVE`` and ``HOLD``: the paper's scene for time per step, a 19-sphere hand closing on the cube
  and carrying it (``LIVE``) or holding it still (``HOLD``). Equal work is checked by geometry
  (``LiveScene.overlaps``): how many spheres touch the cube, and where the cube is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.integrate import solve_ivp

FINGER_RADIUS = 0.008
"""m: fingertip sphere radius (a 16 mm wide distal phalanx)."""
HAND_MASS = 1000.0
"""kg: peers drive a sphere this heavy kinematically (pose and velocity set every step)."""


@dataclass(frozen=True)
class Box:
    """A free box: full edge lengths (m), mass (kg), material; its principal axes are the body axes."""

    name: str
    size: tuple[float, float, float]
    mass: float
    restitution: float = 0.4
    static_friction: float = 0.8
    dynamic_friction: float = 0.5

    @property
    def half(self) -> np.ndarray:
        return 0.5 * np.asarray(self.size)

    @property
    def inertia(self) -> np.ndarray:
        x, y, z = self.size
        return self.mass / 12.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])


CUBE = Box("cube", (0.06, 0.06, 0.06), 0.1512)
FLAT = Box("flat_cuboid", (0.12, 0.015, 0.08), 0.1008)
BAR = Box("long_cuboid", (0.20, 0.04, 0.025), 0.14)
"""The shipped objects (``protocols/objects``), repeated here so peers need no TOML reader."""


def box_overlap(centre: np.ndarray, radius: float, position: np.ndarray, rotation: np.ndarray,
                half: np.ndarray) -> float:
    """How deep (m) a sphere reaches into a box; 0 when apart. Independent of every engine."""
    local = rotation.T @ (np.asarray(centre) - np.asarray(position))
    outside = np.abs(local) - half
    distance = np.linalg.norm(np.maximum(outside, 0.0)) + min(outside.max(), 0.0)
    return max(0.0, radius - distance)


def quat_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


@dataclass(frozen=True)
class Impact:
    """A fingertip straight down onto the bar's top face, ``offset`` m from its centre along x."""

    box: Box = BAR
    centre: tuple[float, float, float] = (0.0, 0.2, 0.0)
    speed: float = 1.0
    offset: float = 0.02
    """m: close enough to the centre that the bar outruns the finger (one impact, no second hit)."""
    lead: float = 0.1
    """s the finger travels before it touches: long enough for any window filter to settle."""
    duration: float = 0.2
    phase: float = 0.0
    """Where in a frame the touch falls, as a fraction of the frame period (``with_phase``)."""

    @property
    def normal_mass(self) -> float:
        """n^T K n for the hit (Eq. 12): 1/m + d^2 / I_zz for a vertical hit at x = d."""
        return 1.0 / self.box.mass + self.offset ** 2 / self.box.inertia[2]

    def finger(self, t: float, frame_period: float) -> np.ndarray:
        top = self.centre[1] + self.box.half[1]
        touch = self.lead + self.phase * frame_period
        return np.array([self.offset, top + FINGER_RADIUS + self.speed * (touch - t), 0.0])

    def restitution_error(self, linear_momentum_change: np.ndarray) -> float:
        """|e_effective - e| / e, e_effective from the impulse the box actually took."""
        j = -float(linear_momentum_change[1])
        effective = j * self.normal_mass / self.speed - 1.0
        return abs(effective - self.box.restitution) / self.box.restitution


@dataclass(frozen=True)
class Tumble:
    """The long bar spun near its intermediate (y) axis, free for ``duration`` s."""

    box: Box = BAR
    omega: tuple[float, float, float] = (0.2, 4.0, 0.1)
    """rad/s in the body frame at t = 0 (body = world at t = 0)."""
    duration: float = 60.0
    sample: float = 0.5

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.sample, self.duration + 1e-9, self.sample)

    def reference(self) -> np.ndarray:
        """(T, 3) body-frame angular velocity at ``times`` from Euler's equations (DOP853, rtol 1e-12)."""
        return _euler_reference(tuple(self.box.inertia), self.omega, self.duration, self.sample)

    def errors(self, momentum: np.ndarray, energy: np.ndarray, omega_body: np.ndarray) -> dict[str, float]:
        """Relative |L| and energy drift (max over time) and the body-rate error against ``reference``."""
        inertia, omega = self.box.inertia, np.asarray(self.omega)
        L0 = np.linalg.norm(inertia * omega)
        E0 = 0.5 * omega @ (inertia * omega)
        return {
            "L_drift": float(np.max(np.abs(np.linalg.norm(momentum, axis=1) - L0)) / L0),
            "E_drift": float(np.max(np.abs(energy - E0)) / E0),
            "omega_error": float(np.max(np.linalg.norm(omega_body - self.reference(), axis=1)) / np.linalg.norm(omega)),
        }


@lru_cache(maxsize=8)
def _euler_reference(inertia, omega, duration, sample) -> np.ndarray:
    inertia = np.asarray(inertia)

    def rhs(_, w):
        return np.array([(inertia[1] - inertia[2]) * w[1] * w[2] / inertia[0],
                         (inertia[2] - inertia[0]) * w[2] * w[0] / inertia[1],
                         (inertia[0] - inertia[1]) * w[0] * w[1] / inertia[2]])

    times = np.arange(sample, duration + 1e-9, sample)
    solution = solve_ivp(rhs, (0.0, duration), np.asarray(omega, dtype=float), method="DOP853",
                         t_eval=times, rtol=1e-12, atol=1e-14)
    return solution.y.T


@dataclass(frozen=True)
class Shake:
    """Thumb and index pinch the cube ``depth`` deep, then shake it along y (tangential to the faces).

    Timeline: the fingers close (``close`` s), hold (``hold`` s), shake ``cycles`` cycles at
    ``frequency`` with a one-cycle raised-cosine ramp at each end, then hold again. Tracking noise
    (white, ``noise`` m SD per axis per frame, one vector for the whole hand, seeded) rides on top.
    """

    box: Box = CUBE
    centre: tuple[float, float, float] = (0.0, 0.2, 0.0)
    depth: float = 0.010
    amplitude: float = 0.04
    frequency: float = 2.0
    cycles: int = 10
    close: float = 0.4
    hold: float = 1.0
    noise: float = 0.3e-3
    seed: int = 7

    @property
    def shake_start(self) -> float:
        return self.close + self.hold

    @property
    def shake_end(self) -> float:
        return self.shake_start + self.cycles / self.frequency

    @property
    def duration(self) -> float:
        return self.shake_end + self.hold

    def lateral(self, t: float) -> float:
        """The hand's true displacement along y."""
        if t <= self.shake_start or t >= self.shake_end:
            return 0.0
        s = t - self.shake_start
        ramp_time = 1.0 / self.frequency
        envelope = min(1.0, s / ramp_time, (self.shake_end - t) / ramp_time)
        envelope = 0.5 - 0.5 * math.cos(math.pi * envelope)
        return self.amplitude * envelope * math.sin(2 * math.pi * self.frequency * s)

    def fingers(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """True (noise-free) thumb and index centres at t."""
        reach = self.box.half[0] + FINGER_RADIUS
        closing = min(1.0, t / self.close)
        x = reach + 0.02 * (1 - closing) - self.depth * closing
        base = np.array(self.centre) + (0.0, self.lateral(t), 0.0)
        return base + (-x, 0.0, 0.0), base + (x, 0.0, 0.0)

    def noise_track(self, times: np.ndarray) -> np.ndarray:
        """(T, 3) the hand-wide tracking noise at each frame."""
        return np.random.default_rng(self.seed).normal(0.0, self.noise, (len(times), 3))

    def steady_cycles(self, times: np.ndarray) -> np.ndarray:
        """Mask of the full-amplitude cycles (ramps excluded)."""
        ramp = 1.0 / self.frequency
        return (times >= self.shake_start + ramp) & (times <= self.shake_end - ramp)

    def slip(self, times: np.ndarray, offset: np.ndarray) -> float:
        """|lasting change of the cube's offset from the grasp centre| (m): mean of the hold after
        the shake minus the mean of the last half of the hold before it."""
        before = (times >= self.shake_start - 0.5 * self.hold) & (times < self.shake_start)
        after = times > self.shake_end
        return float(np.linalg.norm(offset[after].mean(axis=0) - offset[before].mean(axis=0)))

    def tracking(self, times: np.ndarray, hand_y: np.ndarray) -> dict[str, float]:
        """Lag (s) of the physics hand behind the true hand at the shake frequency, from the
        phase of the fundamental over the steady cycles, and the RMS tracking error (m)."""
        mask = self.steady_cycles(times)
        t = times[mask]
        truth = np.array([self.lateral(s) for s in t])
        w = 2 * math.pi * self.frequency
        basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
        a_true, *_ = np.linalg.lstsq(basis, truth, rcond=None)
        a_sim, *_ = np.linalg.lstsq(basis, hand_y[mask], rcond=None)
        phase = math.atan2(a_true[1], a_true[0]) - math.atan2(a_sim[1], a_sim[0])
        phase = (phase + math.pi) % (2 * math.pi) - math.pi
        return {"lag": phase / w, "tracking_rms": float(np.sqrt(np.mean((hand_y[mask] - truth) ** 2)))}


IMPACT, TUMBLE, SHAKE = Impact(), Tumble(), Shake()


@dataclass(frozen=True)
class LiveScene:
    """The paper's scene for throughput: one right hand (19 phalanges), the three objects, a grasp.

    Four fingers lie along the cube's +x face (proximal, intermediate, distal: 12 phalanges), the
    thumb's proximal and distal press its -x face, the metacarpals run below the cube; the flat and
    long cuboids float out of reach. The hand carries the cube 10 cm along z and back, every 2 s.
    """

    cube: Box = CUBE
    flat: Box = FLAT
    bar: Box = BAR
    cube_at: tuple[float, float, float] = (0.0, 0.2, 0.0)
    flat_at: tuple[float, float, float] = (0.25, 0.2, 0.0)
    bar_at: tuple[float, float, float] = (-0.25, 0.2, 0.0)
    depth: float = 0.004
    carry: float = 0.10
    period: float = 2.0
    close: float = 0.3

    @property
    def boxes(self) -> tuple[tuple[Box, tuple[float, float, float]], ...]:
        return ((self.cube, self.cube_at), (self.flat, self.flat_at), (self.bar, self.bar_at))

    def joints(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(5, 5, 3) joints and (5, 4) widths of the hand at t, cube frame at rest: the digits close
        on the cube over the first ``close`` s, then the hand carries it."""
        h = self.cube.half
        opening = 0.02 * (1.0 - min(1.0, t / self.close))
        joints = np.zeros((5, 5, 3))
        widths = np.full((5, 4), 2 * FINGER_RADIUS)
        x_fingers = h[0] + FINGER_RADIUS - self.depth + opening
        for d, z in zip(range(1, 5), (-0.0225, -0.0075, 0.0075, 0.0225)):
            joints[d, 0] = (0.0, -h[1] - 0.04, z)  # metacarpal below the cube
            joints[d, 1:, 0] = x_fingers            # three phalanges up the +x face
            joints[d, 1:, 1] = -h[1] + np.array([-0.005, 0.025, 0.045, 0.062])
            joints[d, 1:, 2] = z
        x_thumb = -(h[0] + FINGER_RADIUS - self.depth + opening)
        joints[0, 0] = joints[0, 1] = (-0.02, -h[1] - 0.03, 0.0)  # the thumb's metacarpal has zero length
        joints[0, 2:, 0] = x_thumb
        joints[0, 2:, 1] = (-0.012, 0.012, 0.032)
        return joints + np.asarray(self.cube_at) + self.offset(t), widths

    def offset(self, t: float) -> np.ndarray:
        """The hand's displacement at t: after closing, to and fro along z, minimum-jerk each way."""
        t = max(0.0, t - self.close)
        s = (t % self.period) / (0.5 * self.period)
        s = s if s <= 1.0 else 2.0 - s
        return np.array([0.0, 0.0, self.carry * s ** 3 * (10 - 15 * s + 6 * s * s)])

    def spheres(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(K, 3) centres and (K,) radii of the hand's phalanx spheres at t (zero-length bones left out)."""
        joints, widths = self.joints(t)
        centres = 0.5 * (joints[:, 1:] + joints[:, :-1])
        lengths = np.linalg.norm(joints[:, 1:] - joints[:, :-1], axis=-1)
        keep = lengths > 1e-4
        return centres[keep], widths[keep] / 2

    def overlaps(self, t: float, position, orientation) -> int:
        """How many of the hand's spheres at t overlap the cube at this pose (w, x, y, z): the
        grasp's contacts counted by geometry alone, the same way for every engine."""
        centres, radii = self.spheres(t)
        rotation = quat_matrix(np.asarray(orientation) / np.linalg.norm(orientation))
        return sum(box_overlap(c, r, position, rotation, self.cube.half) > 0.0 for c, r in zip(centres, radii))


LIVE = LiveScene()
HOLD = LiveScene(carry=0.0)
"""The live scene with the grasp held still once it has closed: the one every peer can do in its
own idiom (a MuJoCo mocap body has no velocity, so its friction cannot carry the cube)."""
