"""Horizon angles and sky-view factor on the device (kernels/horizon.cl).

>>> caster = HorizonCaster(Heightmap.from_array(dem, cellsize=30.0))
>>> angles = caster.horizons(64)              # float32 (64, rows, cols), degrees, band i at 360 i / 64
>>> for azimuth, band in caster.iter_horizons(64): ...     # one azimuth at a time (streamed)
>>> svf = caster.sky_view_factor(64)          # float32 (rows, cols), the cosine-weighted definition
>>> soft = caster.sun_disc(Sun(300, 4))       # float32 (rows, cols): the share of the sun disc seen

Per cell and azimuth the horizon angle is the elevation angle, in degrees, of
the highest point of the bilinear surface seen from the cell's surface point
(exact, as the cast-shadow masks: a cell is in cast shadow at (az, e) iff its
horizon at az is above e); -90 where the ray sees no terrain (at the map's
edge looking out), NaN at nodata cells.  Beyond the map there is no terrain.
``max_distance`` limits the search to a radius in metres (r.horizon's ``maxdistance``,
WhiteboxTools' ``max_dist``, RVT's radius): exact over the surface within it.
One traversal of the extrema pyramid per cell and azimuth; over the whole map
it starts from a lower bound carried from an exact walk on every 8th row and
column (a second launch per azimuth; kernels/horizon.cl, "Seeds").  Within a
short radius (a ray crossing at most the tuning knob ``sweep_cells`` patch columns
and rows) the cells of a row step through their patches together instead, without
the pyramid (kernels/horizon.cl, "The sweep": the same angles bit for bit); past that
reach the knob ``sweep_far`` chooses, by default the faster of the two on the map, timed on
bands of its rows (:mod:`oclshade.horizon.pilot`).  The
pyramid is shared with the shadow casters over the same heights (process-wide
cache).  Definitions: kernels/horizon.cl and docs/methods.md;
float64 twin: :func:`oclshade.reference.horizon_angles`.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, Iterator, Mapping, Sequence

import numpy as np
import pyopencl as cl

from .. import tuning
from ..heightmap import Heightmap
from ..pyramid import ExtremaPyramid, cached_pyramid
from ..reference.horizons import SVF_DEFINITIONS
from ..runtime import Runtime, get_runtime
from ..solar.field import on_heightmap
from ..solar.scale import EARTH_RADIUS, SCALE_TOLERANCE, ScaleBlocks, direction_factor, scale_blocks
from ..sun import Sun, SunField, SunLike, as_sun, libm, sun_rays
from .disc import DEFAULT_COLUMNS, SUN_RADIUS, disc_columns, disc_columns_of, disc_stretch, visible_fraction
from .pilot import MIN_CELLS as PILOT_MIN_CELLS, MIN_ROWS as PILOT_MIN_ROWS, Pilot
from .pilot import bands as pilot_bands, measure as measure_pilot

#: degrees added on both sides of a strip's elevations before its horizons are clamped: far
#: above the float32 error of an angle, so a clamped angle never lands inside the strip
STRIP_MARGIN = 1e-3
MAX_AZIMUTHS = 65536
#: kernels/horizon.cl's OCLS_SEED_STRIDE: the seed grid's spacing in cells (part of the algorithm:
#: the angles' last bits may depend on it, so it is not a tuning knob)
SEED_STRIDE = 8
_SVF_CODE = {"cosine": 1, "solid-angle": 2}
#: the knob ``sweep_far``'s values: what the rays past the reach of ``sweep_cells`` take
#: (pilot: the faster on this map, timed on bands of its rows; oclshade/horizon/pilot.py)
SWEEP_FAR = {"walk": 0, "pilot": 1, "sweep": 2}

Progress = Callable[[int, int], None]


def azimuth_grid(n: int) -> np.ndarray:
    """``n`` equally spaced azimuths, degrees clockwise from north: 360 i / n, i = 0 .. n-1."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_AZIMUTHS:
        raise ValueError(f"the number of azimuths must be an integer in 1..{MAX_AZIMUTHS}, got {n!r}")
    return 360.0 * np.arange(int(n)) / int(n)


def as_azimuths(azimuths: int | Sequence[float] | np.ndarray) -> np.ndarray:
    """An azimuth count (:func:`azimuth_grid`) or finite azimuths in degrees, as float64."""
    if isinstance(azimuths, (int, np.integer)) and not isinstance(azimuths, bool):
        return azimuth_grid(azimuths)
    values = np.asarray(azimuths, np.float64) if not isinstance(azimuths, bool) else np.zeros(0)
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise ValueError(f"azimuths must be a count or a non-empty list of finite degrees, got {azimuths!r}")
    return values


def check_max_distance(max_distance: float | None) -> float | None:
    """The search radius as the kernel's float32 value (None: the whole map)."""
    if max_distance is None:
        return None
    ok = isinstance(max_distance, (int, float, np.floating, np.integer)) and not isinstance(max_distance, bool)
    value = float(np.float32(max_distance)) if ok and math.isfinite(max_distance) else math.nan
    if not value > 0.0:
        raise ValueError(f"max_distance must be None or a positive finite number of metres, got {max_distance!r}")
    return value


