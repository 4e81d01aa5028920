"""The final frame: albedo x (Lambert sun x shadow + sky ambient x AO), as 8-bit sRGB.

>>> rgba = compose(gbuf, camera)                                  # uint8 (height, width, 4)
>>> rgba = compose(gbuf, camera, shadow=coef, ao=occlusion)       # passes written elsewhere

Shadow coefficients (1 = lit) and AO factors (1 = unoccluded) are optional
per-pixel float inputs (numpy (height, width) arrays or device buffers of
height*width floats); a missing one is compiled out (-D OCLS_SHADOW /
-D OCLS_AO).  The G-buffer may be on the host (:class:`~oclshade.gbuffer.GBuffer`)
or on the device (:class:`~oclshade.terrain.DeviceGBuffer`).  Kernel:
``kernels/compose.cl``; twin: :func:`oclshade.reference.compose`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from .camera import Camera
from .gbuffer import GBuffer
from .runtime import Runtime, get_runtime
from .sun import Sun, SunLike, as_sun
from .terrain import DeviceGBuffer


@dataclass(frozen=True)
class Lighting:
    """Sun (gdaldem words: azimuth, elevation in degrees) and sky, linear RGB."""

    sun: SunLike = (315.0, 45.0)
    sun_intensity: float = 1.6
    sky: tuple[float, float, float] = (0.22, 0.26, 0.32)
    background: tuple[float, float, float] = (0.45, 0.62, 0.85)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sun", as_sun(self.sun))
        for name in ("sky", "background"):
            v = np.asarray(getattr(self, name), float)
            if v.shape != (3,) or not np.all(np.isfinite(v)) or v.min() < 0:
                raise ValueError(f"{name} must be 3 non-negative linear RGB values, got {getattr(self, name)!r}")
        if not np.isfinite(self.sun_intensity) or self.sun_intensity < 0:
            raise ValueError(f"sun_intensity must be >= 0, got {self.sun_intensity!r}")

    def sun_view(self, camera: Camera) -> np.ndarray:
        """Unit vector towards the sun in view space."""
        assert isinstance(self.sun, Sun)
        return camera.rotation @ np.array(self.sun.vector())


@dataclass(frozen=True)
class ComposeFeatures:
    shadow: bool = False
    ao: bool = False

    def defines(self) -> dict[str, object]:
        return {"OCLS_SHADOW": self.shadow, "OCLS_AO": self.ao}


def _factor(rt: Runtime, value: object, shape: tuple[int, int], name: str) -> cl.Buffer | None:
    if value is None or isinstance(value, cl.Buffer):
        return value
    arr = np.asarray(value, dtype=np.float32)
    if arr.shape != shape:
        raise ValueError(f"{name} must have the frame's shape {shape}, got {arr.shape}")
    return rt.to_device(arr, name)


def compose(gbuffer: GBuffer | DeviceGBuffer, camera: Camera, lighting: Lighting = Lighting(),
            shadow: np.ndarray | cl.Buffer | None = None, ao: np.ndarray | cl.Buffer | None = None,
            device: str | int | Runtime | None = None) -> np.ndarray:
    """uint8 sRGB (height, width, 4) frame of a G-buffer seen by ``camera``."""
    if isinstance(gbuffer, DeviceGBuffer):
        rt = gbuffer.runtime
        pos, nrm, alb = (gbuffer.buffers[k] for k in ("position", "normal", "albedo"))
    elif isinstance(gbuffer, GBuffer):
        rt = get_runtime(device)
        pos, nrm, alb = (rt.to_device(getattr(gbuffer, k), f"G-buffer {k}") for k in ("position", "normal", "albedo"))
    else:
        raise TypeError(f"gbuffer must be a GBuffer or DeviceGBuffer, got {type(gbuffer).__name__}")
    shape = gbuffer.shape
    if shape != (camera.height, camera.width):
        raise ValueError(f"camera is {camera.height}x{camera.width} pixels but the G-buffer is {shape[0]}x{shape[1]}")
    extra = [b for b in (_factor(rt, shadow, shape, "shadow"), _factor(rt, ao, shape, "ao")) if b is not None]
    n = shape[0] * shape[1]
    kernel = rt.kernel("compose.cl", "compose", ComposeFeatures(shadow is not None, ao is not None).defines())
    s = lighting.sun_view(camera)
    out = rt.empty(4 * n, "frame")
    f4 = lambda *v: np.array(v, np.float32)  # noqa: E731
    kernel.set_args(pos, nrm, alb, np.int32(n), f4(*s, lighting.sun_intensity), f4(*lighting.sky, 0.0),
                    f4(*lighting.background, 0.0), *extra, out)
    local = rt.local_size(kernel, 64)
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (-(-n // local) * local,), (local,))
    frame = np.empty(shape + (4,), np.uint8)
    cl.enqueue_copy(rt.queue, frame, out)
    rt.queue.finish()
    return frame
