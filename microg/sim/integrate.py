"""Time integration of the objects: gravity, the velocity update, and the drift of the poses.

Each step first updates the velocities u = (v, omega) with everything the contact kernels
accumulated, linearly implicitly, so that stiff contacts on light objects stay stable at the
tracking rate:

    (M + h D + h^2 K) u' = M u + h w

M = diag(m I, I_w), w the generalised force, K and D the contact stiffness and damping
(see ``wrench``). With no contact, this is the plain kick u' = u + h M^-1 w.
Then the poses drift: x' = x + h v', and the orientation turns either as a free rigid body
(the ``gyroscopic`` effect: Euler's equations, angular momentum conserved) or, without the
effect, at constant world angular velocity.
"""

from __future__ import annotations


from .scene import ANGULAR_INTEGRATORS
from .vec import (add, conjugated, cross, kernel, mat_t_vec, mat_vec, quat_mul, quat_turn, quat_unit, rotation, row,
                  scale, set_row)

MIDPOINT, SEMI_IMPLICIT_EULER, EXPLICIT_EULER = (ANGULAR_INTEGRATORS.index(name) for name in
                                                 ("midpoint", "semi_implicit_euler", "explicit_euler"))
"""The scene's ``angular_integrator`` as the model's ``angular_method``."""


@kernel
def add_gravity(p, o, wrench):
    """m g on object o."""
    for i in range(3):
        wrench[i] += p.mass[o] * p.gravity[i]


@kernel
def solve6(system, rhs):
    """system^-1 rhs by Gaussian elimination with partial pivoting; overwrites both."""
    for column in range(6):
        pivot = column
        for below in range(column + 1, 6):
            if abs(system[below, column]) > abs(system[pivot, column]):
                pivot = below
        if pivot != column:
            for j in range(6):
                system[column, j], system[pivot, j] = system[pivot, j], system[column, j]
            rhs[column], rhs[pivot] = rhs[pivot], rhs[column]
        for below in range(column + 1, 6):
            factor = system[below, column] / system[column, column]
            for j in range(column + 1, 6):
                system[below, j] -= factor * system[column, j]
            rhs[below] -= factor * rhs[column]
    for i in range(5, -1, -1):
        total = rhs[i]
        for j in range(i + 1, 6):
            total -= system[i, j] * rhs[j]
        rhs[i] = total / system[i, i]
    return rhs


@kernel
def update_velocity(p, s, o, rot, wrench, stiffness, damping, h):
    """u' of object o from the accumulated force, stiffness and damping; clears the accumulators."""
    mass, inertia = p.mass[o], p.inertia[o]
    if not (_any(stiffness) or _any(damping)):
        set_row(s.velocity, o, add(row(s.velocity, o), (h * wrench[0] / mass, h * wrench[1] / mass,
                                                      h * wrench[2] / mass)))
        body_torque = mat_t_vec(rot, (h * wrench[3], h * wrench[4], h * wrench[5]))
        body_change = (body_torque[0] / inertia[0], body_torque[1] / inertia[1], body_torque[2] / inertia[2])
        set_row(s.angular_velocity, o, add(row(s.angular_velocity, o), mat_vec(rot, body_change)))
    else:
        world_inertia = conjugated(rot, (inertia[0], inertia[1], inertia[2]))
        momentum = mat_vec(world_inertia, row(s.angular_velocity, o))
        for i in range(6):
            for j in range(6):
                stiffness[i, j] = h * damping[i, j] + h * h * stiffness[i, j]
            wrench[i] = h * wrench[i]
        for i in range(3):
            stiffness[i, i] += mass
            wrench[i] += mass * s.velocity[o, i]
            wrench[3 + i] += momentum[i]
            for j in range(3):
                stiffness[3 + i, 3 + j] += world_inertia[i][j]
        u = solve6(stiffness, wrench)
        set_row(s.velocity, o, (u[0], u[1], u[2]))
        set_row(s.angular_velocity, o, (u[3], u[4], u[5]))
    wrench[:] = 0.0
    stiffness[:, :] = 0.0
    damping[:, :] = 0.0


