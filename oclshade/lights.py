"""Lights of a frame: the sun (directional) or a point light.

A directional light is the sun (:class:`oclshade.sun.Sun`, azimuth/elevation, or an
(azimuth, elevation) pair); a point light is :class:`PointLight` (a world position, metres,
and optionally the reference distance of its inverse-square falloff).  Both shade a frame
(:class:`oclshade.scene.ObjectScene`, compose) and cast every kind of shadow (terrain,
quadrics, meshes); docs/meshes.md "Point lights".
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Union

import numpy as np

from .sun import Sun, SunLike, as_sun


@dataclass(frozen=True, eq=False)
class PointLight:
    """A light at a finite distance: world position (x east, y north, z up; metres).

    ``distance``: the reference distance (metres) of the inverse-square falloff: the light's
    intensity (:attr:`oclshade.compose.Lighting.sun_intensity`) is its irradiance on a plane
    facing it ``distance`` metres away, ``intensity (distance / d)^2`` at d metres; None (the
    default): no falloff, the intensity at every distance (a local sun: predictable without
    tuning to the scene's size)."""

    position: np.ndarray
    distance: float | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.position, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"a point light's position must be 3 finite numbers (x east, y north, z up), "
                             f"got {self.position!r}")
        object.__setattr__(self, "position", p)
        d = self.distance
        if d is not None:
            if isinstance(d, bool) or not isinstance(d, (int, float, np.floating)) or not math.isfinite(d) or d <= 0:
                raise ValueError(f"a point light's distance (the falloff's reference distance, metres) must be a "
                                 f"positive finite number or None, got {d!r}")
            object.__setattr__(self, "distance", float(d))

    def __repr__(self) -> str:
        tail = "" if self.distance is None else f", distance={self.distance!r}"
        return f"PointLight({self.position.tolist()!r}{tail})"


Light = Union[Sun, PointLight]
LightLike = Union[Sun, PointLight, SunLike]


def as_light(value: LightLike) -> Light:
    """A Sun or a PointLight (an (azimuth, elevation) pair is a sun)."""
    return value if isinstance(value, PointLight) else as_sun(value)


def towards_light(light: Light, points: np.ndarray) -> np.ndarray:
    """Float64 (..., 3) vectors from ``points`` towards the light: the sun's unit vector, or
    the light's position minus the point (not normalised)."""
    points = np.asarray(points, dtype=np.float64)
    if isinstance(light, PointLight):
        return light.position - points
    return np.broadcast_to(np.array(light.vector()), points.shape)


def light_key(light: Light) -> tuple:
    """A hashable key naming the light exactly (for caches)."""
    if isinstance(light, PointLight):
        return ("point", *light.position.tolist())
    return ("sun", light.azimuth, light.elevation)
