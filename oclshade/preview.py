"""Quick-look images: gdaldem-style hillshade and a shadow-mask overlay written as PNG."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .heightmap import as_heights, positive_finite
from .io import write_raster

__all__ = ["hillshade", "shadow_overlay", "write_preview"]

_SHADOW_RGB = np.array([10.0, 25.0, 90.0])   # dark blue blended over cast-shadow cells
_SHADOW_BLEND = 0.55
_NODATA_RGB = np.array([96, 56, 56], dtype=np.uint8)  # flat dark red-grey: holes stay visible
_GREY_FLOOR = 0.2  # hillshade 0 is drawn at 20 % grey so the shadow tint still shows


def _check(heights: np.ndarray, dx: float, dy: float) -> np.ndarray:
    positive_finite("dx", dx)
    positive_finite("dy", dy)
    return as_heights(heights)


def hillshade(heights: np.ndarray, dx: float, dy: float, azimuth: float = 315.0,
              elevation: float = 45.0) -> np.ndarray:
    """Hillshade in [0, 1] (float32) as ``gdaldem hillshade``: Horn's 3x3 gradient, edges replicated.

    Row 0 is north, column 0 west; azimuth clockwise from north, elevation above
    the horizon, in degrees. NaN where the 3x3 window holds a NaN.
    """
    heights = _check(heights, dx, dy)
    h = np.pad(heights, 1, mode="edge")
    nw, n, ne = h[:-2, :-2], h[:-2, 1:-1], h[:-2, 2:]
    w, e = h[1:-1, :-2], h[1:-1, 2:]
    sw, s, se = h[2:, :-2], h[2:, 1:-1], h[2:, 2:]
    p = ((ne + 2 * e + se) - (nw + 2 * w + sw)) / (8.0 * dx)   # dz / d(east)
    q = ((nw + 2 * n + ne) - (sw + 2 * s + se)) / (8.0 * dy)   # dz / d(north)
    az, alt = math.radians(azimuth), math.radians(elevation)
    shade = (math.sin(alt) - math.cos(alt) * (p * math.sin(az) + q * math.cos(az))) / np.sqrt(1 + p * p + q * q)
    shade[np.isnan(heights)] = np.nan  # Horn's kernel skips the centre cell
    return np.maximum(shade, 0.0).astype(np.float32)   # NaN survives np.maximum


def shadow_overlay(heights: np.ndarray, dx: float, dy: float, azimuth: float, elevation: float,
                   mask: np.ndarray | None) -> np.ndarray:
    """uint8 RGB (rows, cols, 3): grey hillshade, mask == 1 tinted dark blue, nodata dark red-grey.

    Nodata is NaN heights or mask == 255; cells next to a hole (hillshade
    undefined) are drawn as flat ground.
    """
    h = _check(heights, dx, dy)
    shade = hillshade(h, dx, dy, azimuth, elevation).astype(np.float64)
    shade = np.where(np.isnan(shade), max(math.sin(math.radians(elevation)), 0.0), shade)
    grey = 255.0 * (_GREY_FLOOR + (1.0 - _GREY_FLOOR) * shade)
    rgb = np.repeat(grey[..., None], 3, axis=2)
    nodata = np.isnan(h)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape != h.shape:
            raise ValueError(f"mask must have the heights' shape {h.shape}, got {m.shape}")
        shadow = m == 1
        rgb[shadow] = (1 - _SHADOW_BLEND) * rgb[shadow] + _SHADOW_BLEND * _SHADOW_RGB
        nodata |= m == 255
    out = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    out[nodata] = _NODATA_RGB
    return out


def write_preview(path: str | os.PathLike, heights: np.ndarray, dx: float, dy: float,
                  azimuth: float, elevation: float, mask: np.ndarray | None = None,
                  max_size: int = 2048) -> None:
    """Write :func:`shadow_overlay` as a PNG (atomic), strided down to at most ``max_size`` pixels a side."""
    if Path(path).suffix.lower() != ".png":
        raise ValueError(f"preview path must end in .png, got {os.fspath(path)!r}")
    if max_size < 1:
        raise ValueError(f"max_size must be >= 1, got {max_size!r}")
    h = _check(heights, dx, dy)
    step = max(1, math.ceil(max(h.shape) / max_size))
    small_mask = None
    if mask is not None:
        small_mask = np.asarray(mask)
        if small_mask.shape != h.shape:
            raise ValueError(f"mask must have the heights' shape {h.shape}, got {small_mask.shape}")
        small_mask = small_mask[::step, ::step]
    rgb = shadow_overlay(h[::step, ::step], dx * step, dy * step, azimuth, elevation, small_mask)
    write_raster(path, rgb)
