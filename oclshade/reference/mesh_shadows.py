"""Float64 twin of the mesh shadow volumes (kernels/shadow_volume.cl,
oclshade.meshes.shadow_volumes): a shadow ray from each pixel's surface point towards the
light, tested against every triangle of every casting mesh (numpy, vectorised).

Decisions: a point is shadowed when its ray meets a triangle (two-sided) at t > 0 (towards a
point light: before the light).  A triangle within ``band`` of the point holds it: it hides
the light exactly when the point is seen on its side turned away from the light (a lit
surface does not shadow itself; a surface seen from its dark side is in its own shadow, as
the volumes count it).

Ties (:func:`tie_pixels`): the float32 count can differ from these decisions only where a
quantity it compares is within its rounding of the boundary.  Its inputs are view-space
float32 (relative rounding u = 2^-24 of the coordinates, of magnitude up to M, the largest
distance from the eye involved).  An edge function is evaluated as d . (a x e), e = b - a
the edge (exact or within u |e|: Sterbenz), a plane side as a . N with N = e1 x e2 from edges:
for a line d between the edge's ends, rounding the inputs moves d . (a x e) by about
2 u |d| M |e|, the cross product's two products and difference by 2 u per component (3.5 u
in norm) and the dot product by 3 u more: about 9 u |d| M |e| in all (Higham's gamma_n
bounds, first order); a plane side likewise within 9 u M |N|.  The band is 16 u: ties are
pixels whose surface point lies within 16 u M of a volume side or dark cap, whose view line
passes between a silhouette edge's ends within 16 u |d| M |e| of its plane through the start
(the G-buffer's own outline of a caster), whose near-plane point lies within 16 u M of a
cap, or whose shadow ray meets a triangle at a sine below 16 u (the light grazing a face:
:func:`shadow_mask`).

Independent edge count: :func:`boundary_edges` (numpy unique over directed edges).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..camera import Camera
from ..meshes.lights import Light, PointLight, towards_light
from ..meshes.mesh import TriangleMesh

#: the band in units of u M (see the module doc: the rounding bound is about 9 u)
BAND_ULPS = 16.0
U32 = 2.0 ** -24


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """Directed edges (i, j) of ``faces`` not cancelled by an opposite edge (j, i), each as
    often as it is left over, sorted: numpy over sorted edge keys with their orientation."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(e, axis=1)
    sign = np.where(e[:, 0] < e[:, 1], 1, -1)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    net = np.zeros(len(uniq), np.int64)
    np.add.at(net, inverse.reshape(-1), sign)
    out = [((a, b) if s > 0 else (b, a)) for (a, b), s in zip(uniq.tolist(), net.tolist()) for _ in range(abs(s))]
    return np.array(sorted(out), np.int64).reshape(-1, 2)


#: the count's segment stops this fraction of the point's depth short of it (kernels/shadow_volume.cl)
BIAS = 2.0 ** -18


def world_points(camera: Camera, position: np.ndarray) -> np.ndarray:
    """World float64 (H, W, 3) of the G-buffer's view-space positions (float32 (H, W, 4)),
    each moved :data:`BIAS` x its depth towards the eye along its view ray, as the count's
    segment ends."""
    view = position[..., :3].astype(np.float64)
    depth = -view[..., 2:3]
    if camera.projection == "perspective":
        view = view * (1.0 - BIAS)
    else:
        view = view + BIAS * depth * np.array([0.0, 0.0, 1.0])
    return (view - camera.view[:3, 3]) @ camera.view[:3, :3]


