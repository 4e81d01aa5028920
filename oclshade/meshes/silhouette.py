"""Shadow casters and their silhouette (paper 003, section 3).

Casters: the faces of a mesh that face the light, ``n . (light - v0) > 0`` (n = (v1 - v0) x
(v2 - v0), float64; edge-on faces cast nothing).  On an *open* mesh (an edge without its
opposite twin: a boundary, or faces of inconsistent orientation) a face turned away from the
light still stops light, so every face that is not edge-on casts, turned to face the light
(two-sided; docs/shadow_volumes.md "Open meshes").

Silhouette: the paper's adjacency-list edge cancellation over the caster faces: for each face,
each edge (i, j): if L[j] contains i, remove i from L[j], else add j to L[i].  An edge shared by
two casters (met once as (i, j), once as (j, i)) cancels; what remains, as directed edges
i -> j (the casters' winding), is the boundary of the caster set: the silhouette of a closed
mesh, plus the open boundary where the mesh has one.  The shadow volume is the casters (light
cap), the silhouette edges extruded away from the light (sides) and the casters moved to the
extrusion's end, reversed (dark cap): a closed oriented surface whichever the mesh.
"""
from __future__ import annotations

import numpy as np

from .lights import Light, towards_light
from .mesh import TriangleMesh


def is_closed(faces: np.ndarray) -> bool:
    """Every directed edge (i, j) of the faces is met once, and (j, i) once: a closed,
    consistently oriented surface."""
    f = np.asarray(faces, dtype=np.int64)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    n = int(f.max()) + 1
    key = edges[:, 0] * n + edges[:, 1]
    twin = edges[:, 1] * n + edges[:, 0]
    if len(np.unique(key)) != len(key):
        return False
    return bool(np.isin(twin, key, assume_unique=False).all())


def caster_faces(mesh: TriangleMesh, light: Light, closed: bool | None = None) -> np.ndarray:
    """The caster faces of ``mesh`` for ``light``, int32 (K, 3), each wound so that its normal
    faces the light (see the module doc); ``closed``: :func:`is_closed` of the mesh, computed
    when None.  Empty when the mesh does not cast shadows."""
    if not mesh.cast_shadows:
        return np.zeros((0, 3), np.int32)
    if closed is None:
        closed = is_closed(mesh.faces)
    v0 = mesh.vertices[mesh.faces[:, 0]]
    facing = np.einsum("ij,ij->i", mesh.face_normals, towards_light(light, v0))
    if closed:
        return mesh.faces[facing > 0.0]
    front, back = mesh.faces[facing > 0.0], mesh.faces[facing < 0.0]
    return np.concatenate([front, back[:, [0, 2, 1]]]).astype(np.int32)


def silhouette_edges(faces: np.ndarray) -> np.ndarray:
    """Directed edges (i, j), int32 (E, 2), left by the paper's adjacency-list cancellation
    over ``faces`` (module doc).  L is a multiset per vertex, so an edge met twice the same way
    (inconsistent winding) stays twice: the volume's boundary stays exact."""
    lists: dict[int, list[int]] = {}
    for a, b, c in np.asarray(faces, dtype=np.int64).tolist():
        for i, j in ((a, b), (b, c), (c, a)):
            lj = lists.get(j)
            if lj is not None and i in lj:
                lj.remove(i)
            else:
                lists.setdefault(i, []).append(j)
    out = [(i, j) for i, js in lists.items() for j in js]
    return np.array(out, np.int32).reshape(-1, 2)
