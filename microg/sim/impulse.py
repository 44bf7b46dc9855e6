"""The impulse phase (paper, Eqs. 9-15): one impulse at the onset of a colliding contact.

The hand is kinematic (infinite mass), so only the object's velocities change. With r the contact
point relative to the object's centre of mass and I_w its world inertia, the collision matrix is

    K = (1/m) I - [r]x I_w^-1 [r]x                                  (Eq. 12)

Newton's impact law (Eq. 10) asks the relative normal velocity to go from u_init to -e u_init,
which takes the impulse magnitude

    j = -(1 + e) u_init / (n^T K n)                                 (Eq. 14)

J = j n acts on the hand; the object receives -J at the contact point, changing its linear
velocity by -J/m (Eq. 15) and its angular velocity by I_w^-1 (r x -J).
Contacts that start separating or resting (Eq. 8) get no impulse.

Several colliding contacts that start on one object in the same step (a face landing on four
fingertips) are solved together: the impulses j_k make every contact obey Newton's law with the
others' impulses counted, sum_l n_k^T K_kl n_l j_l = -(1 + e) u_k, with
K_kl = (1/m) I - [r_k]x I_w^-1 [r_l]x, and each j_k lies between 0 (a contact never pulls) and the
impulse Eq. 14 gives that contact alone (the paper computes each contact independently; no
contact hits harder than it would alone). Where the contacts do not determine the impulses (four
points on one face) the smallest are taken, which shares them evenly; where they cannot all be
met (two fingers closing on an object from both sides) the bounded contacts leave the rest to the
penetration phase. For one contact this is Eq. 14. Applied together, independent impulses on a
flat landing would add up to four times the bounce; applied one after another, the first contact
would take it all and set the object spinning.

**At the time of impact.** A contact is found when the sphere already overlaps, up to a step
after it touched. Found depth deep, its penetration spring would give the object gamma depth^2 / 2
on the way out that no motion paid for (at the tracking rate, a 2.5 g object left 10 % faster than
it came, a 15 g one 85 %). So where the scene has penetration springs, the impulse is applied as at
the time of impact, s = depth / |u_init| ago (the depth grows at the normal speed, Eq. 8; at most
one step): the object is moved as if its new velocities had held since then, by (v' - v) s and
turned by (omega' - omega) s, which leaves the phalanx e depth clear of the surface, as a contact
found on time would, with no spring holding anything. That is for free impacts only. An object
that other phalanges already press (a finger closing a pinch: the thumb's spring pushes the cube
onto it), or whose bounce gravity takes back within the steps a series of bounces needs to die
out (e |u_init| <= |g| h / (1 - e): it settles on fingertips), would be pushed straight back and,
moved clear, bounce off again every step, for ever. For these the spring stays, and what it
will give back comes off the bounce, e' = sqrt(e^2 - gamma depth^2 n^T K n / u_init^2);
where it holds more than the whole bounce, e' = 0 and the object is moved out along the normal to
the depth that holds exactly the bounce. Without the impulse phase, ``spring_onsets`` replays the
missed time with the spring itself. Either way no energy appears from the late finding, at any step.
"""

from __future__ import annotations

import math

import numpy as np

from .contact import COLLIDING, SEPARATING, classify, point_velocity
from microg.skeleton import SLOTS
from .vec import (add, cell, conjugated, cross, dot, kernel, mat_t_vec, mat_vec, quat_mul, quat_turn,
                  quat_unit, rotation, row, scale, set_row, sub)


@kernel
def collision_response(mass, inverse_inertia, r_a, r_b, v):
    """K_ab v: the change of the object's velocity at offset r_a per impulse v at offset r_b from a
    kinematic body, K_ab = (1/m) I - [r_a]x I_w^-1 [r_b]x. K_aa is Eq. 12."""
    turned = cross(r_a, mat_vec(inverse_inertia, cross(r_b, v)))
    return (v[0] / mass - turned[0], v[1] / mass - turned[1], v[2] / mass - turned[2])


