"""Mean mip pyramid and extrema (max/min) pyramid, built on the device.

Layouts are documented in ``kernels/pyramid.cl``.  An :class:`ExtremaPyramid`
stays resident on the device and is shared by every sun and every pass over
the same heightmap.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np
import pyopencl as cl

from . import cache, tuning
from .heightmap import Heightmap
from .runtime import Runtime, get_runtime

if TYPE_CHECKING:
    from .pyramid_images import PyramidImages


def level_shapes(rows: int, cols: int) -> list[tuple[int, int]]:
    """Shapes of levels 0.. down to 1 x 1: each ceil(half) of the one below."""
    shapes = [(rows, cols)]
    while shapes[-1] != (1, 1):
        r, c = shapes[-1]
        shapes.append(((r + 1) // 2, (c + 1) // 2))
    return shapes


def level_offsets(shapes: list[tuple[int, int]]) -> np.ndarray:
    sizes = [r * c for r, c in shapes]
    return np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int32)


@dataclass
class ExtremaPyramid:
    """Device-resident extrema pyramid (float2 max/min per texel, all levels)."""

    runtime: Runtime
    heights: cl.Buffer            # the relative float32 heights it was built from
    buffer: cl.Buffer             # float2 texels, levels back to back
    offsets: cl.Buffer            # int32 level offsets
    shapes: list[tuple[int, int]]  # stored levels 1..L
    map_shape: tuple[int, int]
    _images: PyramidImages | None | bool = field(default=None, repr=False, compare=False)
    #: the process-wide cache's key when the pyramid is stored there (:func:`cached_pyramid`)
    _cache_key: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def nbytes(self) -> int:
        """Device memory it holds: heights, levels, offsets and, once built, its images."""
        images = self._images.nbytes if self._images else 0
        return self.heights.size + self.buffer.size + self.offsets.size + images

    def images(self) -> PyramidImages | None:
        """The heights and levels as device images (built on first use, then kept with the
        pyramid and counted in the cache's size); None where the device cannot hold them
        (:mod:`oclshade.pyramid_images`)."""
        if self._images is None:
            from .pyramid_images import build_pyramid_images
            self._images = build_pyramid_images(self) or False
            if self._images and self._cache_key is not None:
                cache.PYRAMIDS.put(self._cache_key, self, self.nbytes)
        return self._images or None

    @property
    def levels(self) -> int:
        """Number of levels counting level 0 (the heightmap itself)."""
        return len(self.shapes) + 1

    def to_numpy(self) -> list[np.ndarray]:
        """Stored levels 1..L as (rows, cols, 2) float32 arrays [..., 0] = max, [..., 1] = min."""
        offs = level_offsets(self.shapes)
        total = int(offs[-1]) + self.shapes[-1][0] * self.shapes[-1][1]
        flat = np.empty((total, 2), np.float32)
        cl.enqueue_copy(self.runtime.queue, flat, self.buffer)
        return [flat[o:o + r * c].reshape(r, c, 2) for o, (r, c) in zip(offs, self.shapes)]


def _run_2d(rt: Runtime, kernel: cl.Kernel, cols: int, rows: int, args: tuple) -> None:
    kernel.set_args(*args)
    cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, cols, rows, wanted=256, max_x=64))


def extrema_shapes(patch_rows: int, patch_cols: int) -> list[tuple[int, int]]:
    """Shapes of the stored extrema levels 1..L (level 0 is the heightmap itself)."""
    shapes = level_shapes(patch_rows, patch_cols)
    return shapes[1:] if len(shapes) > 1 else [(1, 1)]


def build_extrema_pyramid(hm: Heightmap, device=None, knobs: Mapping[str, int] | None = None) -> ExtremaPyramid:
    """The extrema pyramid of a heightmap on the device.  ``knobs``: tuning values of the
    ``pyramid`` family (:data:`TUNING`) to use instead of the device's (same texels)."""
    rt = get_runtime(device)
    knob = TUNING.check(knobs) if knobs is not None else tuning.settings(rt, "pyramid").values
    rows, cols = hm.shape
    heights_buffer = rt.share(hm.relative32, "heightmap", bool(knob["in_place"]))
    hp, wp = hm.patch_shape
    shapes = extrema_shapes(hp, wp)
    offs = level_offsets(shapes)
    total = int(offs[-1]) + 1  # the last level is 1 x 1
    buf = rt.empty(total * 8, "extrema pyramid")
    r1, c1 = shapes[0]
    lanes = knob["base_lanes"]                                   # -D OCLS_BASE_LANES (kernels/pyramid.cl)
    own = bool(knob["own_builtins"])
    base = rt.kernel("pyramid.cl", "extrema_base", {"OCLS_BASE_LANES": lanes if lanes > 1 else None,
                                                     "OCLS_OWN_BUILTINS": own})
    _run_2d(rt, base, -(-c1 // lanes), r1,
            (heights_buffer, np.int32(rows), np.int32(cols), buf, np.int32(hp), np.int32(wp),
             np.int32(r1), np.int32(c1)))
    reduce_k = rt.kernel("pyramid.cl", "extrema_reduce", {"OCLS_OWN_BUILTINS": own})
    for (ri, ci), (ro, co), oi, oo in zip(shapes[:-1], shapes[1:], offs[:-1], offs[1:]):
        _run_2d(rt, reduce_k, co, ro, (buf, np.int32(oi), np.int32(ri), np.int32(ci),
                                       np.int32(oo), np.int32(ro), np.int32(co)))
    kernel_offsets = np.concatenate([[-1], offs]).astype(np.int32)  # indexed by level, [0] unused
    return ExtremaPyramid(rt, heights_buffer, buf, rt.to_device(kernel_offsets, "level offsets"), shapes, hm.shape)


def cached_pyramid(heightmap: Heightmap, runtime: Runtime, use_cache: bool | None = None) -> ExtremaPyramid:
    """The pyramid of ``heightmap`` on ``runtime``: from the process-wide cache
    (:mod:`oclshade.cache`; ``use_cache`` None follows :func:`oclshade.cache.enabled`) when it
    is there, else built (and stored there when caching, counted by
    :attr:`ExtremaPyramid.nbytes`)."""
    caching = cache.enabled() if use_cache is None else bool(use_cache)
    key = (cache.heights_digest(heightmap), id(runtime)) if caching else None
    pyr = cache.PYRAMIDS.get(key) if key else None
    if pyr is None:
        pyr = build_extrema_pyramid(heightmap, runtime)
        if key:
            pyr._cache_key = key
            cache.PYRAMIDS.put(key, pyr, pyr.nbytes)
    return pyr


def build_mip_pyramid(hm: Heightmap, device=None) -> list[np.ndarray]:
    """Mean mip pyramid of the relative float32 heights (level 0 = the map), as numpy arrays."""
    return build_mip_levels(hm.relative32, device)


def build_mip_levels(values: np.ndarray, device=None) -> list[np.ndarray]:
    """Mean mip pyramid of any 2-D float32 array (NaN = no data), level 0 = the array itself.

    Multi-channel data (a colour texture) goes through channel by channel."""
    rt = get_runtime(device)
    values = np.ascontiguousarray(values, dtype=np.float32)
    if values.ndim != 2 or values.size == 0:
        raise ValueError(f"values must be a non-empty 2-D array, got shape {values.shape}")
    reduce_k = rt.kernel("pyramid.cl", "mip_reduce")
    shapes = level_shapes(*values.shape)
    bufs = [rt.to_device(values, "mip level 0")]
    for (ri, ci), (ro, co) in zip(shapes[:-1], shapes[1:]):
        out = rt.empty(ro * co * 4, "mip level")
        _run_2d(rt, reduce_k, co, ro, (bufs[-1], np.int32(ri), np.int32(ci), out, np.int32(ro), np.int32(co)))
        bufs.append(out)
    levels = []
    for buf, (r, c) in zip(bufs, shapes):
        a = np.empty((r, c), np.float32)
        cl.enqueue_copy(rt.queue, a, buf)
        levels.append(a)
    return levels


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    heights = tuning.standard_heightmap(67).heights[:, :61]
    build_extrema_pyramid(Heightmap.from_array(heights, cellsize=30.0), rt, knobs).to_numpy()


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    hm = tuning.standard_heightmap(1024 if quick else 4096)

    return lambda: build_extrema_pyramid(hm, rt, knobs)


#: the pyramid's knobs (kernels/pyramid.cl): texels per work-item of the base level, and
#: whether the kernels read the heights in place (host memory) or from a device copy
TUNING = tuning.register(tuning.Family(
    "pyramid",
    (tuning.Param("base_lanes", (1, 4, 8, 16), 1, "level-1 texels per work-item (-D OCLS_BASE_LANES)", vector=True,
                  rule="width"),
     tuning.OWN_BUILTINS_WHERE_CALLED,
     tuning.Param("in_place", (0, 1), 0, "read the heights in place from host memory (CL_MEM_USE_HOST_PTR)",
                  rule="host_memory")),
    ("pyramid.cl",), _smoke, _workload, "extrema pyramid build (paper 000)"))
