"""Float64 references of the mip and extrema pyramids (kernels/pyramid.cl); bit-identical by construction."""
from __future__ import annotations

import numpy as np

from ..heightmap import Heightmap
from ..pyramid import level_shapes
def patch_corners(hm: Heightmap) -> np.ndarray:
    """The four corner samples of every patch, (4, Hp, Wp) float32: NaN for a hole or a
    corner past the map (a single row or column has one degenerate patch row / column)."""
    h = hm.relative32
    rows, cols = h.shape
    hp, wp = hm.patch_shape
    pad = np.full((hp + 1, wp + 1), np.nan, np.float32)
    pad[:rows, :cols] = h
    return np.stack([pad[:-1, :-1], pad[:-1, 1:], pad[1:, :-1], pad[1:, 1:]])


def extrema_pyramid(hm: Heightmap) -> list[np.ndarray]:
    """Stored levels 1..L as (rows, cols, 2) float32 arrays (max, min) — see kernels/pyramid.cl.

    Built from a per-patch level 0 (max of valid corners; min, or -inf if a
    corner is a hole) reduced 2x2 — a different route from the kernel's 3x3
    sample windows, so the test compares two constructions.
    """
    hp, wp = hm.patch_shape
    corners = patch_corners(hm)
    with np.errstate(invalid="ignore"):
        hi = np.where(np.isnan(corners).all(0), -np.inf, np.nanmax(np.where(np.isnan(corners), -np.inf, corners), 0))
    lo = np.where(np.isnan(corners).any(0), -np.inf, np.min(corners, 0))
    levels = [np.stack([hi, lo], -1).astype(np.float32)]
    for r, c in level_shapes(hp, wp)[1:]:
        prev = levels[-1]
        pr, pc = prev.shape[:2]
        ext = np.empty((2 * r, 2 * c, 2), np.float32)
        ext[:pr, :pc] = prev
        ext[pr:, :pc] = prev[-1:, :]          # odd sizes: repeat the last row/col
        ext[:, pc:] = ext[:, pc - 1:pc]
        blocks = ext.reshape(r, 2, c, 2, 2)
        levels.append(np.stack([blocks[..., 0].max((1, 3)), blocks[..., 1].min((1, 3))], -1))
    return levels[1:] if len(levels) > 1 else [levels[0].reshape(1, 1, 2)]


def mip_pyramid(hm: Heightmap) -> list[np.ndarray]:
    """Mean mip pyramid in float32 with the kernel's summation order (bit-exact twin)."""
    levels = [hm.relative32.copy()]
    for r, c in level_shapes(*hm.shape)[1:]:
        prev = levels[-1]
        pr, pc = prev.shape
        pad = np.full((2 * r, 2 * c), np.nan, np.float32)
        pad[:pr, :pc] = prev
        total = np.zeros((r, c), np.float32)
        count = np.zeros((r, c), np.float32)
        for dr in (0, 1):
            for dc in (0, 1):
                v = pad[dr::2, dc::2]
                ok = ~np.isnan(v)
                total = np.where(ok, total + np.where(ok, v, 0), total).astype(np.float32)
                count += ok
        with np.errstate(invalid="ignore", divide="ignore"):
            levels.append(np.where(count > 0, total / count, np.nan).astype(np.float32))
    return levels
