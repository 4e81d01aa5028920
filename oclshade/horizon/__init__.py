"""Horizon angles and sky-view factor: per cell and azimuth, the elevation angle of the highest
terrain seen over the bilinear surface (kernels/horizon.cl), and the sky-view factor from them
(docs/methods.md, "Horizons and sky-view factor")."""
from .caster import (EARTH_RADIUS, MAX_AZIMUTHS, Curvature, HorizonCaster, as_azimuths, azimuth_grid,
                     check_definition)
from ..reference.horizons import SVF_DEFINITIONS

__all__ = ["EARTH_RADIUS", "MAX_AZIMUTHS", "SVF_DEFINITIONS", "Curvature", "HorizonCaster", "as_azimuths",
           "azimuth_grid", "check_definition"]
