"""Mesh objects: a closed triangle mesh read from a file, its mass properties, and its convex parts.

An object file with ``shape = "mesh"`` names an OBJ or STL file (``mesh = "bracket.obj"``, relative
to the object file's folder; lengths in metres) and a ``density`` (kg/m^3) or a ``mass`` (kg).
``load_mesh`` reads it once, when the object file is loaded:

- the mesh must be closed (watertight) and enclose a positive volume; the mass, centre of mass and
  inertia are those of the solid it bounds, of uniform density;
- the body frame is the principal frame centred at the centre of mass, as for a box or a sphere;
  when the file's axes already are principal (a box, a sphere, anything symmetric about its axes)
  they are kept, so such a mesh is placed in a scene exactly as its analytic twin;
- the contact kernels (``mesh_contact``) work on convex polytopes: a convex mesh is one part, a
  non-convex one is split into convex parts by V-HACD (pybullet's ``vhacd``), once: the parts are
  cached in the user's cache directory under the hash of the file's content, so a study does not
  split them again each session.

Each convex part is described by its faces: a face is a maximal set of coplanar triangles of the
part's hull (a box part has six), with its outward unit normal n and offset d (the plane
n . x = d; inside, n . x < d), and its boundary edges, each with its in-plane outward normal m.
``pack_meshes`` lays every part of a scene's mesh objects out as the flat arrays the kernels read
(``state.unpack_mesh``); scenes without meshes never import this module's dependencies.
"""

from __future__ import annotations

import hashlib
import io
import os
import shutil
import sys
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from microg.skeleton.cache import user_cache_dir

MESH_SUFFIXES = (".obj", ".stl")
COPLANAR = 1e-6
"""How far apart (m, and in the normals' components) two face planes may be and still be one
plane: a seam between two parts of one flat side is not an edge of it."""
VHACD = {"resolution": 4_000_000, "depth": 32, "concavity": 1e-4}
"""V-HACD's settings: finer than its defaults (1e6 voxels, depth 20, concavity 1e-3), which let the
shipped mallet's parts stand 2.9 mm out of its concave corners; with these they stay within 0.9 mm
(an L bracket's within 0.2 mm), for a split of half a minute, once per mesh."""


@dataclass(frozen=True, eq=False)
class ConvexPart:
    """A convex polytope in the body frame, by its faces."""

    planes: np.ndarray
    """(F, 4): each face's outward unit normal and offset d (the face lies in n . x = d)."""
    edges: tuple[np.ndarray, ...]
    """Per face, (E, 10): each boundary edge's start (3), end (3), in-plane outward normal m (3), and
    1.0 when it is a seam (inside a coplanar face of another part: no edge of the object)."""
    vertices: np.ndarray
    """(V, 3): the hull's vertices."""


@dataclass(frozen=True, eq=False)
class MeshShape:
    """A mesh object's geometry in its body frame."""

    vertices: np.ndarray
    """(V, 3) the surface, for drawing."""
    faces: np.ndarray
    """(F, 3) vertex indices of the surface's triangles."""
    parts: tuple[ConvexPart, ...]
    volume: float
    unit_inertia: np.ndarray
    """(3,) principal moments per kg (m^2): a solid of uniform density."""
    from_file: np.ndarray
    """4x4: takes the file's coordinates to the body frame."""


class MeshError(ValueError):
    """A mesh file the physics cannot use; ``bodies`` turns it into a SceneError naming the object file."""


