"""Sunshine at one site: for each time step, whether the sun (NREL SPA at the site) stands above
the site's horizon at its own azimuth, that horizon traced along the geodesic
(:func:`oclshade.horizon.site_horizon`, float64 on the host), and the hours of direct sun over
the period.  The map's sunshine (:class:`~oclshade.sunshine.SunshineCaster`) traces the grid's
lines per cell; one place can afford each sun's exact horizon (docs/solar.md)."""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

import numpy as np

from ..horizon.caster import Curvature
from ..horizon.site import site_horizon
from ..io import Raster
from ..solar.position import suns_at
from ..sun import Sun
from .steps import TimeSteps


@dataclass(frozen=True)
class SiteSunshine:
    """Per step k: ``times[k]`` its midpoint (UTC), ``seconds[k]`` its length, ``suns[k]`` the
    sun there (true azimuth, apparent elevation), ``horizon[k]`` the site's horizon at that
    azimuth (degrees; NaN while the sun is down) and ``sunlit[k]`` whether the sun is up and
    above it."""

    times: list[datetime]
    seconds: np.ndarray
    suns: list[Sun]
    horizon: np.ndarray
    sunlit: np.ndarray

    @property
    def hours(self) -> float:
        """Hours of direct sun over the period."""
        return float(self.seconds[self.sunlit].sum()) / 3600.0

    @property
    def daylight_hours(self) -> float:
        """Hours with the sun above the horizontal plane."""
        return float(self.seconds[np.isfinite(self.horizon)].sum()) / 3600.0


def site_sunshine(raster: Raster, latitude: float, longitude: float, steps: TimeSteps, above: float = 0.0,
                  curvature: Curvature | None = None, z_factor: float = 1.0) -> SiteSunshine:
    """The sunshine of the site at ``latitude``, ``longitude`` (degrees), ``above`` metres over
    the surface, over ``steps`` (:func:`oclshade.sunshine.time_steps`): each step's sun by NREL
    SPA at the site (refraction as :func:`oclshade.solar.sun_position`), up when its elevation is
    above 0, sunlit when it is also above the site's horizon at its azimuth (strictly: a sun on
    the horizon is hidden, as the masks count a tie).  From the surface that horizon holds the
    surface itself along the sun's azimuth, so sunlit is "not in cast shadow" as the masks count
    it; the map's ``hours`` also drop steps where a cell's normal faces away, which at a sample
    (a kink of the bilinear surface) can differ: its like is daylight x (1 - ``fraction``).
    ``curvature`` lowers distant terrain as the horizon's (the map's sunshine has none: 0.13
    degree at 30 km).  ValueError as :func:`oclshade.horizon.site_horizon`."""
    suns = suns_at(steps.times, latitude, longitude)
    elevation = np.array([sun.elevation for sun in suns])
    up = elevation > 0.0
    horizon = np.full(len(suns), np.nan)
    if np.any(up):
        horizon[up] = site_horizon(raster, latitude, longitude, np.array([sun.azimuth for sun in suns])[up],
                                   above=above, curvature=curvature, z_factor=z_factor)
    else:                                               # (the place checked all the same)
        site_horizon(raster, latitude, longitude, [0.0], above=above, z_factor=z_factor)
    with np.errstate(invalid="ignore"):
        sunlit = up & (elevation > horizon)
    return SiteSunshine(list(steps.times), np.asarray(steps.seconds), suns, horizon, sunlit)
