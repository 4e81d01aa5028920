"""Float64 numpy references of the kernels: the definitions the tests hold them to.

One module per kernel family; everything public is re-exported here, so
``from oclshade import reference as ref; ref.cast_shadows(...)`` works for all.
"""
from .compose import compose
from .pyramid import extrema_pyramid, mip_pyramid
from .shadows import (CORNER_SNAP, CORNER_TIE, ReferenceShadows, cast_shadows,
                      shadow_coefficient, tie_tolerance)
from .terrain import ReferenceTerrain, cast_terrain, dilated_max_levels

__all__ = [
    "CORNER_SNAP", "CORNER_TIE", "ReferenceShadows", "ReferenceTerrain", "cast_shadows", "cast_terrain", "compose", "dilated_max_levels",
    "extrema_pyramid", "mip_pyramid", "shadow_coefficient", "tie_tolerance",
]
