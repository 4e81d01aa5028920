"""Heightmap terrain rendered by ray casting into a G-buffer (paper 004, voxel bisection).

>>> field = Heightfield(Heightmap.from_array(dem, cellsize=30.0))
>>> camera = frame_heightmap(field.heightmap, 1920, 1080)
>>> gbuf = TerrainRenderer(field).render(camera)        # GBuffer of numpy arrays
>>> dev = TerrainRenderer(field).render(camera, on_device=True)   # cl.Buffers for the next pass

The surface model (paper 004 sec. 4-5, "differential heightmap"): a base
surface plus per-sample deviations, bilinear between samples, no surface over
a patch with a hole corner, nothing beyond the map (so 1 x N maps have no
surface at all).  Kernel: ``kernels/terrain.cl``; float64 twin:
:func:`oclshade.reference.cast_terrain`.
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
from functools import cached_property
from typing import Callable

import numpy as np
import pyopencl as cl

from .camera import Camera, heightmap_from_world
from .gbuffer import CHANNELS, GBuffer
from .heightmap import Heightmap, positive_finite
from .pyramid import ExtremaPyramid, build_extrema_pyramid, build_mip_levels, level_offsets
from .runtime import Runtime, get_runtime
from . import tuning

METHODS = ("bisect", "march", "dda")
_METHOD_CODE = {"bisect": 1, "march": 2, "dda": 3}
MAX_ITERATIONS = 1 << 16      # hard bound of every traversal loop (never reached on valid input)
_STATS_N, _ST_PATCH = 35, 32   # OCLS_STATS_N, OCLS_ST_PATCH of kernels/terrain.cl (rays, hits follow)


def check_method(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    return method


def _colour_array(colour: object, shape: tuple[int, int] | None = None) -> np.ndarray:
    """float32 (rows, cols, 4) linear RGBA in [0, 1] from uint8 / float RGB(A)."""
    arr = np.asarray(colour)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"colour must be a (rows, cols, 3|4) RGB(A) array, got shape {arr.shape}")
    if arr.dtype == np.uint8:
        rgba = arr.astype(np.float32) / 255.0
        rgba[..., :3] = np.where(rgba[..., :3] <= 0.04045, rgba[..., :3] / 12.92,
                                 ((rgba[..., :3] + 0.055) / 1.055) ** 2.4)   # sRGB -> linear
    elif arr.dtype.kind == "f":
        rgba = arr.astype(np.float32)
        if not np.all(np.isfinite(rgba)) or rgba.min() < 0.0 or rgba.max() > 1.0:
            raise ValueError("a float colour array must hold linear values in [0, 1]")
    else:
        raise TypeError(f"colour must be uint8 (sRGB) or float (linear, [0, 1]), got dtype {arr.dtype}")
    if rgba.shape[2] == 3:
        rgba = np.concatenate([rgba, np.ones(rgba.shape[:2] + (1,), np.float32)], axis=2)
    return np.ascontiguousarray(rgba)


@dataclass(frozen=True)
class Heightfield:
    """A heightmap on a base surface, with an optional colour texture.

    ``radius`` (metres) puts the map on a sphere: the base drops by
    ``(X^2 + Y^2) / (2 radius)`` at horizontal distance (X, Y) from the
    centre sample (:attr:`centre`), deviations stay vertical.  Against a true
    sphere with deviations along its normal this paraboloid errs, at
    distance d and height h, by at most ``d^4 / (8 R^3)`` vertically in the
    base (+0.003 m at d = 50 km on the Earth) plus ``|h| d^2 / (2 R^2)``
    vertically and ``|h| d / R`` horizontally for the deviation direction;
    the renderer and the reference share the paraboloid exactly.

    ``colour``: RGB(A) covering the map's cells (texel centres spread evenly
    over ``u in [-0.5, cols - 0.5]``, ``v in [-0.5, rows - 0.5]``), any size;
    uint8 is sRGB, float is linear in [0, 1].  None: hypsometric tint.
    """

    heightmap: Heightmap
    radius: float | None = None
    colour: np.ndarray | None = dc_field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.heightmap, Heightmap):
            raise TypeError(f"heightmap must be an oclshade.Heightmap, got {type(self.heightmap).__name__}")
        if self.radius is not None:
            object.__setattr__(self, "radius", positive_finite("radius", self.radius))
        if self.colour is not None:
            object.__setattr__(self, "colour", _colour_array(self.colour))

    @classmethod
    def from_array(cls, heights: object, cellsize: float | tuple[float, float] = 1.0, z_factor: float = 1.0,
                   nodata: float | None = None, radius: float | None = None,
                   colour: object | None = None) -> "Heightfield":
        return cls(Heightmap.from_array(heights, cellsize, z_factor, nodata), radius, colour)

    @property
    def centre(self) -> tuple[int, int]:
        """(row, col) of the sample that is the origin of the kernel's centred coordinates
        and of the sphere's paraboloid."""
        rows, cols = self.heightmap.shape
        return (max(rows - 1, 0) // 2, max(cols - 1, 0) // 2)

    @property
    def curvature(self) -> float:
        """k = 1 / (2 R) (1/m), 0 on a plane."""
        return 0.0 if self.radius is None else 0.5 / self.radius

    @cached_property
    def height_range(self) -> tuple[float, float]:
        """(min, max) of the finite relative float32 heights; (0, 0) for an all-hole map.  Computed
        once (every render passes it: recomputing it cost 170 ms per frame of a 4096^2 map)."""
        rel = self.heightmap.relative32
        if not np.isfinite(rel).any():
            return (0.0, 0.0)
        return (float(np.nanmin(rel)), float(np.nanmax(rel)))


@dataclass(frozen=True)
class TerrainFeatures:
    """Compile-time options of kernels/terrain.cl."""

    method: str = "bisect"
    orthographic: bool = False
    sphere: bool = False
    colour: bool = False
    march_step: float = 0.5       # march: step in cells
    descend: int = 3              # bisect: levels a split voxel descends at once
    leaf: int = 2                 # bisect: voxels of this level or finer are walked patch by patch
    stats: bool = False           # profiling build: traversal counters (TerrainRenderer.step_counts)
    own_builtins: bool = False    # inline built-ins (kernels/common.h; tuning knob)

    def defines(self) -> dict[str, object]:
        return {
            "OCLS_METHOD": _METHOD_CODE[check_method(self.method)],
            "OCLS_ORTHO": self.orthographic,
            "OCLS_SPHERE": self.sphere,
            "OCLS_COLOUR": self.colour,
            "OCLS_MARCH_STEP": f"{float(self.march_step)!r}f",
            "OCLS_MAX_IT": MAX_ITERATIONS,
            "OCLS_DESCEND": self.descend,
            "OCLS_LEAF": self.leaf,
            "OCLS_STATS": self.stats,
            "OCLS_OWN_BUILTINS": self.own_builtins,
        }


@dataclass
class DeviceGBuffer:
    """A G-buffer left on the device: one cl.Buffer per field (layout of :mod:`oclshade.gbuffer`)."""

    runtime: Runtime
    shape: tuple[int, int]
    buffers: dict[str, cl.Buffer]

    def to_host(self) -> GBuffer:
        rows, cols = self.shape
        arrays = {}
        for name, ch in CHANNELS.items():
            a = np.empty((rows, cols) if ch == 1 else (rows, cols, ch), np.float32)
            cl.enqueue_copy(self.runtime.queue, a, self.buffers[name])
            arrays[name] = a
        self.runtime.queue.finish()
        return GBuffer(**arrays)


class TerrainRenderer:
    """Ray-casts one heightfield for any number of cameras; pyramids stay on the device."""

    def __init__(self, heightfield: Heightfield, device: str | int | Runtime | None = None,
                 descend: int | None = None, leaf: int | None = None, group: int | None = None,
                 own_builtins: int | None = None):
        """Bisection options (kernels/terrain.cl), tuning knobs of the ``terrain`` family
        (:data:`TUNING`; None: the device's tuning entry, :func:`oclshade.tuning.settings`; the
        frames are the same for every value): ``descend``, the levels a split voxel descends at
        once (1 halves its footprint, like the paper's halving; OCLS_DESCEND); ``leaf``, the
        level at or below which a voxel that is not rejected is walked patch by patch (0 is the
        paper's finest level; dilated levels below it are not built; OCLS_LEAF); ``group``, the
        work-group size; ``own_builtins``, inline built-ins (kernels/common.h)."""
        if not isinstance(heightfield, Heightfield):
            raise TypeError(f"heightfield must be an oclshade.terrain.Heightfield, got {type(heightfield).__name__}")
        self.field = heightfield
        self.runtime = get_runtime(device)
        tuned = tuning.settings(self.runtime, "terrain").values
        given = {k: v for k, v in (("descend", descend), ("leaf", leaf), ("group", group),
                                   ("own_builtins", own_builtins)) if v is not None}
        knobs = {**tuned, **TUNING.check(given, partial=True)}
        self.descend = knobs["descend"]
        self._leaf = knobs["leaf"]
        self.group = knobs["group"]
        self.own_builtins = bool(knobs["own_builtins"])
        self._pyramid: ExtremaPyramid | None = None
        self._dilated: tuple[cl.Buffer, cl.Buffer] | None = None
        self._texture: tuple[cl.Buffer, cl.Buffer, int] | None = None

    @property
    def pyramid(self) -> ExtremaPyramid:
        if self._pyramid is None:
            self._pyramid = build_extrema_pyramid(self.field.heightmap, self.runtime)
        return self._pyramid

    @property
    def leaf(self) -> int:
        """The bisection's leaf level option (fixed: the dilated levels are built for it)."""
        return self._leaf

    @property
    def leaf_level(self) -> int:
        """The finest dilated level bisection reads: min(leaf, top level)."""
        return min(self.leaf, self.pyramid.levels - 1)

    @property
    def dilated(self) -> tuple[cl.Buffer, cl.Buffer]:
        """(float max texels of dilated levels :attr:`leaf_level`..L back to back, int2 (offset, cols)
        per level 0..L, offset 0 below leaf_level): texel (R, C) of level l bounds the surface over
        the level-l tiles (R..R+1, C..C+1), so bisection tests a voxel with one read
        (kernels/terrain.cl, terrain_dilate).  Derived from :attr:`pyramid` (level 0 from the
        heights) and cached with it."""
        if self._dilated is None:
            rt, pyr, lmin = self.runtime, self.pyramid, self.leaf_level
            shapes = [self.field.heightmap.patch_shape] + list(pyr.shapes)
            offs = level_offsets(shapes[lmin:])
            buf = rt.empty(4 * (int(offs[-1]) + shapes[-1][0] * shapes[-1][1]), "dilated max levels")
            rows, cols = self.field.heightmap.shape
            k = rt.kernel("terrain.cl", "terrain_dilate", TerrainFeatures().defines())
            for lev, (r, c), off in zip(range(lmin, len(shapes)), shapes[lmin:], offs):
                k.set_args(pyr.heights, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets, np.int32(lev),
                           np.int32(r), np.int32(c), buf, np.int32(off))
                cl.enqueue_nd_range_kernel(rt.queue, k, *rt.grid_2d(k, c, r))
            table = np.array([[0, c] for _, c in shapes[:lmin]] + [[o, c] for o, (_, c) in zip(offs, shapes[lmin:])],
                             np.int32)
            self._dilated = (buf, rt.to_device(table, "dilated levels (offset, cols)"))
        return self._dilated

    @property
    def texture(self) -> tuple[cl.Buffer, cl.Buffer, int]:
        """(float4 texels of all mip levels, int4 (offset, cols, rows, 0) per level, level count)."""
        if self._texture is None:
            rt = self.runtime
            if self.field.colour is None:
                self._texture = (rt.empty(16, "dummy texture"), rt.empty(16, "dummy levels"), 0)
            else:
                channels = [build_mip_levels(self.field.colour[..., k], rt) for k in range(4)]
                levels = [np.stack([ch[i] for ch in channels], -1) for i in range(len(channels[0]))]
                shapes = [lv.shape[:2] for lv in levels]
                offs = level_offsets(shapes)
                table = np.array([[o, c, r, 0] for o, (r, c) in zip(offs, shapes)], np.int32)
                texels = np.concatenate([lv.reshape(-1, 4) for lv in levels]).astype(np.float32)
                self._texture = (rt.to_device(texels, "colour mip pyramid"), rt.to_device(table, "mip levels"),
                                 len(levels))
        return self._texture

    def features(self, camera: Camera, method: str, stats: bool = False) -> TerrainFeatures:
        bisect = check_method(method) == "bisect"
        return TerrainFeatures(method, camera.projection == "orthographic",
                               self.field.radius is not None, self.field.colour is not None,
                               descend=self.descend if bisect else TerrainFeatures.descend,
                               leaf=self.leaf if bisect else TerrainFeatures.leaf, stats=stats,
                               own_builtins=self.own_builtins)

    def warm_up(self, camera: Camera, method: str = "bisect") -> None:
        self.pyramid, self.dilated, self.texture
        self.runtime.queue.finish()
        self.runtime.program("terrain.cl", self.features(camera, method).defines())

    def kernel_args(self, camera: Camera) -> tuple:
        """Arguments of ``terrain_cast`` up to (not including) the output buffers."""
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be an oclshade.camera.Camera, got {type(camera).__name__}")
        hm, pyr = self.field.heightmap, self.pyramid
        dil, dil_off = self.dilated
        rows, cols = hm.shape
        g = heightmap_from_world(hm, self.field.centre) @ np.linalg.inv(camera.view)
        sx, sy = camera.scale
        hmin, hmax = self.field.height_range
        cv, cu = self.field.centre
        tex, table, ntex = self.texture
        rot, geo = self._rotation_geo(camera)
        return (pyr.heights, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets, np.int32(pyr.levels),
                dil, dil_off,
                *(np.array(row, np.float32) for row in g[:3]), *rot,
                np.array([sx, sy, camera.near, camera.far], np.float32), np.int32(camera.width),
                np.int32(camera.height), np.int32(cu), np.int32(cv), geo,
                np.array([hmin, hmax, 0.0, 0.0], np.float32),
                tex, table, np.int32(ntex))

    def _rotation_geo(self, camera: Camera) -> tuple[list[np.ndarray], np.ndarray]:
        """The float4 rows r0, r1, r2 of the world -> view rotation and geo = (dx, dy, kx, ky)."""
        hm = self.field.heightmap
        rot = [np.array([*row, 0.0], np.float32) for row in camera.rotation]
        k = self.field.curvature
        return rot, np.array([hm.dx, hm.dy, k * hm.dx ** 2, k * hm.dy ** 2], np.float32)

    def _gbuffer(self, camera: Camera, out: DeviceGBuffer | None) -> DeviceGBuffer:
        """``out`` if it has the camera's shape, else new device buffers."""
        shape = (camera.height, camera.width)
        if out is not None and out.shape == shape:
            return out
        n = camera.width * camera.height
        return DeviceGBuffer(self.runtime, shape, {name: self.runtime.empty(4 * ch * n, f"G-buffer {name}")
                                                   for name, ch in CHANNELS.items()})

    def render(self, camera: Camera, method: str = "bisect", on_device: bool = False,
               out: DeviceGBuffer | None = None) -> GBuffer | DeviceGBuffer:
        """Cast one ray per pixel.  ``on_device``: return a :class:`DeviceGBuffer` (no copy back);
        ``out``: reuse its buffers (same shape) instead of allocating."""
        rt = self.runtime
        args = self.kernel_args(camera)
        kernel = rt.kernel("terrain.cl", "terrain_cast", self.features(camera, method).defines())
        out = self._gbuffer(camera, out)
        kernel.set_args(*args, *(out.buffers[name] for name in CHANNELS))
        cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, camera.width, camera.height, self.group))
        if on_device:
            return out
        return out.to_host()

    def shading_normals(self, camera: Camera, gbuffer: GBuffer | DeviceGBuffer, method: str = "bisect",
                        out: cl.Buffer | None = None) -> np.ndarray | cl.Buffer:
        """Smooth shading normals of a G-buffer this renderer made for ``camera``: view-space unit
        normals (w = 0, 0 on empty pixels) of slopes interpolated from the samples' central
        differences (kernels/terrain.cl, "Shading normals"), so a smooth terrain shades without
        per-cell facets; the G-buffer's own normal stays the geometric one.  A
        :class:`DeviceGBuffer` gives a ``cl.Buffer`` (``out`` if given), a :class:`GBuffer` a
        float32 (height, width, 4) array.  ``method``: the ray caster the program was built
        for (any works; the same one shares its build).  Twin:
        :func:`oclshade.reference.terrain.shading_normals`."""
        rt = self.runtime
        if isinstance(gbuffer, DeviceGBuffer):
            uv, pos = gbuffer.buffers["uv"], gbuffer.buffers["position"]
        elif isinstance(gbuffer, GBuffer):
            uv, pos = rt.to_device(gbuffer.uv, "G-buffer uv"), rt.to_device(gbuffer.position, "G-buffer position")
        else:
            raise TypeError(f"gbuffer must be a GBuffer or DeviceGBuffer, got {type(gbuffer).__name__}")
        if gbuffer.shape != (camera.height, camera.width):
            raise ValueError(f"camera is {camera.height}x{camera.width} pixels but the G-buffer is "
                             f"{gbuffer.shape[0]}x{gbuffer.shape[1]}")
        rows, cols = self.field.heightmap.shape
        cv, cu = self.field.centre
        rot, geo = self._rotation_geo(camera)
        n = camera.width * camera.height
        buf = out if out is not None else rt.empty(16 * n, "shading normals")
        kernel = rt.kernel("terrain.cl", "terrain_normals", self.features(camera, method).defines())
        kernel.set_args(self.pyramid.heights, np.int32(rows), np.int32(cols), uv, pos, *rot, geo, np.int32(cu),
                        np.int32(cv), np.int32(n), buf)
        local = rt.local_size(kernel, 64)
        cl.enqueue_nd_range_kernel(rt.queue, kernel, (-(-n // local) * local,), (local,))
        if isinstance(gbuffer, DeviceGBuffer):
            return buf
        host = np.empty(gbuffer.shape + (4,), np.float32)
        cl.enqueue_copy(rt.queue, host, buf)
        rt.queue.finish()
        return host


    def step_counts(self, camera: Camera, method: str = "bisect", band_pixels: int = 1 << 18,
                    out: DeviceGBuffer | None = None) -> dict[str, object]:
        """Traversal counters of one frame summed over its pixels (a profiling build, -D OCLS_STATS):
        ``levels``, int64 per pyramid level (bisect voxel tests, dda texel visits, march samples at
        that level); ``patches`` (exact patch tests); ``rays`` (pixels with a non-empty segment);
        ``hits``.  Bands of at most ``band_pixels`` pixels keep the uint32 counters from wrapping
        (Runtime.count_in_bands).  ``out``: where the frame itself goes (default: scratch buffers)."""
        rt = self.runtime
        kernel = rt.kernel("terrain.cl", "terrain_cast", self.features(camera, method, stats=True).defines())
        out = self._gbuffer(camera, out)
        total = rt.count_in_bands(kernel, (*self.kernel_args(camera), *(out.buffers[name] for name in CHANNELS)),
                                  _STATS_N, camera.width, camera.height, band_pixels)
        return {"levels": total[:self.pyramid.levels], "patches": int(total[_ST_PATCH]),
                "rays": int(total[_ST_PATCH + 1]), "hits": int(total[_ST_PATCH + 2])}


def render_terrain(heights: object, camera: Camera, cellsize: float | tuple[float, float] = 1.0, *,
                   method: str = "bisect", z_factor: float = 1.0, nodata: float | None = None,
                   radius: float | None = None, colour: object | None = None,
                   device: str | int | Runtime | None = None) -> GBuffer:
    """One-call API: the G-buffer of a 2-D height array seen by ``camera``."""
    field = Heightfield.from_array(heights, cellsize, z_factor, nodata, radius, colour)
    return TerrainRenderer(field, device).render(camera, method)


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    from .camera import frame_heightmap
    field = Heightfield(tuning.standard_heightmap(48))
    renderer = TerrainRenderer(field, rt, **knobs)
    renderer.render(frame_heightmap(field.heightmap, 40, 30, 200.0, 30.0))


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    from .camera import frame_heightmap
    field = Heightfield(tuning.standard_heightmap(512 if quick else 1024))
    renderer = TerrainRenderer(field, rt, **knobs)
    camera = frame_heightmap(field.heightmap, *((640, 360) if quick else (1920, 1080)), 200.0, 25.0)
    return lambda: renderer.render(camera, on_device=True)


#: the terrain caster's knobs (kernels/terrain.cl, bisect)
TUNING = tuning.register(tuning.Family(
    "terrain",
    (tuning.Param("descend", (1, 2, 3, 4, 5), 3, "levels a split voxel descends at once (-D OCLS_DESCEND)"),
     tuning.Param("leaf", (0, 1, 2, 3, 4), 2, "level at or below which voxels are walked patch by patch (-D OCLS_LEAF)"),
     tuning.Param("group", (16, 64, 256), 64, "work-group size (work-items)"),
     tuning.OWN_BUILTINS_WHERE_CALLED),
    ("terrain.cl",), _smoke, _workload, "terrain ray casting (paper 004)"))