@kernel
def least_squares(matrix, rhs, free):
    """The minimum-norm least-squares solution x of matrix x = rhs over the ``free`` rows and
    columns of a symmetric positive semi-definite matrix (others untouched: returned as 0), from
    its eigen-decomposition by Jacobi rotations; eigenvalues below 1e-12 of the largest count as
    zero."""
    size = rhs.shape[0]
    a, vectors = np.zeros((size, size)), np.zeros((size, size))
    for i in range(size):
        vectors[i, i] = 1.0
        for j in range(size):
            if free[i] and free[j]:
                a[i, j] = matrix[i, j]
    for _ in range(100):
        off, total = 0.0, 0.0
        for i in range(size):
            for j in range(size):
                total += a[i, j] * a[i, j]
                off += a[i, j] * a[i, j] if i != j else 0.0
        if off <= 1e-30 * total:
            break
        for i in range(size):
            for j in range(i + 1, size):
                if a[i, j] == 0.0:
                    continue
                theta = 0.5 * (a[j, j] - a[i, i]) / a[i, j]
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * c
                for m in range(size):
                    a[m, i], a[m, j] = c * a[m, i] - sn * a[m, j], sn * a[m, i] + c * a[m, j]
                for m in range(size):
                    a[i, m], a[j, m] = c * a[i, m] - sn * a[j, m], sn * a[i, m] + c * a[j, m]
                for m in range(size):
                    vectors[m, i], vectors[m, j] = c * vectors[m, i] - sn * vectors[m, j], \
                        sn * vectors[m, i] + c * vectors[m, j]
    largest = 0.0
    for i in range(size):
        largest = max(largest, abs(a[i, i]))
    x = np.zeros(size)
    for i in range(size):
        if abs(a[i, i]) <= 1e-12 * largest:
            continue
        along = 0.0
        for m in range(size):
            along += vectors[m, i] * (rhs[m] if free[m] else 0.0)
        for m in range(size):
            x[m] += vectors[m, i] * along / a[i, i]
    return x


@kernel
def simultaneous_impulses(mass, inverse_inertia, arms, normals, u_init, restitution):
    """Impulse magnitudes for contacts that collide together (see module docstring): Newton's law
    for every contact with the others counted, each impulse between 0 and its own Eq. 14; an
    impulse that leaves those bounds is fixed at the bound and the rest solved again."""
    count = u_init.shape[0]
    matrix, target, alone = np.empty((count, count)), np.empty(count), np.empty(count)
    for a in range(count):
        for b in range(count):
            matrix[a, b] = dot(row(normals, a), collision_response(mass, inverse_inertia, row(arms, a),
                                                                      row(arms, b), row(normals, b)))
    for a in range(count):
        target[a] = -(1.0 + restitution[a]) * u_init[a]
        alone[a] = target[a] / matrix[a, a]
    j = np.zeros(count)
    free = np.ones(count, dtype=np.bool_)
    rhs = np.empty(count)
    for _ in range(count):
        for a in range(count):
            rhs[a] = target[a]
            for b in range(count):
                rhs[a] -= 0.0 if free[b] else matrix[a, b] * j[b]
        solution = least_squares(matrix, rhs, free)
        worst, excess = -1, 1e-12
        for a in range(count):
            if free[a]:
                j[a] = solution[a]
                beyond = max(-j[a], j[a] - alone[a]) / alone[a]
                if beyond > excess:
                    worst, excess = a, beyond
        if worst < 0:
            break
        j[worst] = 0.0 if j[worst] < 0.0 else alone[worst]
        free[worst] = False
    for a in range(count):
        j[a] = min(max(j[a], 0.0), alone[a])
    return j


@kernel
def move_out(p, s, o, rot, r, n, distance, compliance):
    """Move object o so that its point at offset r goes ``distance`` along -n (away from the
    hand), the way an impulse at r along -n would move it: by M^-1 J^T n distance / (n^T K n)."""
    push = scale(-distance / compliance, n)
    inverse_inertia = conjugated(rot, (1.0 / p.inertia[o, 0], 1.0 / p.inertia[o, 1], 1.0 / p.inertia[o, 2]))
    displace(s, o, scale(1.0 / p.mass[o], push), mat_vec(inverse_inertia, cross(r, push)))


@kernel
def displace(s, o, shift, turn):
    """Move object o by ``shift`` and turn it by the rotation vector ``turn``, its spin turned with
    it: its angular velocity in its own frame, and so its kinetic energy, stay as they were (kept
    fixed in the world instead, the spin of a long bar about its axis would, once the bar is turned,
    load its large moments of inertia and gain energy from a mere change of pose)."""
    set_row(s.position, o, add(row(s.position, o), shift))
    q = s.orientation[o]
    by = quat_turn(turn)
    turned = quat_unit(quat_mul(by, (q[0], q[1], q[2], q[3])))
    q[0], q[1], q[2], q[3] = turned
    set_row(s.angular_velocity, o, mat_vec(rotation(by), row(s.angular_velocity, o)))


