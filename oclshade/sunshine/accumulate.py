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
with its own sun, read from the step's sun table in one launch over the map (-D
OCLS_SUN_TABLE; the horizon route: one launch per interval of grid azimuths holding some
block's sun), and a cell's daylight time, the denominator of its ``fraction``, is the sum over
the steps whose block sun was up there.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, Sequence

import numpy as np
import pyopencl as cl

from ..heightmap import Heightmap
from ..horizon import HorizonCaster, azimuth_grid
from ..runtime import ArgBinder, Runtime
from ..shadows import ShadowCaster, check_outputs
from ..solar.field import on_heightmap
from ..sun import Sun, SunField, SunLike, Traced, as_traced, true_directions

OUTPUTS = ("hours", "fraction", "irradiation")
METHODS = ("masks", "horizons")
DEFAULT_AZIMUTHS = 64
MAX_SECONDS = 2**32 - 1     # the per-cell sums are uint32 seconds
# sun fields' steps enqueued ahead of the device at most: each holds its tables (about 0.4 MB a
# step on a 1-degree SRTM tile) until it has run; unbounded, a month of them held 1 GB
TABLES_IN_FLIGHT = 8
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
class _Launch:
    """One launch of a daylight step: the step's index, the kernel, its arguments up to the sun
    vector, and after the sums the sun table's (band, suns, keys, key), () for one sun."""

    step: int
    kernel: cl.Kernel
    head: tuple
    table: tuple = ()


