"""Time integration of the objects: gravity, the velocity update, and the drift of the poses.

Each step first updates the velocities u = (v, omega) with everything the stages accumulated,
linearly implicitly, so that stiff contacts on light objects stay stable at the tracking rate:

    (M + h D + h^2 K) u' = M u + h w

M = diag(m I, I_w), w the generalised force, K and D the contact stiffness and damping
(see ``wrench``). With no contact, this is the plain kick u' = u + h M^-1 w.
Then the poses drift: x' = x + h v', and the orientation turns either as a free rigid body
(the ``gyroscopic`` effect: Euler's equations, angular momentum conserved) or, without the
effect, at constant world angular velocity.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .rotation import cross, quat_from_rotation_vector, quat_multiply, quat_normalize, quat_to_matrix

MIDPOINT, SEMI_IMPLICIT_EULER, EXPLICIT_EULER = 0, 1, 2


def apply_gravity(model, data, h: float) -> None:
    """m g on every object."""
    data.wrench[:, :3] += model.mass[:, None] * model.gravity


@njit(cache=True)
def _integrate_velocity(mass, inertia, orientation, velocity, angular_velocity, wrench, stiffness, damping, h):
    for o in range(mass.shape[0]):
        rot = quat_to_matrix(orientation[o])
        world_inertia = rot @ np.diag(inertia[o]) @ rot.T
        if not (stiffness[o].any() or damping[o].any()):
            velocity[o] += h * wrench[o, :3] / mass[o]
            angular_velocity[o] += np.linalg.solve(world_inertia, h * wrench[o, 3:])
        else:
            system = h * damping[o] + h * h * stiffness[o]
            momentum = np.empty(6)
            for i in range(3):
                system[i, i] += mass[o]
            system[3:, 3:] += world_inertia
            momentum[:3] = mass[o] * velocity[o]
            momentum[3:] = world_inertia @ angular_velocity[o]
            u = np.linalg.solve(system, momentum + h * wrench[o])
            velocity[o] = u[:3]
            angular_velocity[o] = u[3:]
        wrench[o] = 0.0
        stiffness[o] = 0.0
        damping[o] = 0.0


def integrate_velocity(model, data, h: float) -> None:
    """u' from the accumulated forces, stiffness and damping; clears the accumulators."""
    _integrate_velocity(model.mass, model.inertia, data.orientation, data.velocity, data.angular_velocity,
                        data.wrench, data.stiffness, data.damping, h)


def integrate_position(model, data, h: float) -> None:
    """x' = x + h v' (semi-implicit Euler: exact for free flight)."""
    data.position += h * data.velocity


@njit(cache=True)
def _rotate_constant(orientation, angular_velocity, h):
    for o in range(orientation.shape[0]):
        orientation[o] = quat_normalize(quat_multiply(quat_from_rotation_vector(h * angular_velocity[o]),
                                                      orientation[o]))


def rotate_without_gyroscopic(model, data, h: float) -> None:
    """Turn each object by h omega about a fixed world axis (no gyroscopic term)."""
    _rotate_constant(data.orientation, data.angular_velocity, h)


@njit(cache=True)
def free_rotation(q, body_inertia, body_momentum, h, method):
    """Advance a torque-free rigid body by h: returns the new orientation and body momentum.

    ``MIDPOINT``: the implicit midpoint rule on Euler's equations, pi' - pi = h pi_m x omega_m,
    solved exactly in the form pi' = cay(h omega_m)^T pi with the orientation turned by the same
    Cayley rotation. World angular momentum R pi is conserved to round-off and kinetic energy to
    the fixed-point tolerance, at any h. The Euler variants are the benchmarks' references.
    """
    if method == MIDPOINT:
        midpoint = body_momentum.copy()
        turn = np.array([1.0, 0.0, 0.0, 0.0])
        for _ in range(50):
            half_turn = 0.5 * h * midpoint / body_inertia
            turn = quat_normalize(np.array([1.0, half_turn[0], half_turn[1], half_turn[2]]))
            rotated = quat_to_matrix(turn).T @ body_momentum
            new_midpoint = 0.5 * (body_momentum + rotated)
            change = np.abs(new_midpoint - midpoint).max()
            midpoint = new_midpoint
            if change <= 1e-15 * (np.abs(body_momentum).max() + 1e-300):
                break
        half_turn = 0.5 * h * midpoint / body_inertia
        turn = quat_normalize(np.array([1.0, half_turn[0], half_turn[1], half_turn[2]]))
        return quat_normalize(quat_multiply(q, turn)), quat_to_matrix(turn).T @ body_momentum
    omega = body_momentum / body_inertia
    new_momentum = body_momentum + h * cross(body_momentum, omega)
    if method == SEMI_IMPLICIT_EULER:
        return quat_normalize(quat_multiply(q, quat_from_rotation_vector(h * new_momentum / body_inertia))), new_momentum
    derivative = quat_multiply(q, np.array([0.0, omega[0], omega[1], omega[2]]))
    return quat_normalize(q + 0.5 * h * derivative), new_momentum


@njit(cache=True)
def _rotate_free(inertia, orientation, angular_velocity, h, method):
    for o in range(orientation.shape[0]):
        rot = quat_to_matrix(orientation[o])
        body_momentum = inertia[o] * (rot.T @ angular_velocity[o])
        q, body_momentum = free_rotation(orientation[o], inertia[o], body_momentum, h, method)
        orientation[o] = q
        angular_velocity[o] = quat_to_matrix(q) @ (body_momentum / inertia[o])


def rotate_free(model, data, h: float) -> None:
    """Turn each object as a torque-free rigid body (gyroscopic term included)."""
    _rotate_free(model.inertia, data.orientation, data.angular_velocity, h, model.angular_method)