def _ray_hits(origins: np.ndarray, dirs: np.ndarray, tri: np.ndarray, t_max: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """(hits, grazing), (P, T) bool each: ray P meets triangle T (two-sided, Moeller-Trumbore)
    at 0 < t < t_max[P]; it meets it (or passes within its float32 band) at a sine below the
    band to its plane."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    pv = np.cross(dirs[:, None, :], e2[None])
    det = np.einsum("ptk,tk->pt", pv, e1)
    scale = np.linalg.norm(np.cross(e1, e2), axis=1)[None] * np.linalg.norm(dirs, axis=1)[:, None]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / det
        s = origins[:, None, :] - a[None]
        u = np.einsum("ptk,ptk->pt", s, pv) * inv
        q = np.cross(s, e1[None])
        v = np.einsum("ptk,pk->pt", q, dirs) * inv
        t = np.einsum("ptk,tk->pt", q, e2) * inv
        hits = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < t_max[:, None])
        flat = (np.abs(det) <= BAND_ULPS * U32 * scale) & (scale > 0)
        near = (u >= -0.01) & (v >= -0.01) & (u + v <= 1.01) & (t >= 0)
    return hits, flat & near


def point_triangle_distance(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Float64 distances from points (N, 3) to triangles (N, 3, 3), pair by pair."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("nk,nk->n", n, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.einsum("nk,nk->n", points - a, n) / np.sqrt(nn)
    inside = nn > 0
    for p0, p1 in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("nk,nk->n", np.cross(p1 - p0, points - p0), n) >= 0
    best = np.where(inside, np.abs(h), np.inf)
    for p0, p1 in ((a, b), (b, c), (c, a)):
        e, r = p1 - p0, points - p0
        ee = np.einsum("nk,nk->n", e, e)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.clip(np.nan_to_num(np.einsum("nk,nk->n", r, e) / ee), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(r - s[:, None] * e, axis=1))
    return best


def near_triangles(points: np.ndarray, tri: np.ndarray, band: np.ndarray) -> np.ndarray:
    """(P, T) bool: point p within band[p, t] (or band[p]) of triangle t (boxes first)."""
    band = np.broadcast_to(band if np.ndim(band) == 2 else np.asarray(band)[:, None], (len(points), len(tri)))
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    cand = np.ones(band.shape, bool)
    for k in range(3):
        x = points[:, k, None]
        cand &= (x >= lo[None, :, k] - band) & (x <= hi[None, :, k] + band)
    pi, ti = np.nonzero(cand)
    out = np.zeros(band.shape, bool)
    out[pi, ti] = point_triangle_distance(points[pi], tri[ti]) <= band[pi, ti]
    return out


def _chunks(n: int, per: int) -> list[slice]:
    step = max(1, per)
    return [slice(k, min(k + step, n)) for k in range(0, n, step)]


def shadow_mask(meshes: Sequence[TriangleMesh], light: Light, points: np.ndarray, hit: np.ndarray,
                viewer: np.ndarray, band: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(mask, grazing), bool (same shape as ``hit``): the light hidden from the world
    ``points`` (..., 3) by a triangle of a mesh with ``cast_shadows`` (module doc); the shadow
    ray meets a triangle at a grazing angle (a tie).  A triangle within ``band`` (per
    point, or one) of its point holds it: it hides the light only when the point is seen
    (``viewer``: (..., 3) vectors from the points towards the eye) on its side turned away
    from the light."""
    tri = np.concatenate([m.vertices[m.faces] for m in meshes if m.cast_shadows] or [np.zeros((0, 3, 3))])
    flat = points.reshape(-1, 3)[hit.reshape(-1)]
    bands = np.broadcast_to(np.asarray(band, np.float64), hit.shape).reshape(-1)[hit.reshape(-1)]
    eyes = np.broadcast_to(viewer, points.shape).reshape(-1, 3)[hit.reshape(-1)]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.zeros(len(flat), bool)
    graze = np.zeros(len(flat), bool)
    if len(tri):
        for sl in _chunks(len(flat), 2_000_000 // max(len(tri), 1)):
            p = flat[sl]
            to = towards_light(light, p)
            t_max = np.ones(len(p)) if isinstance(light, PointLight) else np.full(len(p), np.inf)
            hits, flat_hits = _ray_hits(p, np.ascontiguousarray(to), tri, t_max)
            graze[sl] = flat_hits.any(axis=1)
            seen = np.einsum("pk,tk->pt", eyes[sl], nrm) * np.einsum("pk,tk->pt", to, nrm)
            holds = near_triangles(p, tri, bands[sl])
            hits = (hits & ~(holds & (seen > 0))) | (holds & (seen < 0))
            out[sl] = hits.any(axis=1)
    mask, grazing = np.zeros(hit.shape, bool), np.zeros(hit.shape, bool)
    mask[hit], grazing[hit] = out, graze
    return mask, grazing


def towards_viewer(camera: Camera, points: np.ndarray) -> np.ndarray:
    """World vectors from ``points`` (..., 3) towards the eye (orthographic: the view's back axis)."""
    if camera.projection == "orthographic":
        return np.broadcast_to(camera.view[2, :3], np.shape(points))
    return camera.position - points


def float32_band(camera: Camera, world: np.ndarray | float) -> np.ndarray:
    """64 u M for world points: M their view-space distance from the eye (at least 1 m)."""
    dist = np.linalg.norm(np.asarray(world, np.float64) - camera.position, axis=-1)
    return BAND_ULPS * U32 * np.maximum(dist, 1.0)


def tie_pixels(camera: Camera, volumes, points: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Bool (H, W): pixels whose float32 count may differ from the float64 decision (module
    doc).  ``volumes``: :class:`oclshade.meshes.shadow_volumes.Volumes` of the frame's light."""
    kinds = volumes.faces[:, 3]
    tri = volumes.triangles
    caps_top = (kinds == 1)
    n_caps = int(caps_top.sum())
    light_cap = np.zeros(len(tri), bool)
    light_cap[np.flatnonzero(caps_top)[: n_caps // 2]] = True
    rows, cols = np.nonzero(hit)
    p = points[rows, cols]
    ties = np.zeros(len(p), bool)
    if len(tri) == 0 or len(p) == 0:
        return np.zeros(hit.shape, bool)
    tri_m = np.linalg.norm(tri - camera.position, axis=-1).max(axis=1)        # M per face
    origins, _ = camera.view_rays(rows, cols)
    starts = origins @ camera.view[:3, :3] + camera.position                    # world start (depth 0)
    depth = -((p - camera.position) @ camera.view[2, :3])
    near_pts = starts + (p - starts) * (camera.near / np.maximum(depth, camera.near))[:, None]
    sides = volumes.faces[kinds == 0]
    sil = sides[: len(sides) // 2]                       # (j, i, i + n): silhouette edge i -> j on top
    caps = tri[kinds == 1]
    for sl in _chunks(len(p), 2_000_000 // max(len(tri), 1)):
        pm = np.linalg.norm(p[sl] - camera.position, axis=1)
        band = BAND_ULPS * U32 * np.maximum(np.maximum(pm[:, None], tri_m[None]), 1.0)
        ties[sl] |= near_triangles(p[sl], tri[~light_cap], band[:, ~light_cap]).any(axis=1)
        if len(caps):
            ties[sl] |= near_triangles(near_pts[sl], caps, band[:, kinds == 1]).any(axis=1)
        if len(sil):       # |d . (a x b)| within 16 u |d| max(|a|, |b|) |b - a| (orthographic: across the view)
            view = camera.view[:3, :3]
            o = (starts[sl] - camera.position) @ view.T
            ra = (volumes.vertices[sil[:, 1]] - camera.position) @ view.T - o[:, None, :]
            rb = (volumes.vertices[sil[:, 0]] - camera.position) @ view.T - o[:, None, :]
            dirs = ((p[sl] - camera.position) @ view.T - o)[:, None, :]
            n = np.cross(ra, rb)
            f = np.einsum("pek,pek->pe", dirs, n)
            ld, la, lb, ln = (np.linalg.norm(x, axis=-1) for x in (dirs, ra, rb, n))
            between = (np.einsum("pek,pek->pe", np.cross(dirs, rb), n) >= -0.01 * ld * lb * ln) & \
                      (np.einsum("pek,pek->pe", np.cross(ra, dirs), n) >= -0.01 * ld * la * ln)
            if camera.projection == "orthographic":
                ra[..., 2] = rb[..., 2] = 0.0
            bound = ld * np.maximum(np.linalg.norm(ra, axis=-1), np.linalg.norm(rb, axis=-1)) * \
                np.linalg.norm(rb - ra, axis=-1)
            ties[sl] |= ((np.abs(f) <= BAND_ULPS * U32 * bound) & between).any(axis=1)
    out = np.zeros(hit.shape, bool)
    out[rows, cols] = ties
    return out
