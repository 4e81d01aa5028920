"""Float64 references of the per-pixel shadow pass (kernels/shadow.cl, ``shadow_pixels``).

* :func:`minimal_lod` — paper 000 Algo 1 exactly as printed, in float64.
* :func:`pixel_shadows` — the cast shadow of every G-buffer pixel at q = 0:
  a sun ray from the surface point at the pixel's heightmap coordinates
  (u, v) (bilinear height there) walked through every patch it crosses
  (:func:`oclshade.reference.shadows.walk_rays`, the same walk as the
  heightmap-space reference, from arbitrary start points), on the heights the
  kernel reads (``Heightmap.relative32``, exact in float64) along the float32
  ray of :meth:`oclshade.Sun.ray`: both sides trace the very same ray over
  the very same surface.

Ties.  Every pixel gets a margin (``tan(horizon) - tan(elevation)``, cast
shadow iff > 0) and two more, ``margin_lo`` and ``margin_hi``: the same walk
with every value of f = S - z the kernel tests lowered / raised by a bound of
the kernel's float32 error in that value (:class:`Rounding`, derived there
from the operations ``patch_hits`` and ``pixel_ray`` actually perform).  The
kernel can only say shadow if ``margin_hi > 0`` and lit if ``margin_lo <= 0``,
so a pixel is a tie iff both hold.  A ray grazing a patch corner, which a
float32 traversal may pass on either side (:attr:`Rounding.corner_gap`), gets
the side patch's sliver in margin_hi only.  The bound holds for each tested
point, at its own distance: a far point's error is not divided by the
distance of the nearest one, so ties stay rare (see docs/methods.md).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..heightmap import Heightmap
from ..sun import Sun
from .shadows import walk_rays

UNIT_ROUNDOFF = 2.0 ** -24     # float32, round to nearest


@dataclass
class ReferencePixelShadows:
    mask: np.ndarray        # uint8 (height, width): 1 cast shadow, 0 lit, 255 empty / off the map / in a hole
    margin: np.ndarray      # float64, NaN where mask is 255
    graze: np.ndarray       # bool: a corner pass the kernel may decide otherwise (counted in margin_lo / _hi)
    margin_lo: np.ndarray   # float64: the margin with every tested f lowered by the kernel's error bound
    margin_hi: np.ndarray   # ... raised by it

    def ties(self) -> np.ndarray:
        """Pixels a float32 kernel may decide either way: margin_lo <= 0 < margin_hi."""
        with np.errstate(invalid="ignore"):
            return (self.margin_lo <= 0) & (self.margin_hi > 0)


@dataclass
class Rounding:
    """A bound of the float32 error of every value of f = S - z that ``shadow_pixels`` (q = 0)
    tests, given per ray by its bases (kernels/shadow.cl, ``Ray``): hb, the sample the
    heights are taken relative to, and dz0 = z0 - hb, the start height above it.

    u = 2^-24 is float32's unit roundoff; one operation's error is at most u times its
    result.  In a patch with corners h00..h11 the spans Dx, Dy (largest |difference| of
    its two x / y edges) and K = |h00 - h01 - h10 + h11| bound what the kernel combines:

    * positions: fx = (x0 + ux t) - (pc - xb), x0 in [0, 1] relative to the base column,
      errs by u (2 |ux| t + 2) (the subtraction of the integer is exact but near 0), plus
      3 u |ux| t for the rounding of t itself: u (5 |ux| t + 2) cells, which moves S by
      Dx times that (likewise y).
    * the surface at entry, s_a = (h00 - hb) + ex fx + ey fy + k fx fy: the first
      difference u |h00 - hb|, three sums u (|h00 - hb| + Dx + Dy) each (a partial sum
      is a bilinear interpolation of corners minus hb), the coefficients ex, ey, k
      (u Dx, u Dy, 2 u Dx + u K) and the products (u Dx, u Dy, 2 u K): together
      u (4 |h00 - hb| + 7 Dx + 5 Dy + 3 K).
    * the start height dz0: bilinear of the corners minus hb (each difference u Ms, Ms the
      largest |corner - hb| of the start patch), two lerps of 6 u Ms, the last 11 u Ms.
    * the ray: z = dz0 + (w + c t) t: u (2 |dz0| + 3 w t + 4 c t^2) (both sides of the
      tile tests that compare it with hb-relative extrema are covered by the same terms:
      a wrongly skipped tile can hide only f within this bound at the point it hides).
    * the slope at entry a = s1 - w - 2 c t, s1 = (ex + k fy) ux + (ey + k fx) uy:
      u (|ux| + |uy|)(5 Dx + 3 Dy + 2 K) + K (|ux| dfy + |uy| dfx) + u (|s1| + |a| + 2 w + 6 c t);
      the curvature b = k ux uy - c: |ux uy| u (2 Dx + 3 K) + u (|b| + c).
    * along the segment (f_b = f_a + (a + b len) len, and the tangent point's value
      f_a - a^2 / 4b when its tau lies inside, where a^2 / 4|b| <= |a| tau / 2): at tau
      from the entry, tau da + tau^2 db plus the roundings u (|f_a| + e_fa) and
      u (|b| len + 2 |a| + 2 |a + b len|) tau; so e0 + e1 tau bounds the error at every
      value tested, and sup (f +- (e0 + e1 tau)) / t over the segment (the same closed
      form) decides what the kernel can conclude there.

    f at a patch's entry is either these heights' difference (far: error e_far, at
    t >= t_near) or, while near (t < t_near, see ``Ray``), the value carried from the
    previous patch (its error carried with it; the start patch's linear test is exact
    at t -> 0 and errs by da + len db in margin units).  Where t is within 1e-6 of
    t_near the larger of the two counts.  Errors of the heights' float32 rounding do
    not count: the reference walks the kernel's own heights.
    """

    ray: tuple[float, float, float]     # (ux, uy, w) as float32 values
    curvature: float                    # c per square metre (float32 value)
    t_near: float                       # the kernel's float32 1 / max(|ux|, |uy|)
    hb: np.ndarray                      # per ray
    dz0: np.ndarray                     # per ray
    ez0: np.ndarray                     # per ray: the error bound of the kernel's dz0
    spread: float                       # largest |difference| of adjacent samples (Dx + Dy bound)
    relief: float
    u: float = UNIT_ROUNDOFF

    def segment(self, idx: np.ndarray, t: np.ndarray, length: np.ndarray, first: np.ndarray, carry: np.ndarray,
                carried: np.ndarray, f_a: np.ndarray, a: np.ndarray, b: np.ndarray, corner0: np.ndarray,
                spans: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e_first, e0, e1): the start patch test's bound in margin units; and the bound
        e0 + e1 tau (metres) of every f the kernel tests at tau into this segment (its
        entry, its exit and the tangent point)."""
        u, (ux, uy, w), c = self.u, self.ray, self.curvature
        ax, ay = abs(ux), abs(uy)
        dx_, dy_, kk = spans
        t_out = t + length
        dfx, dfy = u * (5 * ax * t_out + 2), u * (5 * ay * t_out + 2)
        s1 = a + w + 2 * c * t
        da = (u * (ax + ay) * (5 * dx_ + 3 * dy_ + 2 * kk) + kk * (ax * dfy + ay * dfx)
              + u * (np.abs(s1) + np.abs(a) + 2 * w + 6 * c * t))
        db = ax * ay * u * (2 * dx_ + 3 * kk) + u * (np.abs(b) + c)
        end = a + b * length
        e_first = da + length * db + u * (np.abs(b * length) + np.abs(end))
        with np.errstate(invalid="ignore"):
            e_far = (u * (4 * np.abs(corner0 - self.hb[idx]) + 7 * dx_ + 5 * dy_ + 3 * kk) + dx_ * dfx + dy_ * dfy
                     + self.ez0[idx] + u * (2 * np.abs(self.dz0[idx]) + 3 * w * t_out + 4 * c * t_out * t_out))
        near_possible = carried & (t < self.t_near * (1 + 1e-6))
        far_possible = t >= self.t_near * (1 - 1e-6)
        e_fa = np.where(near_possible, np.maximum(carry, np.where(far_possible, e_far, 0.0)), e_far)
        e0 = e_fa * (1 + u) + u * np.abs(f_a)
        e1 = da + length * db + u * (np.abs(b) * length + 2 * np.abs(a) + 2 * np.abs(end))
        return e_first, e0, e1

    def corner(self, idx: np.ndarray, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Bound of (v - hb) - z at a corner pass out of a hole (corner_hits), metres."""
        u, w, c = self.u, self.ray[2], self.curvature
        with np.errstate(invalid="ignore"):
            return (u * (2 * np.abs(v - self.hb[idx]) + 2 * np.abs(self.dz0[idx]) + 3 * w * t + 4 * c * t * t)
                    + self.ez0[idx])

    @property
    def corner_gap(self) -> float:
        """Relative gap |tx - ty| / max(tx, ty) between the ray's crossings of a patch's two
        sides under which the kernel may decide the corner pass otherwise: it snaps at 8 u
        (OCLS_CORNER_EPS) on tx, ty that each err by 3 u (a difference, a reciprocal, a
        product), so at true gaps up to 14 u; 16 u."""
        return 16 * self.u

    def sliver(self, t: np.ndarray) -> np.ndarray:
        """Margin a corner pass within corner_gap may add or drop: a side patch's sliver of
        relative length corner_gap, where S moves by at most the steepest slope along the ray
        and z by its slope."""
        ux, uy, w = self.ray
        return self.corner_gap * (self.spread * (abs(ux) + abs(uy)) + w + 2 * self.curvature * t)

    def top_error(self, idx: np.ndarray, t: np.ndarray, gmax: float) -> np.ndarray:
        """How far above the highest sample the ray must be before no later tested f plus its
        bound can be positive (the walk stops there): every term above at its largest (corner
        differences up to the relief, spans up to the spread, segments up to t_near long),
        inf if the bound grows faster along the ray than the ray rises."""
        u, (ux, uy, w), c = self.u, self.ray, self.curvature
        ax, ay, d = abs(ux), abs(uy), self.spread
        grow = u * (10 * d * (ax + ay) + 12 * w) + 20 * u * d * (ax + ay)
        if grow >= w:
            return np.full(t.shape, np.inf)
        tn = self.t_near
        fixed = (u * (4 * (self.relief + abs(gmax - self.hb[idx])) + 30 * d + 2 * np.abs(self.dz0[idx])) + 4 * u * d
                 + self.ez0[idx] + tn * u * (ax + ay) * 20 * d * 4 + tn * u * 6 * w + 8 * u * c * (t + tn) ** 2)
        return fixed + grow * t


def minimal_lod(uv_grad: np.ndarray, top: int, n_a_max: int = 16, bias: int = 0) -> np.ndarray:
    """Algo 1 of paper 000 per pixel, float64: the minimal level of detail q.

    uv_grad (..., 4) = (du/dc, dv/dc, du/dr, dv/dr) in sample units per pixel
    (the paper's w ds/dx, h dt/dx, w ds/dy, h dt/dy).  |a|^2 = s_x^2 + t_x^2,
    |b|^2 = s_y^2 + t_y^2; n_a = min(ceil(sqrt(d2max / d2min)), n_a_max);
    q = floor(0.5 log2 d2max - log2 n_a) + bias, clamped to [0, top].
    Zero (or NaN) derivatives give q = 0 (log2 0 = -inf); d2min = 0 gives n_a = n_a_max.
    """
    g = np.asarray(uv_grad, np.float64)
    a2 = g[..., 0] ** 2 + g[..., 1] ** 2
    b2 = g[..., 2] ** 2 + g[..., 3] ** 2
    dmax, dmin = np.maximum(a2, b2), np.minimum(a2, b2)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_a = np.minimum(np.ceil(np.sqrt(dmax / dmin)), n_a_max)
        q = np.floor(0.5 * np.log2(dmax) - np.log2(n_a)) + bias
    q = np.where(dmax > 0, q, 0.0)
    return np.clip(q, 0, top).astype(np.int64)


def _lerp(a: np.ndarray, b: np.ndarray, f: np.ndarray) -> np.ndarray:
    """a + (b - a) f, leaving out the sample whose weight is exactly 0 (kernel: pixel_ray)."""
    with np.errstate(invalid="ignore"):
        return np.where(f == 0, a, np.where(f == 1, b, a + (b - a) * f))


def surface_height(h: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear height of the map at continuous sample coordinates (u = col, v = row),
    all inside the map; NaN in a hole.  A sample with weight 0 does not count, so a
    point on a grid line sees that line only."""
    rows, cols = h.shape
    c = np.clip(np.floor(u).astype(np.int64), 0, max(cols - 2, 0))
    r = np.clip(np.floor(v).astype(np.int64), 0, max(rows - 2, 0))
    fx, fy = u - c, v - r
    c1, r1 = np.minimum(c + 1, cols - 1), np.minimum(r + 1, rows - 1)
    top = _lerp(h[r, c], h[r, c1], fx)
    bottom = _lerp(h[r1, c], h[r1, c1], fx)
    return _lerp(top, bottom, fy)


def pixel_shadows(hm: Heightmap, sun: Sun, uv: np.ndarray, hit: np.ndarray,
                  curvature: float = 0.0) -> ReferencePixelShadows:
    """Float64 cast shadows of G-buffer pixels (the kernel at q = 0, any exact method).

    uv: (height, width, 2) heightmap coordinates (float32 values are taken
    exactly); hit: (height, width) bool, the pixel sees terrain.  A pixel
    that is empty, off the map or inside a hole patch gets 255.  Sun at or
    below the horizon: all shadowed; at the zenith: nothing cast.
    ``curvature``: the Earth's drop per square metre (the kernel's float32 value).
    """
    uv = np.asarray(uv, np.float64)
    shape = uv.shape[:2]
    u, v = uv[..., 0].ravel(), uv[..., 1].ravel()
    rows, cols = hm.shape
    h = hm.relative32.astype(np.float64)
    with np.errstate(invalid="ignore"):
        inside = np.asarray(hit, bool).ravel() & (u >= 0) & (u <= cols - 1) & (v >= 0) & (v <= rows - 1)
    idx = np.flatnonzero(inside)
    z0 = surface_height(h, u[idx], v[idx])
    idx, z0 = idx[~np.isnan(z0)], z0[~np.isnan(z0)]
    margin = np.full(u.size, np.nan)
    graze = np.zeros(u.size, bool)
    lo, hi = margin.copy(), margin.copy()
    if sun.below_horizon:
        margin[idx] = lo[idx] = hi[idx] = np.inf
    elif sun.at_zenith:
        margin[idx] = lo[idx] = hi[idx] = -np.inf
    elif idx.size:
        rounding = _rounding(hm, h, sun, u[idx], v[idx], z0, curvature)
        margin[idx], graze[idx], lo[idx], hi[idx] = walk_rays(hm, sun, u[idx], v[idx], z0, h, curvature, rounding)
    mask = np.where(np.isnan(margin), 255, margin > 0).astype(np.uint8)
    return ReferencePixelShadows(*(a.reshape(shape) for a in (mask, margin, graze, lo, hi)))


def _rounding(hm: Heightmap, h: np.ndarray, sun: Sun, x: np.ndarray, y: np.ndarray, z0: np.ndarray,
              curvature: float) -> Rounding:
    """The kernel's bases of each ray (pixel_ray) and the bound of its start height."""
    rows, cols = h.shape
    c = np.clip(np.floor(x).astype(np.int64), 0, max(cols - 2, 0))
    r = np.clip(np.floor(y).astype(np.int64), 0, max(rows - 2, 0))
    fx, fy = x - c, y - r
    c1, r1 = np.minimum(c + 1, cols - 1), np.minimum(r + 1, rows - 1)
    hb = h[np.where(fy > 0.5, r1, r), np.where(fx > 0.5, c1, c)]
    corners = np.stack([h[r, c], h[r, c1], h[r1, c], h[r1, c1]])
    with np.errstate(invalid="ignore"):
        ms = np.nanmax(np.abs(corners - hb), axis=0)
    ux, uy, w = sun.ray(hm.dx, hm.dy)
    steps = [np.abs(np.diff(h, axis=a)) for a in (0, 1) if h.shape[a] > 1]
    spread = 2.0 * max((float(np.nanmax(s)) for s in steps if np.isfinite(s).any()), default=0.0)
    finite = h[np.isfinite(h)]
    t_near = float(np.float32(1.0) / np.float32(max(abs(ux), abs(uy))))
    return Rounding((ux, uy, w), curvature, t_near, hb, z0 - hb, 11 * UNIT_ROUNDOFF * ms, spread,
                    float(finite.max() - finite.min()))
