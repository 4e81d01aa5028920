"""oclshade: OpenCL terrain and scene shading — exact heightmap shadows over an extrema
pyramid, voxel-bisection terrain ray casting, per-pixel shadows and SSAO over G-buffers."""
from .camera import Camera, frame_heightmap
from .frames import AOSettings, FrameSettings, TerrainScene
from .gbuffer import GBuffer
from .heightmap import Heightmap
from .runtime import (AllocationError, DeviceNotFoundError, OclshadeError, ProgramBuildError,
                      get_runtime, list_devices, select_device)
from .screen_shadows import ScreenShadowCaster
from .shadows import METHODS, OUTPUTS, ShadowCaster, ShadowResult, cast_shadows
from .specialize import SpecializeError, specialize
from .ssao import SSAO
from .sun import Sun
from .terrain import Heightfield, TerrainRenderer

from ._version import __version__

__all__ = [
    "AOSettings", "AllocationError", "Camera", "DeviceNotFoundError", "FrameSettings", "GBuffer", "Heightfield",
    "Heightmap", "METHODS", "OUTPUTS", "OclshadeError", "ProgramBuildError", "SSAO", "ScreenShadowCaster",
    "ShadowCaster", "ShadowResult", "SpecializeError", "Sun", "TerrainRenderer", "TerrainScene", "cast_shadows",
    "frame_heightmap", "get_runtime", "list_devices", "select_device", "specialize",
]
