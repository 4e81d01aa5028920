"""Quick-look images: gdaldem-style hillshade and a shadow-mask overlay written as PNG."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .heightmap import as_heights, positive_finite
from .io import Raster, RasterWriter, decimated

__all__ = ["Preview", "hillshade", "shadow_overlay", "write_preview"]

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


class Preview(RasterWriter):
    """A :func:`shadow_overlay` PNG of a ``shape`` (rows, cols) map, opened before it is drawn
    (so an unwritable destination fails before any work); a :class:`~oclshade.io.RasterWriter`
    that :meth:`draw` fills. The map is strided down to at most ``max_size`` pixels a side;
    with a georeferenced ``like`` (the map's raster) the PNG gets a world file and its CRS
    (``oclshade.io.decimated``: each preview pixel is georeferenced at the map cell it shows)."""

    def __init__(self, path: str | os.PathLike, shape: tuple[int, int], like: Raster | None = None,
                 max_size: int = 2048):
        if Path(path).suffix.lower() != ".png":
            raise ValueError(f"preview path must end in .png, got {os.fspath(path)!r}")
        if isinstance(max_size, bool) or not isinstance(max_size, int) or max_size < 1:
            raise ValueError(f"max_size must be a positive integer, got {max_size!r}")
        self.map_shape = tuple(shape)
        self.step = max(1, math.ceil(max(self.map_shape) / max_size))
        rows, cols = (-(-n // self.step) for n in self.map_shape)
        super().__init__(path, (3, rows, cols), np.uint8, like=None if like is None else decimated(like, self.step))

    def draw(self, heights: np.ndarray, dx: float, dy: float, azimuth: float, elevation: float,
             mask: np.ndarray | None = None) -> None:
        """Render the preview of ``heights`` (the map's shape) and the shadow ``mask`` into the file."""
        h = _check(heights, dx, dy)
        for name, a in (("heights", h), ("mask", mask)):
            if a is not None and np.shape(a) != self.map_shape:
                raise ValueError(f"{name} must have the preview's map shape {self.map_shape}, got {np.shape(a)}")
        s = self.step
        rgb = shadow_overlay(h[::s, ::s], dx * s, dy * s, azimuth, elevation,
                             None if mask is None else np.asarray(mask)[::s, ::s])
        for c in range(3):
            self.write(rgb[..., c])


def write_preview(path: str | os.PathLike, heights: np.ndarray, dx: float, dy: float,
                  azimuth: float, elevation: float, mask: np.ndarray | None = None,
                  max_size: int = 2048, like: Raster | None = None) -> None:
    """Write :func:`shadow_overlay` as a PNG (atomic), strided down to at most ``max_size`` pixels
    a side; georeferenced (world file and CRS sidecar) when ``like`` is (see :class:`Preview`)."""
    h = _check(heights, dx, dy)
    with Preview(path, h.shape, like, max_size) as preview:
        preview.draw(h, dx, dy, azimuth, elevation, mask)
