"""Float64 twins of kernels/quadric.cl: quadrics ray-cast in world space, their G-buffer
fields, and the shadow rays (against quadrics and the terrain).

A quadric (:class:`oclshade.quadrics.Quadric` or anything with ``kind``, ``centre``, ``radii``
and ``frame``) is a unit shape in local coordinates q = S^-1 R^T (p - centre), R = ``frame``
(columns: the local x, y, z axes in the world), S = diag(``radii``):

=============  ===========================================  =====================================
kind           surface in q                                 normal (gradient in q)
=============  ===========================================  =====================================
ellipsoid      |q|^2 = 1 (a sphere has three equal radii)   q
cylinder       qx^2 + qy^2 = 1, |qz| <= 1; caps qz = +-1     (qx, qy, 0); caps (0, 0, +-1)
               with qx^2 + qy^2 <= 1
paraboloid     qx^2 + qy^2 = qz, 0 <= qz <= 1 (open: the    (2 qx, 2 qy, -1)
               vertex at ``centre``, the rim at qz = 1)
=============  ===========================================  =====================================

The world normal is R S^-1 times the gradient, normalised (the inverse transpose of the
local map).  Normals in the G-buffer face the viewer where the surface is seen from its
inside (the open paraboloid's bowl, a camera inside a closed shape).  The twins solve
A t^2 + B t + C = 0 with textbook float64 formulas; the kernel's robust float32 forms are
what the tests hold against them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..camera import Camera

KINDS = ("sphere", "ellipsoid", "cylinder", "paraboloid")


def _local(q, origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f, g, M): ray origins and directions in the unit frame, M = S^-1 R^T."""
    m = np.diag(1.0 / np.asarray(q.radii, float)) @ np.asarray(q.frame, float).T
    return (origins - np.asarray(q.centre, float)) @ m.T, dirs @ m.T, m


def _roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both real roots of a t^2 + b t + c = 0 (NaN where none; a == 0: the linear root twice)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4.0 * a * c
        sq = np.sqrt(disc)
        r1 = (-b - sq) / (2.0 * a)
        r2 = (-b + sq) / (2.0 * a)
        lin = np.where(b != 0.0, -c / b, np.nan)
        r1 = np.where(a == 0.0, lin, r1)
        r2 = np.where(a == 0.0, lin, r2)
    return r1, r2