def _has_daylight(step: Traced) -> bool:
    """A sun above the horizon, or a field with a block whose sun is."""
    if isinstance(step, SunField):
        return bool(np.any(step.angles[1] > 0.0))
    return step.elevation > 0.0


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
    keep = [k for k, step in enumerate(sun_list) if _has_daylight(step)]
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
        :class:`oclshade.sun.SunField` (see the module docstring); on a heightmap with
        :attr:`~oclshade.heightmap.Heightmap.row_scales` a sun given by its angles is traced per
        band of rows (:func:`oclshade.solar.field.on_heightmap`).  ``progress(done, total)``
        after each launch is complete on the device: one per daylight step (the horizon route:
        per step and interval of grid azimuths holding its sun)."""
        outs = check_outputs(outputs, OUTPUTS)
        if method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
        if method == "horizons":
            azimuth_grid(azimuths)   # checks the count
        day, weights = daylight(suns, seconds)
        day = [on_heightmap(self.heightmap, step) for step in day]
        for k, step in enumerate(day):
            if isinstance(step, SunField):
                step.check_shape(self.heightmap.shape)
                if step.plain is not None:     # (one block of a scaled grid stays a field: its beam's scale)
                    day[k] = step.plain
        sums = self._sums(outs)
        total, launches = (0, iter(())) if not day else \
            self._by_masks(day, outs) if method == "masks" else self._by_horizons(day, outs, azimuths)
        rt = self.runtime
        rows, cols = self.heightmap.shape
        binders: dict[cl.Kernel, ArgBinder] = {}
        # one pair of objects per step, so that the binder sees them unchanged across its launches
        step_weights = [(np.uint32(int(w)), np.float32(int(w) / 3600.0)) for w in weights]
        in_flight: deque[cl.Event] = deque()    # launches with sun tables not yet waited for
        for done, launch in enumerate(launches, 1):
            bind = binders.setdefault(launch.kernel, ArgBinder(launch.kernel))
            bind(*launch.head, *step_weights[launch.step], *sums.values(), *launch.table)
            event = cl.enqueue_nd_range_kernel(rt.queue, launch.kernel, *rt.grid_2d(launch.kernel, cols, rows))
            if launch.table:
                in_flight.append(event)
                if len(in_flight) > TABLES_IN_FLIGHT:
                    in_flight.popleft().wait()
            if progress is not None:
                rt.queue.finish()
                progress(done, total)
        return self._maps(outs, sums, int(weights.sum()), len(day), _daylight_map(day, weights, self.heightmap.shape))

    def _grid_args(self, heights: cl.Buffer) -> tuple:
        hm = self.heightmap
        return heights, np.int32(hm.shape[0]), np.int32(hm.shape[1]), np.array([hm.dx, hm.dy], np.float32)

    def _by_masks(self, day: list[Traced], outs: tuple[str, ...]) -> tuple[int, Iterator[_Launch]]:
        """How many launches, and the launches: one per step, reading the step's exact mask (a
        field's: traced with its sun table), which :meth:`ShadowCaster.masks_on_device` leaves in
        its one device buffer just before (the queue is in order: each launch must be enqueued
        before the next is made)."""
        return len(day), self._mask_launches(day, outs)

    def _mask_launches(self, day: list[Traced], outs: tuple[str, ...]) -> Iterator[_Launch]:
        kernels = {table: self._kernel("sunshine_masks", outs, table) for table in (False, True)}
        grid = self._grid_args(self.shadows.pyramid.heights)
        no_sun = np.zeros(4, np.float32)
        for k, (step, (_, mask)) in enumerate(zip(day, self.shadows.masks_on_device(day))):
            if isinstance(step, SunField):     # (one block too: a scaled grid's beam reads its table)
                up = step.angles[1] > 0.0
                table = self._table(step, np.where(up, 0, -1), np.zeros((len(up), 2)))
                yield _Launch(k, kernels[True], (*grid, mask, no_sun), (*table, np.int32(0)))
            else:
                yield _Launch(k, kernels[False], (*grid, mask, _sun_vector(step)))

    def _by_horizons(self, day: list[Traced], outs: tuple[str, ...], n: int) -> tuple[int, Iterator[_Launch]]:
        """As :meth:`_by_masks` by horizons: one launch per step and interval of grid azimuths
        holding its sun (a field: some block's sun up), in order of the interval, each between the
        horizon bands of the grid azimuths around it.  Only the bands next to some sun are
        computed, each once, and at most three are kept (where the horizon caster batches
        azimuths, its knob ``batch``, a batch's bands share one device buffer until the last of
        them is dropped)."""
        kernels = {table: self._kernel("sunshine_horizons", outs, table) for table in (False, True)}
        planned: list[tuple[int, int, Traced]] = []           # (interval, step index, step)
        for k, step in enumerate(day):
            azimuth, elevation = step.angles if isinstance(step, SunField) else ([step.azimuth], [step.elevation])
            _, interval = _positions(azimuth, n)
            planned += [(int(i), k, step) for i in sorted(set(interval[np.asarray(elevation) > 0.0].tolist()))]
        return len(planned), self._horizon_launches(planned, kernels, n)

    def _horizon_launches(self, planned: list[tuple[int, int, Traced]], kernels: dict[bool, cl.Kernel], n: int
                          ) -> Iterator[_Launch]:
        """The planned launches as the bands they read are made; a field's sun table is made and
        sent at its launch (not at planning: the device holds one step's table at a time)."""
        horizons = HorizonCaster(self.heightmap, self.runtime,        # at the grid's cells: the suns are the grid's
                                 row_scales=np.ones((self.heightmap.shape[0], 2)))
        grid = self._grid_args(horizons.pyramid.heights)
        no_sun = (np.float32(0.0), np.float32(0.0), np.zeros(4, np.float32))
        pending = sorted({p[0] for p in planned})                  # intervals with suns, in azimuth order
        needed = sorted(set(pending) | {(i + 1) % n for i in pending})
        bands: dict[int, cl.Buffer] = {}
        for k, (_, buf) in zip(needed, horizons.angles_on_device(azimuth_grid(n)[needed])):
            bands[k] = buf
            while pending and pending[0] in bands and (pending[0] + 1) % n in bands:
                i = pending.pop(0)
                low, high = bands[i], bands[(i + 1) % n]
                for interval, step_index, step in planned:
                    if interval != i:
                        continue
                    if isinstance(step, SunField):
                        azimuth, elevation = step.angles
                        position, intervals = _positions(azimuth, n)
                        table = self._table(step, np.where(elevation > 0.0, intervals, -1),
                                            np.stack([position - intervals, elevation], axis=1))
                        yield _Launch(step_index, kernels[True], (*grid, low, high, *no_sun), (*table, np.int32(i)))
                    else:
                        frac = np.float32(_positions([step.azimuth], n)[0][0] - i)
                        yield _Launch(step_index, kernels[False],
                                      (*grid, low, high, frac, np.float32(step.elevation), _sun_vector(step)))
                keep = set(pending) | {(j + 1) % n for j in pending}
                bands = {j: b for j, b in bands.items() if j in keep}

    def _table(self, field: SunField, block_keys: np.ndarray, block_at: np.ndarray) -> tuple[cl.Buffer, ...]:
        """sunshine.cl's sun table of a field on the device (band, suns, keys): each block's sun
        vector and cell sizes on the ground (:func:`oclshade.sun.true_directions`), ``block_at``
        (frac, elevation) and its key."""
        band, owner = field.bands
        hm = self.heightmap
        vectors, cells = true_directions(*field.angles, field.scales, hm.dx, hm.dy)
        at = np.concatenate([np.asarray(block_at, np.float64)[:, :2], cells], axis=1)
        vectors = np.concatenate([vectors, np.zeros((len(field.blocks), 1))], axis=1)
        suns = np.stack([vectors, at], axis=1).astype(np.float32)[owner]
        keys = np.asarray(block_keys, np.int32)[owner]
        rt = self.runtime
        return (rt.to_device(band, "sun table bands"), rt.to_device(np.ascontiguousarray(suns), "sun table"),
                rt.to_device(np.ascontiguousarray(keys), "sun table keys"))

    def _kernel(self, name: str, outs: tuple[str, ...], table: bool = False) -> cl.Kernel:
        return self.runtime.kernel("sunshine.cl", name, {**{_SUMS[out][2]: True for out in outs},
                                                         "OCLS_SUN_TABLE": table})

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


def _positions(azimuth: np.ndarray | list[float], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Each sun's azimuth in units of the ``n`` grid azimuths' spacing (float64), and the
    interval holding it (the band at its lower end)."""
    position = np.mod(np.asarray(azimuth, np.float64), 360.0) * n / 360.0
    return position, np.minimum(np.floor(position).astype(np.int64), n - 1)


def _sun_vector(sun: Sun) -> np.ndarray:
    """sunshine.cl's sunvec of a sun, float32 (east, north, up, 0)."""
    return np.array([*sun.vector(), 0.0], np.float32)


def _daylight_map(day: list[Traced], weights: np.ndarray, shape: tuple[int, int]) -> np.ndarray | None:
    """Each cell's daylight seconds (int64) when some step's sun is up on part of the map only
    (a field's blocks: through its bands, :attr:`oclshade.sun.SunField.bands`); else None."""
    if not any(isinstance(step, SunField) for step in day):
        return None
    rows = shape[0]
    total = np.zeros(shape, np.int64)
    by_bands: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}   # fields on the same bands summed there first
    for step, w in zip(day, weights):
        if not isinstance(step, SunField):
            total += int(w)
            continue
        band, owner = step.bands
        up = np.where(step.angles[1] > 0.0, int(w), 0)[owner]
        key = band.tobytes()
        by_bands[key] = (band, by_bands[key][1] + up if key in by_bands else up)
    for band, up in by_bands.values():
        total += up[band[:rows, None] + band[None, rows:]]
    return total


def _finish(values: np.ndarray, nodata: np.ndarray) -> np.ndarray:
    return np.where(nodata, np.nan, values).astype(np.float32)
