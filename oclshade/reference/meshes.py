"""Float64 twin of kernels/mesh.cl's primary rays: every pixel's ray against every triangle
(vectorised numpy; fine for small meshes and frames), and the float32 band around triangle
edges inside which the device may differ.

>>> ref = cast_meshes(meshes, camera)         # hit, depth, normal (view), uv, mesh, face, cos
>>> near = near_edges(meshes, camera)          # rays within the float32 band of an edge

Rays are the kernel's (pixel centres, ``t`` = depth), from the camera position in float64.
The intersection is Moller-Trumbore in float64, two-sided; the nearest hit in [near, far]
wins.  Normals: the per-vertex normals interpolated by the barycentrics, turned to face the
viewer when the triangle is seen from its back (as the kernel); uvs interpolated the same
way; alpha cut-outs by the nearest texel as the kernel (normal maps and colours are not
twinned: tests/test_mesh_gbuffer.py checks them in closed form).

The band (docs/meshes.md "Precision").  The device's ray misses the float64 one by at most
the float32 rounding of (a) the vertices relative to the mesh origin, u |v - origin|,
(b) the camera relative to it, u |c - origin|, (c) the ray direction, a few u t |d|, and
(d) the sheared coordinates of the watertight test, a few u times the same magnitudes
(u = 2^-24).  ``band(t) = 32 u (R + |c - origin| + t |d|)`` metres, R the largest |v -
origin|, bounds their sum with room; a pixel whose float64 ray passes within band(t) of a
triangle edge at its crossing may hit or miss that triangle on the device.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..camera import Camera
from ..meshes.mesh import TriangleMesh

U32 = 2.0 ** -24
#: the band's factor on u (module doc)
BAND = 32.0


def world_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(origins, directions) float64 (H*W, 3) in world coordinates; t along them is the depth."""
    o, d = camera.view_rays()
    rt = camera.rotation.T
    return (o.reshape(-1, 3) @ rt.T + camera.position), d.reshape(-1, 3) @ rt.T


