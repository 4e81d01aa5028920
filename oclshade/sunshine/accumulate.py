"""Sunshine over time, accumulated on the device (kernels/sunshine.cl).

>>> caster = SunshineCaster(Heightmap.from_array(dem, cellsize=30.0))
>>> maps = caster.accumulate(suns, seconds=600, outputs=("hours", "fraction"))
>>> maps.hours                  # float32 hours of direct sun per cell, NaN = nodata

Per daylight sun (elevation > 0; the others are skipped) the exact cast-shadow
mask is traced into a device buffer (:meth:`ShadowCaster.masks_on_device`)
and ``sunshine_masks`` adds the sun's contribution to per-cell sums on the
device: no mask crosses to the host, and memory does not grow with the suns.
The horizon route (``method="horizons"``) compares each sun instead with the
horizon angles (:class:`oclshade.horizon.HorizonCaster`, left on the device)
interpolated between the grid azimuths around it (``sunshine_horizons``).
Definitions (direct sun, cast shadow, incidence) in kernels/sunshine.cl and
docs/solar.md; float64 twin :func:`oclshade.reference.sunshine_sums`.

A step's sun may be a :class:`oclshade.sun.SunField` (each cell's own sun to a tolerance,
:func:`oclshade.solar.sun_field`): each of its blocks whose sun is up adds its cells' share
with its own sun, one launch per block (of exactly its cells: the sums are not idempotent, so
no launch may round up past its block), and a cell's daylight time, the denominator of its
``fraction``, is the sum over the steps whose block sun was up there.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np
import pyopencl as cl

from ..heightmap import Heightmap
from ..horizon import HorizonCaster, azimuth_grid
from ..runtime import ArgBinder, Runtime
from ..shadows import ShadowCaster, check_outputs
from ..sun import Sun, SunBlock, SunField, SunLike, Traced, as_traced

OUTPUTS = ("hours", "fraction", "irradiation")
METHODS = ("masks", "horizons")
DEFAULT_AZIMUTHS = 64
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
    daylight_seconds: int = 0              # total length of the daylight steps (a sun field's: where its sun
                                           # is up somewhere on the map)
    daylight_suns: int = 0                 # how many steps had the sun above the horizon (somewhere)


@dataclass(frozen=True)
class _Unit:
    """One launch's share of a step: the step's index, its sun, and the block (None: the map)."""

    step: int
    sun: Sun
    block: SunBlock | None = None


def _units(steps: list[Traced]) -> list[_Unit]:
    """The daylight launches of the steps, in step order: a sun above the horizon, or each block
    of a field whose sun is."""
    out = []
    for k, step in enumerate(steps):
        if isinstance(step, SunField):
            out += [_Unit(k, b.sun, b) for b in step.blocks if b.sun.elevation > 0.0]
        elif step.elevation > 0.0:
            out.append(_Unit(k, step))
    return out


def daylight(suns: Iterable[SunLike | SunField], seconds: int | Sequence[int] | np.ndarray
             ) -> tuple[list[Traced], np.ndarray]:
    """The suns above the horizon (elevation > 0; a sun field: above it on some block) and their
    weights in seconds (int64), checked: ``seconds`` is one whole positive number for every sun
    or one per sun, and the daylight total fits the uint32 sums (:data:`MAX_SECONDS`)."""
    sun_list = as_traced(suns)
    weights = np.broadcast_to(np.asarray(seconds), (len(sun_list),)) if np.ndim(seconds) == 0 else np.asarray(seconds)
    if weights.shape != (len(sun_list),):
        raise ValueError(f"seconds must be one number or one per sun ({len(sun_list)}), got {weights.shape[0]}")
    if weights.dtype.kind not in "iu" or np.any(weights < 1):
        raise ValueError(f"seconds must be whole numbers >= 1, got {seconds!r}")
    keep = sorted({unit.step for unit in _units(sun_list)})
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

    def accumulate(self, suns: Iterable[SunLike | SunField], seconds: int | Sequence[int] | np.ndarray,
                   outputs: str | Sequence[str] = ("hours",), method: str = "masks",
                   azimuths: int = DEFAULT_AZIMUTHS,
                   progress: Callable[[int, int], None] | None = None) -> SunshineMaps:
        """Sums over the suns weighted by ``seconds`` (one number for all, or one per sun) of
        direct sun, cast shadow and beam incidence.  ``outputs``: any of :data:`OUTPUTS` (or
        'all').  ``method``: ``masks`` (an exact cast-shadow mask per sun) or ``horizons``
        (horizon angles at ``azimuths`` equally spaced azimuths, computed once, interpolated
        linearly at each sun's azimuth: approximate, docs/solar.md).  A sun may be a
        :class:`oclshade.sun.SunField` (see the module docstring).  ``progress(done, total)``
        after each daylight sun (each block of a field) is complete on the device."""
        outs = check_outputs(outputs, OUTPUTS)
        if method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
        if method == "horizons":
            azimuth_grid(azimuths)   # checks the count
        day, weights = daylight(suns, seconds)
        for k, step in enumerate(day):
            if isinstance(step, SunField):
                step.check_shape(self.heightmap.shape)
                if step.uniform:
                    day[k] = step.blocks[0].sun
        units = _units(day)
        sums = self._sums(outs)
        launches = self._by_masks(day, units, outs) if method == "masks" else \
            self._by_horizons(units, outs, azimuths)
        rt = self.runtime
        rows, cols = self.heightmap.shape
        bind = None
        last = {unit.step: k for k, unit in enumerate(units)}     # a step's last unit (as listed)
        finals = {id(units[k]) for k in last.values()}
        vectors = _sun_vectors(units)
        row = {id(unit): k for k, unit in enumerate(units)}
        # one pair of objects per step, so that the binder sees them unchanged across a field's blocks
        step_weights = {step: (np.uint32(int(weights[step])), np.float32(int(weights[step]) / 3600.0))
                        for step in last}
        for done, (unit, kernel, args) in enumerate(launches if units else (), 1):
            bind = bind or ArgBinder(kernel)                       # one kernel per call
            bind(*args, vectors[row[id(unit)]], *step_weights[unit.step], *sums.values())
            if unit.block is None:
                cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, cols, rows))
            else:   # exactly the block's cells
                b = unit.block
                cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.exact_grid_2d(kernel, b.col1 - b.col0, b.row1 - b.row0),
                                           global_work_offset=(b.col0, b.row0))
            if progress is not None and (id(unit) in finals or done == len(units)):
                rt.queue.finish()          # once a step (a field's last block), not every block
                progress(done, len(units))
        return self._maps(outs, sums, int(weights.sum()), len(day), _daylight_map(units, weights, self.heightmap.shape))

    def _grid_args(self, heights: cl.Buffer) -> tuple:
        hm = self.heightmap
        return heights, np.int32(hm.shape[0]), np.int32(hm.shape[1]), np.array([hm.dx, hm.dy], np.float32)

    def _by_masks(self, day: list[Traced], units: list[_Unit], outs: tuple[str, ...]
                  ) -> Iterator[tuple[_Unit, cl.Kernel, tuple]]:
        """(unit, kernel, arguments before the sun's) per unit: each step's exact mask (per
        block for a field), traced into the device buffer that ``sunshine_masks`` reads next."""
        kernel = self._kernel("sunshine_masks", outs)
        grid = self._grid_args(self.shadows.pyramid.heights)
        by_step: dict[int, list[_Unit]] = {}
        for unit in units:
            by_step.setdefault(unit.step, []).append(unit)
        for k, (_, mask) in enumerate(self.shadows.masks_on_device(day)):
            for unit in by_step.get(k, ()):
                yield unit, kernel, (*grid, mask)

    def _by_horizons(self, units: list[_Unit], outs: tuple[str, ...], n: int
                     ) -> Iterator[tuple[_Unit, cl.Kernel, tuple]]:
        """As :meth:`_by_masks` by horizons: the units in order of azimuth, each between the
        horizon bands of the grid azimuths around its sun.  Only the bands next to some sun are
        computed, each once, and at most three are kept (where the horizon caster batches
        azimuths, its knob ``batch``, a batch's bands share one device buffer until the last of
        them is dropped)."""
        horizons = HorizonCaster(self.heightmap, self.runtime)
        kernel = self._kernel("sunshine_horizons", outs)
        grid = self._grid_args(horizons.pyramid.heights)
        day = [unit.sun for unit in units]
        position = np.array([sun.azimuth % 360.0 for sun in day]) * n / 360.0
        interval = np.minimum(np.floor(position).astype(np.int64), n - 1)
        pending = sorted(set(interval.tolist()))                  # intervals with suns, in azimuth order
        needed = sorted(set(pending) | {(i + 1) % n for i in pending})
        bands: dict[int, cl.Buffer] = {}
        for k, (_, buf) in zip(needed, horizons.angles_on_device(azimuth_grid(n)[needed])):
            bands[k] = buf
            while pending and pending[0] in bands and (pending[0] + 1) % n in bands:
                i = pending.pop(0)
                low, high = bands[i], bands[(i + 1) % n]
                for s in np.flatnonzero(interval == i):
                    frac = np.float32(position[s] - i)
                    yield units[s], kernel, (*grid, low, high, frac, np.float32(day[s].elevation))
                keep = set(pending) | {(j + 1) % n for j in pending}
                bands = {j: b for j, b in bands.items() if j in keep}

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

    def _maps(self, outs: tuple[str, ...], sums: dict[str, cl.Buffer], total: int, count: int,
              daylight_map: np.ndarray | None) -> SunshineMaps:
        """The sums read back and turned into the outputs (float64 arithmetic, float32 results);
        ``daylight_map``: each cell's daylight seconds where they differ over the map (fields),
        else None (``total`` everywhere)."""
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
            if daylight_map is not None:
                with np.errstate(invalid="ignore", divide="ignore"):
                    maps.fraction = _finish(np.where(daylight_map > 0, cast / daylight_map, np.nan), nodata)
            else:
                maps.fraction = _finish(cast / total if total else np.full((rows, cols), np.nan), nodata)
        if "irradiation" in outs:
            beam = read("beam", np.float32, (rows, cols, 2)).astype(np.float64)
            maps.irradiation = _finish(beam[..., 0] - beam[..., 1], nodata)   # the sum less its compensation
        return maps


def _sun_vectors(units: list[_Unit]) -> np.ndarray:
    """sunshine.cl's sunvec of each unit's sun, float32 (units, 4): (east, north, up, 0)."""
    return np.array([(*unit.sun.vector(), 0.0) for unit in units], np.float32).reshape(len(units), 4)


def _daylight_map(units: list[_Unit], weights: np.ndarray, shape: tuple[int, int]) -> np.ndarray | None:
    """Each cell's daylight seconds (int64) when some step's sun is up on part of the map only
    (a field's blocks), by a 2-D difference array: O(1) per block; else None."""
    if all(unit.block is None for unit in units):
        return None
    rows, cols = shape
    diff = np.zeros((rows + 1, cols + 1), np.int64)
    for unit in units:
        w = int(weights[unit.step])
        r0, r1, c0, c1 = (0, rows, 0, cols) if unit.block is None else \
            (unit.block.row0, unit.block.row1, unit.block.col0, unit.block.col1)
        diff[r0, c0] += w
        diff[r0, c1] -= w
        diff[r1, c0] -= w
        diff[r1, c1] += w
    return np.cumsum(np.cumsum(diff, axis=0), axis=1)[:rows, :cols]


def _finish(values: np.ndarray, nodata: np.ndarray) -> np.ndarray:
    return np.where(nodata, np.nan, values).astype(np.float32)
