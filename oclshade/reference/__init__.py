"""Float64 numpy references of the kernels: the definitions the tests hold them to.

One module per kernel family; everything public is re-exported here, so
``from oclshade import reference as ref; ref.cast_shadows(...)`` works for all.
"""
from .ao import (ReferenceAO, TopDownView, bilinear, box_blur, cosine_directions, edge_blur,
                 raytraced_ao, rotation_vectors, ssao, ssao_lines, ssao_rays, topdown_gbuffer, volume_ao,
                 volume_ao_lines, world_frame)
from .compose import compose
from .envmap import (CONE_SAMPLES, FACE_NAMES, cone_directions, cube_to_latlong, face_direction, face_st,
                     latlong_directions, latlong_to_cube, reflect, reflect_frame, sample_cube, sample_face,
                     sample_latlong, schlick, seam_jump, texel_directions)
from .horizons import (SVF_DEFINITIONS, angle_tolerance, banded_horizon_angles, horizon_angles, horizon_tangents, horizon_tolerance,
                       sky_view_factor)
from .projected import ground_metre
from .pyramid import extrema_pyramid, mip_pyramid
from .quadrics import (ReferenceQuadrics, cast_quadrics, intersect, quadric_occludes, quadric_segment_occludes,
                       terrain_margin, terrain_segment_occludes)
from .screen_shadows import ReferencePixelShadows, minimal_lod, pixel_shadows, surface_height
from .shadows import (CORNER_SNAP, CORNER_TIE, ReferenceShadows, cast_field_shadows, cast_shadows, field_tie_tolerance,
                      shadow_coefficient, tie_tolerance)
from .sunshine import ReferenceSunshine, facing_tolerance, gradient_error, sunshine_sums, surface_gradient
from .terrain import ReferenceTerrain, cast_terrain, dilated_max_levels

__all__ = [
    "CORNER_SNAP", "CORNER_TIE", "ReferenceAO", "ReferencePixelShadows", "ReferenceShadows", "ReferenceSunshine",
    "ReferenceTerrain", "facing_tolerance", "gradient_error", "sunshine_sums", "surface_gradient",
    "SVF_DEFINITIONS", "TopDownView", "angle_tolerance", "banded_horizon_angles", "bilinear", "box_blur", "cast_field_shadows", "cast_shadows", "cast_terrain", "compose", "cosine_directions", "field_tie_tolerance",
    "dilated_max_levels", "edge_blur", "extrema_pyramid", "ground_metre", "horizon_angles", "horizon_tangents",
    "horizon_tolerance", "minimal_lod", "mip_pyramid", "pixel_shadows", "raytraced_ao",
    "rotation_vectors", "shadow_coefficient", "sky_view_factor", "ssao", "ssao_lines", "ssao_rays", "surface_height", "tie_tolerance", "topdown_gbuffer",
    "volume_ao", "volume_ao_lines", "world_frame",
    "FACE_NAMES", "cube_to_latlong", "face_direction", "face_st", "latlong_directions", "latlong_to_cube",
    "sample_cube", "sample_face", "sample_latlong", "seam_jump", "texel_directions",
    "CONE_SAMPLES", "cone_directions", "reflect", "reflect_frame", "schlick",
    "ReferenceQuadrics", "cast_quadrics", "intersect", "quadric_occludes", "terrain_margin",
    "quadric_segment_occludes", "terrain_segment_occludes",
]