def check_definition(definition: str) -> str:
    if definition not in SVF_DEFINITIONS:
        raise ValueError(f"definition must be one of {', '.join(SVF_DEFINITIONS)}; got {definition!r}")
    return definition


@dataclass(frozen=True)
class Curvature:
    """Earth curvature along the rays: heights drop by (1 - k) d^2 / (2 R) at distance d, R the
    radius in metres and k the refraction coefficient (light bent down by the air: about 0.13 by
    day, an effective radius R / (1 - k)).  ``coefficient`` is that drop per square metre as the
    kernel's float32 (the value the float64 reference is given, so both trace the same rays)."""

    radius: float = EARTH_RADIUS
    refraction: float = 0.0

    def __post_init__(self) -> None:
        if not (isinstance(self.radius, (int, float)) and math.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"radius must be a positive number of metres, got {self.radius!r}")
        if not (isinstance(self.refraction, (int, float)) and 0.0 <= self.refraction < 1.0):
            raise ValueError(f"refraction must be a coefficient in [0, 1), got {self.refraction!r}")

    @property
    def coefficient(self) -> float:
        return float(np.float32((1.0 - self.refraction) / (2.0 * self.radius)))


class HorizonCaster:
    """Horizon angles of one heightmap for any number of azimuths, over one resident pyramid.

    curvature: None for a flat Earth (default), or a :class:`Curvature` (``Curvature()`` is
    the mean Earth radius without refraction).  max_distance: None (default: the whole map)
    or the search radius in metres, a positive number: each angle is then the highest
    terrain within that horizontal distance of the cell (the float32 value is the one
    used, :attr:`radius`).  cache: share the pyramid through the
    process-wide cache (:mod:`oclshade.cache`; None follows :func:`oclshade.cache.enabled`).
    knobs: the ``horizon`` family's tuning values (:data:`TUNING`: ``group``, ``own_builtins``,
    ``lanes``, ``sweep_cells``), any subset; the rest from the device's tuning entry.  Results
    never depend on them.  row_scales: None (default: the heightmap's
    :attr:`~oclshade.heightmap.Heightmap.row_scales`; without them every cell is dx by dy metres),
    or float64 (rows[, column bands], 2 or 4), for each row (in each column band) the true metres
    east and north of one of the grid's, and a projected grid's stretch by direction (a geographic
    raster's cells are wider towards the equator; :meth:`oclshade.solar.MapPlaces.row_scales`,
    :mod:`oclshade.solar.scale`).  The horizons and sky-view factor are then traced per block
    (:attr:`scale_blocks`) with the block's own cell sizes (times its stretch at each azimuth), so their azimuths and angles
    are true ones to :data:`SCALE_TOLERANCE`; the soft shadows stay on the
    grid (their suns are the grid's: :func:`oclshade.solar.sun_field`, and a sun given by its
    angles on a heightmap with row scales is its bands', :func:`oclshade.solar.field.on_heightmap`).
    """

    def __init__(self, heightmap: Heightmap, device: str | int | Runtime | None = None, *,
                 curvature: Curvature | None = None, max_distance: float | None = None,
                 cache: bool | None = None, knobs: Mapping[str, int] | None = None,
                 row_scales: np.ndarray | None = None):
        if curvature is not None and not isinstance(curvature, Curvature):
            raise TypeError(f"curvature must be None or a Curvature, got {curvature!r}")
        self.radius = check_max_distance(max_distance)
        self.heightmap = heightmap
        self.scale_blocks: ScaleBlocks = scale_blocks(
            heightmap.shape, heightmap.row_scales if row_scales is None else row_scales, SCALE_TOLERANCE)
        self.runtime = get_runtime(device)
        self.curvature = curvature
        self.cache = cache
        self.knobs = {**tuning.settings(self.runtime, "horizon").values, **TUNING.check(knobs or {}, partial=True)}
        self._pyramid: ExtremaPyramid | None = None
        self._heights: cl.Buffer | None = None
        self._pilot: Pilot | None = None
        self._dummy = self.runtime.empty(8, "dummy")

    @property
    def pyramid(self) -> ExtremaPyramid:
        """The extrema pyramid (built on first use, or the one the shadow casters share)."""
        if self._pyramid is None:
            self._pyramid = cached_pyramid(self.heightmap, self.runtime, self.cache)
        return self._pyramid

    @property
    def heights_buffer(self) -> cl.Buffer:
        """The relative float32 heights on the device: the pyramid's once it is built, else a copy
        of its own (the sweep needs no pyramid; dropped when a walk builds the pyramid)."""
        if self._pyramid is not None:
            return self._pyramid.heights
        if self._heights is None:
            self._heights = self.runtime.to_device(self.heightmap.relative32, "heightmap")
        return self._heights

    @property
    def pilot(self) -> Pilot | None:
        """What the pilot measured on this map (at the first azimuth past the knob ``sweep_cells``
        with ``sweep_far`` 1), None until then or where none ran (oclshade/horizon/pilot.py)."""
        return self._pilot

    @property
    def coefficient(self) -> float:
        """The curvature drop per square metre the kernel uses (0 for a flat Earth)."""
        return 0.0 if self.curvature is None else self.curvature.coefficient

    def horizons(self, azimuths: int | Sequence[float], progress: Progress | None = None) -> np.ndarray:
        """Horizon angles, float32 (N, rows, cols) degrees, for N azimuths (a count: 360 i / N)."""
        az = as_azimuths(azimuths)
        rows, cols = self.heightmap.shape
        out = np.empty((az.size, rows, cols), np.float32)
        for k, (_, band) in enumerate(self.iter_horizons(az, progress)):
            out[k] = band
        return out

    def iter_horizons(self, azimuths: int | Sequence[float], progress: Progress | None = None
                      ) -> Iterator[tuple[float, np.ndarray]]:
        """(azimuth, float32 (rows, cols) degrees) one azimuth at a time, each yielded as soon as it
        is computed (after ``progress(done, total)``): a caller that writes and drops it holds one
        band.  The arguments are checked at the call."""
        az = as_azimuths(azimuths)
        return self._bands(az, progress)

    def _bands(self, az: np.ndarray, progress: Progress | None) -> Iterator[tuple[float, np.ndarray]]:
        rows, cols = self.heightmap.shape
        for k, (a, buf) in enumerate(self._device_angles(az)):
            band = np.empty((rows, cols), np.float32)
            cl.enqueue_copy(self.runtime.queue, band, buf)
            if progress is not None:
                progress(k + 1, az.size)
            yield float(a), band

    def angles_on_device(self, azimuths: int | Sequence[float]) -> Iterator[tuple[float, cl.Buffer]]:
        """(azimuth, device buffer) one azimuth at a time, for a kernel that reads the angles next
        on this caster's queue (``runtime.queue``): float32 rows * cols degrees, values as
        :meth:`horizons`; nothing is copied or waited for (but for the pilot's timing, once per
        caster with a search radius past ``sweep_cells``: :mod:`.pilot`).  Each azimuth gets its
        own buffer (keep two to interpolate between azimuths; drop them to free the memory).  The
        arguments are checked at the call."""
        return self._device_angles(as_azimuths(azimuths))

    def _device_angles(self, az: np.ndarray) -> Iterator[tuple[float, cl.Buffer]]:
        rows, cols = self.heightmap.shape
        if self._batched():
            align = max(1, self.runtime.device.mem_base_addr_align // 32)   # floats
            stride = -(-rows * cols // align) * align          # each band at an aligned offset
            launch, size = self._batch_launcher({"OCLS_OUT_ANGLE": True}, az.size, 4 * stride)
            for first in range(0, az.size, size):
                chunk = az[first:first + size]
                buf = self.runtime.empty(4 * stride * chunk.size, "horizon angles")
                launch(chunk, buf, stride, self._dummy)
                for k, a in enumerate(chunk):
                    yield float(a), buf.get_sub_region(4 * stride * k, 4 * rows * cols)
            return
        enqueue = self._enqueuer({"OCLS_OUT_ANGLE": True})
        for a in az:
            buf = self.runtime.empty(4 * rows * cols, "horizon angles")
            enqueue(float(a), buf, self._dummy)
            yield float(a), buf

    def sky_view_factor(self, azimuths: int | Sequence[float], definition: str = "cosine",
                        progress: Progress | None = None) -> np.ndarray:
        """Sky-view factor, float32 (rows, cols), NaN = nodata, from the horizons of N equally
        spaced azimuths (a count; or the azimuths, which should be equally spaced), summed on
        the device without writing the angles.  ``definition``: ``cosine`` (default: the share
        of an isotropic sky's irradiance on a horizontal surface, 1 - mean sin^2 h) or
        ``solid-angle`` (Zaksek / RVT: 1 - mean sin h); horizons below 0 count as 0."""
        az = as_azimuths(azimuths)
        check_definition(definition)
        rt = self.runtime
        rows, cols = self.heightmap.shape
        sums = rt.empty(8 * rows * cols, "sky-view factor sums")
        cl.enqueue_fill_buffer(rt.queue, sums, np.float32(0.0), 0, 8 * rows * cols)
        outputs = {"OCLS_OUT_SVF": _SVF_CODE[definition]}
        if self._batched():
            launch, size = self._batch_launcher(outputs, az.size, 0)
            for first in range(0, az.size, size):
                launch(az[first:first + size], self._dummy, 0, sums)
                if progress is not None:
                    rt.queue.finish()
                    progress(min(first + size, az.size), az.size)
        else:
            enqueue = self._enqueuer(outputs)
            for k, a in enumerate(az):
                enqueue(float(a), self._dummy, sums)
                if progress is not None:
                    rt.queue.finish()
                    progress(k + 1, az.size)
        acc = np.empty((rows, cols, 2), np.float32)
        cl.enqueue_copy(rt.queue, acc, sums)
        total = acc[..., 0].astype(np.float64) - acc[..., 1]          # the sum less its compensation
        svf = (1.0 - total / az.size).astype(np.float32)
        svf[np.isnan(self.heightmap.heights)] = np.nan
        return svf

    def sun_disc(self, sun: SunLike | SunField, radius: float = SUN_RADIUS, columns: int = DEFAULT_COLUMNS,
                 progress: Progress | None = None) -> np.ndarray:
        """Soft shadows: the share of the sun's disc each cell sees, float32 in [0, 1] (NaN =
        nodata), from its horizons at ``columns`` azimuths across the disc (the disc's
        angular ``radius`` in degrees; :mod:`oclshade.horizon.disc`).  A
        :class:`oclshade.sun.SunField`: each block's cells with the disc of its own sun (the
        strips of every block traced over its cells only), bit for bit each block sun's
        whole-map fractions on its cells, where its scales are 1 (else the disc as the grid draws
        it: :func:`oclshade.horizon.disc.disc_stretch`).  On a heightmap with
        :attr:`~oclshade.heightmap.Heightmap.row_scales`, a sun given by its angles is its bands'
        field (:func:`oclshade.solar.field.on_heightmap`)."""
        sun = on_heightmap(self.heightmap, sun if isinstance(sun, SunField) else as_sun(sun))
        if isinstance(sun, SunField):
            if sun.plain is None:
                return self._field_disc(sun, radius, columns, progress)     # (a scaled grid's disc: per block)
            sun = sun.plain
        azimuths, half_chords = disc_columns(sun, radius, columns)
        return visible_fraction(self._strip_angles(sun.elevation, azimuths, half_chords, progress),
                                sun.elevation, half_chords).astype(np.float32)

    def _field_disc(self, field: SunField, radius: float, columns: int, progress: Progress | None) -> np.ndarray:
        """Strip k of every block's disc in one launch (-D OCLS_SUN_TABLE: each cell's ray and
        bounds from its block's row of the strip's table), as the one-sun strips."""
        field.check_shape(self.heightmap.shape)
        azimuth, elevation = field.angles
        stretch, sky = disc_stretch(field.scales, azimuth, elevation)   # the disc's height on the grid
        azimuths, half_chords = disc_columns_of(azimuth, sky, radius, columns)   # checks each sun
        band, owner = field.bands
        rows, cols = self.heightmap.shape
        cell_block = owner[band[:rows, None] + band[None, rows:]]
        cell_elevation, cell_stretch = elevation[cell_block], stretch[cell_block]
        enqueue = self._enqueuer({"OCLS_OUT_ANGLE": True, "OCLS_CLAMP": True, "OCLS_SUN_TABLE": True})
        buf = self.runtime.empty(4 * rows * cols, "horizon angles")
        band_buf = self.runtime.to_device(band, "sun table bands")

        def strips() -> Iterator[np.ndarray]:
            for k in range(columns):
                table = np.zeros((len(azimuth), 2, 4), np.float32)
                table[:, 0] = self._rays(azimuths[:, k])
                table[:, 1, :2] = np.stack(strip_bounds(elevation, half_chords[k] * stretch), axis=-1)
                strip_table = self.runtime.to_device(np.ascontiguousarray(table[owner]), "strip table")
                enqueue(0.0, buf, self._dummy, (0.0, 0.0), table=(band_buf, strip_table))
                out = np.empty((rows, cols), np.float32)
                cl.enqueue_copy(self.runtime.queue, out, buf)
                if progress is not None:
                    progress(k + 1, columns)
                yield out

        return visible_fraction(strips(), cell_elevation, [c * cell_stretch for c in half_chords]).astype(np.float32)

    def _strip_angles(self, elevation: float, azimuths: np.ndarray, half_chords: np.ndarray,
                      progress: Progress | None) -> Iterator[np.ndarray]:
        """Each strip's horizon angles, exact within the strip's elevations [e - c, e + c]
        widened by :data:`STRIP_MARGIN` and clamped outside (-D OCLS_CLAMP: the rays stop as
        soon as the answer is known); the strip's visible chord is the same as from the
        unclamped angles (tested bit for bit)."""
        rows, cols = self.heightmap.shape
        enqueue = self._enqueuer({"OCLS_OUT_ANGLE": True, "OCLS_CLAMP": True})
        buf = self.runtime.empty(4 * rows * cols, "horizon angles")
        for k, (a, c) in enumerate(zip(azimuths, half_chords)):
            enqueue(float(a), buf, self._dummy, strip_bounds(elevation, c))
            band = np.empty((rows, cols), np.float32)
            cl.enqueue_copy(self.runtime.queue, band, buf)
            if progress is not None:
                progress(k + 1, azimuths.size)
            yield band

    def _enqueuer(self, outputs: Mapping[str, object]) -> Callable[..., None]:
        """A function enqueueing one azimuth's traversal into (angle, svf) buffers: over the whole
        map, the seed grid's walk (``horizon_seeds``), then every cell's walk from its seeds' bound
        (``horizon_cells``); with a search radius the sweep (``horizon_sweep``) where :func:`sweeps`
        or, past that, where the knob ``sweep_far`` says (the pilot: :mod:`.pilot`, run at the first
        such azimuth, waits for the queue), else the cells' walk alone, as with ``OCLS_CLAMP`` among
        the outputs (then ``enqueue`` takes the (lo, hi) tangents; kernels/horizon.cl, "Seeds" and
        "The sweep": the same angles either way).  The pyramid and the walk's kernels are made at
        the first azimuth that walks, the sweep's at the first it sweeps."""
        rt, hm = self.runtime, self.heightmap
        rows, cols = hm.shape
        defines = self._defines(outputs)
        clamped = bool(outputs.get("OCLS_CLAMP"))
        seeded = not clamped and self.radius is None

        @functools.cache
        def walker(tabled: bool = False) -> dict[str, object]:
            """The walk's kernels (``tabled``: horizon_cells built to read its blocks' table)."""
            pyr = self.pyramid
            self._heights = None             # a sweep's own copy: the pyramid's heights from now on
            kernel = rt.kernel("horizon.cl", "horizon_cells", {**defines, "OCLS_SUN_TABLE": True} if tabled else defines)
            walk = {"kernel": kernel, "grid": self._grid(kernel, cols, rows),
                    "fixed": (pyr.heights, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets,
                              np.int32(pyr.levels))}
            if seeded:
                seed_rows, seed_cols = (seed_extent(n) for n in (rows, cols))
                seeder = rt.kernel("horizon.cl", "horizon_seeds", defines)
                walk.update(seeder=seeder, seed_grid=self._grid(seeder, seed_cols, seed_rows),
                            seeds=rt.empty(8 * seed_rows * seed_cols, "horizon seeds"))
            return walk

        @functools.cache
        def sweeper(tabled: bool = False) -> tuple[cl.Kernel, tuple]:
            """The sweep's kernel (``tabled``: built to read its blocks' rays) and grid."""
            lanes = self.knobs["lanes"]
            kernel = rt.kernel("horizon.cl", "horizon_sweep",
                               {**defines, "OCLS_SWEEP": lanes, "OCLS_SUN_TABLE": tabled or None})
            return kernel, self._grid(kernel, -(-cols // lanes), rows)

        def sweep(ray: np.ndarray, angle: cl.Buffer, svf: cl.Buffer, band: tuple[int, int] | None = None,
                  azimuth: float | None = None) -> None:
            # a map in blocks of their own scale: one launch, each block's ray from a table
            tabled = azimuth is not None and not self.scale_blocks.as_drawn
            kernel, grid = sweeper(tabled)
            table = ()
            if tabled:          # (kept referenced until enqueued: set_args does not hold the buffer)
                table = (self._block_bands, rt.to_device(np.ascontiguousarray(self._block_rays(np.array([azimuth]))[0][:, 0]),
                                                         "horizon block rays"))
            kernel.set_args(self.heights_buffer, np.int32(rows), np.int32(cols), ray, angle, svf, *table)
            cl.enqueue_nd_range_kernel(rt.queue, kernel, *self._band_launch(grid, band))

        def walk(ray: np.ndarray, angle: cl.Buffer, svf: cl.Buffer, bounds: tuple[float, float] = (),
                 band: tuple[int, int] | None = None, table: tuple = (), azimuth: float | None = None) -> None:
            # a map in blocks of their own scale: one launch, each block's ray and cells from a table
            tabled = azimuth is not None and not table and not self.scale_blocks.as_drawn
            w = walker(tabled)
            if seeded:                # any seed gives each cell a lower bound (horizon.cl): the middle block's ray
                w["seeder"].set_args(*w["fixed"], ray if azimuth is None else self._ray(azimuth, self._seed_scales),
                                     w["seeds"])
                cl.enqueue_nd_range_kernel(rt.queue, w["seeder"], *w["seed_grid"])
            if tabled:
                rays, cells = self._block_rays(np.array([azimuth]))
                strips = np.empty((len(cells), 2, 4), np.float32)
                strips[:, 0], strips[:, 1, :2], strips[:, 1, 2:] = rays[:, 0], bounds or (-np.inf, np.inf), cells
                table = (self._block_bands, rt.to_device(strips, "horizon block table"))
                bounds = bounds or (0.0, 0.0)                                      # (unread)
            w["kernel"].set_args(*w["fixed"], ray, angle, svf, w["seeds"] if seeded else self._dummy,
                                 self._grid_cell,
                                 *([np.array(bounds, np.float32)] if bounds else []), *table)
            cl.enqueue_nd_range_kernel(rt.queue, w["kernel"], *self._band_launch(w["grid"], band))

        def pilot(ray: np.ndarray, angle: cl.Buffer, crossings: float) -> Pilot:
            """Both on bands of rows (pilot.py): into ``angle`` (the launch that follows writes the
            same values there), and sums into a scratch buffer of their own."""
            (_, (_, sweep_rows)), (_, (_, walk_rows)) = sweeper()[1], walker()["grid"]
            group_rows = math.lcm(sweep_rows, walk_rows)            # powers of two <= 16
            spans = pilot_bands(rows, group_rows)
            sums = (rt.empty(8 * rows * cols, "pilot's sky-view factor sums") if "OCLS_OUT_SVF" in outputs
                    else self._dummy)
            return measure_pilot(lambda r0, n: sweep(ray, angle, sums, (r0, n)),
                                 lambda r0, n: walk(ray, angle, sums, band=(r0, n)),
                                 rt.queue.finish, spans, group_rows, crossings)

        def enqueue(azimuth: float, angle: cl.Buffer, svf: cl.Buffer, bounds: tuple[float, float] = (),
                    table: tuple = ()) -> None:
            ray = self._ray(azimuth)
            ux, uy = float(ray[0]), float(ray[1])
            if table:                 # a sun table's rays and bounds (sun fields, with OCLS_CLAMP): the walk
                walk(ray, angle, svf, bounds, table=table)
                return
            route = not clamped and self._route(ux, uy)
            if route is None:
                self._pilot = pilot(ray, angle, float(ray[3]) * (abs(ux) + abs(uy)))
                route = self._pilot.sweeps
            if route:
                sweep(ray, angle, svf, azimuth=azimuth)
            else:
                walk(ray, angle, svf, bounds, azimuth=None if clamped else azimuth)

        return enqueue

    @staticmethod
    def _band_launch(grid: tuple, band: tuple[int, int] | None) -> tuple[tuple[int, int], tuple[int, int], tuple[int, int]]:
        """(global, local, offset) of a 2-D launch on ``grid`` over the rows of ``band`` ((first, count);
        None: the map)."""
        (gx, gy), (lx, ly) = grid
        first, stop = (0, gy) if band is None else (band[0], band[0] + band[1])
        return (gx, stop - first), (lx, ly), (0, first)

    @functools.cached_property
    def _seed_scales(self) -> np.ndarray | None:
        """The scales of the seeds' rays: those of the block holding the middle cell, so that a
        seed's horizon point lies near every block's cells' own rays (a seed gives any cell a
        lower bound, kernels/horizon.cl "Seeds"; a poor one, traced at another scale, only
        prunes less: at the grid's metres, Web Mercator's horizons had cost 1.8-2x); None (the
        map's) where the map is traced as it is."""
        return None if self.scale_blocks.as_drawn else self.scale_blocks.middle()

    @functools.cached_property
    def _block_bands(self) -> cl.Buffer:
        """kernels/horizon.cl's ``band`` of :attr:`scale_blocks` (OCLS_SUN_TABLE): cell (i, j) is in
        block band[i] + band[rows + j], raster order."""
        blocks = self.scale_blocks
        across = len(blocks.col_edges) - 1
        band = np.concatenate([np.repeat(np.arange(len(blocks.row_edges) - 1) * across, np.diff(blocks.row_edges)),
                               np.repeat(np.arange(across), np.diff(blocks.col_edges))]).astype(np.int32)
        return self.runtime.to_device(band, "scale block bands")

    def _block_rays(self, azimuths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rays float32 (blocks, azimuths, 4), cells float32 (blocks, 2)): :meth:`_scaled_rays` of
        every block of :attr:`scale_blocks` (raster order), at once."""
        rays, cells = self._scaled_rays(self.scale_blocks.scales.reshape(-1, self.scale_blocks.scales.shape[-1]),
                                        azimuths)
        return rays, cells.astype(np.float32)

    def _scaled_rays(self, scales: np.ndarray, azimuths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rays float32 (len(scales), azimuths, 4), cells float64 (len(scales), 2)): kernels/horizon.cl's
        float4 ray (ux, uy, c, R) of blocks of these scales (float64 (n, 2 or 4),
        :mod:`oclshade.solar.scale`) at each azimuth, and their cell sizes in true metres (dx, dy
        times the scales): the rays' are the cell sizes times the block's stretch that way
        (:func:`oclshade.solar.scale.direction_factor`; host/src/horizon.c band_ray, the same
        floats)."""
        dx, dy = self.heightmap.dx * scales[:, 0], self.heightmap.dy * scales[:, 1]
        stretch = direction_factor(scales[:, None, :], azimuths[None, :])
        rays = np.empty((len(scales), len(azimuths), 4), np.float32)
        rays[..., :2] = sun_rays(np.broadcast_to(azimuths, stretch.shape), np.zeros(stretch.shape),
                                 dx[:, None] * stretch, dy[:, None] * stretch)[..., :2]
        rays[..., 2], rays[..., 3] = self.coefficient, self.radius or 0.0
        return rays, np.stack([dx, dy], axis=-1)

    @functools.cached_property
    def _grid_cell(self) -> np.ndarray:
        """float32 (dx, dy): the map's cell sizes, the kernels' ``cell`` argument where no table
        gives a block's (the seeds' bound reads them: any cell size gives a lower bound, and a
        batch's azimuths share one)."""
        return np.array([self.heightmap.dx, self.heightmap.dy], np.float32)

    def _grid(self, kernel: cl.Kernel, cols: int, rows: int) -> tuple[tuple[int, int], tuple[int, int]]:
        """(global, local) sizes for one work-item per (col, row): work-groups of the knob ``group``
        work-items, the knob ``width`` of them across (:meth:`Runtime.grid_2d`)."""
        return self.runtime.grid_2d(kernel, cols, rows, wanted=self.knobs["group"], max_x=self.knobs["width"])

    def _defines(self, outputs: Mapping[str, object]) -> dict[str, object]:
        return {**outputs, "OCLS_CURVATURE": self.curvature is not None,
                "OCLS_MAX_DISTANCE": self.radius is not None,
                "OCLS_LEVEL_SCAN": 1 if self.knobs["scan"] else None,
                "OCLS_OWN_BUILTINS": bool(self.knobs["own_builtins"])}

    def _ray(self, azimuth: float, scales: np.ndarray | None = None) -> np.ndarray:
        """kernels/horizon.cl's float4 ray (ux, uy, c, R) at ``azimuth`` (``scales``: a block's,
        :attr:`scale_blocks`; default the map's cell sizes)."""
        return self._rays(np.array([azimuth]), scales)[0]

    def _rays(self, azimuths: np.ndarray, scales: np.ndarray | None = None) -> np.ndarray:
        """:meth:`_ray` of each azimuth, float32 (n, 4): :meth:`_scaled_rays` of one block."""
        one = np.ones(2) if scales is None else np.asarray(scales, np.float64)
        return self._scaled_rays(one[None, :], np.asarray(azimuths, np.float64))[0][0]

    def _batched(self) -> bool:
        """Whether the whole map's walk takes several azimuths per launch (the knob ``batch``;
        kernels/horizon.cl, "Batches": the same bits either way)."""
        return self.radius is None and self.knobs["batch"] > 1

    def _batch_launcher(self, outputs: Mapping[str, object], n_azimuths: int, band_bytes: int
                        ) -> tuple[Callable[[np.ndarray, cl.Buffer, int, cl.Buffer], None], int]:
        """(launch, size): ``launch(azimuths, angle, stride, svf)`` enqueues the seeded walk of up to
        ``size`` azimuths (horizon_seeds_batch, then horizon_cells_batch: the angles into bands
        ``stride`` floats apart, or the sky-view sums, each cell's in azimuth order); ``size`` is
        the knob ``batch``, at most ``n_azimuths``, and small enough that the batch's buffers
        (``band_bytes`` of outputs and the seeds per azimuth) stay within an eighth of the device's
        memory and one allocation."""
        rt, hm = self.runtime, self.heightmap
        rows, cols = hm.shape
        seed_bytes = 8 * seed_extent(rows) * seed_extent(cols)
        device = rt.device
        room = min(device.global_mem_size // 8, device.max_mem_alloc_size) // (band_bytes + seed_bytes)
        size = int(max(1, min(self.knobs["batch"], n_azimuths, room)))
        defines = self._defines(outputs)
        tabled = not self.scale_blocks.as_drawn       # each block's rays and cells from a table, in one launch
        pyr = self.pyramid
        seeder = rt.kernel("horizon.cl", "horizon_seeds_batch", defines)
        walker = rt.kernel("horizon.cl", "horizon_cells_batch", {**defines, "OCLS_SUN_TABLE": True} if tabled else defines)
        (sgx, sgy), (slx, sly) = self._grid(seeder, seed_extent(cols), seed_extent(rows))
        (gx, gy), (lx, ly) = self._grid(walker, cols, rows)
        fixed = (pyr.heights, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets, np.int32(pyr.levels))
        seeds = rt.empty(seed_bytes * size, "horizon seeds")
        sums = "OCLS_OUT_SVF" in outputs         # a work-item per cell walks the azimuths in order

        def launch(azimuths: np.ndarray, angle: cl.Buffer, stride: int, svf: cl.Buffer) -> None:
            n = azimuths.size
            # the seeds' rays (and the cells' where the map is not banded)
            rays = rt.to_device(self._rays(azimuths, self._seed_scales), "horizon rays")
            seeder.set_args(*fixed, rays, seeds, np.int32(0))
            cl.enqueue_nd_range_kernel(rt.queue, seeder, (sgx, sgy, n), (slx, sly, 1))
            table = ()
            if tabled:
                block_rays, cells = self._block_rays(azimuths)
                block_table = np.empty((len(cells), 1 + n, 4), np.float32)
                block_table[:, 0, :2], block_table[:, 0, 2:], block_table[:, 1:] = cells, 0.0, block_rays
                table = (self._block_bands, rt.to_device(block_table, "horizon block table"), np.int32(1 + n))
            walker.set_args(*fixed, rays, angle, svf, seeds, self._grid_cell,
                            np.int32(stride), np.int32(0), np.int32(n), *table)
            cl.enqueue_nd_range_kernel(rt.queue, walker, (gx, gy, 1 if sums else n), (lx, ly, 1))

        return launch, size

    def takes_sweep(self, azimuth: float) -> bool | None:
        """Whether the rays at ``azimuth`` take the sweep (else the walk) for the angles and the
        sky-view factor; None where the pilot decides and has not run yet (the soft shadows' clamped
        rays always walk)."""
        ux, uy, _ = Sun(float(azimuth), 0.0).ray(self.heightmap.dx, self.heightmap.dy)
        return self._route(ux, uy)

    def _route(self, ux: float, uy: float) -> bool | None:
        rows, cols = self.heightmap.shape
        radius = self.radius or 0.0
        if min(rows, cols) < 2 or radius <= 0.0:
            return False
        far = self.knobs["sweep_far"]
        if sweeps(ux, uy, radius, self.knobs["sweep_cells"]) or far == SWEEP_FAR["sweep"]:
            return True
        if far == SWEEP_FAR["walk"] or rows < PILOT_MIN_ROWS or rows * cols < PILOT_MIN_CELLS:
            return False
        return None if self._pilot is None else self._pilot.sweeps


def strip_bounds(elevation: float | np.ndarray, half_chord: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (lo, hi) tangents a strip of the sun's disc clamps its horizons to: its elevations
    [e - c, e + c] widened by :data:`STRIP_MARGIN` (float64, of the arguments' shape)."""
    return (_tan(np.radians(np.subtract(elevation, np.add(half_chord, STRIP_MARGIN)))),
            _tan(np.radians(np.add(elevation, np.add(half_chord, STRIP_MARGIN)))))


_tan = libm(math.tan)


def sweeps(ux: float, uy: float, radius: float, sweep_cells: int) -> bool:
    """Whether a ray (cells per metre ``ux``, ``uy``, as float32 values) within the search radius
    ``radius`` (metres, float32; 0: none) is within the reach of the knob ``sweep_cells``, where it
    takes the sweep: it crosses at most that many patch columns and rows there (host/src/horizon.c
    computes the same float64 product).  Past it the knob ``sweep_far`` decides.  Either way the
    angles are the same bits (kernels/horizon.cl, "The sweep")."""
    return radius > 0.0 and radius * (abs(ux) + abs(uy)) <= sweep_cells


def seed_extent(n: int) -> int:
    """Seed cells along an axis of ``n`` cells (kernels/horizon.cl ``ocls_seed_extent``)."""
    return (n - 1) // SEED_STRIDE + 2


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    hm = Heightmap.from_array(tuning.standard_heightmap(64).heights[:, :45], cellsize=30.0)
    for radius in (None, 600.0, 3000.0):   # the whole map, the sweep (20 cells), a walk within a radius
        HorizonCaster(hm, rt, max_distance=radius, cache=False, knobs=knobs).horizons([37.0, 200.0])


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    # 1024^2 and 4 azimuths, a few seconds a run: at 2048^2 and 8 azimuths (30-40 s a run on a
    # 2-core Xeon) the full tuner's rotation took half an hour for this family alone
    # and the sweep (`lanes`): 16 azimuths within 10 cells, about a fifth of the time; and
    # (`sweep_cells`) an axis and a diagonal azimuth within 120 cells (120 and 170 crossings: 128
    # sweeps the first, 192 both, 64 neither) on the canyon and on the canyon roughened by 20 m of
    # noise (the sweep's cost depends on the crossings alone, the walk's on the ground: rough ground
    # prunes well, like the SRTM tiles, smooth ground badly; docs/solar.md, "The sweep")
    # The whole map's walk: 16 azimuths of a map half as wide (as many rays as 4 azimuths of the
    # full one), so that `batch` is measured with more than one azimuth per launch.
    hm = tuning.standard_heightmap(512 if quick else 1024)
    rough = Heightmap.from_array(hm.heights + np.random.default_rng(0).normal(0.0, 20.0, hm.shape), (hm.dx, hm.dy))
    caster = HorizonCaster(tuning.standard_heightmap(hm.shape[0] // 2), rt, cache=False, knobs=knobs)
    near = HorizonCaster(hm, rt, max_distance=10 * hm.dx, cache=False, knobs=knobs)
    mid = [HorizonCaster(m, rt, max_distance=120 * hm.dx, cache=False, knobs=knobs) for m in (hm, rough)]
    caster.pyramid
    return lambda: (caster.horizons(16), near.horizons(16), *(c.horizons([0.0, 45.0]) for c in mid))


#: the horizon kernel's knobs (kernels/horizon.cl)
TUNING = tuning.register(tuning.Family(
    "horizon",
    (tuning.OWN_BUILTINS_WHERE_CALLED,
     tuning.Param("group", (16, 64, 256), 64, "work-group size (work-items)"),
     tuning.Param("width", (4, 8, 16, 32), 16, "work-group width in cells (the rest of `group` down the "
                  "rows: square groups keep a warp's rays alike)"),
     tuning.Param("batch", (1, 8, 64), 1, "azimuths per launch of the whole map's walk "
                  "(horizon_seeds_batch / horizon_cells_batch; device memory for that many bands)",
                  rule="gpu"),
     tuning.Param("scan", (0, 1), 0, "how the walk finds the largest tile it may skip (-D OCLS_LEVEL_SCAN): 0 "
                  "from the last step's level up or down, one read after another; 1 every level's read at once "
                  "(more reads, no chain of them: GPUs); the same tile either way", rule="gpu"),
     tuning.Param("lanes", (1, 4, 8, 16), 1, "cells per work-item of the sweep on vector lanes (-D OCLS_SWEEP)",
                  vector=True, rule="width"),
     tuning.Param("sweep_cells", (0, 64, 128, 192, 256), 128,
                  "within a search radius, the most patch columns and rows a ray crosses for the sweep "
                  "(horizon_sweep) to run instead of the walk (0: none)", rule="crossings"),
     tuning.Param("sweep_far", tuple(SWEEP_FAR.values()), SWEEP_FAR["pilot"],
                  "the rays past sweep_cells: 0 the walk, 1 the faster of the two on the map, timed on "
                  "bands of rows at the first such azimuth (the Python host; the C host walks), 2 the sweep "
                  "(the tuner leaves it: the pilot chooses per map)", tuned=False)),
    ("horizon.cl",), _smoke, _workload, "horizon angles and sky-view factor (issue 19)"))