def load_mesh(path: Path, content: bytes | None = None) -> MeshShape:
    """Read, check and prepare a mesh file (module docstring), or its ``content`` kept elsewhere (a
    study's stored protocol); raises MeshError saying what is wrong."""
    import trimesh

    if path.suffix.lower() not in MESH_SUFFIXES:
        raise MeshError(f"{path}: must be an OBJ or STL file ({', '.join(MESH_SUFFIXES)})")
    if content is None:
        if not path.is_file():
            raise MeshError(f"{path}: no such file")
        content = path.read_bytes()
    try:
        surface = trimesh.load(io.BytesIO(content), file_type=path.suffix.lower()[1:], force="mesh")
    except (ValueError, IndexError, KeyError, TypeError, UnicodeDecodeError) as error:  # a corrupt file
        raise MeshError(f"{path}: cannot read: {error}") from None
    if len(surface.faces) == 0:
        raise MeshError(f"{path}: has no triangles")
    if not surface.is_watertight:
        raise MeshError(f"{path}: is not closed (watertight): a solid's surface must have no holes")
    with np.errstate(invalid="ignore", divide="ignore"):  # trimesh divides by the volume, maybe 0
        volume = surface.volume
    if volume < 0:
        surface.invert()
    if not abs(volume) > 1e-15:
        raise MeshError(f"{path}: encloses no volume (volume = {surface.volume:.3g} m^3)")
    from_file = principal_transform(surface.center_mass, surface.moment_inertia)
    body = surface.copy()
    body.apply_transform(from_file)
    unit_inertia = np.diag(body.moment_inertia) / body.volume
    if surface.is_convex:
        pieces = [body.vertices]
    else:
        digest = hashlib.sha256(content).hexdigest()[:32]
        pieces = [piece @ from_file[:3, :3].T + from_file[:3, 3] for piece in convex_pieces(path, digest, surface)]
    return MeshShape(np.asarray(body.vertices), np.asarray(body.faces), describe_parts(pieces),
                     float(body.volume), unit_inertia, from_file)


