"""Float64 twins of kernels/ssao.cl and two ground truths of ambient occlusion on heightmaps.

Three different quantities live here; each function says which it computes.

* :func:`ssao` — the screen-space estimator of paper 001 exactly as the
  kernel defines it (same sample kernel, same per-pixel hash, same skip and
  occlusion rules), in float64.  It estimates, with m samples, the fraction
  of the *sample kernel's* point set around P whose pixel in the depth buffer
  holds a surface at least ``delta`` nearer to the camera.  Also returns per
  pixel the number of counted samples and of *tie* samples, whose decision
  float32 rounding may flip (see :func:`ssao`); kernel and twin agree to
  1e-6 except by at most ties / (counted - ties) on pixels with ties.
* :func:`volume_ao` — ground truth (a), the quantity the paper's test stands
  for when the view is ideal: the fraction of the *volume* of the hemisphere
  of radius R on the normal at P that lies under the terrain (below the
  bilinear surface, inside the map), by stratified Monte Carlo with n points.
  ``1 - fraction`` is reported, like the kernel's AO.
* :func:`raytraced_ao` — ground truth (b), classic ambient occlusion: the
  fraction of cosine-weighted directions on the hemisphere at P whose ray of
  length R hits the bilinear surface, each ray tested exactly patch by patch
  (quadratic along the ray in every patch); ``1 - fraction`` reported.

Heightmap frames: world x east, y north, z up, sample (i, j) at
(j dx, -i dy, h[i, j]) (oclshade/gbuffer.py).  :func:`topdown_gbuffer`
builds the simplest honest terrain G-buffer: an orthographic view straight
down, every pixel's position and normal taken from the bilinear surface at
the pixel centre, so the depth test of the estimator is the "under the
terrain" test up to the pixel grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gbuffer import GBuffer
from ..heightmap import Heightmap
from ..ssao import DEPTH_TOL, RAY_STEPS, disk_points, hemisphere_points, line_eye, line_table

HASH_SALT = np.uint32(0x9E3779B9)
F32 = float(np.finfo(np.float32).eps)


# ----------------------------------------------------------------------------- hash (kernel: ocls_mix)
def mix32(x: np.ndarray) -> np.ndarray:
    """The kernel's 32-bit integer mix, on uint32 arrays (wrapping arithmetic)."""
    x = np.asarray(x, np.uint32).copy()
    with np.errstate(over="ignore"):
        x ^= x >> np.uint32(16)
        x *= np.uint32(0x7FEB352D)
        x ^= x >> np.uint32(15)
        x *= np.uint32(0x846CA68B)
        x ^= x >> np.uint32(16)
    return x


def _signed_unit(h: np.ndarray) -> np.ndarray:
    k = (h >> np.uint32(8)).astype(np.int64)
    return (2 * k + 1 - (1 << 24)).astype(np.float64) * 2.0 ** -24


def rotation_vectors(width: int, height: int, seed: int) -> np.ndarray:
    """V_r = (2 f1 - 1, 2 f2 - 1, 0) per pixel, (height, width, 3) float64, exact like the kernel."""
    cols = np.arange(width, dtype=np.uint32)[None, :]
    rows = np.arange(height, dtype=np.uint32)[:, None]
    h = mix32(cols ^ mix32(rows ^ mix32(np.uint32(seed))))
    v = np.zeros((height, width, 3))
    v[..., 0] = _signed_unit(h)
    v[..., 1] = _signed_unit(mix32(h ^ HASH_SALT))
    return v


