"""Float64 reference of the visible share of the sun's disc (:mod:`oclshade.horizon.disc`):
the same strips, with the float64 horizons (:func:`horizon_angles`).  With many strips (256)
it is the truth the device's fewer strips are measured against: the midpoint rule's own
error is then below 2e-3 of the disc even where the horizon jumps inside the disc (one
strip's share: 2 w c / (pi r^2) <= 4 / (pi 256))."""
from __future__ import annotations

import numpy as np

from ..heightmap import Heightmap
from ..horizon.disc import disc_columns, visible_fraction
from ..sun import Sun, SunLike, as_sun
from .horizons import horizon_angles


def sun_disc_fraction(hm: Heightmap, sun: SunLike, radius: float, curvature: float = 0.0,
                      columns: int = 256, scale: float = 1.0) -> np.ndarray:
    """Visible share of the disc per cell, float64 (rows, cols), NaN at nodata.  ``scale``: the
    true metres of a grid metre along the sun's grid azimuth where ``sun`` is the grid's sun of a
    scaled grid (:meth:`oclshade.solar.MapPlaces.on_grid`): each strip then compares the true
    horizon, atan(tan(h) / scale), with the true disc around the true sun, atan(tan(e) / scale)
    (what :func:`oclshade.horizon.disc.disc_stretch` takes to first order)."""
    sun = as_sun(sun)
    if scale == 1.0:
        azimuths, half_chords = disc_columns(sun, radius, columns)
        return visible_fraction((horizon_angles(hm, float(az), curvature) for az in azimuths), sun.elevation,
                                half_chords)
    sky = float(np.degrees(np.arctan(np.tan(np.radians(sun.elevation)) / scale)))
    azimuths, half_chords = disc_columns(Sun(sun.azimuth, sky), radius, columns)
    true = (np.degrees(np.arctan(np.tan(np.radians(horizon_angles(hm, float(az), curvature))) / scale))
            for az in azimuths)
    return visible_fraction(true, sky, half_chords)