def _chunks(n_rays: int, n_tris: int, budget: int = 1 << 21):
    step = max(1, budget // max(n_tris, 1))
    for a in range(0, n_rays, step):
        yield slice(a, min(a + step, n_rays))


def texel(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The nearest texel of each uv (..., 2), wrapping: column floor(frac(u) w), row
    floor((1 - frac(v)) h), both clamped to the image (kernels/mesh.cl texel_at)."""
    h, w = image.shape[:2]
    fu, fv = uv[..., 0] - np.floor(uv[..., 0]), uv[..., 1] - np.floor(uv[..., 1])
    col = np.clip(np.floor(fu * w).astype(np.int64), 0, w - 1)
    row = np.clip(np.floor((1.0 - fv) * h).astype(np.int64), 0, h - 1)
    return image[row, col]


def cast_meshes(meshes: Sequence[TriangleMesh], camera: Camera) -> dict[str, np.ndarray]:
    """Per pixel (H, W): hit (bool), depth (+inf empty), normal (view, (H, W, 3)), uv (the
    mesh's, 0 without; (H, W, 2)), mesh (index, -1 none), face (index, -1 none), cos (|cos|
    of the angle between the ray and the face).  Alpha cut-outs as the kernel: a hit whose
    nearest texel's alpha is below the surface's cutoff is no hit."""
    o, d = world_rays(camera)
    n = len(o)
    depth = np.full(n, np.inf)
    normal = np.zeros((n, 3))
    uv_of = np.zeros((n, 2))
    mesh_of = np.full(n, -1)
    face_of = np.full(n, -1)
    cosine = np.zeros(n)
    for k, mesh in enumerate(meshes):
        p = mesh.vertices[mesh.faces]
        e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        vn = mesh.vertex_normals[mesh.faces]
        tuv = mesh.uvs[mesh.faces] if mesh.uvs is not None else np.zeros((len(p), 3, 2))
        tex = mesh.surface.texture
        ng = np.cross(e1, e2)
        for sl in _chunks(n, len(p)):
            oo, dd = o[sl, None, :], d[sl, None, :]
            pv = np.cross(dd, e2)
            det = np.einsum("rtk,tk->rt", pv, e1)
            ok = det != 0
            inv = 1.0 / np.where(ok, det, 1.0)
            tv = oo - p[None, :, 0]
            b1 = np.einsum("rtk,rtk->rt", tv, pv) * inv
            qv = np.cross(tv, e1[None])
            b2 = np.einsum("rtk,rtk->rt", dd, qv) * inv
            t = np.einsum("tk,rtk->rt", e2, qv) * inv
            ok &= (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t >= camera.near) & (t <= camera.far)
            if tex is not None:
                r, c = np.nonzero(ok)
                uv = (1 - b1[r, c] - b2[r, c])[:, None] * tuv[c, 0] + b1[r, c][:, None] * tuv[c, 1] \
                    + b2[r, c][:, None] * tuv[c, 2]
                ok[r, c] = texel(tex, uv)[:, 3] >= mesh.surface.alpha_cutoff
            t = np.where(ok, t, np.inf)
            j = np.argmin(t, axis=1)
            rows = np.arange(len(j))
            tj = t[rows, j]
            better = tj < depth[sl]
            if not better.any():
                continue
            idx = np.arange(n)[sl][better]
            jb, rb = j[better], rows[better]
            w1, w2 = b1[rb, jb], b2[rb, jb]
            nn = (1 - w1 - w2)[:, None] * vn[jb, 0] + w1[:, None] * vn[jb, 1] + w2[:, None] * vn[jb, 2]
            g = ng[jb]
            length = np.linalg.norm(nn, axis=1, keepdims=True)
            nn = np.where(length > 0, nn / np.where(length > 0, length, 1), g / np.linalg.norm(g, axis=1)[:, None])
            back = np.einsum("ij,ij->i", g, d[idx]) > 0
            nn[back] *= -1
            depth[idx], normal[idx], mesh_of[idx], face_of[idx] = tj[better], nn, k, jb
            uv_of[idx] = (1 - w1 - w2)[:, None] * tuv[jb, 0] + w1[:, None] * tuv[jb, 1] + w2[:, None] * tuv[jb, 2]
            cosine[idx] = np.abs(np.einsum("ij,ij->i", g, d[idx])) / (
                np.linalg.norm(g, axis=1) * np.linalg.norm(d[idx], axis=1))
    shape = (camera.height, camera.width)
    return {"hit": np.isfinite(depth).reshape(shape), "depth": depth.reshape(shape),
            "normal": (normal @ camera.rotation.T).reshape(shape + (3,)), "uv": uv_of.reshape(shape + (2,)),
            "mesh": mesh_of.reshape(shape),
            "face": face_of.reshape(shape), "cos": cosine.reshape(shape)}


def band(mesh: TriangleMesh, camera: Camera, distance: np.ndarray) -> np.ndarray:
    """The float32 band (metres) at ``distance`` metres along a ray (module doc: t |d|)."""
    lo, hi = mesh.bounds
    origin = 0.5 * (lo + hi)
    reach = float(np.linalg.norm(mesh.vertices - origin, axis=1).max())
    return BAND * U32 * (reach + float(np.linalg.norm(camera.position - origin)) + distance)


def near_edges(meshes: Sequence[TriangleMesh], camera: Camera, pixels: np.ndarray | None = None) -> np.ndarray:
    """Bool (H, W): the pixel's float64 ray passes within :func:`band` of an edge of some
    triangle (its closest approach to the edge segment, t >= 0); only the ``pixels`` (bool
    (H, W)) are tested when given, the others read False."""
    o, d = world_rays(camera)
    keep = np.ones(len(o), bool) if pixels is None else np.asarray(pixels, bool).reshape(-1)
    o, d = o[keep], d[keep]
    dlen = np.linalg.norm(d, axis=1)
    u = d / dlen[:, None]
    out = np.zeros(len(o), bool)
    for mesh in meshes:
        f = mesh.faces
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        edges = np.unique(np.sort(edges, axis=1), axis=0)
        a, b = mesh.vertices[edges[:, 0]], mesh.vertices[edges[:, 1]]
        e = b - a
        ee = np.einsum("ij,ij->i", e, e)
        for sl in _chunks(len(o), len(a)):
            w = o[sl, None, :] - a[None]                          # (r, e, 3)
            ue = u[sl] @ e.T                                     # u . e
            uw = np.einsum("rk,rek->re", u[sl], w)
            ew = np.einsum("ek,rek->re", e, w)
            den = ee[None] - ue * ue                             # |e|^2 (1 - cos^2)
            s = np.where(den > 1e-300, (ew - ue * uw) / np.where(den > 1e-300, den, 1.0), 0.0)
            s = np.clip(s, 0.0, 1.0)                             # closest point's edge parameter
            q = a[None] + s[..., None] * e[None]
            tq = np.maximum(np.einsum("rk,rek->re", u[sl], q - o[sl, None, :]), 0.0)
            gap = np.linalg.norm(o[sl, None, :] + tq[..., None] * u[sl, None, :] - q, axis=2)
            out[sl] |= (gap <= band(mesh, camera, tq)).any(axis=1)
    full = np.zeros(keep.shape, bool)
    full[keep] = out
    return full.reshape(camera.height, camera.width)
