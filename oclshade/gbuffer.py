"""The G-buffer: the per-pixel contract between the renderer and the screen-space passes.

Frames (public, see README "Conventions"):

* **World (terrain) space**, metres, right-handed: x east, y north, z up.
  Heightmap sample (row i, col j) sits at ``(j*dx, -i*dy, height)``; the
  origin is sample (0, 0) at height 0 (absolute heights, after the z-factor).
* **View space**: right-handed, camera at the origin looking down -Z, +Y up,
  +X right (DESIGN.md).  ``view`` maps world to view, ``projection`` view to
  clip space (OpenGL style, NDC in [-1, 1]^3); numpy 4x4 on column vectors.
* **Screen**: pixel (row r, col c), row 0 at the top, ``c`` grows to the
  right; the pixel centre is at NDC ``x = (2c + 1)/W - 1``, ``y = 1 - (2r + 1)/H``.
* **Heightmap coordinates** (u, v): continuous sample coordinates,
  u = column (east), v = row (south); sample (i, j) is at (u, v) = (j, i).

Layout: every field is a float32 array, C order, one row of pixels after
another (``height`` rows of ``width`` pixels), channels last:

==========  ========  ==========================================================
field       channels  meaning
==========  ========  ==========================================================
position    4         view-space x, y, z of the first hit; w = 1 hit, 0 empty
normal      4         view-space unit normal of the bilinear surface; w = 0
uv          2         heightmap coordinates (u, v) of the hit
uv_grad     4         du/dc, dv/dc, du/dr, dv/dr: change per pixel to the right
                      and per pixel down (screen-space derivatives, paper 000
                      Algo 1 takes its level of detail from them)
depth       1         linear depth -z_view of the hit; +inf where empty
albedo      4         linear RGBA surface colour; a = coverage (1 opaque)
==========  ========  ==========================================================

On an empty pixel (``position.w == 0``) every other field is 0 except
``depth`` (+inf).  On the device each field is one ``cl.Buffer`` with the same
layout (``float4`` for 4 channels, ``float2`` for 2), so an embedding pipeline
can bind them directly.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

CHANNELS = {"position": 4, "normal": 4, "uv": 2, "uv_grad": 4, "depth": 1, "albedo": 4}


@dataclass
class GBuffer:
    """Host copy of a G-buffer (numpy float32 arrays of shape (height, width[, channels]))."""

    position: np.ndarray
    normal: np.ndarray
    uv: np.ndarray
    uv_grad: np.ndarray
    depth: np.ndarray
    albedo: np.ndarray

    def __post_init__(self) -> None:
        shape = None
        for f in fields(self):
            value = np.ascontiguousarray(getattr(self, f.name), dtype=np.float32)
            channels = CHANNELS[f.name]
            if value.ndim == 2 and channels == 1:
                pass
            elif value.ndim != 3 or value.shape[2] != channels:
                want = "(height, width)" if channels == 1 else f"(height, width, {channels})"
                raise ValueError(f"G-buffer field {f.name!r} must have shape {want}, got {value.shape}")
            if shape is None:
                shape = value.shape[:2]
            elif value.shape[:2] != shape:
                raise ValueError(f"G-buffer field {f.name!r} is {value.shape[:2]}, expected {shape} "
                                 "like the position field")
            setattr(self, f.name, value)

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        return self.position.shape[:2]

    @property
    def hit(self) -> np.ndarray:
        """Boolean (height, width): the pixel sees terrain."""
        return self.position[..., 3] > 0.5