def principal_transform(centre: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """The 4x4 transform from the file's frame to the body frame: the centre of mass to the origin
    and, unless the file's axes already are principal, the principal axes onto x, y, z (right-handed)."""
    transform = np.eye(4)
    scale = np.abs(inertia).max()
    off_diagonal = inertia - np.diag(np.diag(inertia))
    if np.abs(off_diagonal).max() > 1e-9 * scale:
        _, axes = np.linalg.eigh(inertia)
        if np.linalg.det(axes) < 0:
            axes[:, 2] = -axes[:, 2]
        transform[:3, :3] = axes.T
    transform[:3, 3] = -transform[:3, :3] @ centre
    return transform


def convex_pieces(path: Path, digest: str, surface) -> list[np.ndarray]:
    """The vertices of each convex part of a non-convex mesh, in the file's frame: V-HACD's split,
    from the cache when a file of this content (``digest``) was split before."""
    settings = "-".join(f"{key}{value:g}" for key, value in VHACD.items())
    cached = parts_cache_folder() / f"{digest}-vhacd-{settings}.obj"
    if not cached.is_file():
        import pybullet

        with tempfile.TemporaryDirectory() as folder:
            source, log, result = (Path(folder) / name for name in ("mesh.obj", "vhacd.log", "parts.obj"))
            surface.export(source)
            with _quiet_stdout():
                pybullet.vhacd(str(source), str(result), str(log), **VHACD)
            if not result.is_file():
                raise MeshError(f"{path}: V-HACD could not split it into convex parts (see {log})")
            shutil.move(result, cached)
    return read_obj_objects(cached)


def parts_cache_folder() -> Path:
    """Where the convex parts are kept: the user's cache directory, else (not writable) the temporary one."""
    for folder in (user_cache_dir() / "microg" / "meshes", Path(tempfile.gettempdir()) / "microg-meshes"):
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(folder, os.W_OK):
            return folder
    raise MeshError("no writable folder to keep convex parts in (the user's cache directory, the temporary one)")


@contextmanager
def _quiet_stdout():
    """Silence what a C library prints on the process's standard output (V-HACD prints its progress)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def read_obj_objects(path: Path) -> list[np.ndarray]:
    """The vertices listed under each ``o`` line of an OBJ file (V-HACD writes one object per part)."""
    pieces: list[list[list[float]]] = []
    for line in path.read_text().splitlines():
        if line.startswith("o ") or (line.startswith("v ") and not pieces):
            pieces.append([])
        if line.startswith("v "):
            pieces[-1].append([float(x) for x in line.split()[1:4]])
    return [np.array(piece) for piece in pieces if len(piece) >= 4]


def describe_parts(pieces: list[np.ndarray]) -> tuple[ConvexPart, ...]:
    """Each piece's convex hull by its faces, with the edges between coplanar faces of different
    parts marked as seams."""
    import trimesh

    parts = []
    for piece in pieces:
        hull = trimesh.convex.convex_hull(piece)
        groups = [list(facet) for facet in hull.facets]
        grouped = set(np.concatenate(groups)) if groups else set()
        groups += [[t] for t in range(len(hull.faces)) if t not in grouped]
        planes, edges = [], []
        for group in groups:
            normal = hull.face_normals[group[0]]
            planes.append([*normal, float(normal @ hull.vertices[hull.faces[group[0]][0]])])
            edges.append(_face_edges(hull, group, normal))
        parts.append(ConvexPart(np.array(planes), tuple(edges), hull.vertices.copy()))
    _mark_seams(parts)
    return tuple(parts)


def _face_edges(hull, group: list[int], normal: np.ndarray) -> np.ndarray:
    """The boundary edges of a face (a group of coplanar triangles), each with its in-plane outward normal."""
    import trimesh

    triangles = hull.faces[group]
    centroid = hull.vertices[np.unique(triangles)].mean(axis=0)
    pairs = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    boundary = pairs[trimesh.grouping.group_rows(pairs, require_count=1)]
    rows = []
    for a, b in hull.vertices[boundary]:
        outward = np.cross(b - a, normal)
        outward /= np.linalg.norm(outward)
        if outward @ (centroid - a) > 0:
            outward = -outward
        rows.append([*a, *b, *outward, 0.0])
    return np.array(rows)


def _mark_seams(parts: list[ConvexPart]) -> None:
    """An edge of a face is a seam when just past it the same plane continues as a face of another part."""
    for i, part in enumerate(parts):
        for f, plane in enumerate(part.planes):
            for edge in part.edges[f]:
                beyond = 0.5 * (edge[0:3] + edge[3:6]) + 2 * COPLANAR * edge[6:9]
                edge[9] = float(any(_over_polygon(other.planes[g], other.edges[g], beyond)
                                    for j, other in enumerate(parts) if j != i
                                    for g in range(len(other.planes))
                                    if np.abs(other.planes[g] - plane).max() <= COPLANAR))


def _over_polygon(plane: np.ndarray, edges: np.ndarray, point: np.ndarray) -> bool:
    return bool(abs(plane[:3] @ point - plane[3]) <= COPLANAR
                and np.all(np.einsum("ij,ij->i", edges[:, 6:9], point - edges[:, 0:3]) <= COPLANAR))


def pack_meshes(meshes: list[MeshShape | None]) -> tuple[np.ndarray, np.ndarray]:
    """The convex parts of a scene's objects (None: not a mesh) as the tails of the model's buffers
    (reals, ints) that ``state.unpack_mesh`` reads: the counts (parts, faces, edges, corners), then
    [first, stop) ranges per object (parts, corners), per part (faces) and per face (edges); the
    face planes, the edges and the corners (the parts' vertices)."""
    object_parts, object_corners, part_faces, face_edges = [], [], [], []
    planes, edges, corners = [], [], []
    counts = np.zeros(4, dtype=np.int64)  # parts, faces, edges, corners so far
    for mesh in meshes:
        parts = mesh.parts if mesh is not None else ()
        object_parts.append([counts[0], counts[0] + len(parts)])
        first_corner = counts[3]
        for part in parts:
            part_faces.append([counts[1], counts[1] + len(part.planes)])
            for face in part.edges:
                face_edges.append([counts[2], counts[2] + len(face)])
                edges.append(face)
                counts[2] += len(face)
            planes.append(part.planes)
            corners.append(part.vertices)
            counts += [1, len(part.planes), 0, len(part.vertices)]
        object_corners.append([first_corner, counts[3]])
    ints = np.concatenate([counts, np.ravel(object_parts), np.ravel(object_corners), np.ravel(part_faces),
                           np.ravel(face_edges)])
    reals = np.concatenate([np.ravel(block) for block in planes + edges + corners] or [np.empty(0)])
    return reals.astype(np.float64), ints.astype(np.int64)
