"""The final frame: albedo x (Lambert sun x shadow + sky x AO), box-filtered, as 8-bit sRGB.

>>> rgba = compose(gbuf, camera)                                  # uint8 (height, width, 4)
>>> rgba = compose(gbuf, camera, shadow=coef, ao=occlusion)       # passes written elsewhere
>>> rgba = compose(big, big_camera, ssaa=3)                       # 3 x 3 samples per pixel
>>> buf = compose_linear(gbuf, camera, shadow=coef)               # float4 linear, on the device

Shadow coefficients (1 = lit) and AO factors (1 = unoccluded) are optional
per-sample float inputs (numpy (height, width) arrays or device buffers of
height*width floats); a missing one is compiled out (-D OCLS_SHADOW /
-D OCLS_AO).  ``normal`` replaces the G-buffer's normal field for the shading (the
terrain's smooth shading normals, :meth:`oclshade.terrain.TerrainRenderer.shading_normals`).
The G-buffer may be on the host (:class:`~oclshade.gbuffer.GBuffer`) or on the device
(:class:`~oclshade.terrain.DeviceGBuffer`).  Kernel: ``kernels/compose.cl`` (the formulas);
twin: :func:`oclshade.reference.compose`.

The light (``Lighting.sun``) is the sun or a :class:`oclshade.lights.PointLight` (-D
OCLS_POINT_LIGHT; the sun's program is unchanged): per sample the unit vector from the
surface point to the light (view space), Lambert, and the inverse-square falloff about the
light's reference ``distance`` r0, ``sun_intensity (r0 / d)^2`` at d metres (none when
``distance`` is None).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyopencl as cl

from .camera import Camera
from .gbuffer import GBuffer
from .lights import LightLike, PointLight, as_light
from .runtime import Runtime, get_runtime
from .sun import Sun
from .terrain import DeviceGBuffer


@dataclass(frozen=True)
class Lighting:
    """The light and the sky, linear RGB.  ``sun``: the light, a sun (gdaldem words: azimuth,
    elevation in degrees) or a :class:`oclshade.lights.PointLight`.

    ``sun_intensity``: the light's irradiance on a plane facing it (a point light: at its
    reference distance, inverse-square beyond; everywhere without one); ``sky``: the sky's
    irradiance on an unoccluded horizontal plane (a tilted plane gets (1 + cos tilt) / 2 of
    it).  The defaults keep the clear-sky ratio of diffuse horizontal to direct normal
    irradiance, about 0.12 (sky luminance 0.24 to the sun's 2.0; docs/methods.md "Image
    quality in render"), so a cast shadow on sunlit ground keeps only the sky's share."""

    sun: LightLike = (315.0, 45.0)
    sun_intensity: float = 2.0
    sky: tuple[float, float, float] = (0.21, 0.24, 0.30)
    background: tuple[float, float, float] = (0.45, 0.62, 0.85)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sun", as_light(self.sun))
        for name in ("sky", "background"):
            v = np.asarray(getattr(self, name), float)
            if v.shape != (3,) or not np.all(np.isfinite(v)) or v.min() < 0:
                raise ValueError(f"{name} must be 3 non-negative linear RGB values, got {getattr(self, name)!r}")
        if not np.isfinite(self.sun_intensity) or self.sun_intensity < 0:
            raise ValueError(f"sun_intensity must be >= 0, got {self.sun_intensity!r}")

    def sun_view(self, camera: Camera) -> np.ndarray:
        """Unit vector towards the sun in view space."""
        if not isinstance(self.sun, Sun):
            raise TypeError("sun_view: the light is a point light; its view-space position is light_view")
        return camera.rotation @ np.array(self.sun.vector())

    def light_view(self, camera: Camera) -> np.ndarray:
        """compose.cl's ``sun`` xyz: the unit vector towards the sun, or the point light's
        view-space position (float64, rounded once by the caller), in view space."""
        if isinstance(self.sun, PointLight):
            return camera.view[:3, :3] @ self.sun.position + camera.view[:3, 3]
        return self.sun_view(camera)

    @property
    def falloff(self) -> float:
        """compose.cl's ``falloff``: the point light's reference distance squared, 0 for none."""
        d = self.sun.distance if isinstance(self.sun, PointLight) else None
        return 0.0 if d is None else d * d

    @staticmethod
    def up_view(camera: Camera) -> np.ndarray:
        """Unit vector of world up (+z) in view space (the sky dome's axis)."""
        return camera.rotation[:, 2].copy()


@dataclass(frozen=True)
class ComposeFeatures:
    shadow: bool = False
    ao: bool = False
    linear: bool = False
    point: bool = False

    def defines(self) -> dict[str, object]:
        return {"OCLS_SHADOW": self.shadow, "OCLS_AO": self.ao, "OCLS_LINEAR": self.linear,
                "OCLS_POINT_LIGHT": self.point}


def _factor(rt: Runtime, value: object, shape: tuple[int, int], name: str) -> cl.Buffer | None:
    if value is None or isinstance(value, cl.Buffer):
        return value
    arr = np.asarray(value, dtype=np.float32)
    if arr.shape != shape:
        raise ValueError(f"{name} must have the frame's shape {shape}, got {arr.shape}")
    return rt.to_device(arr, name)


def _normals(rt: Runtime, value: object, shape: tuple[int, int]) -> cl.Buffer:
    if isinstance(value, cl.Buffer):
        return value
    arr = np.asarray(value, dtype=np.float32)
    if arr.shape[:2] != shape or arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise ValueError(f"normal must be a {shape + (4,)} (or xyz) float array like the G-buffer's, got {arr.shape}")
    if arr.shape[2] == 3:
        arr = np.concatenate([arr, np.zeros(shape + (1,), np.float32)], axis=2)
    return rt.to_device(np.ascontiguousarray(arr), "shading normals")


#: the largest supersampling factor (MAX_SSAA^2 samples per pixel)
MAX_SSAA = 8


def check_ssaa(ssaa: object) -> int:
    """Samples per pixel along each axis: an integer in 1..MAX_SSAA."""
    if not isinstance(ssaa, (int, np.integer)) or isinstance(ssaa, bool) or not 1 <= ssaa <= MAX_SSAA:
        raise ValueError(f"ssaa must be an integer in 1..{MAX_SSAA} (samples per pixel along each axis), got {ssaa!r}")
    return int(ssaa)


def compose(gbuffer: GBuffer | DeviceGBuffer, camera: Camera, lighting: Lighting = Lighting(),
            shadow: np.ndarray | cl.Buffer | None = None, ao: np.ndarray | cl.Buffer | None = None,
            device: str | int | Runtime | None = None, normal: np.ndarray | cl.Buffer | None = None,
            ssaa: int = 1) -> np.ndarray:
    """uint8 sRGB frame of a G-buffer seen by ``camera`` (the G-buffer's size).  ``ssaa``: the
    G-buffer holds ssaa x ssaa samples per output pixel, box-filtered into a frame of
    (height / ssaa, width / ssaa, 4) pixels; ``normal``: shading normals in place of the G-buffer's."""
    rt, out, size = _enqueue(gbuffer, camera, lighting, shadow, ao, device, normal, ssaa, linear=False)
    frame = np.empty(size + (4,), np.uint8)
    cl.enqueue_copy(rt.queue, frame, out)
    rt.queue.finish()
    return frame


def compose_linear(gbuffer: GBuffer | DeviceGBuffer, camera: Camera, lighting: Lighting = Lighting(),
                   shadow: np.ndarray | cl.Buffer | None = None, ao: np.ndarray | cl.Buffer | None = None,
                   device: str | int | Runtime | None = None, normal: np.ndarray | cl.Buffer | None = None,
                   ssaa: int = 1) -> cl.Buffer:
    """As :func:`compose`, but the frame stays on the device in linear light with its full
    range (no clamp, no sRGB): a buffer of (height / ssaa) x (width / ssaa) float4 (r, g, b, 1),
    row-major (-D OCLS_LINEAR; what generated cube maps are made of)."""
    return _enqueue(gbuffer, camera, lighting, shadow, ao, device, normal, ssaa, linear=True)[1]


def _enqueue(gbuffer: GBuffer | DeviceGBuffer, camera: Camera, lighting: Lighting, shadow: object, ao: object,
             device: str | int | Runtime | None, normal: object, ssaa: int,
             linear: bool) -> tuple[Runtime, cl.Buffer, tuple[int, int]]:
    """Check the inputs and enqueue compose.cl: (runtime, output buffer, output size)."""
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
    ssaa = check_ssaa(ssaa)
    if shape[0] % ssaa or shape[1] % ssaa:
        raise ValueError(f"ssaa {ssaa} must divide the G-buffer's size {shape[0]}x{shape[1]}")
    if normal is not None:
        nrm = _normals(rt, normal, shape)
    extra = [b for b in (_factor(rt, shadow, shape, "shadow"), _factor(rt, ao, shape, "ao")) if b is not None]
    size = (shape[0] // ssaa, shape[1] // ssaa)
    n = size[0] * size[1]
    point = isinstance(lighting.sun, PointLight)
    features = ComposeFeatures(shadow is not None, ao is not None, linear, point)
    kernel = rt.kernel("compose.cl", "compose", features.defines())
    out = rt.empty((16 if linear else 4) * n, "linear frame" if linear else "frame")
    f4 = lambda *v: np.array(v, np.float32)  # noqa: E731
    kernel.set_args(pos, nrm, alb, np.int32(size[1]), np.int32(size[0]), np.int32(ssaa),
                    f4(*lighting.light_view(camera), lighting.sun_intensity), f4(*lighting.sky, 0.0),
                    f4(*lighting.up_view(camera), 0.0), f4(*lighting.background, 0.0),
                    *([np.float32(lighting.falloff)] if point else []), *extra, out)
    local = rt.local_size(kernel, 64)
    cl.enqueue_nd_range_kernel(rt.queue, kernel, (-(-n // local) * local,), (local,))
    return rt, out, size
