"""Float64 reference of the visible share of the sun's disc (:mod:`oclshade.horizon.disc`):
the same strips, with the float64 horizons (:func:`horizon_angles`).  With many strips (256)
it is the truth the device's fewer strips are measured against: the midpoint rule's own
error is then below 2e-3 of the disc even where the horizon jumps inside the disc (one
strip's share: 2 w c / (pi r^2) <= 4 / (pi 256))."""
from __future__ import annotations

import numpy as np

from ..heightmap import Heightmap
from ..horizon.disc import disc_columns, visible_fraction
from ..sun import SunLike, as_sun
from .horizons import horizon_angles


def sun_disc_fraction(hm: Heightmap, sun: SunLike, radius: float, curvature: float = 0.0,
                      columns: int = 256) -> np.ndarray:
    """Visible share of the disc per cell, float64 (rows, cols), NaN at nodata."""
    sun = as_sun(sun)
    azimuths, half_chords = disc_columns(sun, radius, columns)
    bands = (horizon_angles(hm, float(az), curvature) for az in azimuths)
    return visible_fraction(bands, sun.elevation, half_chords)
