"""Float64 reference of kernels/compose.cl (the final frame); equal to the kernel within 1/255."""
from __future__ import annotations

import numpy as np


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1.0 / 2.4) - 0.055)


def compose(position: np.ndarray, normal: np.ndarray, albedo: np.ndarray, sun_view: np.ndarray,
            sun_intensity: float, sky: np.ndarray, background: np.ndarray,
            shadow: np.ndarray | None = None, ao: np.ndarray | None = None) -> np.ndarray:
    """uint8 (h, w, 4) sRGB: albedo * (I_sun max(n.s, 0) shadow + sky ao), background where empty."""
    hit = position[..., 3] > 0.5
    lit = sun_intensity * np.maximum(np.einsum("...k,k->...", normal[..., :3].astype(float), sun_view), 0.0)
    if shadow is not None:
        lit = lit * shadow
    amb = np.ones(hit.shape) if ao is None else np.asarray(ao, float)
    colour = albedo[..., :3] * (lit[..., None] + np.asarray(sky, float) * amb[..., None])
    colour = np.where(hit[..., None], colour, np.asarray(background, float))
    out = np.full(hit.shape + (4,), 255, np.uint8)
    out[..., :3] = np.floor(255.0 * srgb_encode(colour) + 0.5).astype(np.uint8)
    return out