@kernel
def apply_impulses(p, s, o, rot, springs, h):
    """Eqs. 9-15 for the contacts with object o that began colliding this step, solved together;
    with penetration ``springs``, as at their time of impact (module docstring). Returns True when
    that moved the object."""
    impulse, onset = s.impulse, s.onset
    count = 0
    for k in range(SLOTS):
        impulse[k, o] = 0.0
        count += onset[k, o]
    if count == 0:
        return False
    held = False
    for k in range(SLOTS):
        held |= s.active[k, o] and not onset[k, o]
    velocity, angular_velocity = row(s.velocity, o), row(s.angular_velocity, o)
    inverse_inertia = conjugated(rot, (1.0 / p.inertia[o, 0], 1.0 / p.inertia[o, 1], 1.0 / p.inertia[o, 2]))
    slots = np.empty(count, dtype=np.int64)
    arms, normals = np.empty((count, 3)), np.empty((count, 3))
    u_init, restitution, too_deep, compliance = np.empty(count), np.empty(count), np.zeros(count), np.empty(count)
    bounced = np.zeros(count, dtype=np.bool_)
    leaving, n_leaving, pressed = np.empty(count, dtype=np.int64), 0, held
    since, pull = 0.0, math.sqrt(p.gravity[0] ** 2 + p.gravity[1] ** 2 + p.gravity[2] ** 2) * h
    count = 0
    for k in range(SLOTS):
        if not s.onset[k, o]:
            continue
        r = mat_vec(rot, cell(s.anchor, k, o))
        n = mat_vec(rot, cell(s.normal, k, o))
        u = dot(n, sub(row(s.hand_velocity, k), point_velocity(velocity, angular_velocity, r)))
        kind = classify(u, p.resting_tolerance)
        if kind == SEPARATING:
            leaving[n_leaving] = k
            n_leaving += 1
        if kind != COLLIDING:
            continue
        e, depth = p.restitution[o], s.depth[k, o]
        slots[count], u_init[count], restitution[count] = k, u, e
        compliance[count] = dot(n, collision_response(p.mass[o], inverse_inertia, r, r, n))
        if springs:
            if not held and -e * u * (1.0 - e) > pull:  # a free impact: as if it began depth / |u| ago
                since = max(since, min(h, depth / -u))
                bounced[count] = True
            else:  # pressed on by gravity: the spring stays, and what it will give back comes off the bounce
                pressed = True
                bounce, stored = e * e * u * u, p.penetration_stiffness * depth * depth * compliance[count]
                restitution[count] = math.sqrt(max(0.0, bounce - stored)) / -u
                if stored > bounce:
                    too_deep[count] = depth - math.sqrt(bounce / (p.penetration_stiffness * compliance[count]))
        set_row(arms, count, r)
        set_row(normals, count, n)
        count += 1
    moved = False
    if count > 0:
        j = simultaneous_impulses(p.mass[o], inverse_inertia, arms[:count], normals[:count], u_init[:count],
                                  restitution[:count])
        for i in range(count):
            on_object = scale(-j[i], row(normals, i))
            dv = (on_object[0] / p.mass[o], on_object[1] / p.mass[o], on_object[2] / p.mass[o])
            dw = mat_vec(inverse_inertia, cross(row(arms, i), on_object))
            set_row(s.velocity, o, add(row(s.velocity, o), dv))
            set_row(s.angular_velocity, o, add(row(s.angular_velocity, o), dw))
            s.impulse[slots[i], o] = j[i]
        if since > 0.0:
            moved = True
            at_time_of_impact(s, o, velocity, angular_velocity, since)
            for i in range(count):  # a bounce that leaves is over: its phalanx is clear
                if bounced[i]:
                    end_bounce(p, s, o, slots[i], row(arms, i), row(normals, i))
        for i in range(count):
            if too_deep[i] > 0.0:
                move_out(p, s, o, rot, row(arms, i), row(normals, i), too_deep[i], compliance[i])
                moved = True
    if springs and not pressed:  # found inside while leaving: nothing to bounce, and nothing to store
        for i in range(n_leaving):
            clear(p, s, o, leaving[i])
            moved = True
    return moved


CLEARING_TRIES = 4
"""Moves out that ``clear`` makes at most (each leaves a remainder of second order in the turn)."""


@kernel
def engaged(s, o, rot, k):
    """How deep phalanx k is below the tangent plane at its anchor on object o (<= 0: clear), and
    the point of that plane under it (body frame)."""
    local = mat_t_vec(rot, sub(row(s.hand_position, k), row(s.position, o)))
    normal = cell(s.normal, k, o)
    below = dot(sub(cell(s.anchor, k, o), local), normal)
    return below + s.radius[k], add(local, scale(below, normal))


