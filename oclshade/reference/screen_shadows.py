"""Float64 references of the per-pixel shadow pass (kernels/shadow.cl, ``shadow_pixels``).

* :func:`minimal_lod` — paper 000 Algo 1 exactly as printed, in float64.
* :func:`pixel_shadows` — the cast shadow of every G-buffer pixel at q = 0:
  a sun ray from the surface point at the pixel's heightmap coordinates
  (u, v) (bilinear height there) walked through every patch it crosses
  (:func:`oclshade.reference.shadows.walk_rays`, the same walk as the
  heightmap-space reference, from arbitrary start points).

Ties.  Like the heightmap-space reference, every pixel gets a margin
(``tan(horizon) - tan(elevation)``, cast shadow iff > 0).  A float32 kernel
makes height errors of a few ulps of the relief; the margin divides them by
the ray parameter, which for a ray starting anywhere in a patch can be far
below one cell when it next meets a patch boundary.  The per-pixel tie
tolerance is therefore :func:`~oclshade.reference.shadows.tie_tolerance`
scaled by ``max(1, cell / t1)``, t1 the ray parameter where the ray leaves
its start patch.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..heightmap import Heightmap
from ..sun import Sun
from .shadows import start_patches, tie_tolerance, walk_rays


@dataclass
class ReferencePixelShadows:
    mask: np.ndarray        # uint8 (height, width): 1 cast shadow, 0 lit, 255 empty / off the map / in a hole
    margin: np.ndarray      # float64, NaN where mask is 255
    graze: np.ndarray       # bool: the ray passed within CORNER_TIE of a corner that could occlude
    tolerance: np.ndarray   # float64 per-pixel tie tolerance (see the module docstring)

    def ties(self) -> np.ndarray:
        """Pixels a float32 kernel may decide either way."""
        with np.errstate(invalid="ignore"):
            return (np.abs(self.margin) <= self.tolerance) | self.graze


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
    """a + (b - a) f, leaving out the sample whose weight is exactly 0 (kernel: bilinear_at)."""
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


def pixel_shadows(hm: Heightmap, sun: Sun, uv: np.ndarray, hit: np.ndarray) -> ReferencePixelShadows:
    """Float64 cast shadows of G-buffer pixels (the kernel at q = 0, any exact method).

    uv: (height, width, 2) heightmap coordinates (float32 values are taken
    exactly); hit: (height, width) bool, the pixel sees terrain.  A pixel
    that is empty, off the map or inside a hole patch gets 255.  Sun at or
    below the horizon: all shadowed; at the zenith: nothing cast.
    """
    uv = np.asarray(uv, np.float64)
    shape = uv.shape[:2]
    u, v = uv[..., 0].ravel(), uv[..., 1].ravel()
    rows, cols = hm.shape
    with np.errstate(invalid="ignore"):
        inside = np.asarray(hit, bool).ravel() & (u >= 0) & (u <= cols - 1) & (v >= 0) & (v <= rows - 1)
    idx = np.flatnonzero(inside)
    z0 = surface_height(hm.heights, u[idx], v[idx])
    idx, z0 = idx[~np.isnan(z0)], z0[~np.isnan(z0)]
    margin = np.full(u.size, np.nan)
    graze = np.zeros(u.size, bool)
    tolerance = np.full(u.size, tie_tolerance(hm, sun))
    if sun.below_horizon:
        margin[idx] = np.inf
    elif sun.at_zenith:
        margin[idx] = -np.inf
    else:
        margin[idx], graze[idx] = walk_rays(hm, sun, u[idx], v[idx], z0)
        tolerance[idx] *= np.maximum(1.0, min(hm.dx, hm.dy) / _first_exit(hm, sun, u[idx], v[idx]))
    mask = np.where(np.isnan(margin), 255, margin > 0).astype(np.uint8)
    return ReferencePixelShadows(mask.reshape(shape), margin.reshape(shape), graze.reshape(shape),
                                 tolerance.reshape(shape))


def _first_exit(hm: Heightmap, sun: Sun, x0: np.ndarray, y0: np.ndarray) -> np.ndarray:
    """Ray parameter (metres) at which each ray leaves its start patch."""
    ux, uy, _ = sun.ray(hm.dx, hm.dy)
    pr, pc = start_patches(hm, ux, uy, x0, y0)
    with np.errstate(divide="ignore"):
        tx = np.full(x0.shape, np.inf) if ux == 0 else ((pc + (ux > 0)) - x0) / ux
        ty = np.full(y0.shape, np.inf) if uy == 0 else ((pr + (uy > 0)) - y0) / uy
    return np.minimum(tx, ty)