def _candidates(kind: str, f: np.ndarray, g: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """[(t, local gradient at t)] for every root whose point lies on the bounded surface."""
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind in ("sphere", "ellipsoid"):
            for t in _roots((g * g).sum(1), 2.0 * (f * g).sum(1), (f * f).sum(1) - 1.0):
                out.append((t, f + t[:, None] * g))
        elif kind == "cylinder":
            a = g[:, 0] ** 2 + g[:, 1] ** 2
            b = 2.0 * (f[:, 0] * g[:, 0] + f[:, 1] * g[:, 1])
            c = f[:, 0] ** 2 + f[:, 1] ** 2 - 1.0
            for t in _roots(np.where(a == 0.0, np.nan, a), b, c):
                q = f + t[:, None] * g
                out.append((np.where(np.abs(q[:, 2]) <= 1.0, t, np.nan), q * [1.0, 1.0, 0.0]))
            for side in (1.0, -1.0):
                t = (side - f[:, 2]) / g[:, 2]
                q = f + t[:, None] * g
                ok = q[:, 0] ** 2 + q[:, 1] ** 2 <= 1.0
                out.append((np.where(ok, t, np.nan), np.tile([0.0, 0.0, side], (len(t), 1))))
        elif kind == "paraboloid":
            a = g[:, 0] ** 2 + g[:, 1] ** 2
            b = 2.0 * (f[:, 0] * g[:, 0] + f[:, 1] * g[:, 1]) - g[:, 2]
            c = f[:, 0] ** 2 + f[:, 1] ** 2 - f[:, 2]
            for t in _roots(a, b, c):
                q = f + t[:, None] * g
                ok = (q[:, 2] >= 0.0) & (q[:, 2] <= 1.0)
                out.append((np.where(ok, t, np.nan), np.stack([2 * q[:, 0], 2 * q[:, 1], -np.ones(len(t))], 1)))
        else:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    return out


def intersect(q, origins: np.ndarray, dirs: np.ndarray, t_min: float | np.ndarray = 0.0,
              t_max: float | np.ndarray = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """(t, world unit normal) of the first hit with t_min <= t <= t_max of rays origin + t dir
    (world space, float64, (N, 3)); t = +inf and normal 0 where none.  The normal is the
    gradient's (outward for closed shapes), not yet turned to face the ray."""
    origins, dirs = np.atleast_2d(np.asarray(origins, float)), np.atleast_2d(np.asarray(dirs, float))
    f, g, m = _local(q, origins, dirs)
    best = np.full(len(f), np.inf)
    grad = np.zeros((len(f), 3))
    for t, gr in _candidates(q.kind, f, g):
        ok = np.isfinite(t) & (t >= t_min) & (t <= t_max) & (t < best)
        best = np.where(ok, t, best)
        grad = np.where(ok[:, None], gr, grad)
    n = grad @ m                                       # (R S^-1 grad)^T = grad^T S^-1 R^T = grad^T M
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return best, np.where(norm > 0, n / np.where(norm > 0, norm, 1.0), 0.0)


@dataclass
class ReferenceQuadrics:
    """Per pixel (height, width) of the nearest quadric hit."""

    depth: np.ndarray      # t = -z_view (+inf where no quadric)
    position: np.ndarray   # view space (H, W, 3)
    normal: np.ndarray     # view space unit, facing the viewer (H, W, 3)
    object: np.ndarray     # int: index + 1 of the quadric, 0 none


def cast_quadrics(quadrics, camera: Camera) -> ReferenceQuadrics:
    """The quadrics' G-buffer fields seen by ``camera`` (visible segment near <= t <= far)."""
    o_view, d_view = camera.view_rays()
    shape = o_view.shape[:2]
    rot = camera.rotation
    origins = o_view.reshape(-1, 3) @ rot + camera.position          # view -> world
    dirs = d_view.reshape(-1, 3) @ rot
    depth = np.full(len(origins), np.inf)
    normal = np.zeros((len(origins), 3))
    obj = np.zeros(len(origins), np.int64)
    for k, q in enumerate(quadrics):
        t, n = intersect(q, origins, dirs, camera.near, camera.far)
        nearer = t < depth
        depth = np.where(nearer, t, depth)
        normal = np.where(nearer[:, None], n, normal)
        obj = np.where(nearer, k + 1, obj)
    n_view = normal @ rot.T
    facing = np.sum(n_view * d_view.reshape(-1, 3), 1) > 0.0
    n_view = np.where(facing[:, None], -n_view, n_view)
    hit = np.isfinite(depth)
    pos = np.where(hit[:, None], o_view.reshape(-1, 3) + np.where(hit, depth, 0.0)[:, None] * d_view.reshape(-1, 3), 0.0)
    return ReferenceQuadrics(depth.reshape(shape), pos.reshape(shape + (3,)), n_view.reshape(shape + (3,)),
                             obj.reshape(shape))


def quadric_occludes(quadrics, points: np.ndarray, sun: np.ndarray, skip: np.ndarray | None = None,
                     t_min: float = 0.0) -> np.ndarray:
    """Boolean per world point (N, 3): the ray towards the sun (unit world vector) hits a
    quadric at t > t_min; ``skip`` (N,) int: quadric index + 1 to leave out (0 none)."""
    points = np.atleast_2d(np.asarray(points, float))
    dirs = np.broadcast_to(np.asarray(sun, float), points.shape)
    hit = np.zeros(len(points), bool)
    for k, q in enumerate(quadrics):
        t, _ = intersect(q, points, dirs, t_min)
        mine = np.zeros(len(points), bool) if skip is None else (skip == k + 1)
        hit |= np.isfinite(t) & (t > t_min) & ~mine
    return hit


def terrain_margin(heights: np.ndarray, start: tuple[float, float, float], ray: tuple[float, float, float]
                   ) -> float:
    """max over t > 0 of (surface - ray height) along a sun ray in heightmap units: start
    (u = column, v = row, z) and ray (ux, uy, w) per horizontal metre (:meth:`oclshade.Sun.ray`),
    heights (rows, cols) bilinear between samples, holes (NaN) and the world beyond the map
    occlude nothing; -inf if the ray meets no surface.  The terrain occludes iff the margin
    is > 0.  Every patch the ray's ground track crosses is tested exactly (a quadratic in t)."""
    h = np.asarray(heights, float)
    rows, cols = h.shape
    if rows < 2 or cols < 2:
        return -np.inf
    x0, y0, z0 = start
    ux, uy, w = ray
    ts = [0.0]
    for p0, u, n in ((x0, ux, cols), (y0, uy, rows)):
        if u != 0.0:
            ts += [(k - p0) / u for k in range(n)]
    ts = np.unique([t for t in ts if t >= 0.0 and np.isfinite(t)])
    worst = -np.inf
    for ta, tb in zip(ts[:-1], ts[1:]):
        tm = 0.5 * (ta + tb)
        xm, ym = x0 + ux * tm, y0 + uy * tm
        if not (0.0 <= xm <= cols - 1 and 0.0 <= ym <= rows - 1):
            continue
        pc, pr = min(int(np.floor(xm)), cols - 2), min(int(np.floor(ym)), rows - 2)   # a ray along the last line
        c = h[pr:pr + 2, pc:pc + 2]
        if np.isnan(c).any():
            continue
        fx, fy = x0 + ux * ta - pc, y0 + uy * ta - pr
        ex, ey, k = c[0, 1] - c[0, 0], c[1, 0] - c[0, 0], c[0, 0] - c[0, 1] - c[1, 0] + c[1, 1]
        s_a = c[0, 0] + ex * fx + ey * fy + k * fx * fy
        a = (ex + k * fy) * ux + (ey + k * fx) * uy - w
        s2 = k * ux * uy
        f_a = s_a - (z0 + w * ta)
        length = tb - ta
        cand = [f_a, f_a + (a + s2 * length) * length]
        if s2 < 0.0:
            tau = -a / (2.0 * s2)
            if 0.0 < tau < length:
                cand.append(f_a - a * a / (4.0 * s2))
        worst = max(worst, max(cand))
    return worst


def terrain_segment_occludes(heights: np.ndarray, start: tuple[float, float, float],
                             end: tuple[float, float, float], surface: bool = False) -> bool:
    """Whether the terrain rises strictly above the segment from ``start`` to ``end`` (a point
    light) somewhere with 0 < t <= 1 (kernels/terrain_ray.h terrain_segment_blocks): both in
    heightmap units (u = column, v = row, z relative as ``heights``), heights bilinear between
    samples, holes and the world beyond the map occlude nothing.  Every patch the segment's
    ground track crosses is tested exactly (a quadratic in t); a segment along z tests the
    patch under the start.  ``surface``: the start is a terrain surface point: its height is
    the bilinear surface's at (u, v) (its z is not read) on the first valid patch the segment
    meets within one cell along its major axis (the start patch; a start on a hole's border
    or the map's edge rounded off it gets that patch's surface, extended), and f = surface -
    segment is 0 there, so the segment is blocked at once when f's slope a > 0 (the light
    below the local surface); a start with no such patch keeps its z."""
    h = np.asarray(heights, float)
    rows, cols = h.shape
    if rows < 2 or cols < 2:
        return False
    x0, y0, z0 = (float(v) for v in start)
    ux, uy, w = (float(e) - float(s) for e, s in zip(end, start))
    ts = [0.0, 1.0]
    for p0, u, n in ((x0, ux, cols), (y0, uy, rows)):
        if u != 0.0:
            ts += [(k - p0) / u for k in range(n)]
    ts = np.unique([t for t in ts if 0.0 <= t <= 1.0])

    def patch(ta: float, tb: float) -> np.ndarray | None:
        tm = 0.5 * (ta + tb)
        xm, ym = x0 + ux * tm, y0 + uy * tm
        if not (0.0 <= xm <= cols - 1 and 0.0 <= ym <= rows - 1):
            return None
        pc, pr = min(int(np.floor(xm)), cols - 2), min(int(np.floor(ym)), rows - 2)
        c = h[pr:pr + 2, pc:pc + 2]
        return None if np.isnan(c).any() else (pr, pc, c)

    first = None                # the start patch's entry (the first valid patch within t_near)
    if surface:
        major = max(abs(ux), abs(uy))
        t_near = 1.0 / major if major > 0.0 else np.inf
        for ta, tb in zip(ts[:-1], ts[1:]):
            if ta >= t_near:
                break
            got = patch(ta, tb)
            if got is not None:
                pr, pc, c = got
                fx, fy = x0 - pc, y0 - pr                   # the start, on this patch's surface extended
                z0 = (c[0, 0] + (c[0, 1] - c[0, 0]) * fx + (c[1, 0] - c[0, 0]) * fy
                      + (c[0, 0] - c[0, 1] - c[1, 0] + c[1, 1]) * fx * fy)
                first = ta
                break
    for ta, tb in zip(ts[:-1], ts[1:]):
        got = patch(ta, tb)
        if got is None:
            continue
        pr, pc, c = got
        fx, fy = x0 + ux * ta - pc, y0 + uy * ta - pr
        ex, ey, k = c[0, 1] - c[0, 0], c[1, 0] - c[0, 0], c[0, 0] - c[0, 1] - c[1, 0] + c[1, 1]
        a = (ex + k * fy) * ux + (ey + k * fx) * uy - w
        s2 = k * ux * uy
        start = first == 0.0 and ta == 0.0
        f_a = 0.0 if start else c[0, 0] + ex * fx + ey * fy + k * fx * fy - (z0 + w * ta)
        length = tb - ta
        if (a > 0.0 if start else f_a > 0.0) or f_a + (a + s2 * length) * length > 0.0:
            return True
        if s2 < 0.0 and 0.0 < -a / (2.0 * s2) < length and f_a - a * a / (4.0 * s2) > 0.0:
            return True
    return False


def quadric_segment_occludes(quadrics, points: np.ndarray, light: np.ndarray, skip: np.ndarray | None = None,
                             t_min: float | np.ndarray = 0.0) -> np.ndarray:
    """Boolean per world point (N, 3): the segment to a point light at world ``light`` meets a
    quadric at t_min < t <= 1 (t in units of the segment); ``skip`` (N,) int: quadric index + 1
    to leave out (0 none)."""
    points = np.atleast_2d(np.asarray(points, float))
    dirs = np.asarray(light, float) - points
    hit = np.zeros(len(points), bool)
    for k, q in enumerate(quadrics):
        t, _ = intersect(q, points, dirs, t_min, 1.0)
        mine = np.zeros(len(points), bool) if skip is None else (skip == k + 1)
        hit |= np.isfinite(t) & (t > t_min) & ~mine
    return hit
