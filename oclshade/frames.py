"""Frames of a terrain scene: G-buffer -> shading normals -> per-pixel shadows -> AO -> compose, each pass
run only when its inputs changed (paper 003's reuse across frames) and compiled only
with the features the frame uses (paper 002).

>>> scene = TerrainScene(Heightfield(heightmap))
>>> for sun in sun_path:                       # fixed camera: the G-buffer and AO run once
...     frame = scene.frame(camera, sun, FrameSettings(ao=AOSettings(radius=60.0)))
...     frame.image, frame.ran                  # uint8 (H, W, 4); which passes ran

Passes and the inputs that key them (a digest of each):

==============  ==============================================  =========================
pass            inputs                                          skipped when
==============  ==============================================  =========================
gbuffer         heights (fixed per scene), camera, ray caster   never needed twice
normals         G-buffer                                        ``normals="geometric"``
shadows         G-buffer, light, method, Algo 1 settings        ``shadows=False``
ao              G-buffer, AO settings                           ``ao=None`` or radius 0
compose         all of the above, lighting (the light too)      never needed twice
==============  ==============================================  =========================

Supersampling (``ssaa=N``): every pass before compose runs on a frame of N x N samples
per pixel (the camera with N times the width and height: the same view volume), so cast
shadows and AO are resolved per sample; compose box-filters the samples into the frame.
The G-buffer, shadow and AO buffers of a :class:`Frame` are then at that resolution.

Everything stays on the device between passes; one pyramid serves the ray caster
and the shadow pass.  ``caching=False`` runs every pass every frame (the baseline
the skipping benchmark compares against).
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pyopencl as cl

from .camera import MAX_SIDE, Camera
from .compose import Lighting, check_ssaa, compose
from .lights import LightLike, PointLight, as_light
from .runtime import Runtime
from .screen_shadows import LodOptions, ScreenShadowCaster
from .shadows import check_coefficients
from .ssao import DEFAULT_FEATURES, DEFAULT_M, SSAO, AOFeatures, AOInputs, check_params
from .sun import Sun
from .terrain import DeviceGBuffer, Heightfield, TerrainRenderer

PASSES = ("gbuffer", "normals", "shadows", "ao", "compose")
#: shading normals: ``smooth`` (interpolated slopes, TerrainRenderer.shading_normals) or the G-buffer's
#: ``geometric`` normal of each bilinear patch (faceted where the terrain is smooth)
NORMALS = ("smooth", "geometric")


@dataclass(frozen=True)
class AOSettings:
    """Screen-space AO (see :mod:`oclshade.ssao`): radius in metres, m samples; radius 0 or
    m 0 switch AO off.  Checked as :meth:`SSAO.run <oclshade.ssao.SSAO.run>` checks them."""

    radius: float
    m: int = DEFAULT_M
    delta: float = 0.0
    features: AOFeatures = DEFAULT_FEATURES

    def __post_init__(self) -> None:
        check_params(self.m, self.radius, self.delta)


@dataclass(frozen=True)
class FrameSettings:
    """What a frame computes.  A feature switched off is neither compiled nor run."""

    caster: str = "bisect"                 # terrain ray caster (oclshade.terrain.METHODS)
    shadows: bool = True                   # per-pixel cast shadows (paper 000)
    shadow_method: str = "exact"
    lod: LodOptions = LodOptions()
    ao: AOSettings | None = None           # None: no AO pass
    lighting: Lighting = field(default_factory=Lighting)
    #: the sun's visibility in shadow, paper 000 eq. (1)'s (k_dark, k_bright): k_dark + (k_bright - k_dark)
    #: sin(sun elevation); (0, 0): none (physical: the sky term lights shadows); the paper's (0.25, 0.65)
    #: counts sky light twice (the look before docs/methods.md "Image quality in render")
    shadow_k: tuple[float, float] = (0.0, 0.0)
    normals: str = "smooth"                # shading normals (NORMALS); SSAO always uses the geometric one
    ssaa: int = 1                          # N x N samples per pixel, box-filtered (see the module doc)

    def __post_init__(self) -> None:
        if self.normals not in NORMALS:
            raise ValueError(f"normals must be one of {', '.join(NORMALS)}; got {self.normals!r}")
        check_ssaa(self.ssaa)
        check_coefficients(*self.shadow_k)


@dataclass
class Frame:
    """One composed frame; ``ran`` names the passes that ran (the others were reused or off);
    ``ms`` the wall time of each pass that ran (queue finished after each).  ``image`` has the
    camera's size; the buffers have ssaa times its width and height."""

    image: np.ndarray
    gbuffer: DeviceGBuffer
    normals: cl.Buffer | None
    shadow: cl.Buffer | None
    ao: cl.Buffer | None
    ran: tuple[str, ...]
    ms: dict[str, float]

    def ao_factor(self) -> np.ndarray:
        """The AO factor per pixel on the host (float32, 1 = unoccluded; all 1 without AO)."""
        out = np.ones(self.gbuffer.shape, np.float32)
        if self.ao is not None:
            queue = self.gbuffer.runtime.queue
            cl.enqueue_copy(queue, out, self.ao)
            queue.finish()
        return out


def _digest(*parts: object) -> str:
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        h.update(np.ascontiguousarray(p).tobytes() if isinstance(p, np.ndarray) else repr(p).encode())
        h.update(b"\x00")
    return h.hexdigest()


