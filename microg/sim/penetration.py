"""The penetration phase (paper, Eqs. 16-20): a spring from each god-object proxy to its phalanx.

For a phalanx in contact, with c its anchor on the surface and s its innermost point (the
centroid p moved by the radius against the normal, so a sphere that only touches feels nothing):

    f = gamma (c - s)                                  (Eq. 16, gamma = 100 N/m)
    f_n = (f . n) n,  f_t = f - f_n                    (Eqs. 17-18)

f pulls the rendered hand out of the object; the object receives -f, as force and torque. Since
c - s = (c + rho n) - p, f is a spring between the tracked phalanx centre and the god-object
phalanx centre c + rho n, a point fixed in the object: the torque is taken there. For a point
phalanx (the paper's, rho = 0) that is c itself; for a sphere the normal part has the same torque
at either point, and only there does the spring's energy add up (applied at c, the friction part
would turn with a torque off by rho n x f_t and a still hand could spin an object up).
The velocity update treats the spring implicitly on the *relative* motion of hand and object over
the step (both move; see ``wrench``), and a spring only pushes: a contact predicted to release
within the step (depth < h times its separating speed, Eq. 8) acts with its mean force until the
release and adds no stiffness, so an object leaving a finger is never pulled back.

Two kernels. ``friction_cone`` (Eqs. 19-20) runs first: inside the cone, f . n > 0 and
|f_t| <= mu (f . n), the contact sticks and the anchor stays; outside it the anchor slides along
the surface until the tangential pull is the dynamic friction, |f_t| = phi (f . n) (Eq. 20 read
as Coulomb's law: kinetic friction is phi times the normal force, so a fast tangential jerk cannot
pull harder than friction allows). ``penetration_forces`` then applies f. In a scene
without friction the surface is frictionless: the anchor follows the phalanx's projection on the
face and only f_n acts.
"""

from __future__ import annotations


from .bodies import BOX, MESH
from .contact import _with, point_velocity, project_on_face
from .mesh_contact import mesh_along_face
from microg.skeleton import SLOTS
from .vec import add, cell, dot, kernel, mat_t_vec, mat_vec, norm, row, scale, set_cell, sub
from .wrench import add_point_force, add_point_matrix, outer


@kernel
def spring_offset(rot, position, hand_position, radius, anchor, normal):
    """c - s in the body frame, its normal length delta and its tangential part (Eqs. 16-18)."""
    p = mat_t_vec(rot, sub(hand_position, position))
    offset = sub(anchor, sub(p, scale(radius, normal)))
    delta = dot(offset, normal)
    return offset, delta, sub(offset, scale(delta, normal))


@kernel
def along_face(shape, half_size, anchor, normal, tangential):
    """The part of a sliding contact's tangential offset that friction can act on: without what
    points past the edge of the face its anchor is held at (a box's phalanx is over its face up
    to rho beyond the edge). The anchor cannot slide there, so that pull is no friction: its
    direction is set by where the phalanx hangs over the edge, not by the sliding, and turning the
    object under it, it does work that no motion of the hand paid for (a still fingertip resting
    over the edge of a spinning box kept it spinning faster, at any step)."""
    if shape != BOX:
        return tangential
    axis = 0
    for i in range(1, 3):
        if abs(normal[i]) > abs(normal[axis]):
            axis = i
    result = (tangential[0], tangential[1], tangential[2])
    for i in range(3):
        if i != axis and abs(anchor[i]) >= half_size[i] and anchor[i] * tangential[i] < 0.0:
            result = _with(result, i, 0.0)
    return result


@kernel
def friction_cone(p, s, o, rot, mesh):
    """Eqs. 19-20: each contact with object o sticks inside the cone, or its anchor slides until
    the tangential pull is phi times the normal one."""
    position = row(s.position, o)
    mu, phi = p.static_friction[o], p.dynamic_friction[o]
    sliding, active = s.sliding, s.active
    for k in range(SLOTS):
        sliding[k, o] = False
        if not active[k, o]:
            continue
        anchor, normal = cell(s.anchor, k, o), cell(s.normal, k, o)
        _, delta, tangential = spring_offset(rot, position, row(s.hand_position, k), s.radius[k], anchor, normal)
        length = norm(tangential)
        if delta > 0.0 and length > mu * delta:
            moved = sub(anchor, scale((length - phi * delta) / length, tangential))
            anchor, normal = project_on_face(mesh, o, p.shape[o], row(p.half_size, o), moved, normal)
            set_cell(s.anchor, k, o, anchor)
            set_cell(s.normal, k, o, normal)
            sliding[k, o] = True


@kernel
def penetration_forces(p, s, o, rot, friction, wrench, stiffness, h, mesh, under_phalanx):
    """Eqs. 16-18: the spring force of every contact with object o, applied at its god-object
    phalanx, with the stiffness the implicit velocity update needs. ``under_phalanx`` (the
    penetration-only baseline): past the face's edge where its anchor is held, the spring acts from
    the point of the face's plane under the phalanx, so an object turning under a still fingertip
    pays for what it charges the spring (docs/physics.md, "The baselines at coarse steps"); the
    paper's model keeps Eq. 16's anchor (its impulse phase takes the bounce)."""
    gamma = p.penetration_stiffness
    position = row(s.position, o)
    velocity, angular_velocity = row(s.velocity, o), row(s.angular_velocity, o)
    active = s.active
    for k in range(SLOTS):
        if not active[k, o]:
            continue
        hand, radius = row(s.hand_position, k), s.radius[k]
        anchor, normal = cell(s.anchor, k, o), cell(s.normal, k, o)
        offset, delta, tangential = spring_offset(rot, position, hand, radius, anchor, normal)
        if not friction:
            anchor, normal = project_on_face(mesh, o, p.shape[o], row(p.half_size, o), sub(anchor, tangential),
                                             normal)
            set_cell(s.anchor, k, o, anchor)
            set_cell(s.normal, k, o, normal)
            offset, delta, tangential = spring_offset(rot, position, hand, radius, anchor, normal)
        s.depth[k, o] = delta
        if delta <= 0.0:  # off the face it pressed on: nothing presses, nothing pulls
            continue
        if not friction or s.sliding[k, o]:  # an anchor held at a face's edge cannot pull past the cone
            limit = p.dynamic_friction[o] * delta if friction else 0.0
            if mesh is not None and p.shape[o] == MESH:
                along = mesh_along_face(mesh, o, anchor, normal, tangential)
            else:
                along = along_face(p.shape[o], row(p.half_size, o), anchor, normal, tangential)
            length = norm(along)
            if length > limit or along != tangential:
                offset = add(scale(delta, normal), scale(min(1.0, limit / length) if length > 0.0 else 0.0, along))
                if under_phalanx:
                    anchor = sub(anchor, sub(tangential, along))
        n_world = mat_vec(rot, normal)
        r = add(mat_vec(rot, anchor), scale(radius, n_world))
        on_object = scale(-gamma, mat_vec(rot, offset))
        hand_velocity = row(s.hand_velocity, k)
        separating = dot(n_world, sub(hand_velocity, point_velocity(velocity, angular_velocity, r)))
        if delta <= h * separating:
            add_point_force(wrench, r, scale(delta / (2.0 * h * separating), on_object))
            continue
        if friction and not s.sliding[k, o]:
            local = ((gamma, 0.0, 0.0), (0.0, gamma, 0.0), (0.0, 0.0, gamma))
        else:
            local = outer(gamma, n_world, n_world)
        add_point_force(wrench, r, add(on_object, scale(h, mat_vec(local, hand_velocity))))
        add_point_matrix(stiffness, r, local)