@kernel
def _any(matrix):
    """Whether any entry is not 0 (all of them looked at: a loop without an early exit is vectorised)."""
    found = False
    for i in range(6):
        for j in range(6):
            found |= matrix[i, j] != 0.0
    return found


@kernel
def update_position(s, o, h):
    """x' = x + h v' (semi-implicit Euler: exact for free flight)."""
    set_row(s.position, o, add(row(s.position, o), scale(h, row(s.velocity, o))))


@kernel
def rotate_constant(s, o, h):
    """Turn object o by h omega about a fixed world axis (no gyroscopic term)."""
    q = s.orientation[o]
    turned = quat_unit(quat_mul(quat_turn(scale(h, row(s.angular_velocity, o))), (q[0], q[1], q[2], q[3])))
    q[0], q[1], q[2], q[3] = turned


@kernel
def _turn(h, momentum, inertia):
    """The Cayley rotation by h omega: the unit quaternion (1, h omega / 2) (omega = momentum / inertia)."""
    half = 0.5 * h
    return quat_unit((1.0, half * momentum[0] / inertia[0], half * momentum[1] / inertia[1],
                      half * momentum[2] / inertia[2]))


@kernel
def free_rotation(q, inertia, body_momentum, h, method):
    """Advance a torque-free rigid body by h: returns the new orientation and body momentum.

    ``MIDPOINT``: the implicit midpoint rule on Euler's equations, pi' - pi = h pi_m x omega_m,
    solved exactly in the form pi' = cay(h omega_m)^T pi with the orientation turned by the same
    Cayley rotation. World angular momentum R pi is conserved to round-off and kinetic energy to
    the fixed-point tolerance, at any h. The Euler variants are the benchmarks' references.
    """
    if method == MIDPOINT:
        largest = max(abs(body_momentum[0]), abs(body_momentum[1]), abs(body_momentum[2]))
        midpoint = body_momentum
        for _ in range(50):
            rotated = mat_t_vec(rotation(_turn(h, midpoint, inertia)), body_momentum)
            new_midpoint = scale(0.5, add(body_momentum, rotated))
            change = max(abs(new_midpoint[0] - midpoint[0]), abs(new_midpoint[1] - midpoint[1]),
                         abs(new_midpoint[2] - midpoint[2]))
            midpoint = new_midpoint
            if change <= 1e-15 * (largest + 1e-300):
                break
        turn = _turn(h, midpoint, inertia)
        return quat_unit(quat_mul(q, turn)), mat_t_vec(rotation(turn), body_momentum)
    omega = (body_momentum[0] / inertia[0], body_momentum[1] / inertia[1], body_momentum[2] / inertia[2])
    new_momentum = add(body_momentum, scale(h, cross(body_momentum, omega)))
    if method == SEMI_IMPLICIT_EULER:
        turn = (h * new_momentum[0] / inertia[0], h * new_momentum[1] / inertia[1], h * new_momentum[2] / inertia[2])
        return quat_unit(quat_mul(q, quat_turn(turn))), new_momentum
    derivative = quat_mul(q, (0.0, omega[0], omega[1], omega[2]))
    half = 0.5 * h
    return quat_unit((q[0] + half * derivative[0], q[1] + half * derivative[1], q[2] + half * derivative[2],
                      q[3] + half * derivative[3])), new_momentum


@kernel
def rotate_free(p, s, o, h):
    """Turn object o as a torque-free rigid body (gyroscopic term included)."""
    q = s.orientation[o]
    inertia = (p.inertia[o, 0], p.inertia[o, 1], p.inertia[o, 2])
    body = mat_t_vec(rotation(q), row(s.angular_velocity, o))
    momentum = (inertia[0] * body[0], inertia[1] * body[1], inertia[2] * body[2])
    turned, momentum = free_rotation((q[0], q[1], q[2], q[3]), inertia, momentum, h, p.angular_method)
    q[0], q[1], q[2], q[3] = turned
    set_row(s.angular_velocity, o, mat_vec(rotation(turned), (momentum[0] / inertia[0], momentum[1] / inertia[1],
                                                           momentum[2] / inertia[2])))
