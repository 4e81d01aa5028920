"""Mesh files (OBJ, PLY, and whatever else trimesh reads) -> :class:`TriangleMesh`, and the
images a mesh's surface uses (PNG textures and normal maps).

>>> mesh = load_mesh("bunny.obj", up="y")     # vertices turned from y-up to z-up
>>> surface = MeshSurface(texture=load_texture("leaf.png"), normal_map=load_normal_map("leaf_n.png"))

Loading goes through trimesh (process=False: vertices kept as in the file, none merged or
dropped).  Every part of the file is put into one mesh, each under its scene-graph
transform.  Per-vertex normals are the file's when every part has them, else computed
(area-weighted, :attr:`TriangleMesh.vertex_normals`); uvs are the file's when every part has
one per vertex, else None.  ``up="y"``: the file's y axis is turned to world z (a rotation of
+90 degrees about x: (x, y, z) -> (x, -z, y)), normals with it.
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from .mesh import TriangleMesh

UPS = ("z", "y")
#: y-up file coordinates -> z-up world coordinates (a proper rotation about x)
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def load_mesh(path: str | os.PathLike, up: str = "z", name: str | None = None, **kwargs) -> TriangleMesh:
    """Read a triangle mesh file; ``kwargs`` go to :class:`TriangleMesh` (cast_shadows, surface)."""
    import trimesh

    if up not in UPS:
        raise ValueError(f"up must be one of {', '.join(UPS)} (the file's up axis), got {up!r}")
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {path} does not exist")
    try:
        with warnings.catch_warnings():                 # trimesh's texture bookkeeping warns on NaN uvs
            warnings.simplefilter("ignore", RuntimeWarning)
            scene = trimesh.load(str(path), force="scene", process=False)
    except Exception as exc:                            # trimesh raises many kinds per format
        raise ValueError(f"{path}: cannot read it as a mesh: {exc}") from None
    parts = []
    for node in scene.graph.nodes_geometry:
        transform, geometry = scene.graph[node]
        part = scene.geometry[geometry]
        if isinstance(part, trimesh.Trimesh) and len(part.faces):
            parts.append((np.asarray(transform, float), part))
    if not parts:
        raise ValueError(f"{path}: holds no triangles")
    vertices, faces, normals, uvs, base = [], [], [], [], 0
    for transform, part in parts:
        v = np.asarray(part.vertices, float)
        vertices.append(v @ transform[:3, :3].T + transform[:3, 3])
        faces.append(np.asarray(part.faces, np.int64) + base)
        base += len(v)
        n = part._cache["vertex_normals"] if "vertex_normals" in part._cache else None
        normals.append(None if n is None or len(n) != len(v) else np.asarray(n, float) @ transform[:3, :3].T)
        uv = getattr(part.visual, "uv", None)
        uvs.append(None if uv is None or len(uv) != len(v) else np.asarray(uv, float))
    v, f = np.concatenate(vertices), np.concatenate(faces)
    n = None if any(x is None for x in normals) else np.concatenate(normals)
    if n is not None:
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    if up == "y":
        v = v @ Y_UP_TO_Z_UP.T
        n = None if n is None else n @ Y_UP_TO_Z_UP.T
    return TriangleMesh(v, f, n, None if any(x is None for x in uvs) else np.concatenate(uvs),
                        name=name or path.stem, **kwargs)


def _image(path: str | os.PathLike) -> np.ndarray:
    from PIL import Image

    try:
        with Image.open(path) as im:
            return np.asarray(im.convert("RGBA"), np.float32) / 255.0
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the image: {exc}") from None


def load_texture(path: str | os.PathLike) -> np.ndarray:
    """An 8-bit image (PNG) as a texture: float32 (h, w, 4), RGB from sRGB to linear, alpha as
    stored (opaque without an alpha channel)."""
    rgba = _image(path)
    c = rgba[..., :3]
    rgba[..., :3] = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return rgba


def load_normal_map(path: str | os.PathLike) -> np.ndarray:
    """An 8-bit tangent-space normal map (PNG; RGB = (n + 1) / 2, no sRGB curve) as float32
    (h, w, 3) unit vectors."""
    n = 2.0 * _image(path)[..., :3] - 1.0
    length = np.linalg.norm(n, axis=2, keepdims=True)
    return np.divide(n, length, out=np.tile(np.float32([0, 0, 1]), n.shape[:2] + (1,)), where=length > 0)
