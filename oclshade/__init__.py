"""oclshade: OpenCL terrain and scene shading (exact heightmap shadows over an extrema pyramid)."""
from .heightmap import Heightmap
from .runtime import (AllocationError, DeviceNotFoundError, OclshadeError, ProgramBuildError,
                      get_runtime, list_devices, select_device)
from .shadows import METHODS, OUTPUTS, ShadowCaster, ShadowResult, cast_shadows
from .specialize import SpecializeError, specialize
from .sun import Sun

__version__ = "0.1.0"
__all__ = [
    "AllocationError", "DeviceNotFoundError", "Heightmap", "METHODS", "OUTPUTS", "OclshadeError",
    "ProgramBuildError", "ShadowCaster", "ShadowResult", "SpecializeError", "Sun", "cast_shadows",
    "get_runtime", "list_devices", "select_device", "specialize",
]
