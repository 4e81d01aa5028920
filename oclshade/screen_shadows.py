"""Per-pixel terrain shadows over a G-buffer (paper 000 in screen space: Algo 1, 2, 3, eq. 1).

>>> caster = ScreenShadowCaster(Heightmap.from_array(dem, cellsize=30.0))
>>> res = caster.shade(gbuffer, Sun(315, 10))          # exact (q = 0)
>>> fast = caster.shade(gbuffer, Sun(315, 10), lod=LodOptions.automatic())   # Algo 1
>>> res.flag          # uint8 (height, width): 1 cast shadow, 0 lit, 255 empty
>>> res.coefficient   # float32: eq. (1), 1 = lit (and on empty pixels)

For every pixel that sees terrain, a level of detail q is chosen (0, a fixed
level, or with automatic q Algo 1's minimal level from the pixel's
heightmap-coordinate derivatives, the G-buffer's ``uv_grad``); the sun ray
starts on the level-q surface at the pixel's (u, v) and is traced through the
extrema pyramid from level q (Algo 3), with the same exact / paper / maxmip / dda variants and the very same traversal code
as the heightmap-space masks (kernels/shadow.cl: ``shadow_cells`` and
``shadow_pixels`` call one ``trace``).

At q = 0 the pass is exact: equal to :func:`oclshade.reference.pixel_shadows`
but for float32 ties, which are rare (a tie is a pixel whose verdict the
kernel's own rounding, bounded at every value it tests, could flip: well under
0.01 % of the tests in ``bench/screen_shadows.py``).  It is the default
(``LodOptions()``, ``force_q=0``; ``oclshade render --shadow-level 0``).

Level q > 0 is approximate by design, and automatic q (Algo 1,
``LodOptions.automatic()``, ``--shadow-level auto``) is a **speed setting, not an exact mode**.  Its surface is the mean mip pyramid
(:func:`oclshade.pyramid.build_mip_pyramid`) at level q, positioned where its
samples belong (level-q sample j is the mean of level-0 samples 2^q j ..
2^q j + 2^q - 1, centred at 2^q j + (2^q - 1) / 2), resampled bilinearly
(clamped to the edge) at the corners of the level-q tiles and bilinear
between them: the level-q "heightmap" of :func:`coarse_grid`.  The ray
starts on that surface (so a pixel is never shadowed by the smoothing of its
own neighbourhood) and its finest test is the exact patch test on it; the
levels above q are the extrema of the true surface.  The smoothing loses
shadows narrower than the level's tiles, so the error grows with q and with
the sun's elevation (shadows thin out): measured as the share of the pixels
q = 0 shadows that a setting misses or adds (figures of the run recorded in
docs/methods.md), automatic q errs by 1.6-77 % of
them at 480x270 on a 2048^2 map (sun 3-40 degrees; LOD bias -1: 0.08-9.5 %)
and by at most 0.4-1.4 % at 1920x1080, where nearly every pixel gets q = 0
anyway, while it saves at most 17 % of the traversal steps (and on Puget Sound
costs up to 24 % more).  No rule on footprint or sun elevation meets a bound
such as 0.5 % of the shadowed pixels short of q = 0 (a shadow a few cells wide
is gone at q = 1), so none is applied: docs/methods.md "Per-pixel shadows:
exactness at q = 0 and the error of q"; the table is ``bench/screen_shadows.py``'s.

Inputs: a :class:`~oclshade.gbuffer.GBuffer` (host arrays), a rendered
:class:`oclshade.terrain.DeviceGBuffer`, or :class:`PixelBuffers` wrapping
existing ``pyopencl`` buffers of the same layout (no host round trip in the
last two); only ``position`` (w = hit), ``uv`` and ``uv_grad`` are read.
The heightmap is flat unless ``curvature`` lowers distant terrain along each
sun ray (the Earth's drop from the pixel's surface point, as the masks do); a
:class:`~oclshade.terrain.Heightfield` on a sphere (``radius``) is otherwise
shadowed as if its base were flat.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence, Union

import numpy as np
import pyopencl as cl

from .gbuffer import GBuffer
from .heightmap import Heightmap
from .pyramid import ExtremaPyramid, build_extrema_pyramid, build_mip_pyramid, level_offsets
from . import tuning
from .runtime import Runtime, get_runtime
from .horizon.caster import Curvature
from .shadows import (DEFAULT_K_BRIGHT, DEFAULT_K_DARK, ShadowFeatures, check_coefficients, check_curvature,
                      check_method, curvature_coefficient)
from .shadows import check_outputs as check_shadow_outputs
from .sun import Sun, SunLike, as_sun
from .terrain import DeviceGBuffer

OUTPUTS = ("flag", "coefficient", "lod")
FLAG_EMPTY = 255
DEFAULT_N_A_MAX = 16


def check_outputs(outputs: str | Sequence[str]) -> tuple[str, ...]:
    return check_shadow_outputs(outputs, OUTPUTS)


@dataclass(frozen=True)
class LodOptions:
    """The level q of the per-pixel pass.  ``force_q`` 0 (the default) is the exact
    pass; a fixed level 1..L or None (Algo 1 picks q per pixel: automatic, a speed
    setting with the error in the module doc) trade exactness for time.  Algo 1's
    settings, with ``force_q=None`` only: n_a_max caps the anisotropy compensation,
    bias is added to q before clamping."""

    n_a_max: int = DEFAULT_N_A_MAX
    bias: int = 0
    force_q: int | None = 0

    def __post_init__(self) -> None:
        if not isinstance(self.n_a_max, (int, np.integer)) or not 1 <= self.n_a_max <= 256:
            raise ValueError(f"n_a_max must be an integer in [1, 256], got {self.n_a_max!r}")
        if not isinstance(self.bias, (int, np.integer)) or abs(self.bias) > 64:
            raise ValueError(f"bias must be an integer in [-64, 64], got {self.bias!r}")
        if self.force_q is not None and (not isinstance(self.force_q, (int, np.integer)) or self.force_q < 0):
            raise ValueError(f"force_q must be None or a level >= 0, got {self.force_q!r}")
        if self.force_q is not None and (self.bias != 0 or self.n_a_max != DEFAULT_N_A_MAX):
            raise ValueError(f"bias and n_a_max apply to automatic q: give force_q=None with them, got "
                             f"force_q={self.force_q!r}")

    @classmethod
    def automatic(cls, n_a_max: int = DEFAULT_N_A_MAX, bias: int = 0) -> "LodOptions":
        """Algo 1 picks q per pixel (a speed setting, not exact)."""
        return cls(n_a_max=n_a_max, bias=bias, force_q=None)


@dataclass(frozen=True)
class PixelShadowFeatures:
    """Compile-time features of ``shadow_pixels``: what is not asked for is not compiled."""

    method: str = "exact"
    outputs: tuple[str, ...] = ("flag", "coefficient")
    stats: bool = False
    own_builtins: bool = False   # inline built-ins (kernels/common.h; tuning knob)
    curvature: bool = False      # Earth curvature along the rays (-D OCLS_CURVATURE)

    def defines(self) -> dict[str, object]:
        # the flag is the heightmap-space mask's define; self-shadow is not a pixel output
        cells = ShadowFeatures(self.method, tuple({"flag": "mask"}.get(o, o) for o in self.outputs
                                                  if o != "lod"), self.stats,
                               own_builtins=self.own_builtins, curvature=self.curvature).defines()
        return {**cells, "OCLS_OUT_SELF": False, "OCLS_OUT_LOD": "lod" in self.outputs}


@dataclass
class PixelBuffers:
    """The three G-buffer fields the shadow pass reads, as existing device buffers (layout:
    :mod:`oclshade.gbuffer`): how a foreign renderer hands its G-buffer over without a
    host round trip.  (A whole rendered :class:`oclshade.terrain.DeviceGBuffer` is
    accepted as it is.)"""

    position: cl.Buffer   # float4 per pixel, w = 1 hit, 0 empty
    uv: cl.Buffer         # float2 per pixel
    uv_grad: cl.Buffer    # float4 per pixel
    shape: tuple[int, int]  # (height, width)

    def __post_init__(self) -> None:
        height, width = self.shape
        if height < 1 or width < 1:
            raise ValueError(f"G-buffer shape must be (height >= 1, width >= 1), got {self.shape!r}")
        n = height * width
        for name, channels in (("position", 4), ("uv", 2), ("uv_grad", 4)):
            buf = getattr(self, name)
            if not isinstance(buf, cl.Buffer) or buf.size < 4 * channels * n:
                raise ValueError(f"PixelBuffers.{name} must be a pyopencl Buffer of at least "
                                 f"{4 * channels * n} bytes (float{channels} x {height}x{width})")

    @classmethod
    def upload(cls, gbuffer: GBuffer, runtime: Runtime) -> "PixelBuffers":
        return cls(runtime.to_device(gbuffer.position, "G-buffer position"),
                   runtime.to_device(gbuffer.uv, "G-buffer uv"),
                   runtime.to_device(gbuffer.uv_grad, "G-buffer uv_grad"), gbuffer.shape)


GBufferLike = Union[GBuffer, DeviceGBuffer, PixelBuffers]


@dataclass
class PixelShadowResult:
    """Per-pixel outputs for one sun; an output that was not requested is None."""

    sun: Sun
    flag: np.ndarray | None = None          # uint8: 1 cast shadow, 0 lit, 255 empty
    coefficient: np.ndarray | None = None   # float32: eq. (1), 1 = lit or empty
    lod: np.ndarray | None = None           # uint8: the level q used, 255 empty


def _lerp(a: np.ndarray, b: np.ndarray, f: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return np.where(f == 0, a, np.where(f == 1, b, a + (b - a) * f))


def coarse_grid(mip: np.ndarray, q: int, patch_shape: tuple[int, int], map_shape: tuple[int, int]) -> np.ndarray:
    """The level-q surface: mip level q (float32 array) resampled at the level-q tile corners.

    Corner (r, c) sits at level-0 sample coordinates (2^q r, 2^q c), clamped to
    the map; there mip level q is sampled bilinearly at its own coordinates
    ((x - (2^q - 1) / 2) / 2^q, clamped to its edge).  Shape
    (ceil(Hp / 2^q) + 1, ceil(Wp / 2^q) + 1), float32; NaN where a hole reaches.
    """
    s = 1 << q
    hp, wp = patch_shape
    rows, cols = map_shape

    def axis(n_tiles: int, n_samples: int, n_mip: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos = np.minimum(np.arange(-(-n_tiles // s) + 1, dtype=np.float64) * s, n_samples - 1)
        m = np.clip((pos - (s - 1) / 2.0) / s, 0.0, n_mip - 1)
        i0 = np.minimum(np.floor(m).astype(np.int64), max(n_mip - 2, 0))
        return i0, np.minimum(i0 + 1, n_mip - 1), m - i0

    r0, r1, fy = axis(hp, rows, mip.shape[0])
    c0, c1, fx = axis(wp, cols, mip.shape[1])
    m = mip.astype(np.float64)
    top = _lerp(m[np.ix_(r0, c0)], m[np.ix_(r0, c1)], fx[None, :])
    bottom = _lerp(m[np.ix_(r1, c0)], m[np.ix_(r1, c1)], fx[None, :])
    return _lerp(top, bottom, fy[:, None]).astype(np.float32)


class ScreenShadowCaster:
    """Per-pixel cast shadows of one heightmap for any number of G-buffers and suns."""

    def __init__(self, heightmap: Heightmap, pyramid: ExtremaPyramid | None = None,
                 device: str | int | Runtime | None = None, group: int | None = None,
                 own_builtins: int | None = None, curvature: Curvature | None = None):
        """``group`` (work-group size) and ``own_builtins`` (inline built-ins, kernels/common.h):
        the ``screen_shadows`` family's tuning knobs (:data:`TUNING`; None: the device's tuning
        entry; same results for every value).  ``curvature``: None for a flat Earth, or an
        :class:`oclshade.horizon.Curvature`: terrain at distance d from a pixel's surface point
        drops by (1 - k) d^2 / (2 R) below its sun ray (as :class:`oclshade.ShadowCaster`)."""
        self.heightmap = heightmap
        self.curvature = check_curvature(curvature)
        self.runtime = pyramid.runtime if pyramid is not None else get_runtime(device)
        given = {k: v for k, v in (("group", group), ("own_builtins", own_builtins)) if v is not None}
        knobs = {**tuning.settings(self.runtime, "screen_shadows").values, **TUNING.check(given, partial=True)}
        self.group, self.own_builtins = knobs["group"], bool(knobs["own_builtins"])
        if pyramid is not None and pyramid.map_shape != heightmap.shape:
            raise ValueError(f"pyramid was built for a {pyramid.map_shape} map, the heightmap is {heightmap.shape}")
        self._pyramid = pyramid
        self._coarse: tuple[cl.Buffer, cl.Buffer] | None = None
        self._dummy = self.runtime.empty(4, "dummy")

    @property
    def pyramid(self) -> ExtremaPyramid:
        """The extrema pyramid, built on first use and kept on the device."""
        if self._pyramid is None:
            self._pyramid = build_extrema_pyramid(self.heightmap, self.runtime)
        return self._pyramid

    @property
    def top_level(self) -> int:
        """L: the coarsest level q can take."""
        return self.pyramid.levels - 1

    @property
    def coarse(self) -> tuple[cl.Buffer, cl.Buffer]:
        """(grids, offsets): the level-q surfaces for q = 1..L back to back (float32), and the
        offset of level q at [q] (int32, [0] unused); built on first use."""
        if self._coarse is None:
            hm = self.heightmap
            mips = build_mip_pyramid(hm, self.runtime)
            grids = [coarse_grid(mips[min(q, len(mips) - 1)], q, hm.patch_shape, hm.shape)
                     for q in range(1, self.top_level + 1)]
            offs = level_offsets([g.shape for g in grids])
            flat = np.concatenate([g.ravel() for g in grids])
            self._coarse = (self.runtime.to_device(flat, "coarse level grids"),
                            self.runtime.to_device(np.concatenate([[-1], offs]).astype(np.int32), "coarse offsets"))
        return self._coarse

    def warm_up(self, method: str = "exact", outputs: Sequence[str] = ("flag", "coefficient")) -> None:
        """Build the pyramids and the kernel variant ahead of time."""
        self.coarse
        self.runtime.queue.finish()
        self.runtime.program("shadow.cl", self._features(method, check_outputs(outputs)).defines())

    def shade(self, gbuffer: GBufferLike, sun: SunLike, method: str = "exact",
              lod: LodOptions = LodOptions(), outputs: str | Sequence[str] = ("flag", "coefficient"),
              k_dark: float = DEFAULT_K_DARK, k_bright: float = DEFAULT_K_BRIGHT) -> PixelShadowResult:
        """Per-pixel outputs for one sun, copied to the host."""
        outs = check_outputs(outputs)
        gb = self._device_gbuffer(gbuffer)
        bufs = self.shade_to_device(gb, sun, method, lod, outs, k_dark, k_bright)
        res = PixelShadowResult(as_sun(sun))
        for name, dtype in (("flag", np.uint8), ("coefficient", np.float32), ("lod", np.uint8)):
            if name in bufs:
                arr = np.empty(gb.shape, dtype)
                cl.enqueue_copy(self.runtime.queue, arr, bufs[name])
                setattr(res, name, arr)
        self.runtime.queue.finish()
        return res

    def shade_to_device(self, gbuffer: GBufferLike, sun: SunLike, method: str = "exact",
                        lod: LodOptions = LodOptions(), outputs: str | Sequence[str] = ("flag", "coefficient"),
                        k_dark: float = DEFAULT_K_DARK, k_bright: float = DEFAULT_K_BRIGHT,
                        out: dict[str, cl.Buffer] | None = None) -> dict[str, cl.Buffer]:
        """Enqueue the pass and return its output buffers (uint8 flag, float32 coefficient,
        uint8 lod per pixel); nothing is copied or waited for.  ``out`` may hold buffers
        to write into (reused across frames)."""
        outs = check_outputs(outputs)
        k_dark, k_bright = check_coefficients(k_dark, k_bright)
        gb = self._device_gbuffer(gbuffer)
        height, width = gb.shape
        n = height * width
        sizes = {"flag": n, "coefficient": 4 * n, "lod": n}
        bufs = dict(out or {})
        for name in outs:
            if name not in bufs or bufs[name].size < sizes[name]:
                bufs[name] = self.runtime.empty(sizes[name], f"pixel shadow {name}")
        kernel = self.runtime.kernel("shadow.cl", "shadow_pixels", self._features(check_method(method), outs).defines())
        kernel.set_args(*self._args(gb, as_sun(sun), lod, k_dark, k_bright),
                        *(bufs.get(name, self._dummy) for name in OUTPUTS))
        cl.enqueue_nd_range_kernel(self.runtime.queue, kernel, *self.runtime.grid_2d(kernel, width, height, self.group))
        return {name: bufs[name] for name in outs}

    def _features(self, method: str, outs: tuple[str, ...], stats: bool = False) -> PixelShadowFeatures:
        return PixelShadowFeatures(method, outs, stats, own_builtins=self.own_builtins,
                                   curvature=self.curvature is not None)

    def step_counts(self, gbuffer: GBufferLike, sun: SunLike, method: str = "exact",
                    lod: LodOptions = LodOptions(), band_pixels: int = 1 << 19) -> np.ndarray:
        """Traversal iterations per pyramid level, summed over all pixels (a profiling build;
        uint32 counters per band of rows, summed here in int64)."""
        rt = self.runtime
        gb = self._device_gbuffer(gbuffer)
        height, width = gb.shape
        kernel = rt.kernel("shadow.cl", "shadow_pixels",
                           self._features(check_method(method), ("flag",), True).defines())
        flag = rt.empty(height * width, "pixel shadow flag")
        args = (*self._args(gb, as_sun(sun), lod, 0.0, 1.0), flag, self._dummy, self._dummy)
        return rt.count_in_bands(kernel, args, self.pyramid.levels, width, height, band_pixels)

    def _device_gbuffer(self, gbuffer: GBufferLike) -> PixelBuffers:
        if isinstance(gbuffer, PixelBuffers):
            return gbuffer
        if isinstance(gbuffer, GBuffer):
            return PixelBuffers.upload(gbuffer, self.runtime)
        if isinstance(gbuffer, DeviceGBuffer):
            if gbuffer.runtime is not self.runtime:
                raise ValueError("the rendered G-buffer lives on another device than this caster")
            b = gbuffer.buffers
            return PixelBuffers(b["position"], b["uv"], b["uv_grad"], gbuffer.shape)
        raise TypeError(f"gbuffer must be a GBuffer, DeviceGBuffer or PixelBuffers, got {type(gbuffer).__name__}")

    def _args(self, gb: PixelBuffers, sun: Sun, lod: LodOptions, k_dark: float, k_bright: float) -> tuple:
        """Kernel arguments up to (not including) the output buffers."""
        hm, pyr = self.heightmap, self.pyramid
        if not isinstance(lod, LodOptions):
            raise TypeError(f"lod must be a LodOptions, got {type(lod).__name__}")
        if lod.force_q is not None and lod.force_q > self.top_level:
            raise ValueError(f"the shadow level q (force_q) must be in [0, {self.top_level}] for this heightmap "
                             f"({pyr.levels} levels), got {lod.force_q}")
        grids, grid_offsets = self.coarse
        ux, uy, w = sun.ray(hm.dx, hm.dy)
        mode = 2 if sun.below_horizon else (1 if sun.at_zenith else 0)
        if mode:
            ux = uy = w = 0.0
        s = sun.vector()
        rows, cols = hm.shape
        height, width = gb.shape
        force = -1 if lod.force_q is None else int(lod.force_q)
        return (pyr.heights, grids, grid_offsets, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets,
                np.int32(pyr.levels), gb.position, gb.uv, gb.uv_grad, np.int32(width), np.int32(height),
                np.array([ux, uy, w, curvature_coefficient(self.curvature)], np.float32),
                np.array([s[0], s[1], s[2], 0.0], np.float32),
                np.array([k_dark, k_bright], np.float32), np.int32(mode),
                np.array([force, lod.bias, lod.n_a_max, 0], np.int32))


def _case(rt: Runtime, size: int, width: int, height: int, knobs: tuning.Values):
    from .camera import frame_heightmap
    from .terrain import Heightfield, TerrainRenderer
    field = Heightfield(tuning.standard_heightmap(size))
    gbuffer = TerrainRenderer(field, rt).render(frame_heightmap(field.heightmap, width, height, 200.0, 25.0))
    return ScreenShadowCaster(field.heightmap, device=rt, **knobs), gbuffer


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    caster, gbuffer = _case(rt, 48, 40, 30, knobs)
    caster.shade(gbuffer, (300.0, 15.0))


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    caster, gbuffer = _case(rt, 512 if quick else 2048, *((640, 360) if quick else (1920, 1080)), knobs)
    device_gbuffer = caster._device_gbuffer(gbuffer)
    return lambda: caster.shade_to_device(device_gbuffer, (300.0, 10.0))


#: per-pixel shadows' knobs (kernels/shadow.cl shadow_pixels)
TUNING = tuning.register(tuning.Family(
    "screen_shadows", (tuning.Param("group", (16, 64, 256), 64, "work-group size (work-items)"),
                       tuning.OWN_BUILTINS_WHERE_CALLED),
    ("shadow.cl",), _smoke, _workload, "per-pixel shadows over a G-buffer (paper 000)"))