# ----------------------------------------------------------------------------- prepare + estimator
def prepare(position: np.ndarray, normal: np.ndarray, alpha: np.ndarray | None = None,
            alpha_eps: float = 0.5, normal_map: np.ndarray | None = None,
            tangent: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Twin of ``ssao_prepare``: (hit mask, normal used by the AO pass) in float64."""
    p = np.asarray(position, np.float64)
    n = np.asarray(normal, np.float64)[..., :3].copy()
    hit = (p[..., 3] >= 0.5) & np.isfinite(p[..., 2])   # x, y unchecked, as in the kernel
    if alpha is not None:
        hit &= np.asarray(alpha, np.float64) >= np.float32(alpha_eps)
    if normal_map is not None:
        tg = np.asarray(tangent, np.float64)
        q = np.asarray(normal_map, np.float64)
        with np.errstate(invalid="ignore", over="ignore"):
            t0 = tg[..., :3] - n * _dot(tg[..., :3], n)[..., None]
            tt = _dot(t0, t0)
            ok = (tt > 1e-12) & np.isfinite(tt)
            t = t0 / np.sqrt(np.where(ok, tt, 1.0))[..., None]
            b = np.cross(n, t) * np.where(tg[..., 3] < 0, -1.0, 1.0)[..., None]
            m = t * q[..., 0:1] + b * q[..., 1:2] + n * q[..., 2:3]
            mm = _dot(m, m)
            ok &= (mm > 1e-12) & np.isfinite(mm)
            n = np.where(ok[..., None], m / np.sqrt(np.where(ok, mm, 1.0))[..., None], n)
    return hit, n


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def occluder_planes(position: np.ndarray, normal: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """Twin of the ``-D OCLS_PLANE_TEST`` output of ``ssao_prepare``: per pixel the tangent plane
    (N, N . Q) of its surface, N the normalised geometric G-buffer normal ((0, 0, 1) when it is
    degenerate: then the plane test is the depth test), (0, 0, 0, -inf) on empty pixels."""
    p = np.asarray(position, np.float64)[..., :3]
    n = np.asarray(normal, np.float64)[..., :3]
    with np.errstate(invalid="ignore", over="ignore"):
        nn = _dot(n, n)
        ok = (nn > 1e-12) & np.isfinite(nn)
        N = np.where(ok[..., None], n / np.sqrt(np.where(ok, nn, 1.0))[..., None], [0.0, 0.0, 1.0])
        d = _dot(N, p)
    good = hit & np.isfinite(d)
    out = np.zeros(p.shape[:-1] + (4,))
    out[..., :3] = np.where(good[..., None], N, 0.0)
    out[..., 3] = np.where(good, d, -np.inf)
    return out


@dataclass
class ReferenceAO:
    ao: np.ndarray        # float64 (H, W): 1 - occluded / counted, 1 on empty pixels
    counted: np.ndarray   # int (H, W): samples on screen and in front of the camera
    ties: np.ndarray      # int (H, W): samples within rounding of a decision boundary
    hit: np.ndarray       # bool (H, W)
    normal: np.ndarray    # float64 (H, W, 3): the normal the pass used (mapped or not)
    bound: np.ndarray     # float64 (H, W): |float32 kernel - this twin| <= bound + 1e-6 (see ssao, ssao_lines)


def ssao(position: np.ndarray, normal: np.ndarray, projection: np.ndarray, kernel: np.ndarray,
         radius: float, delta: float, seed: int = 0, range_check: bool = False, plane_test: bool = False,
         alpha: np.ndarray | None = None, alpha_eps: float = 0.5,
         normal_map: np.ndarray | None = None, tangent: np.ndarray | None = None) -> ReferenceAO:
    """Twin of ``ssao_prepare`` + ``ssao_ao``: the paper's estimator (point samples), see kernels/ssao.cl.

    A sample is a *tie* when float32 rounding may change its fate: its depth
    margin |z_t - (A.z + delta)| (plane test: its distance below the occluder's plane less delta,
    tolerance plus 64 eps32 |N . Q|) or its range margin is within
    ``tol_z = 64 eps32 (|P| + R + |delta|)``, or (depth test) its snapped point's height above
    P's base plane is within :func:`_base_tolerance`, or its pixel coordinate is within
    ``tol_px = 64 eps32 (1 + |u|)`` (in pixels, likewise for rows) of a pixel or
    screen edge, or its clip w within tol_z of 0.  A tie may change the counted samples and the
    occluded ones by one each, so |kernel - twin| <= ties / (counted - ties).
    """
    return _point_estimator(position, normal, projection, np.asarray(kernel, np.float64)[:, :3], (1.0,), radius,
                            delta, seed, range_check, plane_test, alpha, alpha_eps, normal_map, tangent)


def ssao_rays(position: np.ndarray, normal: np.ndarray, projection: np.ndarray, m: int, radius: float,
              delta: float, seed: int = 0, range_check: bool = False, plane_test: bool = False,
              alpha: np.ndarray | None = None, alpha_eps: float = 0.5,
              normal_map: np.ndarray | None = None, tangent: np.ndarray | None = None) -> ReferenceAO:
    """Twin of ``ssao_prepare`` + ``ssao_ao`` with ``-D OCLS_RAYS`` (ray samples, see kernels/ssao.cl
    "Ray samples"): m cosine-weighted rays of length R (:func:`oclshade.ssao.line_table`'s
    directions), each tested at ``RAY_STEPS`` points R k / RAY_STEPS by the point test; a ray counts
    when all its points are on screen and is occluded when one of its counted points is: the
    screen-space estimate of :func:`raytraced_ao`.  ``counted`` and ``ties`` count rays (a tie ray:
    one of its points is a tie, as in :func:`ssao`); |kernel - twin| <= ties / (counted - ties)."""
    steps = tuple(k / RAY_STEPS for k in range(1, RAY_STEPS + 1))
    return _point_estimator(position, normal, projection, line_table(m).astype(np.float64), steps, radius, delta,
                            seed, range_check, plane_test, alpha, alpha_eps, normal_map, tangent)


def _point_estimator(position: np.ndarray, normal: np.ndarray, projection: np.ndarray, table: np.ndarray,
                     steps: tuple[float, ...], radius: float, delta: float, seed: int, range_check: bool,
                     plane_test: bool, alpha: np.ndarray | None, alpha_eps: float, normal_map: np.ndarray | None,
                     tangent: np.ndarray | None) -> ReferenceAO:
    """Point samples (``steps`` = (1,)) and ray samples: each table entry S is a sample made of the
    points P + f R (T S.x + B S.y + N S.z), f in ``steps``; it counts when all its points are on
    screen (a point sample: when it is counted), and is occluded when one of its counted points is."""
    pos = np.asarray(position, np.float64)
    height, width = pos.shape[:2]
    hit, n = prepare(position, normal, alpha, alpha_eps, normal_map, tangent)
    zflat = np.where(hit, pos[..., 2], -np.inf).ravel()
    pflat = pos[..., :3].reshape(-1, 3)
    planes = occluder_planes(pos, normal, hit).reshape(-1, 4) if plane_test else None
    nn = _dot(n, n)
    live = hit & (nn > 1e-12) & (nn < np.inf)
    ao = np.ones((height, width))
    counted = np.zeros((height, width), np.int64)
    ties = np.zeros((height, width), np.int64)
    rr, cc = np.nonzero(live)
    if rr.size == 0 or len(table) == 0:
        return ReferenceAO(ao, counted, ties, hit, n, np.zeros((height, width)))
    N = n[rr, cc] / np.sqrt(nn[rr, cc])[:, None]
    P = pos[rr, cc, :3]
    T, B = _rotated_frame(rotation_vectors(width, height, seed)[rr, cc], N)
    M = np.asarray(projection, np.float64)
    E = line_eye(M)
    tol_z = 64 * F32 * (np.linalg.norm(P, axis=1) + abs(radius) + abs(delta))
    occ_n = np.zeros(rr.size, np.int64)
    cnt_n = np.zeros(rr.size, np.int64)
    tie_n = np.zeros(rr.size, np.int64)
    for s in table:
        count = np.ones(rr.size, bool) if len(steps) > 1 else None
        occ = np.zeros(rr.size, bool)
        tie = np.zeros(rr.size, bool)
        for f in steps:
            A = P + (f * radius) * (T * s[0] + B * s[1] + N * s[2])
            on, j, pixel_tie = _pixel_of(A, M, width, height, tol_z)
            zt = zflat[j]
            if plane_test:
                pl = planes[j]
                with np.errstate(invalid="ignore"):
                    margin = -(_dot(pl[:, :3], A) - pl[:, 3]) - delta   # >= 0: at least delta below the plane
                occ_k = margin >= 0
                tie_k = np.abs(margin) <= tol_z + 64 * F32 * np.abs(np.nan_to_num(pl[:, 3], neginf=0.0))
                count_k = on
            else:
                # the point moved onto pixel j's line of sight at its own depth: A' = Q + g (A.z - Q.z) / g.z;
                # counted only when A' is on or above P's base plane (see kernels/ssao.cl step 4)
                surf, Q, g, w = _pixel_sight(E, pflat, zflat, j, P)
                with np.errstate(invalid="ignore"):
                    margin = zt - (A[:, 2] + (delta + DEPTH_TOL * np.abs(zt)))
                occ_k = surf & (margin >= 0)
                with np.errstate(invalid="ignore", divide="ignore"):
                    base = _dot(N, w) + (A[:, 2] - Q[:, 2]) / g[:, 2] * _dot(N, g)
                    near = np.abs(base) <= _base_tolerance(P, Q, g, N, radius, delta)
                tie_k = surf & ((np.abs(margin) <= tol_z) | near)
                count_k = on & (~surf | (base >= 0))
            if range_check:
                rmargin = radius - (zt - P[:, 2])
                tie_k |= occ_k & (np.abs(rmargin) <= tol_z)
                occ_k &= rmargin >= 0
            count = count_k if count is None else count & on
            occ |= count_k & occ_k
            tie |= pixel_tie | (tie_k & on)
        cnt_n += count
        occ_n += count & occ
        tie_n += tie
    with np.errstate(invalid="ignore", divide="ignore"):
        ao[rr, cc] = np.where(cnt_n > 0, 1.0 - occ_n / np.maximum(cnt_n, 1), 1.0)
    counted[rr, cc] = cnt_n
    ties[rr, cc] = tie_n
    bound = np.where(ties > 0, ties / np.maximum(counted - ties, 1), 0.0)
    return ReferenceAO(ao, counted, ties, hit, n, bound)


def _pixel_sight(E: np.ndarray, pflat: np.ndarray, zflat: np.ndarray, j: np.ndarray,
                 P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Step 4 of kernels/ssao.cl: pixel j's stored surface point Q and its line of sight through
    the camera point E: (surf, Q, g = E.xyz - E.w Q towards the camera (not normalised),
    w = Q - P); surf: j holds a surface usable as an occluder (hit, g.z > 0, g and w finite)."""
    Q = pflat[j]
    with np.errstate(invalid="ignore", over="ignore"):
        g = E[:3] - E[3] * Q
        w = Q - P
        surf = (zflat[j] != -np.inf) & (g[:, 2] > 0) & (_dot(g, g) < np.inf) & (_dot(w, w) < np.inf)
    return surf, Q, g, w


def _base_tolerance(P: np.ndarray, Q: np.ndarray, g: np.ndarray, N: np.ndarray, radius: float,
                    delta: float) -> np.ndarray:
    """How far float32 rounding may move the snapped point's height above the base plane,
    N . w + (A.z - Q.z) / g.z N . g: 64 eps32 (|w| + (|P| + R + |delta| + |Q.z|) (|N . g| + |g|) / g.z)."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        gl = np.linalg.norm(g, axis=1)
        scale = (np.linalg.norm(P, axis=1) + abs(radius) + abs(delta) + np.abs(Q[:, 2])) * (np.abs(_dot(N, g)) + gl)
        return 64 * F32 * (np.linalg.norm(Q - P, axis=1) + scale / g[:, 2])


def _base_cut(lo: np.ndarray | float, hi: np.ndarray | float, a: np.ndarray,
              c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chord [lo, hi] of a line X(t) cut by the base plane a + t c >= 0 (the kernel's rule:
    t >= t_c = -a / c when c >= 0, t <= t_c when c < 0; c = 0: all when a >= 0, none when a < 0):
    (lo, hi, t_c)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = np.where(c != 0, -a / c, np.where(a >= 0, -np.inf, np.inf))
    return np.where(c >= 0, np.maximum(lo, tc), lo), np.where(c >= 0, hi, np.minimum(hi, tc)), tc


def _inside(t: np.ndarray, e: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """e where the cut t (error e) may fall inside the chord [lo, hi], else 0."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(t) & (t >= lo - e) & (t <= hi + e), e, 0.0)


def _sight_chord(g: np.ndarray, w: np.ndarray, N: np.ndarray, radius: float,
                 delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step L4 of kernels/ssao.cl: the line Q + t D (D = g / |g|, w = Q - P) in the coordinate
    tau = t + b, b = w . D (tau = 0 closest to P): its chord through the ball |tau| <= h,
    h = sqrt(max(R^2 - |w x D|^2, 0)), cut by the base plane a + tau c >= 0 (a = N . w - b c,
    c = N . D), and its solid part tau <= b - delta / D.z (at least delta behind Q; the kernel's
    delta + DEPTH_TOL |Q.z|, per line):
    (length, occupied length, float32 error bound e of either).

    e = 2 e_h + the cuts' errors where they fall inside the chord: e_h = min(sqrt(e2), e2 / h) +
    64 eps32 R (e2 = 64 eps32 (|w| (2 |w x D| + 64 eps32 |w|) + R^2), the error of |w x D|^2; 0 where
    R^2 - |w x D|^2 <= -e2: no chord either way),
    base cut 64 eps32 (3 |w| + |t_c|) / |c|, solid cut 64 eps32 (|w| + |delta| / D.z)."""
    k = 64 * F32
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        D = g / np.linalg.norm(g, axis=1)[:, None]
        b = _dot(w, D)
        x = np.cross(w, D)
        d2 = _dot(x, x)
        h = np.sqrt(np.maximum(radius * radius - d2, 0.0))
        cq = _dot(N, D)
        lo, hi, tc = _base_cut(-h, h, _dot(N, w) - b * cq, cq)
        ts = b - delta / D[:, 2]
        length = np.maximum(hi - lo, 0.0)
        occ = np.maximum(np.minimum(hi, ts) - lo, 0.0)
        wl = np.linalg.norm(w, axis=1)
        e2 = k * (wl * (2 * np.sqrt(d2) + k * wl) + radius * radius)
        miss = radius * radius - d2 <= -e2          # the line misses the ball in both: h = 0, no error
        e_h = np.where(miss, 0.0, np.where(h > 0, np.minimum(np.sqrt(e2), e2 / h), np.sqrt(e2)) + k * radius)
        e_c = k * (3 * wl + np.abs(tc)) / np.abs(cq)
        e_s = k * (wl + np.abs(delta) / D[:, 2])
        e = 2 * e_h + _inside(tc, e_c, lo, hi) + _inside(ts, e_s, lo, hi)
    return length, occ, e


def ssao_lines(position: np.ndarray, normal: np.ndarray, projection: np.ndarray, m: int, radius: float,
               delta: float, seed: int = 0, range_check: bool = False, plane_test: bool = False,
               alpha: np.ndarray | None = None, alpha_eps: float = 0.5,
               normal_map: np.ndarray | None = None, tangent: np.ndarray | None = None) -> ReferenceAO:
    """Twin of ``ssao_prepare`` + ``ssao_ao`` with ``-D OCLS_LINES`` (line samples, see
    kernels/ssao.cl "Line samples"): the occupied fraction of the hemisphere's volume, integrated
    analytically along m lines, one depth (or occluder plane) fetch per line: with the depth test
    each line is the line of sight of the pixel its disk point falls in, through that pixel's
    stored point Q (a pixel without a usable surface, and the plane test: the line through the
    disk point parallel to P's line of sight).

    ``counted`` holds the lines on screen, ``ties`` those whose pixel, screen-edge, camera-plane
    (as in :func:`ssao`), range-check or occluder-side decision float32 rounding may flip.
    ``bound`` bounds |kernel - twin| per pixel: each line's two sums (length and occupied length)
    may differ by e = twice the chord ends' error plus, where they fall inside the chord, the
    base-plane cut's and the occluder cut's errors (:func:`_sight_chord`; the plane test's
    occluder cut: 8 eps32 (|L.w| + |A| + |delta|) / |U . L|); a tie line adds the most its
    alternatives differ (another pixel: evaluated; a flipped decision: 2 R).  With E the sum of e,
    |AO error| <= E (1 + O / L) / (L - E), L and O the sums of lengths and occupied lengths."""
    pos = np.asarray(position, np.float64)
    height, width = pos.shape[:2]
    hit, n = prepare(position, normal, alpha, alpha_eps, normal_map, tangent)
    E = line_eye(projection)
    M = np.asarray(projection, np.float64)
    zflat = np.where(hit, pos[..., 2], -np.inf).ravel()
    pflat = pos[..., :3].reshape(-1, 3)
    planes = occluder_planes(pos, normal, hit).reshape(-1, 4) if plane_test else None
    nn = _dot(n, n)
    with np.errstate(invalid="ignore", over="ignore"):
        g = E[:3] - E[3] * pos[..., :3]
        gg = _dot(g, g)
        uz = g[..., 2] / np.sqrt(gg)
    live = hit & (nn > 1e-12) & (nn < np.inf) & (gg < np.inf) & (uz > 0)
    ao = np.ones((height, width))
    counted = np.zeros((height, width), np.int64)
    ties = np.zeros((height, width), np.int64)
    bound = np.zeros((height, width))
    rr, cc = np.nonzero(live)
    if rr.size == 0:
        return ReferenceAO(ao, counted, ties, hit, n, bound)
    N = n[rr, cc] / np.sqrt(nn[rr, cc])[:, None]
    P = pos[rr, cc, :3]
    U = g[rr, cc] / np.sqrt(gg[rr, cc])[:, None]          # P's line of sight, towards the camera
    T, B = _rotated_frame(rotation_vectors(width, height, seed)[rr, cc], U)
    nT, nB, c = _dot(N, T), _dot(N, B), _dot(N, U)
    k = 64 * F32
    tol_z = k * (np.linalg.norm(P, axis=1) + abs(radius) + abs(delta))
    L, O, EL = (np.zeros(rr.size) for _ in range(3))
    cnt_n = np.zeros(rr.size, np.int64)
    tie_n = np.zeros(rr.size, np.int64)

    def plane_cut(ix: slice | np.ndarray, A: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Plane test (step L4): (t_s, its float32 error, tie): the line A + t U is solid for
        t <= t_s, at least delta below the occluder's plane L; L not facing along U: the point test at A."""
        U_ = U[ix]
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            pl = planes[j]
            la = _dot(pl[:, :3], A) - pl[:, 3]          # A's height above L (+inf for an empty pixel)
            lu = _dot(pl[:, :3], U_)
            lw = np.abs(np.nan_to_num(pl[:, 3], neginf=0.0))
            ts = np.where(lu > 0, (-delta - la) / lu, np.where(la <= -delta, np.inf, -np.inf))
            err = np.where(lu > 0, 8 * F32 * (lw + np.linalg.norm(A, axis=1) + abs(delta)) / lu, 0.0)
            tie = np.isfinite(pl[:, 3]) & ((np.abs(lu) <= k) | ((lu <= 0) & (np.abs(la + delta) <= tol_z[ix] + k * lw)))
        return ts, err, tie

    def line(ix: slice | np.ndarray, A: np.ndarray, on: np.ndarray, j: np.ndarray, sx: float, sy: float, hs: float):
        """(length, occupied length, float32 error bound, tie) of the sample's line, for the live pixels ``ix``."""
        # the line through A parallel to U: the chord |t| <= h, cut by the base plane a + t c >= 0
        h = radius * hs
        a = radius * (sx * nT[ix] + sy * nB[ix])
        lo, hi, tc = _base_cut(-h, h, a, c[ix])
        S = radius + abs(delta)
        with np.errstate(divide="ignore", invalid="ignore"):
            e_c = k * (S + np.abs(tc)) / np.abs(c[ix])
        e_t = k * S
        if plane_test:
            ts, e_s, tie = plane_cut(ix, A, j)
            length = np.maximum(hi - lo, 0.0)
            occ = np.maximum(np.minimum(hi, ts) - lo, 0.0)
            e = 2 * e_t + _inside(tc, e_c, lo, hi) + _inside(ts, e_s, lo, hi)
        else:
            # the depth test along pixel j's own line of sight (a pixel without a surface: the
            # line through A, nothing solid)
            surf, Q, g_, w = _pixel_sight(E, pflat, zflat, j, P[ix])
            lq, oq, eq = _sight_chord(g_, w, N[ix], radius, delta + DEPTH_TOL * np.abs(Q[:, 2]))
            length = np.where(surf, lq, np.maximum(hi - lo, 0.0))
            occ = np.where(surf, oq, 0.0)
            e = np.where(surf, eq, 2 * e_t + _inside(tc, e_c, lo, hi))
            with np.errstate(invalid="ignore"):
                tie = (zflat[j] != -np.inf) & (np.abs(g_[:, 2]) <= k * np.linalg.norm(g_, axis=1))
            h = np.where(surf, radius, h)
        length, occ = np.where(on, length, 0.0), np.where(on, occ, 0.0)
        if range_check:
            rmargin = radius - (zflat[j] - P[ix, 2])
            occ = np.where(rmargin >= 0, occ, 0.0)
            tie |= np.abs(rmargin) <= tol_z[ix]
        e = np.where(on, np.minimum(np.nan_to_num(e, nan=np.inf), 2 * (h + e_t)), 0.0)
        return length, occ, e, on & tie

    for sx, sy, hs in line_table(m).astype(np.float64):
        A = P + radius * (T * sx + B * sy)
        on, j, pixel_tie = _pixel_of(A, M, width, height, tol_z)
        length, occ, e, tie = line(slice(None), A, on, j, sx, sy, hs)
        # a tie line: what it would add on any pixel rounding may give it (a flipped decision: 2 R)
        alt = np.flatnonzero(pixel_tie)
        for su in (-1, 0, 1):
            for sv in (-1, 0, 1):
                if alt.size and (su or sv):
                    on2, j2, _ = _pixel_of(A[alt], M, width, height, tol_z[alt], (su, sv))
                    l2, o2, e2, t2 = line(alt, A[alt], on2, j2, sx, sy, hs)
                    e[alt] = np.maximum(e[alt], np.maximum(np.abs(l2 - length[alt]), np.abs(o2 - occ[alt]))
                                        + np.where(t2, 2 * radius, e2))
        camera = pixel_tie & (np.abs(A @ M[3, :3] + M[3, 3]) <= tol_z)
        e = np.where(tie | camera, 2 * radius + e, e)
        cnt_n += on
        tie_n += pixel_tie | tie
        L += length
        O += occ
        EL += e
    with np.errstate(invalid="ignore", divide="ignore"):
        ao[rr, cc] = np.where(L > 0, 1.0 - O / np.where(L > 0, L, 1.0), 1.0)
        bnd = np.where(L > EL, np.minimum(EL * (1.0 + O / np.where(L > 0, L, 1.0)) / (L - EL), 1.0), 1.0)
    counted[rr, cc] = cnt_n
    ties[rr, cc] = tie_n
    bound[rr, cc] = np.where(EL > 0, bnd, 0.0)
    return ReferenceAO(ao, counted, ties, hit, n, bound)


def _rotated_frame(v: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-2 of kernels/ssao.cl: T = V_r made orthogonal to the unit ``axis`` (Gram-Schmidt;
    the view axis least aligned with it when V_r is along it), B = axis x T."""
    t0 = v - axis * _dot(v, axis)[:, None]
    tt = _dot(t0, t0)
    bad = ~(tt >= 1e-8)
    if bad.any():
        a = np.abs(axis[bad])
        k = np.where((a[:, 0] <= a[:, 1]) & (a[:, 0] <= a[:, 2]), 0, np.where(a[:, 1] <= a[:, 2], 1, 2))
        e = np.eye(3)[k]
        t0[bad] = e - axis[bad] * _dot(e, axis[bad])[:, None]
        tt[bad] = _dot(t0[bad], t0[bad])
    T = t0 / np.sqrt(tt)[:, None]
    return T, np.cross(axis, T)


def _pixel_of(A: np.ndarray, M: np.ndarray, width: int, height: int, tol_z: np.ndarray,
              shift: tuple[int, int] = (0, 0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 3: (on screen and in front of the camera, flat pixel index (0 when not on), tie):
    a tie when float32 rounding may move the point to another pixel or across the screen edge or
    the camera plane (pixel coordinate within tol_px = 64 eps32 (1 + |u|) of an integer, clip w
    within tol_z of 0).  ``shift`` moves the pixel coordinates by (su, sv) tol_px: the pixels a
    tie may land on instead."""
    cw = A @ M[3, :3] + M[3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (A @ M[0, :3] + M[0, 3]) / cw
        y = (A @ M[1, :3] + M[1, 3]) / cw
        u = (u + 1.0) * 0.5 * width
        y = (1.0 - y) * 0.5 * height
        tie = np.abs(cw) <= tol_z
        for coord in (u, y):
            tie |= np.abs(coord - np.round(coord)) <= 64 * F32 * (1.0 + np.abs(coord))
        u = u + shift[0] * 64 * F32 * (1.0 + np.abs(u))
        y = y + shift[1] * 64 * F32 * (1.0 + np.abs(y))
        on = (cw > 0) & (u >= 0) & (u < width) & (y >= 0) & (y < height)
    j = np.where(on, np.floor(np.where(on, y, 0)) * width + np.floor(np.where(on, u, 0)), 0).astype(np.int64)
    return on, j, tie & (on | (np.abs(cw) <= tol_z) | np.isfinite(u))


def box_blur(ao: np.ndarray, hit: np.ndarray, half: int) -> np.ndarray:
    """Twin of ``ssao_box_h`` + ``ssao_box_v``: mean of AO over the hit pixels of the clipped
    (2 half + 1)^2 window; empty pixels stay 1."""
    a = np.where(hit, np.asarray(ao, np.float64), 0.0)
    w = hit.astype(np.float64)
    height, width = a.shape
    pa, pw = np.pad(a, half), np.pad(w, half)
    s = np.zeros_like(a)
    c = np.zeros_like(a)
    for dy in range(2 * half + 1):
        for dx in range(2 * half + 1):
            s += pa[dy:dy + height, dx:dx + width]
            c += pw[dy:dy + height, dx:dx + width]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(hit, s / c, 1.0)


def edge_blur(ao: np.ndarray, position: np.ndarray, normal: np.ndarray, hit: np.ndarray,
              half: int, plane_tol: float) -> np.ndarray:
    """Twin of ``ssao_edge``: weights (max(N_p.N_q, 0))^4 / (1 + (|N_p.(P_q - P_p)| / plane_tol)^2)."""
    a = np.asarray(ao, np.float64)
    P = np.asarray(position, np.float64)[..., :3]
    N = np.asarray(normal, np.float64)[..., :3]
    height, width = a.shape
    s = np.zeros_like(a)
    ws = np.zeros_like(a)
    for dy in range(-half, half + 1):
        for dx in range(-half, half + 1):
            r0, r1 = max(0, -dy), min(height, height - dy)
            c0, c1 = max(0, -dx), min(width, width - dx)
            if r0 >= r1 or c0 >= c1:
                continue
            win = (slice(r0, r1), slice(c0, c1))
            nb = (slice(r0 + dy, r1 + dy), slice(c0 + dx, c1 + dx))
            with np.errstate(invalid="ignore"):
                cs = np.maximum(_dot(N[win], N[nb]), 0.0)
                d = np.abs(_dot(N[win], P[nb] - P[win])) / plane_tol
                w = np.where(hit[nb], cs ** 4 / (1.0 + d * d), 0.0)
            w = np.nan_to_num(w, nan=0.0)
            s[win] += w * a[nb]
            ws[win] += w
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(ws > 0, s / ws, a)
    return np.where(hit, out, 1.0)


# ----------------------------------------------------------------------------- terrain G-buffers
def bilinear(hm: Heightmap, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Height and its world gradient (dh/dx, dh/dy) of the bilinear surface at world (x, y).

    NaN outside the map or on a patch with a nodata corner.  On a patch
    boundary the patch to the south-east (larger row/col) is used."""
    h = hm.heights
    rows, cols = h.shape
    u = np.asarray(x, np.float64) / hm.dx
    v = -np.asarray(y, np.float64) / hm.dy
    inside = (u >= 0) & (u <= cols - 1) & (v >= 0) & (v <= rows - 1)
    pc = np.clip(np.floor(np.where(inside, u, 0)), 0, max(cols - 2, 0)).astype(np.int64)
    pr = np.clip(np.floor(np.where(inside, v, 0)), 0, max(rows - 2, 0)).astype(np.int64)
    fx, fy = u - pc, v - pr
    pc1, pr1 = np.minimum(pc + 1, cols - 1), np.minimum(pr + 1, rows - 1)
    h00, h01, h10, h11 = h[pr, pc], h[pr, pc1], h[pr1, pc], h[pr1, pc1]
    ex, ey, k = h01 - h00, h10 - h00, h00 - h01 - h10 + h11
    z = h00 + ex * fx + ey * fy + k * fx * fy
    gx = (ex + k * fy) / hm.dx
    gy = -(ey + k * fx) / hm.dy
    nan = np.where(inside, 0.0, np.nan)
    return z + nan, gx + nan, gy + nan


@dataclass
class TopDownView:
    gbuffer: GBuffer
    projection: np.ndarray      # 4x4 orthographic
    view: np.ndarray            # 4x4 world -> view (a translation)
    world_position: np.ndarray  # float64 (H, W, 3), NaN where empty
    world_normal: np.ndarray    # float64 (H, W, 3)


def topdown_gbuffer(hm: Heightmap, width: int, height: int, pixel: float,
                    origin: tuple[float, float] | None = None) -> TopDownView:
    """Orthographic view straight down on ``hm``: pixel (r, c) sees world
    (x0 + (c + 0.5) pixel, y0 - (r + 0.5) pixel); position and normal are those of
    the bilinear surface there (exact, rounded once to float32)."""
    rows, cols = hm.shape
    if origin is None:  # centred on the map
        origin = (0.5 * ((cols - 1) * hm.dx - width * pixel), -0.5 * ((rows - 1) * hm.dy - height * pixel))
    x0, y0 = origin
    cx, cy = x0 + 0.5 * width * pixel, y0 - 0.5 * height * pixel
    ztop = float(np.nanmax(hm.heights)) + 10.0 * pixel
    view = np.eye(4)
    view[:3, 3] = (-cx, -cy, -ztop)
    proj = np.diag([2.0 / (width * pixel), 2.0 / (height * pixel), -1e-6, 1.0])
    xs = x0 + (np.arange(width) + 0.5) * pixel
    ys = y0 - (np.arange(height) + 0.5) * pixel
    X, Y = np.meshgrid(xs, ys)
    z, gx, gy = bilinear(hm, X, Y)
    hit = np.isfinite(z)
    wn = np.stack([-gx, -gy, np.ones_like(z)], axis=-1)
    wn /= np.linalg.norm(wn, axis=-1, keepdims=True)
    wp = np.stack([X, Y, z], axis=-1)
    wp[~hit] = np.nan
    pos = np.zeros((height, width, 4), np.float32)
    nrm = np.zeros((height, width, 4), np.float32)
    pos[hit, :3] = wp[hit] + view[:3, 3]
    pos[hit, 3] = 1.0
    nrm[hit, :3] = wn[hit]
    uv = np.zeros((height, width, 2), np.float32)
    uv[hit, 0] = X[hit] / hm.dx
    uv[hit, 1] = -Y[hit] / hm.dy
    uv_grad = np.zeros((height, width, 4), np.float32)
    uv_grad[hit] = (pixel / hm.dx, 0.0, 0.0, pixel / hm.dy)
    depth = np.where(hit, -pos[..., 2], np.inf).astype(np.float32)
    albedo = np.zeros((height, width, 4), np.float32)
    albedo[hit] = 1.0
    gb = GBuffer(pos, nrm, uv, uv_grad, depth, albedo)
    return TopDownView(gb, proj, view, wp, np.where(hit[..., None], wn, np.nan))


# ----------------------------------------------------------------------------- ground truths
def _frames(normals: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random tangent frame (T, B) per normal (uniform rotation about N)."""
    a = rng.normal(size=normals.shape)
    t = a - normals * _dot(a, normals)[:, None]
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return t, np.cross(normals, t)


def volume_ao(hm: Heightmap, points: np.ndarray, normals: np.ndarray, radius: float,
              n: int = 1024, seed: int = 1) -> np.ndarray:
    """Ground truth (a): 1 - (fraction of the volume of the radius-R hemisphere on the unit
    normal at each world point that lies under the bilinear terrain), float64.

    Under the terrain means z < h(x, y) inside the map (outside the map and
    over holes nothing is under).  Stratified: the ``uniform`` kernel's point
    set of n points (uniform in volume), rotated about N at random per point;
    the Monte Carlo error is below sqrt(p (1 - p) / n)."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    nrm = np.asarray(normals, np.float64).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    T, B = _frames(nrm, rng)
    unit = hemisphere_points(n, "uniform")
    under = np.zeros(len(pts))
    for s in unit:
        A = pts + radius * (T * s[0] + B * s[1] + nrm * s[2])
        h, _, _ = bilinear(hm, A[:, 0], A[:, 1])
        under += np.nan_to_num(h, nan=-np.inf) > A[:, 2]
    return 1.0 - under / n


def volume_ao_lines(hm: Heightmap, points: np.ndarray, normals: np.ndarray, radius: float,
                    n: int = 4096, seed: int = 1) -> np.ndarray:
    """Ground truth (a) again, by quadrature over vertical lines instead of points: 1 - (volume of
    the radius-R hemisphere on the unit normal under the bilinear terrain) / (its volume), float64.

    A heightfield's solid along a vertical line is one interval, z < h(x, y), so each line's
    occupied length inside the hemisphere is exact (chord of the ball, clipped by the base plane,
    cut at the surface): only the 2-D integral over the lines is a quadrature, n lines on
    :func:`oclshade.ssao.disk_points` (the Vogel spiral over the ball's vertical shadow) rotated at
    random per point; the fraction is the sum of occupied lengths over the sum of lengths.  The
    error falls much faster than :func:`volume_ao`'s sqrt(p (1 - p) / n) (measured in
    bench/ssao.py: the RMS difference to the same quadrature with n / 4 lines is reported as the
    truth's error bound).  Outside the map and over holes nothing is under."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    nrm = np.asarray(normals, np.float64).reshape(-1, 3)
    nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    angle = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, len(pts))
    cs, sn = np.cos(angle), np.sin(angle)
    occupied = np.zeros(len(pts))
    total = np.zeros(len(pts))
    for sx, sy in disk_points(n):
        dx, dy = radius * (cs * sx - sn * sy), radius * (sn * sx + cs * sy)
        half = radius * np.sqrt(max(1.0 - sx * sx - sy * sy, 0.0))
        lo, hi = pts[:, 2] - half, pts[:, 2] + half
        # the base plane N . (X - P) >= 0 along the line: N_z (z - P_z) >= -(N_x dx + N_y dy)
        a, c = nrm[:, 0] * dx + nrm[:, 1] * dy, nrm[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            zc = pts[:, 2] - a / c
        lo = np.where(c > 0, np.maximum(lo, zc), lo)
        hi = np.where(c < 0, np.minimum(hi, zc), hi)
        hi = np.where((c == 0) & (a < 0), lo, hi)
        h, _, _ = bilinear(hm, pts[:, 0] + dx, pts[:, 1] + dy)
        total += np.maximum(hi - lo, 0.0)
        occupied += np.maximum(np.minimum(hi, np.nan_to_num(h, nan=-np.inf)) - lo, 0.0)
    return 1.0 - occupied / total


def cosine_directions(n: int) -> np.ndarray:
    """n stratified cosine-weighted unit directions about +z (Malley: stratified disk lifted)."""
    i = np.arange(n)
    r = np.sqrt((i + 0.5) / n)
    phi = 2.0 * np.pi * ((i * 0.6180339887498949) % 1.0)
    x, y = r * np.cos(phi), r * np.sin(phi)
    return np.stack([x, y, np.sqrt(np.maximum(0.0, 1.0 - x * x - y * y))], axis=1)


def raytraced_ao(hm: Heightmap, points: np.ndarray, normals: np.ndarray, radius: float,
                 n: int = 256, seed: int = 1) -> np.ndarray:
    """Ground truth (b): 1 - (fraction of cosine-weighted rays of length R from each world
    point, on the hemisphere of its unit normal, that hit the bilinear terrain), float64.

    Each ray walks the patches it crosses; in a patch the surface along the
    ray is a quadratic in t and the ray hits iff ray - surface <= 0 somewhere
    in (0, R] (closed form: ends and vertex).  The point itself is on the
    surface, so in its first patch the root at t = 0 is factored out.  Holes
    and the outside of the map occlude nothing."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    nrm = np.asarray(normals, np.float64).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    T, B = _frames(nrm, rng)
    dirs = cosine_directions(n)
    hits = np.zeros(len(pts))
    for d in dirs:
        w = T * d[0] + B * d[1] + nrm * d[2]
        hits += _ray_hits(hm, pts, w, radius)
    return 1.0 - hits / n


def _ray_hits(hm: Heightmap, p: np.ndarray, w: np.ndarray, radius: float) -> np.ndarray:
    """Bool per ray: the ray p + t w, 0 < t <= radius, meets the bilinear surface."""
    h = hm.heights
    rows, cols = h.shape
    hp, wp = max(rows - 1, 1), max(cols - 1, 1)
    x0, y0 = p[:, 0] / hm.dx, -p[:, 1] / hm.dy          # continuous (col, row)
    ux, uy = w[:, 0] / hm.dx, -w[:, 1] / hm.dy          # per unit t
    pc = np.where(ux < 0, np.ceil(x0) - 1, np.floor(x0)).astype(np.int64)
    pr = np.where(uy < 0, np.ceil(y0) - 1, np.floor(y0)).astype(np.int64)
    out = np.zeros(len(p), bool)
    idx = np.arange(len(p))
    t = np.zeros(len(p))
    first = np.ones(len(p), bool)
    max_steps = int(np.ceil(radius / hm.dx) + np.ceil(radius / hm.dy)) + 4
    for _ in range(max_steps):
        alive = (t < radius) & (pr >= 0) & (pr < hp) & (pc >= 0) & (pc < wp)
        if not alive.all():
            keep = np.flatnonzero(alive)
            idx, pc, pr, t, first = idx[keep], pc[keep], pr[keep], t[keep], first[keep]
            x0, y0, ux, uy, p, w = x0[keep], y0[keep], ux[keep], uy[keep], p[keep], w[keep]
        if not idx.size:
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(ux > 0, (pc + 1 - x0) / ux, np.where(ux < 0, (pc - x0) / ux, np.inf))
            ty = np.where(uy > 0, (pr + 1 - y0) / uy, np.where(uy < 0, (pr - y0) / uy, np.inf))
        t_out = np.minimum(np.minimum(tx, ty), radius)
        h00, h01 = h[pr, pc], h[pr, np.minimum(pc + 1, cols - 1)]
        h10, h11 = h[np.minimum(pr + 1, rows - 1), pc], h[np.minimum(pr + 1, rows - 1), np.minimum(pc + 1, cols - 1)]
        ex, ey, k = h01 - h00, h10 - h00, h00 - h01 - h10 + h11
        fx, fy = x0 + ux * t - pc, y0 + uy * t - pr
        s0 = h00 + ex * fx + ey * fy + k * fx * fy
        s1 = (ex + k * fy) * ux + (ey + k * fx) * uy
        s2 = k * ux * uy
        # f(tau) = ray - surface = a + b tau + c tau^2 on [0, L]
        a = np.where(first, 0.0, p[:, 2] + w[:, 2] * t - s0)
        b = w[:, 2] - s1
        c = -s2
        L = t_out - t
        with np.errstate(invalid="ignore", divide="ignore"):
            f_end = a + (b + c * L) * L
            tv = -b / (2.0 * c)
            f_v = a + (b + c * tv) * tv
            vertex = (c > 0) & (tv > 0) & (tv < L) & (f_v <= 0)
            later = (a <= 0) | (f_end <= 0) | vertex
            # first patch: f = tau (b + c tau) with L > 0, so a hit in (0, L] iff b < 0 or b + c L <= 0
            at_start = (b < 0) | (b + c * L <= 0)
            hit = np.where(first, at_start, later) & ~np.isnan(s0)
        out[idx[hit]] = True
        go = ~hit
        via_x, via_y = tx <= ty, ty <= tx
        pc = np.where(via_x, pc + np.sign(ux).astype(np.int64), pc)
        pr = np.where(via_y, pr + np.sign(uy).astype(np.int64), pr)
        t = np.where(go, t_out, radius)
        first = np.zeros(idx.size, bool)
    return out


def world_frame(hm: Heightmap, gbuffer: GBuffer, view: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World positions and normals (float64 (H, W, 3), NaN where empty) of a rendered terrain
    G-buffer: view-space positions mapped back with ``inv(view)``, then snapped to the bilinear
    surface (z = h(x, y), normal from its gradient there), so the ground truths are evaluated on
    the true surface at the pixel's hit point (the float32 G-buffer is off by its rounding)."""
    inv = np.linalg.inv(np.asarray(view, np.float64))
    p = np.asarray(gbuffer.position, np.float64)
    wp = p[..., :3] @ inv[:3, :3].T + inv[:3, 3]
    z, gx, gy = bilinear(hm, wp[..., 0], wp[..., 1])
    hit = gbuffer.hit & np.isfinite(z)
    wp[..., 2] = z
    wn = np.stack([-gx, -gy, np.ones_like(z)], axis=-1)
    with np.errstate(invalid="ignore"):
        wn /= np.linalg.norm(wn, axis=-1, keepdims=True)
    wp[~hit] = np.nan
    wn[~hit] = np.nan
    return wp, wn
