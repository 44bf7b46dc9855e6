"""The table: a static horizontal surface at ``scene.table.height`` that objects rest on.

Under Earth gravity (the paper's evaluation, section 4.3) the objects wait on a table to be
picked up and fall back onto it when dropped. Each box corner (a sphere's lowest point) below the
surface is a compliant contact (see ``compliant``) with the object's static friction. The hand
passes through the table: it is not tracked against it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .bodies import BOX
from .compliant import add_compliant_contact
from .rotation import quat_to_matrix

DOWN = np.array([0.0, -1.0, 0.0])
CORNERS = np.array([[sx, sy, sz] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0) for sz in (-1.0, 1.0)])


@njit(cache=True)
def _table(height, spring, damper, slip_velocity, shape, half_size, static_friction, position, orientation,
           velocity, angular_velocity, wrench, stiffness, damping, corners, down, h):
    still = np.zeros(3)
    for o in range(position.shape[0]):
        rot = quat_to_matrix(orientation[o])
        if shape[o] == BOX:
            for c in range(corners.shape[0]):
                r = rot @ (corners[c] * half_size[o])
                depth = height - (position[o, 1] + r[1])
                if depth > 0.0:
                    add_compliant_contact(wrench[o], stiffness[o], damping[o], r, down, depth, still, velocity[o],
                                          angular_velocity[o], spring, damper, static_friction[o], slip_velocity, h)
        else:
            r = half_size[o, 0] * down
            depth = height - (position[o, 1] + r[1])
            if depth > 0.0:
                add_compliant_contact(wrench[o], stiffness[o], damping[o], r, down, depth, still, velocity[o],
                                      angular_velocity[o], spring, damper, static_friction[o], slip_velocity, h)


def table_contacts(model, data, h: float) -> None:
    """Support, damping and friction from the table on every object corner below its surface."""
    t = model.scene.table
    _table(t.height, t.stiffness, t.damping, t.slip_velocity, model.shape, model.half_size, model.static_friction,
           data.position, data.orientation, data.velocity, data.angular_velocity, data.wrench, data.stiffness,
           data.damping, CORNERS, DOWN, h)
