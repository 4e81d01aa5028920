"""A generated environment: a lat-long sky with a sun disc, for demos, tests and benchmarks.

>>> latlong = procedural_sky(256, 512, Sun(135, 30))     # float32 (256, 512, 3), linear RGB

Directions are those of the lat-long layout (oclshade.envmap.files), placed in the world by
:func:`~oclshade.envmap.cube.cube_frame` with ``rotation``: the sun disc sits where the
scene's sun is.  Above the horizon a blue gradient (brighter near the horizon) with
faint bands every 45 degrees of azimuth (so a reflection shows its direction); below it a
brown ground; the sun a disc of 2 degrees radius, 50 times the sky's brightness.
"""
from __future__ import annotations

import numpy as np

from ..reference.envmap import latlong_directions
from ..sun import Sun
from .cube import cube_frame


def procedural_sky(height: int, width: int, sun: Sun | None = Sun(135.0, 30.0), rotation: float = 0.0) -> np.ndarray:
    """float32 (height, width, 3) linear RGB lat-long map (module doc); ``sun=None``: no disc."""
    if height < 1 or width < 2:
        raise ValueError(f"a lat-long map needs height >= 1 and width >= 2, got {height}x{width}")
    d = latlong_directions(height, width)                    # frame F
    world = d @ cube_frame(rotation)                          # F -> world: the inverse rotation
    up = world[..., 2]
    azimuth = np.arctan2(world[..., 0], world[..., 1])
    t = np.clip(up, 0.0, 1.0)[..., None]
    sky = (1.0 - t) * np.array([0.75, 0.85, 1.0]) + t * np.array([0.15, 0.35, 0.85])
    sky *= (1.0 + 0.15 * np.cos(8.0 * azimuth))[..., None]
    ground = np.array([0.25, 0.2, 0.15]) * (0.6 + 0.4 * np.clip(-up, 0.0, 1.0))[..., None]
    image = np.where((up >= 0.0)[..., None], sky, ground)
    if sun is not None:
        image[world @ np.array(sun.vector()) > np.cos(np.radians(2.0))] = 50.0 * np.array([1.0, 0.95, 0.85])
    return image.astype(np.float32)