@kernel
def end_bounce(p, s, o, k, r, n):
    """After the impulse, contact (k, o) ends clear of the surface when its phalanx now leaves it
    (``clear``). One that still meets the object, as the fingers of a pinch that close on it from
    both sides do (no velocity can leave both), stays a contact when its phalanx is still inside:
    its spring holds the object, and moving it out would push it away from the grasp."""
    u = dot(n, sub(row(s.hand_velocity, k), point_velocity(row(s.velocity, o), row(s.angular_velocity, o), r)))
    if classify(u, p.resting_tolerance) == SEPARATING:
        clear(p, s, o, k)
    elif engaged(s, o, rotation(s.orientation[o]), k)[0] <= 0.0:
        s.active[k, o] = False
        s.depth[k, o] = 0.0


@kernel
def clear(p, s, o, k):
    """End bounced contact (k, o) with its phalanx clear of the surface. Moved as at the time of
    impact, an object that only translates leaves it e depth clear; one that the impulse set
    turning fast (a light box hit near an edge, turning a good part of a radian in a coarse step)
    follows its arc only to first order and may leave it still inside, where a spring would hold
    energy that no motion paid for. Such a remainder is taken out the way an impulse under the
    phalanx would move the object (``move_out``), without changing its velocities."""
    for _ in range(CLEARING_TRIES):
        rot = rotation(s.orientation[o])
        left, under = engaged(s, o, rot, k)
        if left <= 0.0:
            break
        r, n = mat_vec(rot, under), mat_vec(rot, cell(s.normal, k, o))
        inverse_inertia = conjugated(rot, (1.0 / p.inertia[o, 0], 1.0 / p.inertia[o, 1], 1.0 / p.inertia[o, 2]))
        move_out(p, s, o, rot, r, n, left, dot(n, collision_response(p.mass[o], inverse_inertia, r, r, n)))
    s.active[k, o] = False
    s.depth[k, o] = 0.0


@kernel
def at_time_of_impact(s, o, velocity, angular_velocity, since):
    """Move object o as if its velocities had changed from (velocity, angular_velocity) to their
    present values ``since`` seconds ago: by (v' - v) since, turned by (omega' - omega) since."""
    displace(s, o, scale(since, sub(row(s.velocity, o), velocity)),
             scale(since, sub(row(s.angular_velocity, o), angular_velocity)))


@kernel
def spring_onsets(p, s, o, rot, h):
    """Without the impulse phase: each contact with object o that began colliding this step, found
    depth deep, began s = depth / |u| ago (at most h); its spring would since have slowed the
    object's normal approach from |u| to |u| cos(w s) and held it |u| sin(w s) / w deep
    (w^2 = gamma n^T K n, the contact's own oscillation; past w s = pi it has let go). Put the object
    there, so the spring holds only what the approach paid for. All contacts are replayed from the
    same state (two fingers closing on an object alike change nothing). Returns True when it moved
    the object."""
    velocity, angular_velocity = row(s.velocity, o), row(s.angular_velocity, o)
    inverse_inertia = conjugated(rot, (1.0 / p.inertia[o, 0], 1.0 / p.inertia[o, 1], 1.0 / p.inertia[o, 2]))
    linear, angular, shift, turn = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    moved = False
    for k in range(SLOTS):
        if not s.onset[k, o]:
            continue
        r = mat_vec(rot, cell(s.anchor, k, o))
        n = mat_vec(rot, cell(s.normal, k, o))
        u = dot(n, sub(row(s.hand_velocity, k), point_velocity(velocity, angular_velocity, r)))
        if classify(u, p.resting_tolerance) != COLLIDING:
            continue
        compliance = dot(n, collision_response(p.mass[o], inverse_inertia, r, r, n))
        w = math.sqrt(p.penetration_stiffness * compliance)
        phase = min(w * min(h, s.depth[k, o] / -u), math.pi)
        on_object = scale(u * (1.0 - math.cos(phase)) / compliance, n)  # the spring's impulse, along -n
        linear = add(linear, scale(1.0 / p.mass[o], on_object))
        angular = add(angular, mat_vec(inverse_inertia, cross(r, on_object)))
        out = s.depth[k, o] + u * math.sin(phase) / w
        if out > 0.0:
            push = scale(-out / compliance, n)
            shift = add(shift, scale(1.0 / p.mass[o], push))
            turn = add(turn, mat_vec(inverse_inertia, cross(r, push)))
            moved = True
    set_row(s.velocity, o, add(velocity, linear))
    set_row(s.angular_velocity, o, add(angular_velocity, angular))
    if moved:
        displace(s, o, shift, turn)
    return moved
