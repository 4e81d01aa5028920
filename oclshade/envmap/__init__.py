"""Environment maps (paper 002): cube maps from files (faces, crosses, lat-long; EXR, HDR,
PNG), lat-long <-> cube conversion on the device, and the cube-map frame in the world.
Frames, face table and file orientations: docs/reflections.md."""
from .cube import FACES, CubeMap, DeviceCubeMap, cube_frame, latlong_to_cube, stack_cubes

__all__ = ["FACES", "CubeMap", "DeviceCubeMap", "cube_frame", "latlong_to_cube", "stack_cubes"]
