"""Float64 reference of kernels/compose.cl (the final frame); equal to the kernel within 1/255."""
from __future__ import annotations

import numpy as np


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1.0 / 2.4) - 0.055)


def compose(position: np.ndarray, normal: np.ndarray, albedo: np.ndarray, sun_view: np.ndarray,
            sun_intensity: float, sky: np.ndarray, up_view: np.ndarray, background: np.ndarray,
            shadow: np.ndarray | None = None, ao: np.ndarray | None = None, ssaa: int = 1,
            linear: bool = False, point: bool = False, falloff: float = 0.0) -> np.ndarray:
    """uint8 (h / ssaa, w / ssaa, 4) sRGB: per sample albedo * (I_sun max(n.s, 0) shadow
    + sky ao (1 + n.up) / 2), background where empty, clamped to [0, 1]; each output pixel
    the mean of its ssaa x ssaa samples.  ``linear``: float64 (h / ssaa, w / ssaa, 3), the
    mean of the unclamped samples in linear light (compose.cl -D OCLS_LINEAR).  ``point``: a
    point light at the view-space position ``sun_view`` (-D OCLS_POINT_LIGHT): s = (L - p) / |L - p|
    per sample and I_sun times falloff / |L - p|^2 when ``falloff`` (r0^2) > 0; 0 where p = L."""
    hit = position[..., 3] > 0.5
    n = normal[..., :3].astype(float)
    if point:
        to = np.asarray(sun_view, float) - position[..., :3].astype(float)
        d2 = np.sum(to * to, axis=-1)
        safe = np.where(d2 > 0.0, d2, 1.0)
        gain = np.where(d2 > 0.0, falloff / safe if falloff > 0.0 else 1.0, 0.0)
        direct = sun_intensity * gain * np.maximum(np.sum(n * to, axis=-1) / np.sqrt(safe), 0.0)
    else:
        direct = sun_intensity * np.maximum(n @ np.asarray(sun_view, float), 0.0)
    diffuse = 0.5 * (1.0 + n @ np.asarray(up_view, float))
    if shadow is not None:
        direct = direct * shadow
    if ao is not None:
        diffuse = diffuse * ao
    colour = albedo[..., :3] * (direct[..., None] + np.asarray(sky, float) * diffuse[..., None])
    colour = np.where(hit[..., None], colour, np.asarray(background, float))
    if not linear:
        colour = np.clip(colour, 0.0, 1.0)
    rows, cols = hit.shape
    mean = colour.reshape(rows // ssaa, ssaa, cols // ssaa, ssaa, 3).mean(axis=(1, 3))
    if linear:
        return mean
    out = np.full(mean.shape[:2] + (4,), 255, np.uint8)
    out[..., :3] = np.floor(255.0 * srgb_encode(mean) + 0.5).astype(np.uint8)
    return out
