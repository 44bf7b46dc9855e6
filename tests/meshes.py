"""Mesh files for the mesh-object tests, written into a test's folder with their object files."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def ear_clip(outline: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles (counter-clockwise) of a simple counter-clockwise polygon, by clipping ears."""
    left, triangles = list(range(len(outline))), []
    while len(left) > 3:
        for k in range(len(left)):
            i, j, m = left[k - 1], left[k], left[(k + 1) % len(left)]
            a, b, c = outline[i], outline[j], outline[m]
            if _turn(a, b, c) <= 0:
                continue
            inside = [q for q in left if q not in (i, j, m) and _strictly_inside(outline[q], a, b, c)]
            if not inside:
                triangles.append((i, j, m))
                left.pop(k)
                break
    return triangles + [tuple(left)]


def _turn(a, b, c) -> float:
    """Twice the signed area of triangle abc (positive: counter-clockwise)."""
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


def _strictly_inside(point, a, b, c) -> bool:
    return all(_turn(p, q, point) > 1e-12 for p, q in ((a, b), (b, c), (c, a)))


def extruded(outline, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed prism of a counter-clockwise outline in the xy plane, from z = -depth/2 to depth/2."""
    outline = np.asarray(outline, dtype=np.float64)
    n = len(outline)
    vertices = np.vstack([np.column_stack([outline, np.full(n, -depth / 2)]),
                          np.column_stack([outline, np.full(n, depth / 2)])])
    faces = []
    for i, j, m in ear_clip(outline):
        faces += [(i + n, j + n, m + n), (m, j, i)]
    for i in range(n):
        j = (i + 1) % n
        faces += [(i, j, j + n), (i, j + n, i + n)]
    return vertices, np.array(faces)


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


L_ARMS, L_THICKNESS, L_DEPTH = (0.08, 0.06), 0.012, 0.025
"""The test L bracket: arms along x and y from the outer corner at the origin, thickness, depth (m)."""


def l_bracket() -> tuple[np.ndarray, np.ndarray]:
    (a, b), t = L_ARMS, L_THICKNESS
    return extruded([(0, 0), (a, 0), (a, t), (t, t), (t, b), (0, b)], L_DEPTH)


def mesh_object(folder: Path, name: str, vertices, faces, material=(0.4, 0.8, 0.5), **fields) -> Path:
    """An object file for a mesh (written beside it as NAME.obj); ``fields``: mass or density."""
    write_obj(folder / f"{name}.obj", np.asarray(vertices), np.asarray(faces))
    lines = [f'name = "{name}"', 'shape = "mesh"', f'mesh = "{name}.obj"']
    lines += [f"{key} = {value!r}" for key, value in fields.items()]
    lines += ["[material]", f"restitution = {material[0]}", f"static_friction = {material[1]}",
              f"dynamic_friction = {material[2]}"]
    path = folder / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path
