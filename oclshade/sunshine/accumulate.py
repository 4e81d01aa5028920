"""Sunshine over time, accumulated on the device (kernels/sunshine.cl).

>>> caster = SunshineCaster(Heightmap.from_array(dem, cellsize=30.0))
>>> maps = caster.accumulate(suns, seconds=600, outputs=("hours", "fraction"))
>>> maps.hours                  # float32 hours of direct sun per cell, NaN = nodata

Per daylight sun (elevation > 0; the others are skipped) the exact cast-shadow
mask is traced into a device buffer (:meth:`ShadowCaster.masks_on_device`)
and ``sunshine_masks`` adds the sun's contribution to per-cell sums on the
device: no mask crosses to the host, and memory does not grow with the suns.
Definitions (direct sun, cast shadow, incidence) in kernels/sunshine.cl and
docs/solar.md; float64 twin :func:`oclshade.reference.sunshine`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

import numpy as np
import pyopencl as cl

from ..heightmap import Heightmap
from ..runtime import Runtime
from ..shadows import ShadowCaster, check_outputs
from ..sun import Sun, SunLike, as_suns

OUTPUTS = ("hours", "fraction", "irradiation")
MAX_SECONDS = 2**32 - 1     # the per-cell sums are uint32 seconds
_SUMS = {"hours": ("sun", 4, "OCLS_OUT_SUN"), "fraction": ("cast", 4, "OCLS_OUT_CAST"),
         "irradiation": ("beam", 8, "OCLS_OUT_BEAM")}


@dataclass
class SunshineMaps:
    """Per-cell results over the daylight suns; an output not requested is None."""

    hours: np.ndarray | None = None        # float32 hours of direct sun; NaN = nodata
    fraction: np.ndarray | None = None     # float32 share of the daylight time in cast shadow; NaN = nodata,
                                           # and everywhere when there was no daylight
    irradiation: np.ndarray | None = None  # float32 sum of cos(incidence) x hours over the direct-sun steps
                                           # (Wh/m^2 per W/m^2 of direct-normal irradiance); NaN = nodata
    daylight_seconds: int = 0              # total length of the daylight steps
    daylight_suns: int = 0                 # how many steps had the sun above the horizon


def daylight(suns: Iterable[SunLike], seconds: int | Sequence[int] | np.ndarray) -> tuple[list[Sun], np.ndarray]:
    """The suns above the horizon (elevation > 0) and their weights in seconds (int64), checked:
    ``seconds`` is one whole positive number for every sun or one per sun, and the daylight
    total fits the uint32 sums (:data:`MAX_SECONDS`)."""
    sun_list = as_suns(suns)
    weights = np.broadcast_to(np.asarray(seconds), (len(sun_list),)) if np.ndim(seconds) == 0 else np.asarray(seconds)
    if weights.shape != (len(sun_list),):
        raise ValueError(f"seconds must be one number or one per sun ({len(sun_list)}), got {weights.shape[0]}")
    if weights.dtype.kind not in "iu" or np.any(weights < 1):
        raise ValueError(f"seconds must be whole numbers >= 1, got {seconds!r}")
    keep = [k for k, sun in enumerate(sun_list) if sun.elevation > 0.0]
    weights = weights[keep].astype(np.int64)
    if int(weights.sum()) > MAX_SECONDS:
        raise ValueError(f"the daylight steps add up to {int(weights.sum())} s; at most {MAX_SECONDS} s "
                         f"(136 years) fit the per-cell sums: split the period")
    return [sun_list[k] for k in keep], weights


class SunshineCaster:
    """Sunshine sums of one heightmap; the extrema pyramid is built once for all suns.

    analyse, certificates: as :class:`oclshade.shadows.ShadowCaster` (same results either way).
    """

    def __init__(self, heightmap: Heightmap, device: str | int | Runtime | None = None, *,
                 analyse: bool = True, certificates: bool = True):
        self.heightmap = heightmap
        self.shadows = ShadowCaster(heightmap, device, cache=False, analyse=analyse, certificates=certificates)
        self.runtime = self.shadows.runtime

    def accumulate(self, suns: Iterable[SunLike], seconds: int | Sequence[int] | np.ndarray,
                   outputs: str | Sequence[str] = ("hours",),
                   progress: Callable[[int, int], None] | None = None) -> SunshineMaps:
        """Sums over the suns weighted by ``seconds`` (one number for all, or one per sun) of
        direct sun, cast shadow and beam incidence, by exact cast-shadow masks.
        ``outputs``: any of :data:`OUTPUTS` (or 'all').  ``progress(done, total)`` after each
        daylight sun is complete on the device."""
        outs = check_outputs(outputs, OUTPUTS)
        day, weights = daylight(suns, seconds)
        sums = self._sums(outs)
        kernel = self._kernel("sunshine_masks", outs)
        rt, hm = self.runtime, self.heightmap
        rows, cols = hm.shape
        heights = self.shadows.pyramid.heights
        gsize, lsize = rt.grid_2d(kernel, cols, rows)
        for k, (sun, mask) in enumerate(self.shadows.masks_on_device(day) if day else ()):
            kernel.set_args(heights, np.int32(rows), np.int32(cols), np.array([hm.dx, hm.dy], np.float32), mask,
                            *_sun_args(sun, int(weights[k])), *sums.values())
            cl.enqueue_nd_range_kernel(rt.queue, kernel, gsize, lsize)
            if progress is not None:
                rt.queue.finish()
                progress(k + 1, len(day))
        return self._maps(outs, sums, int(weights.sum()), len(day))

    def _kernel(self, name: str, outs: tuple[str, ...]) -> cl.Kernel:
        return self.runtime.kernel("sunshine.cl", name, {_SUMS[out][2]: True for out in outs})

    def _sums(self, outs: tuple[str, ...]) -> dict[str, cl.Buffer]:
        """The per-cell sums of the outputs, zeroed on the device, in kernel argument order
        (a 1-byte dummy for each sum not asked for)."""
        rt = self.runtime
        n = self.heightmap.shape[0] * self.heightmap.shape[1]
        sums = {}
        for out, (name, size, _) in _SUMS.items():
            if out in outs:
                sums[name] = rt.empty(size * n, f"sunshine {name} sums")
                cl.enqueue_fill_buffer(rt.queue, sums[name], np.uint8(0), 0, size * n)
            else:
                sums[name] = rt.empty(1, "dummy")
        return sums

    def _maps(self, outs: tuple[str, ...], sums: dict[str, cl.Buffer], total: int, count: int) -> SunshineMaps:
        """The sums read back and turned into the outputs (float64 arithmetic, float32 results)."""
        rows, cols = self.heightmap.shape
        nodata = np.isnan(self.heightmap.heights)
        maps = SunshineMaps(daylight_seconds=total, daylight_suns=count)

        def read(name: str, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
            out = np.empty(shape, dtype)
            cl.enqueue_copy(self.runtime.queue, out, sums[name])   # blocking: after every sun's kernel
            return out

        if "hours" in outs:
            maps.hours = _finish(read("sun", np.uint32, (rows, cols)) / 3600.0, nodata)
        if "fraction" in outs:
            cast = read("cast", np.uint32, (rows, cols)).astype(np.float64)
            maps.fraction = _finish(cast / total if total else np.full((rows, cols), np.nan), nodata)
        if "irradiation" in outs:
            beam = read("beam", np.float32, (rows, cols, 2)).astype(np.float64)
            maps.irradiation = _finish(beam[..., 0] - beam[..., 1], nodata)   # the sum less its compensation
        return maps


def _sun_args(sun: Sun, weight: int) -> tuple:
    """sunshine.cl's (sunvec, weight, hours) of one sun."""
    s = sun.vector()
    return np.array([s[0], s[1], s[2], 0.0], np.float32), np.uint32(weight), np.float32(weight / 3600.0)


def _finish(values: np.ndarray, nodata: np.ndarray) -> np.ndarray:
    return np.where(nodata, np.nan, values).astype(np.float32)
