"""The table: a static horizontal surface at ``scene.table.height`` that objects rest on.

Under Earth gravity (the paper's evaluation, section 4.3) the objects wait on a table to be
picked up and fall back onto it when dropped. Each box corner (a sphere's lowest point, a mesh's
convex parts' vertices) below the surface is a compliant contact (see ``compliant``) with the object's static friction. The hand
passes through the table: it is not tracked against it.
"""

from __future__ import annotations


from .bodies import BOX, MESH
from .compliant import add_compliant_contact
from .vec import kernel, mat_vec, row

DOWN = (0.0, -1.0, 0.0)
STILL = (0.0, 0.0, 0.0)


@kernel
def _corner(p, s, o, r, wrench, stiffness, damping, h):
    depth = p.table_height - (s.position[o, 1] + r[1])
    if depth > 0.0:
        add_compliant_contact(wrench, stiffness, damping, r, DOWN, depth, STILL, row(s.velocity, o),
                              row(s.angular_velocity, o), p.table_stiffness, p.table_damping,
                              p.static_friction[o], p.table_slip_velocity, h)


@kernel
def table_contacts(p, s, o, rot, wrench, stiffness, damping, h, mesh):
    """Support, damping and friction from the table on every corner of object o below its surface."""
    if mesh is not None and p.shape[o] == MESH:
        for c in range(mesh.object_corners[o, 0], mesh.object_corners[o, 1]):
            _corner(p, s, o, mat_vec(rot, row(mesh.corners, c)), wrench, stiffness, damping, h)
        return
    half = row(p.half_size, o)
    if p.shape[o] != BOX:
        _corner(p, s, o, (0.0, -half[0], 0.0), wrench, stiffness, damping, h)
        return
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                _corner(p, s, o, mat_vec(rot, (sx * half[0], sy * half[1], sz * half[2])), wrench, stiffness,
                        damping, h)
