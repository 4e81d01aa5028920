"""Horizon angles and sky-view factor: per cell and azimuth, the elevation angle of the highest
terrain seen over the bilinear surface (kernels/horizon.cl), and the sky-view factor from them
(docs/methods.md, "Horizons and sky-view factor"); soft shadows, the share of the sun's disc each cell
sees (:mod:`oclshade.horizon.disc`); the horizon of one site along the geodesics
(:mod:`oclshade.horizon.site`)."""
from .disc import DEFAULT_COLUMNS, SUN_RADIUS, disc_columns, visible_fraction
from .caster import (EARTH_RADIUS, MAX_AZIMUTHS, Curvature, HorizonCaster, as_azimuths, azimuth_grid,
                     check_definition)
from .site import site_horizon
from ..reference.horizons import SVF_DEFINITIONS

__all__ = ["DEFAULT_COLUMNS", "EARTH_RADIUS", "MAX_AZIMUTHS", "SUN_RADIUS", "SVF_DEFINITIONS", "Curvature",
           "HorizonCaster", "as_azimuths", "azimuth_grid", "check_definition", "disc_columns", "site_horizon",
           "visible_fraction"]
