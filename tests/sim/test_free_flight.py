"""Free objects: constant drift in zero g, torque-free tumbling, and free fall under gravity."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from microg.sim import angular_momentum, kinetic_energy
from microg.sim.rotation import quat_to_matrix
from tests.physics import coast, placed, world_of


def test_zero_g_drift_is_uniform_motion():
    cube = placed("cube", velocity=(0.1, 0.2, -0.3), angular_velocity=(0.0, 0.0, 0.0))
    world = coast(world_of([cube]), 10.0)
    assert world.data.velocity[0] == pytest.approx([0.1, 0.2, -0.3], abs=1e-15)
    assert world.data.position[0] == pytest.approx(np.array([0.0, 0.2, 0.0]) + 10.0 * np.array([0.1, 0.2, -0.3]),
                                                   abs=1e-12)


def euler_reference(inertia, omega0, times):
    """Euler's torque-free equations in the body frame, solved by an independent integrator."""
    def rhs(_, w):
        return (np.roll(inertia, -1) - np.roll(inertia, -2)) * np.roll(w, -1) * np.roll(w, -2) / inertia
    return solve_ivp(rhs, (0.0, times[-1]), omega0, t_eval=times, rtol=1e-11, atol=1e-13).y.T


def test_long_cuboid_spun_about_intermediate_axis_flips_and_conserves_L_and_energy():
    # 20 x 4 x 2.5 cm bar: I_x < I_y < I_z, so y is the intermediate axis (Dzhanibekov effect).
    omega0 = np.array([1e-3, 4.0, 1e-3])
    bar = placed("long_cuboid", angular_velocity=tuple(omega0))
    world = world_of([bar])
    L0, E0 = angular_momentum(world)[0], kinetic_energy(world)[0]
    times = np.arange(0.5, 60.0 + 1e-9, 0.5)
    body_y_along_L, omega_body, worst_L, worst_E = [], [], 0.0, 0.0
    for _ in times:
        world = coast(world, 0.5)
        rot = quat_to_matrix(world.data.orientation[0])
        body_y_along_L.append(rot[:, 1] @ L0 / np.linalg.norm(L0))
        omega_body.append(rot.T @ world.data.angular_velocity[0])
        worst_L = max(worst_L, np.linalg.norm(angular_momentum(world)[0] - L0) / np.linalg.norm(L0))
        worst_E = max(worst_E, abs(kinetic_energy(world)[0] - E0) / E0)
    assert min(body_y_along_L) < -0.99  # the bar turned over: its y axis points against L
    assert max(body_y_along_L[len(body_y_along_L) // 2:]) > 0.99  # and back again
    assert worst_L < 1e-6
    assert worst_E < 1e-4
    # The flips happen when an independent solution of Euler's equations says they do.
    reference = euler_reference(world.model.inertia[0], omega0, times)
    first_flip = times[np.argmax(np.asarray(omega_body)[:, 1] < 0)]
    first_flip_reference = times[np.argmax(reference[:, 1] < 0)]
    assert first_flip == pytest.approx(first_flip_reference, abs=1.0)


@pytest.mark.parametrize("method", ["explicit_euler", "semi_implicit_euler"])
def test_euler_integrators_drift_where_the_midpoint_rule_does_not(method):
    # The benchmarks' reference integrators: they do not keep |L| (why the default is the midpoint rule).
    bar = placed("long_cuboid", angular_velocity=(1e-3, 4.0, 1e-3))
    world = coast(world_of([bar], angular_integrator=method), 20.0)
    L = np.linalg.norm(angular_momentum(world)[0])
    L0 = np.linalg.norm(world.model.inertia[0] * np.array([1e-3, 4.0, 1e-3]))
    assert abs(L - L0) / L0 > 1e-4


def test_without_the_gyroscopic_effect_angular_velocity_stays_fixed_in_the_world():
    bar = placed("long_cuboid", angular_velocity=(0.5, 3.0, 0.2))
    world = world_of([bar], effects={"impulse"})
    world = coast(world, 5.0)
    assert world.data.angular_velocity[0] == pytest.approx([0.5, 3.0, 0.2], abs=1e-15)


def test_released_object_falls_at_g():
    g = 9.81
    world = world_of([placed("cube")], interaction="impulse_penetration", gravity=(0.0, -g, 0.0))
    world = coast(world, 1.0)
    t = world.time - 0.0
    assert world.data.velocity[0] == pytest.approx([0.0, -g * t, 0.0], rel=1e-12)
    # semi-implicit Euler: position lags the exact parabola by at most h g t / 2
    exact = 0.2 - 0.5 * g * t * t
    assert abs(world.data.position[0, 1] - exact) <= world.model.dt * g * t


def test_residual_gravity_is_any_vector():
    residual = (1e-3, -2e-3, 5e-4)
    world = coast(world_of([placed("ball")], gravity=residual), 2.0)
    assert world.data.velocity[0] == pytest.approx(2.0 * np.array(residual), rel=1e-12)
