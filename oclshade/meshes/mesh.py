"""Triangle meshes in the world (x east, y north, z up; metres): the one shape every mesh
pass shares (the G-buffer caster, shadow volumes, the float64 twins).

>>> mesh = TriangleMesh(vertices, faces)                 # already in world coordinates
>>> mesh = TriangleMesh(vertices, faces).placed(translate=(500, -800, 240), scale=2.0, rotate_z=30.0)

Layouts: ``vertices`` float64 (N, 3) world positions; ``faces`` int32 (M, 3) vertex indices,
counter-clockwise seen from outside (the face normal is (v1 - v0) x (v2 - v0));
``normals`` float64 (N, 3) per-vertex unit normals or None; ``uvs`` float64 (N, 2) texture
coordinates or None.  ``cast_shadows``: whether the mesh is a shadow caster.  ``surface``:
its look in the G-buffer (:class:`MeshSurface`: colour, texture with alpha cut-outs,
tangent-space normal map; docs/meshes.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True, eq=False)
class MeshSurface:
    """How a mesh looks in the G-buffer (kernels/mesh.cl).

    ``colour``: linear RGB albedo, multiplied by the texture's RGB where there is one.
    ``texture``: float32 (h, w, 4) linear RGBA, row 0 the top of the image (uv v = 1), or
    None; texels are looked up nearest, uv wrapping (repeat).  A hit whose texel alpha is
    below ``alpha_cutoff`` is skipped: the ray goes on (an alpha cut-out leaves no trace).
    ``normal_map``: float32 (h, w, 3) tangent-space unit normals (x along the tangent, the
    direction of growing u; y along growing v; z the surface normal), or None.
    Texture and normal map need the mesh's uvs.
    """

    colour: tuple[float, float, float] = (0.8, 0.8, 0.8)
    texture: np.ndarray | None = None
    normal_map: np.ndarray | None = None
    alpha_cutoff: float = 0.5

    def __post_init__(self) -> None:
        c = tuple(float(x) for x in np.asarray(self.colour, float).reshape(-1))
        if len(c) != 3 or not all(math.isfinite(x) and x >= 0 for x in c):
            raise ValueError(f"colour must be 3 finite numbers >= 0 (linear RGB), got {self.colour!r}")
        object.__setattr__(self, "colour", c)
        for name, channels in (("texture", 4), ("normal_map", 3)):
            a = getattr(self, name)
            if a is None:
                continue
            a = np.ascontiguousarray(a, np.float32)
            if a.ndim != 3 or a.shape[2] != channels or min(a.shape[:2]) < 1 or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be finite float32 of shape (height, width, {channels}), got {a.shape}")
            object.__setattr__(self, name, a)
        if not (isinstance(self.alpha_cutoff, (int, float)) and 0.0 <= self.alpha_cutoff <= 1.0):
            raise ValueError(f"alpha_cutoff must be a number in [0, 1], got {self.alpha_cutoff!r}")

    @property
    def cuts_out(self) -> bool:
        """Whether some texel is cut out (alpha below the cutoff)."""
        return self.texture is not None and bool((self.texture[..., 3] < self.alpha_cutoff).any())


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    cast_shadows: bool = True
    name: str = "mesh"
    surface: MeshSurface = MeshSurface()

    def __post_init__(self) -> None:
        v = np.array(self.vertices, dtype=np.float64)
        f = np.array(self.faces)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or not np.all(np.isfinite(v)):
            raise ValueError(f"{self.name}: vertices must be finite numbers of shape (N, 3), got shape {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
            raise ValueError(f"{self.name}: faces must be integer vertex indices of shape (M, 3), got "
                             f"{f.dtype} {f.shape}")
        if f.min() < 0 or f.max() >= len(v):
            raise ValueError(f"{self.name}: face vertex indices must be in 0..{len(v) - 1}, got "
                             f"{int(f.min())}..{int(f.max())}")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f.astype(np.int32))
        for name, width in (("normals", 3), ("uvs", 2)):
            a = getattr(self, name)
            if a is not None:
                a = np.array(a, dtype=np.float64)
                if a.shape != (len(v), width) or not np.all(np.isfinite(a)):
                    raise ValueError(f"{self.name}: {name} must be finite numbers of shape ({len(v)}, {width}), "
                                     f"got shape {a.shape}")
                object.__setattr__(self, name, a)
        if not isinstance(self.surface, MeshSurface):
            raise TypeError(f"{self.name}: surface must be an oclshade.meshes.MeshSurface, got "
                            f"{type(self.surface).__name__}")
        if self.uvs is None and (self.surface.texture is not None or self.surface.normal_map is not None):
            raise ValueError(f"{self.name}: a texture or normal map needs the mesh's uvs")

    def placed(self, translate=(0.0, 0.0, 0.0), scale: float = 1.0, rotate_z: float = 0.0) -> "TriangleMesh":
        """The mesh scaled, turned ``rotate_z`` degrees counter-clockwise about the vertical
        (seen from above) and moved by ``translate``, in that order; normals turned with it."""
        t = np.asarray(translate, float).reshape(-1)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"translate must be 3 finite numbers (x east, y north, z up), got {translate!r}")
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise ValueError(f"scale must be a finite number > 0, got {scale!r}")
        c, s = math.cos(math.radians(rotate_z)), math.sin(math.radians(rotate_z))
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        normals = None if self.normals is None else self.normals @ turn.T
        return replace(self, vertices=scale * self.vertices @ turn.T + t, normals=normals)

    @property
    def face_normals(self) -> np.ndarray:
        """Unnormalised face normals (v1 - v0) x (v2 - v0), float64 (M, 3)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return np.cross(b - a, c - a)

    @property
    def vertex_normals(self) -> np.ndarray:
        """Per-vertex unit normals: the file's (``normals``), else area-weighted averages of
        the faces around each vertex (the sum of their cross products, normalised; a vertex of
        only degenerate faces gets 0)."""
        if self.normals is not None:
            return self.normals
        acc = np.zeros_like(self.vertices)
        fn = self.face_normals
        for k in range(3):
            np.add.at(acc, self.faces[:, k], fn)
        length = np.linalg.norm(acc, axis=1, keepdims=True)
        return np.divide(acc, length, out=np.zeros_like(acc), where=length > 0)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lowest corner, highest corner) of the axis-aligned box around the vertices."""
        return self.vertices.min(axis=0), self.vertices.max(axis=0)