def camera_digest(camera: Camera) -> str:
    """Digest of everything a camera contributes to a G-buffer (matrices bit-exact)."""
    return _digest(camera.position, camera.look_at, camera.up, camera.width, camera.height, camera.fov,
                   camera.near, camera.far, camera.projection, camera.ortho_height)


class TerrainScene:
    """One heightfield on one device, rendered frame after frame."""

    def __init__(self, heightfield: Heightfield, device: str | int | Runtime | None = None,
                 caching: bool = True):
        self.renderer = TerrainRenderer(heightfield, device)
        self.runtime = self.renderer.runtime
        self.caching = caching
        self._shadows: ScreenShadowCaster | None = None
        self._ssao: SSAO | None = None
        self._keys: dict[str, str] = {}
        self._out: dict[str, object] = {}

    @property
    def shadow_caster(self) -> ScreenShadowCaster:
        """Shares the ray caster's extrema pyramid (built once per scene)."""
        if self._shadows is None:
            self._shadows = ScreenShadowCaster(self.renderer.field.heightmap, pyramid=self.renderer.pyramid,
                                               device=self.runtime)
        return self._shadows

    @property
    def ssao(self) -> SSAO:
        if self._ssao is None:
            self._ssao = SSAO(self.runtime)
        return self._ssao

    #: whether :meth:`frame` takes a point light (ObjectScene's passes; TerrainScene's are sun-only)
    POINT_LIGHTS = False

    def frame(self, camera: Camera, sun: LightLike, settings: FrameSettings = FrameSettings()) -> Frame:
        """Render one frame; passes whose inputs are unchanged since the last frame are reused.
        ``sun``: the light, a sun or (:class:`oclshade.scene.ObjectScene` only) a
        :class:`oclshade.lights.PointLight`; it keys the shadows and compose passes."""
        sun = as_light(sun)
        if isinstance(sun, PointLight) and not self.POINT_LIGHTS:
            raise ValueError(f"sun: {type(self).__name__}'s passes are sun-only; render a point light with "
                             "oclshade.scene.ObjectScene (docs/meshes.md \"Point lights\")")
        lighting = replace(settings.lighting, sun=sun)
        ao_on = settings.ao is not None and settings.ao.radius > 0 and settings.ao.m > 0
        camera = supersampled(camera, settings.ssaa)
        g_key = _digest(camera_digest(camera), settings.caster)
        keys = {
            "gbuffer": g_key,
            "normals": _digest(g_key) if settings.normals == "smooth" else None,
            "shadows": (_digest(g_key, sun, settings.shadow_method, settings.lod, settings.shadow_k)
                        if settings.shadows else None),
            "ao": _digest(g_key, settings.ao) if ao_on else None,
        }
        keys["compose"] = _digest(keys["gbuffer"], keys["normals"], keys["shadows"], keys["ao"], lighting,
                                  settings.ssaa)
        ran, ms = [], {}
        for name in PASSES:
            if keys[name] is None:
                self._out[name] = None
                self._keys.pop(name, None)
                continue
            if self.caching and self._keys.get(name) == keys[name]:
                continue
            t0 = time.perf_counter()
            self._out[name] = self._run(name, camera, sun, settings, lighting)
            self.runtime.queue.finish()
            ms[name] = 1e3 * (time.perf_counter() - t0)
            ran.append(name)
            self._keys[name] = keys[name]
        return Frame(self._out["compose"], self._out["gbuffer"], self._out["normals"], self._out["shadows"],
                     self._out["ao"], tuple(ran), ms)

    def _run(self, name: str, camera: Camera, sun: Sun, settings: FrameSettings, lighting: Lighting) -> object:
        gbuf = self._out.get("gbuffer")
        if name == "gbuffer":
            return self.renderer.render(camera, settings.caster, on_device=True,
                                        out=gbuf if isinstance(gbuf, DeviceGBuffer) else None)
        if name == "normals":
            prev = self._out.get("normals")
            reuse = prev is not None and prev.size == 16 * camera.width * camera.height
            return self.renderer.shading_normals(camera, gbuf, settings.caster, out=prev if reuse else None)
        if name == "shadows":
            prev = self._out.get("shadows")
            k_dark, k_bright = settings.shadow_k
            bufs = self.shadow_caster.shade_to_device(gbuf, sun, settings.shadow_method, settings.lod, "coefficient",
                                                      k_dark=k_dark, k_bright=k_bright,
                                                      out={"coefficient": prev} if prev is not None else None)
            return bufs["coefficient"]
        if name == "ao":
            ao = settings.ao
            inputs = AOInputs(gbuf.shape, gbuf.buffers["position"], gbuf.buffers["normal"])
            return self.ssao.run(inputs, camera.projection_matrix, radius=ao.radius, m=ao.m, delta=ao.delta,
                                 features=ao.features)
        return compose(gbuf, camera, lighting, shadow=self._out["shadows"], ao=self._out["ao"],
                       device=self.runtime, normal=self._out["normals"], ssaa=settings.ssaa)


def supersampled(camera: Camera, ssaa: int) -> Camera:
    """The camera with ``ssaa`` times the width and height (the same view volume): its pixel
    (y ssaa + j, x ssaa + k) is sample (j, k) of an ssaa x ssaa grid in pixel (y, x)."""
    if ssaa == 1:
        return camera
    width, height = camera.width * ssaa, camera.height * ssaa
    if max(width, height) > MAX_SIDE:
        raise ValueError(f"ssaa {ssaa} makes the {camera.width}x{camera.height} frame {width}x{height} samples; "
                         f"at most {MAX_SIDE} per side")
    return replace(camera, width=width, height=height)
