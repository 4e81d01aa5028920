"""The flattened mesh tables of kernels/mesh.cl in a file, for the C host API
(``oclshade_mesh_tables_read``; host/README.md "Meshes").

>>> write_mesh_tables([load_mesh("bunny.obj").placed((500, -800, 240), 40.0)], "bunny.ocmesh")

The tables are the very arrays :class:`oclshade.meshes.MeshCaster` uploads (its BVH built by
:mod:`oclshade.meshes.bvh`), so a C program casting them gets the Python host's frames bit
for bit.  Format (every number little-endian):

=========  =====================  ==========================================================
offset     type                   content
=========  =====================  ==========================================================
0          8 bytes                the magic ``OCLSMSH1``
8          int32 x 6              meshes, nodes, slots, vertices, texels, 0 (reserved)
32         int32 meshes x 12      mi: per mesh (root node, flags, 0, 0), texture (first
                                  texel, w, h, 0), normal map (first texel, w, h, 0)
...        float64 meshes x 3     each mesh's origin (world; the tables are relative to it)
...        float64 meshes         each mesh's reach (largest vertex distance from its origin)
...        float32 meshes x 4     each mesh's colour (linear rgb) and alpha cutoff
...        float32 nodes x 8      BVH boxes: lo (xyz, 0), hi (xyz, 0)
...        int32 nodes x 2        BVH nodes (a, count)
...        float32 slots x 12     triangles: three vertices (xyz, 0), mesh-relative
...        int32 slots x 4        triangle vertex indices (global) and 0
...        float32 slots x 4      tangents (xyz, handedness)
...        float32 vertices x 4   vertex normals (xyz, 0)
...        float32 vertices x 2   vertex uvs
...        float32 texels x 4     every texture's and normal map's texels (at least one)
=========  =====================  ==========================================================

Layouts and meanings: the ABI in kernels/mesh.cl's header comment.
"""
from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from .caster import _flatten
from .mesh import TriangleMesh

MAGIC = b"OCLSMSH1"


def mesh_table_arrays(meshes: Sequence[TriangleMesh]) -> list[np.ndarray]:
    """The file's arrays after its header, in order (module doc)."""
    meshes = list(meshes)
    if not meshes or not all(isinstance(m, TriangleMesh) for m in meshes):
        raise ValueError("meshes must be one or more oclshade.meshes.TriangleMesh objects")
    t = _flatten(meshes)
    surface = np.array([(*m.surface.colour, m.surface.alpha_cutoff) for m in meshes], np.float32)
    return [t.mi.astype("<i4"), t.origins.astype("<f8"), np.array(t.reach, "<f8"), surface.astype("<f4"),
            t.box.astype("<f4"), t.info.astype("<i4"), t.tri.astype("<f4"), t.tvtx.astype("<i4"),
            t.tangent.astype("<f4"), t.vnrm.astype("<f4"), t.vuv.astype("<f4"), t.texel.astype("<f4")]


def write_mesh_tables(meshes: Sequence[TriangleMesh], path: str | os.PathLike) -> None:
    """Write the meshes' tables to ``path`` in the format of the module doc."""
    arrays = mesh_table_arrays(meshes)
    counts = [len(arrays[0]), len(arrays[5]), len(arrays[7]), len(arrays[9]), len(arrays[11]), 0]
    with open(path, "wb") as f:
        f.write(MAGIC)
        f.write(np.array(counts, "<i4").tobytes())
        for a in arrays:
            f.write(np.ascontiguousarray(a).tobytes())
