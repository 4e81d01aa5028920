"""Heightmap-space cast shadows: one ray per cell through the extrema pyramid.

>>> caster = ShadowCaster(Heightmap.from_array(dem, cellsize=30.0))
>>> result = caster.cast(Sun(315, 20))           # exact cast-shadow mask
>>> result.mask                                   # uint8: 1 shadow, 0 lit, 255 nodata

The pyramid is built once per heightmap and device (process-wide cache,
:mod:`oclshade.cache`) and stays on the device for every sun; results are
reused while their inputs are unchanged; suns that provably cast nothing skip
the traversal (:mod:`oclshade.analysis`).
Definitions are in ``kernels/shadow.cl``; the float64 twin is
:func:`oclshade.reference.cast_shadows`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np
import pyopencl as cl

from .heightmap import Heightmap
from . import cache as _cache
from . import tuning
from .analysis import SceneAnalysis, slope_fronts
from .horizon.caster import Curvature
from .pyramid import ExtremaPyramid, cached_pyramid
from .runtime import Runtime, get_runtime
from .solar.field import on_heightmap
from .sun import Sun, SunField, SunLike, Traced, as_sun, as_traced, sun_directions

METHODS = ("exact", "paper", "maxmip", "dda")
OUTPUTS = ("mask", "self", "coefficient")
MASK_NODATA = 255
DEFAULT_K_DARK = 0.25
DEFAULT_K_BRIGHT = 0.65

_METHOD_CODE = {"exact": 1, "paper": 2, "maxmip": 3, "dda": 4}
CERTIFIED_METHODS = ("exact", "maxmip")   # methods that use far-field tile certificates
ANALYSED_BLOCKS = 16                      # a field's block suns proved shadow-free at most (else it traces)
CERT_TILE = 16                            # cells per side of a certificate tile: the safe value of the knob
CERT_K = 6                                # thresholds per tile (OCLS_CERT_K)
PACKET_METHODS = ("exact", "maxmip")      # methods with a ray-packet kernel (shadow_cells_packet)


def check_method(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    return method


def check_outputs(outputs: str | Sequence[str], allowed: tuple[str, ...] = OUTPUTS) -> tuple[str, ...]:
    """The requested outputs (a name, names, or 'all') in the order of ``allowed``."""
    items = (outputs,) if isinstance(outputs, str) else tuple(outputs)
    if "all" in items:
        return allowed
    bad = [o for o in items if o not in allowed]
    if bad or not items:
        raise ValueError(f"outputs must be a non-empty subset of {', '.join(allowed)} (or 'all'); got {outputs!r}")
    return tuple(o for o in allowed if o in items)


def check_curvature(curvature: Curvature | None) -> Curvature | None:
    if curvature is not None and not isinstance(curvature, Curvature):
        raise TypeError(f"curvature must be None or an oclshade.horizon.Curvature, got {curvature!r}")
    return curvature


def curvature_coefficient(curvature: Curvature | None) -> float:
    """The drop per square metre the kernels use (float32), 0 for a flat Earth."""
    return 0.0 if curvature is None else curvature.coefficient


#: the largest window origin plus extent: the kernels' int cell coordinates stay far from overflow
MAX_COORDINATE = 1 << 30


def check_origin(origin: tuple[int, int], shape: tuple[int, int]) -> tuple[int, int]:
    """A window's (row, column) origin in its whole map, as ints (see :class:`ShadowCaster`)."""
    try:
        r, c = (int(v) for v in origin)
    except (TypeError, ValueError):
        raise ValueError(f"origin must be a (row, column) pair of ints, got {origin!r}") from None
    if (r, c) != tuple(origin) or r < 0 or c < 0 or r + shape[0] > MAX_COORDINATE or c + shape[1] > MAX_COORDINATE:
        raise ValueError(f"origin must be a (row, column) pair of ints >= 0 with origin + shape <= 2^30, "
                         f"got {origin!r} for shape {shape}")
    return r, c


def check_coefficients(k_dark: float, k_bright: float) -> tuple[float, float]:
    for name, v in (("k_dark", k_dark), ("k_bright", k_bright)):
        if not 0.0 <= float(v) <= 1.0:
            raise ValueError(f"{name} must be in [0, 1] (paper 000 eq. 1), got {v!r}")
    return float(k_dark), float(k_bright)


@dataclass(frozen=True)
class ShadowFeatures:
    """Compile-time features of the shadow kernel: what is not asked for is not compiled."""

    method: str = "exact"
    outputs: tuple[str, ...] = ("mask",)
    stats: bool = False
    certificate: bool = True   # far-field tile certificates (exact and maxmip only)
    lanes: int = 0             # rays per work-item on vector lanes (0: one ray per work-item; tuning knob)
    run: int = 1024            # cells per work-item of the packet kernel (tuning knob)
    own_builtins: bool = False  # inline built-ins (kernels/common.h; tuning knob)
    gather: bool = False       # the packets' lane reads as AVX-512 gather instructions (tuning knob)
    cert_tile: int = CERT_TILE  # cells per side of a certificate tile (tuning knob)
    curvature: bool = False    # Earth curvature along the rays (the drop per m^2 rides in the ray's 4th value)
    images: bool = False       # heights and pyramid read from images (tuning knob; one-ray kernel only)
    sun_table: bool = False    # each cell's sun from a sun field's table (-D OCLS_SUN_TABLE)

    @property
    def certified(self) -> bool:
        return self.certificate and self.method in CERTIFIED_METHODS

    @property
    def packeted(self) -> bool:
        """Ray packets (exact and maxmip without stats, when the lanes knob asks for them)."""
        return self.lanes > 0 and self.method in PACKET_METHODS and not self.stats

    @property
    def imaged(self) -> bool:
        """Heights and pyramid from images (-D OCLS_IMAGES): the one-ray kernel, when asked."""
        return self.images and not self.packeted

    @property
    def cells_kernel(self) -> str:
        """The heightmap-space kernel these features launch."""
        return "shadow_cells_packet" if self.packeted else "shadow_cells"

    def defines(self) -> dict[str, object]:
        return {
            "OCLS_PACKET": self.run if self.packeted else None,
            "OCLS_LANES": self.lanes if self.packeted else None,
            "OCLS_CERT": self.cert_tile if self.certified else None,
            "OCLS_CERT_K": CERT_K if self.certified else None,
            "OCLS_STATS": self.stats,
            "OCLS_METHOD": _METHOD_CODE[check_method(self.method)],
            "OCLS_OUT_MASK": "mask" in self.outputs,
            "OCLS_OUT_SELF": "self" in self.outputs,
            "OCLS_OUT_COEF": "coefficient" in self.outputs,
            "OCLS_OWN_BUILTINS": self.own_builtins,
            "OCLS_HW_GATHER": self.gather and self.packeted,
            "OCLS_CURVATURE": self.curvature,
            "OCLS_IMAGES": self.imaged,
            "OCLS_SUN_TABLE": self.sun_table,
        }


@dataclass
class ShadowResult:
    """Outputs for one sun; an output that was not requested is None."""

    sun: Sun
    mask: np.ndarray | None = None          # uint8, 1 = cast shadow, 0 = lit, 255 = nodata
    self_shadow: np.ndarray | None = None   # uint8, 1 = self-shadowed, 0 = not, 255 = nodata
    coefficient: np.ndarray | None = None   # float32, eq. (1); NaN = nodata


class ShadowCaster:
    """Cast shadows of one heightmap for any number of suns, sharing one pyramid.

    cache: use the process-wide caches of :mod:`oclshade.cache` (pyramid shared
    with every caster over the same heights and device, results reused while
    their inputs are unchanged); None follows :func:`oclshade.cache.enabled`.
    analyse: decide before any traversal whether a sun can cast a shadow at
    all (:mod:`oclshade.analysis`); False always traces (for comparisons).
    certificates: ``exact`` and ``maxmip`` first compute far-field tile
    certificates per sun (``shadow_certify`` in kernels/shadow.cl) that end
    provably lit rays early; False traces every ray in full (same results,
    for comparisons).
    knobs: the ``shadow`` family's tuning values (:data:`TUNING`: ``lanes``, rays
    per work-item on vector lanes for ``exact`` and ``maxmip``, 0 for one ray per
    work-item; ``run``, cells per packet work-item; ``cert_tile``, certificate
    tile size; ``group``, work-group size; ``own_builtins``; ``gather``, the packets' lane
    reads as AVX-512 gather instructions; ``images``, heights and
    pyramid read from OpenCL images by the one-ray kernel), any subset; the rest, or all
    when None, from the device's tuning entry (:func:`oclshade.tuning.settings`).  Results
    never depend on them.
    curvature: None for a flat Earth (default), or a :class:`oclshade.horizon.Curvature`:
    terrain at horizontal distance d from a cell drops by (1 - k) d^2 / (2 R) below its ray
    (r.horizon's and HORAYZON's model; ``Curvature()`` is the mean Earth radius, no
    refraction).  The traversal stays exact: the ray over the flat map becomes the parabola
    z0 + w t + c t^2, still rising, so a tile's lowest ray point is still its entry.
    origin: (row, column) of the heightmap's first cell in a larger map it is a window of
    (:mod:`oclshade.tiles`), (0, 0) for a whole map: the kernels form the cells' coordinates in
    the larger map, so every float32 value a cell's ray computes is the larger map's and a window
    holding the terrain that can shade a cell decides it bit for bit as the whole map does.
    A heightmap with :attr:`~oclshade.heightmap.Heightmap.row_scales` (a geographic raster's,
    :meth:`~oclshade.heightmap.Heightmap.from_raster`) traces a sun given by its angles per band
    of rows with the band's own cell widths (:func:`oclshade.solar.field.on_heightmap`): the
    Earth's shadows, not the centre latitude's.
    """

    def __init__(self, heightmap: Heightmap, device: str | int | Runtime | None = None, *,
                 cache: bool | None = None, analyse: bool = True, certificates: bool = True,
                 knobs: Mapping[str, int] | None = None, curvature: Curvature | None = None,
                 origin: tuple[int, int] = (0, 0)):
        self.heightmap = heightmap
        self.origin = check_origin(origin, heightmap.shape)
        self.curvature = check_curvature(curvature)
        self.runtime = get_runtime(device)
        self.cache = cache
        self.analyse = analyse
        self.certificates = certificates
        self.knobs = {**tuning.settings(self.runtime, "shadow").values, **TUNING.check(knobs or {}, partial=True)}
        self._pyramid: ExtremaPyramid | None = None
        self._analysis: SceneAnalysis | None = None
        self._dummy_u8 = self.runtime.empty(1, "dummy")
        self._dummy_f32 = self.runtime.empty(4, "dummy")

    @property
    def caching(self) -> bool:
        return _cache.enabled() if self.cache is None else bool(self.cache)

    @property
    def pyramid(self) -> ExtremaPyramid:
        """The extrema pyramid, built on first use (or found in the process-wide cache) and
        kept on the device."""
        if self._pyramid is None:
            self._pyramid = cached_pyramid(self.heightmap, self.runtime, self.cache)
        return self._pyramid

    @property
    def analysis(self) -> SceneAnalysis:
        """Scene analysis of the heightmap (per-map data computed once, cached like the pyramid)."""
        if self._analysis is None:
            key = _cache.heights_digest(self.heightmap) if self.caching else None
            entry = _cache.ANALYSES.get(key) if key else None
            if entry is None:
                entry = (slope_fronts(self.heightmap),)
                if key:
                    _cache.ANALYSES.put(key, entry, entry[0].nbytes if entry[0] else 64)
            self._analysis = SceneAnalysis(self.heightmap, entry[0])
        return self._analysis

    def warm_up(self, method: str = "exact", outputs: Sequence[str] = ("mask",)) -> None:
        """Build the pyramid, the scene analysis and the kernel variant ahead of time."""
        self.pyramid
        if self.analyse:
            self.analysis
        self.runtime.queue.finish()
        self.runtime.program("shadow.cl", self._features(method, check_outputs(outputs)).defines())

    def cast(self, sun: SunLike | SunField, method: str = "exact", outputs: str | Sequence[str] = ("mask",),
             k_dark: float = DEFAULT_K_DARK, k_bright: float = DEFAULT_K_BRIGHT) -> ShadowResult:
        """Shadow outputs for one sun (azimuth, elevation in degrees), or one sun field."""
        return self.cast_many([sun if isinstance(sun, SunField) else as_sun(sun)], method, outputs, k_dark,
                              k_bright)[0]

    def cast_many(self, suns: Iterable[SunLike | SunField], method: str = "exact",
                  outputs: str | Sequence[str] = ("mask",), k_dark: float = DEFAULT_K_DARK,
                  k_bright: float = DEFAULT_K_BRIGHT,
                  progress: Callable[[int, int], None] | None = None) -> list[ShadowResult]:
        """Shadow outputs for many suns over the resident pyramid, one launch per sun.

        A sun whose result is cached gets a copy of it; a sun the scene analysis
        proves shadow-free gets its outputs without a kernel; the others trace.
        A :class:`oclshade.sun.SunField` (a sun that varies over the map,
        :func:`oclshade.solar.sun_field`) traces each of its blocks with its own sun, in one
        launch with the field's sun table; its result's ``sun`` is the field's centre sun; no
        result cache.
        """
        return list(self.iter_many(suns, method, outputs, k_dark, k_bright, progress))

    def iter_many(self, suns: Iterable[SunLike | SunField], method: str = "exact",
                  outputs: str | Sequence[str] = ("mask",), k_dark: float = DEFAULT_K_DARK,
                  k_bright: float = DEFAULT_K_BRIGHT,
                  progress: Callable[[int, int], None] | None = None) -> Iterator[ShadowResult]:
        """:meth:`cast_many` one sun at a time: each result is yielded as soon as it is traced
        (after ``progress``), so a caller that writes it and lets it go holds one sun's outputs.
        The arguments are checked at the call, before the first result."""
        items = self._traced(suns)
        outs = check_outputs(outputs)
        k_dark, k_bright = check_coefficients(k_dark, k_bright)
        check_method(method)
        return self._results(items, method, outs, k_dark, k_bright, progress)

    def _traced(self, suns: Iterable[SunLike | SunField]) -> list[Traced]:
        """The suns checked, a uniform sun field as its one sun, a field checked against the map; on
        a geographic heightmap a sun given by its angles as its bands' (:func:`on_heightmap`)."""
        items = [on_heightmap(self.heightmap, item) for item in as_traced(suns)]
        for k, item in enumerate(items):
            if isinstance(item, SunField):
                item.check_shape(self.heightmap.shape)
                if item.uniform:
                    items[k] = item.blocks[0].sun
        return items

    def _casts_nothing(self, item: Traced) -> bool:
        """Whether the scene analysis proves the sun (every block sun of a field of at most
        :data:`ANALYSED_BLOCKS` blocks) casts nothing: about 0.16 ms a sun, so a field of
        thousands of blocks, whose proof would cost more than its one traced launch, traces."""
        if isinstance(item, SunField):
            if len(item.blocks) > ANALYSED_BLOCKS:
                return False
            suns = (b.sun for b in item.blocks)
        else:
            suns = iter([item])
        return self.analyse and all(self.analysis.casts_nothing(sun) for sun in suns)

    def _results(self, items: list[Traced], method: str, outs: tuple[str, ...], k_dark: float, k_bright: float,
                 progress: Callable[[int, int], None] | None) -> Iterator[ShadowResult]:
        launchers: dict[int | None, Callable[[Traced, float, float], ShadowResult]] = {}
        for k, item in enumerate(items):
            sun = item.centre if isinstance(item, SunField) else item
            key = self._result_key(sun, method, outs, k_dark, k_bright) \
                if self.caching and isinstance(item, Sun) else None
            cached = _cache.RESULTS.get(key) if key else None
            if cached is not None:
                res = _copy_result(cached)
            elif self._casts_nothing(item):
                res = _no_shadow_result(sun, outs, self.heightmap.shape)
            else:
                step = _column_step(item)
                if step not in launchers:
                    launchers[step] = self._launcher(method, outs, step)
                res = launchers[step](item, k_dark, k_bright)
                if key:
                    _cache.RESULTS.put(key, _frozen_result(res), _result_nbytes(res))
            if progress is not None:
                progress(k + 1, len(items))
            yield res

    def _result_key(self, sun: Sun, method: str, outs: tuple[str, ...], k_dark: float, k_bright: float) -> tuple:
        hm = self.heightmap
        coef = (k_dark, k_bright) if "coefficient" in outs else None
        return (_cache.heights_digest(hm), hm.dx, hm.dy, sun.azimuth, sun.elevation, method, outs, coef,
                curvature_coefficient(self.curvature), self.origin, self.runtime.device.int_ptr)

    def masks_on_device(self, suns: Iterable[SunLike | SunField], method: str = "exact"
                        ) -> Iterator[tuple[Traced, cl.Buffer]]:
        """Each sun's cast-shadow mask left on the device for a kernel that reads it next on
        this caster's queue (``runtime.queue``): uint8, rows * cols, values as
        :attr:`ShadowResult.mask`.  Nothing is copied or waited for.  One buffer serves every
        sun: enqueue the reader of a yielded mask before advancing the iterator (the queue is
        in order).  No result cache; a sun the scene analysis proves shadow-free gets a fill
        with 0 (what the kernel writes then) instead of a traversal.  The arguments are
        checked at the call, before the first mask.  A sun field is yielded as it came, or as its
        one sun when uniform."""
        items = self._traced(suns)
        check_method(method)
        return self._device_masks(items, method)

    def _device_masks(self, items: list[Traced], method: str) -> Iterator[tuple[Traced, cl.Buffer]]:
        rows, cols = self.heightmap.shape
        mask = self.runtime.empty(rows * cols, "shadow mask")
        enqueuers: dict[int | None, Callable[[Traced, float, float], None]] = {}
        for item in items:
            if self._casts_nothing(item):
                cl.enqueue_fill_buffer(self.runtime.queue, mask, np.uint8(0), 0, rows * cols)
            else:
                step = _column_step(item)
                if step not in enqueuers:
                    enqueuers[step] = self._enqueuer(method, ("mask",), {"mask": mask}, step)[0]
                enqueuers[step](item, DEFAULT_K_DARK, DEFAULT_K_BRIGHT)
            yield item, mask

    def _launcher(self, method: str, outs: tuple[str, ...], column_step: int | None = None
                  ) -> Callable[[Traced, float, float], ShadowResult]:
        """A function tracing one sun or sun field into new host arrays (buffers and kernel shared
        by its calls; ``column_step`` as :meth:`_enqueuer`)."""
        rt = self.runtime
        rows, cols = self.heightmap.shape
        enqueue, bufs = self._enqueuer(method, outs, column_step=column_step)

        def launch(item: Traced, k_dark: float, k_bright: float) -> ShadowResult:
            enqueue(item, k_dark, k_bright)
            res = ShadowResult(item.centre if isinstance(item, SunField) else item)
            if "mask" in outs:
                res.mask = np.empty((rows, cols), np.uint8)
                cl.enqueue_copy(rt.queue, res.mask, bufs["mask"])
            if "self" in outs:
                res.self_shadow = np.empty((rows, cols), np.uint8)
                cl.enqueue_copy(rt.queue, res.self_shadow, bufs["self"])
            if "coefficient" in outs:
                res.coefficient = np.empty((rows, cols), np.float32)
                cl.enqueue_copy(rt.queue, res.coefficient, bufs["coefficient"])
            rt.queue.finish()
            return res

        return launch

    def _enqueuer(self, method: str, outs: tuple[str, ...], bufs: dict[str, cl.Buffer] | None = None,
                  column_step: int | None = None) -> tuple[Callable[[Traced, float, float], None], dict[str, cl.Buffer]]:
        """A function enqueueing the traversal of one sun or sun field into device buffers, and
        those buffers ("mask", "self", "coefficient"; a dummy for an output not in ``outs``;
        ``bufs``: buffers to reuse).  Buffers and kernel are shared by its calls.
        ``column_step``: None for suns; for sun fields whose blocks start at multiples of it
        (0: all at column 0), the packet kernel's runs are made to divide it (or the one-ray
        kernel runs), so that no run crosses a block.

        A field is traced in one launch (and one of the certificates) of the kernel built with
        -D OCLS_SUN_TABLE: each cell reads its block's sun from the field's table
        (:func:`_sun_table`; kernels/shadow.cl, "sun tables"), so every cell gets its own
        block's result at the cost of one sun."""
        rt, hm = self.runtime, self.heightmap
        self.pyramid  # built (once) before the launches
        rows, cols = hm.shape
        n = rows * cols
        features = self._features(method, outs, column_step, sun_table=column_step is not None)
        kernel = rt.kernel("shadow.cl", features.cells_kernel, features.defines())
        certify = self._certifier(features)
        bufs = dict(bufs or {})
        for name, what, nbytes, dummy in (("mask", "shadow mask", n, self._dummy_u8),
                                          ("self", "self-shadow flags", n, self._dummy_u8),
                                          ("coefficient", "shadow coefficients", 4 * n, self._dummy_f32)):
            if name not in bufs:
                bufs[name] = rt.empty(nbytes, what) if name in outs else dummy
        run = features.run if features.packeted else 1
        group = self.knobs["group"]

        def enqueue(item: Traced, k_dark: float, k_bright: float) -> None:
            table = self._table_buffers(item) if features.sun_table else ()
            sun = item.centre if isinstance(item, SunField) else item
            args = self._args(sun, k_dark, k_bright, features.imaged)
            cert = certify(args, table)
            kernel.set_args(*args, bufs["mask"], bufs["self"], bufs["coefficient"], *cert, *table)
            cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, -(-cols // run), rows, wanted=group))

        return enqueue, bufs

    def _table_buffers(self, field: SunField) -> tuple[cl.Buffer, cl.Buffer, cl.Buffer]:
        """The sun table arguments of a field (band, sun_table, sun_mode) on the device."""
        band, suns, modes = _sun_table(field, self.heightmap, self.curvature)
        return tuple(self.runtime.to_device(a, what) for a, what in ((band, "sun table bands"), (suns, "sun table"),
                                                                   (modes, "sun table modes")))

    def _features(self, method: str, outs: tuple[str, ...], column_step: int | None = None,
                  sun_table: bool = False) -> ShadowFeatures:
        """The kernel features of the knobs; ``column_step`` as :meth:`_enqueuer`; ``sun_table``:
        for sun fields."""
        features = ShadowFeatures(method, outs, certificate=self.certificates, lanes=self.knobs["lanes"],
                                  run=self.knobs["run"], own_builtins=bool(self.knobs["own_builtins"]),
                                  gather=bool(self.knobs["gather"]),
                                  cert_tile=self.knobs["cert_tile"], curvature=self.curvature is not None,
                                  images=bool(self.knobs["images"]), sun_table=sun_table)
        if features.imaged and self.pyramid.images() is None:   # the device cannot hold them: buffers
            features = replace(features, images=False)
        if column_step and features.packeted and column_step % features.run:
            run = math.gcd(features.run, column_step)
            features = replace(features, run=run) if run >= features.lanes else replace(features, lanes=0)
        return features

    def step_counts(self, sun: SunLike, method: str = "exact", band_cells: int = 1 << 19) -> np.ndarray:
        """Traversal iterations per pyramid level, summed over all cells (a profiling build).

        The kernel's counters are uint32; it runs over bands of rows of at most
        ``band_cells`` cells (a band wraps only past 8192 steps per cell) and
        the bands are summed here in int64.
        """
        rt, pyr = self.runtime, self.pyramid
        rows, cols = self.heightmap.shape
        features = ShadowFeatures(check_method(method), ("mask",), True, self.certificates,
                                  cert_tile=self.knobs["cert_tile"], curvature=self.curvature is not None)
        kernel = rt.kernel("shadow.cl", "shadow_cells", features.defines())
        mask = rt.empty(rows * cols, "shadow mask")
        sun_args = self._args(as_sun(sun), 0.0, 1.0)
        cert = self._certifier(features)(sun_args)   # kept referenced while the kernel runs
        args = (*sun_args, mask, self._dummy_u8, self._dummy_f32, *cert)
        return rt.count_in_bands(kernel, args, pyr.levels, cols, rows, band_cells)

    def tile_certificates(self, sun: SunLike) -> np.ndarray:
        """The far-field certificates of a tracing sun as float32 (tile rows, tile cols,
        CERT_K), tiles of ``knobs["cert_tile"]`` cells: [..., k] bounds S - w t over the rays
        of the tile's cells beyond t_k = 2^(k+1) major-axis cells (kernels/shadow.cl,
        shadow_certify)."""
        sun = as_sun(sun)
        if sun.below_horizon or sun.at_zenith:
            raise ValueError(f"sun must be above the horizon and below the zenith to trace, got {sun}")
        features = self._features("exact", ("mask",))
        (buf,) = self._certifier(features)(self._args(sun, 0.0, 1.0, features.imaged))
        rows, cols = self.heightmap.shape
        s = self.knobs["cert_tile"]
        out = np.empty((-(-rows // s), -(-cols // s), CERT_K), np.float32)
        cl.enqueue_copy(self.runtime.queue, out, buf)
        return out

    def _certifier(self, features: ShadowFeatures) -> Callable[..., tuple]:
        """A function enqueueing the far-field tile certificates of a sun (kernels/shadow.cl,
        shadow_certify) from the cells kernel's arguments (:meth:`_args`) and sun table (the
        :meth:`_table_buffers`, or ()) and returning shadow_cells' extra argument: () when the
        features have none, else (certificate buffer,).  A sun that does not trace (zenith,
        below the horizon; a table: every block's) gets the buffer unfilled: the kernel does not
        read it."""
        if not features.certified:
            return lambda args, table=(): ()
        rt = self.runtime
        rows, cols = self.heightmap.shape
        tr, tc = -(-rows // features.cert_tile), -(-cols // features.cert_tile)
        kernel = rt.kernel("shadow.cl", "shadow_certify", features.defines())
        buf = rt.empty(tr * tc * CERT_K * 4, "shadow certificates")

        def certify(args: tuple, table: tuple = ()) -> tuple:
            if table or int(args[_MODE_ARG]) == 0:
                kernel.set_args(*args[1:8], buf, *table)   # H, W, origin, ext, lvl_off, nlev, ray
                cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, tc, tr))
            return (buf,)

        return certify

    def _args(self, sun: Sun, k_dark: float, k_bright: float, images: bool = False) -> tuple:
        """Kernel arguments up to (not including) the output buffers; ``images``: the heights and
        pyramid as images (-D OCLS_IMAGES builds), else as buffers."""
        hm, pyr = self.heightmap, self.pyramid
        if images:
            imgs = pyr.images()
            heights, extrema, level_table = imgs.heights, imgs.extrema, imgs.level_rows
        else:
            heights, extrema, level_table = pyr.heights, pyr.buffer, pyr.offsets
        suns, modes = _sun_rows([sun.azimuth], [sun.elevation], hm, self.curvature)
        ray, vector, mode = suns[0, 0], suns[0, 1], modes[0]
        rows, cols = hm.shape
        return (heights, np.int32(rows), np.int32(cols), np.array(self.origin[::-1], np.int32),
                extrema, level_table, np.int32(pyr.levels), ray.copy(), vector.copy(),
                np.array([hm.dx, hm.dy], np.float32), np.array([k_dark, k_bright], np.float32), np.int32(mode))


def _sun_rows(azimuth: np.ndarray, elevation: np.ndarray, hm: Heightmap, curvature: Curvature | None
              ) -> tuple[np.ndarray, np.ndarray]:
    """shadow_cells' sun arguments of suns (degrees): float32 (N, 2, 4), the ray (ux, uy, w,
    curvature) and the sun vector (east, north, up, 0), and the modes int32 (N,) (0 trace, 1
    zenith, 2 at or below the horizon; the ray 0 unless 0)."""
    elevation = np.asarray(elevation, np.float64)
    modes = np.where(elevation <= 0.0, 2, np.where(elevation >= 90.0, 1, 0)).astype(np.int32)
    rows = np.zeros((len(elevation), 2, 4), np.float32)
    rays, vectors = sun_directions(azimuth, elevation, hm.dx, hm.dy)
    rows[:, 0, :3] = np.where(modes[:, None] == 0, rays, np.float32(0.0))
    rows[:, 0, 3] = curvature_coefficient(curvature)
    rows[:, 1, :3] = vectors
    return rows, modes


def _sun_table(field: SunField, hm: Heightmap, curvature: Curvature | None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A field's sun table (kernels/shadow.cl, "sun tables"): band int32 (rows + cols,) as
    :attr:`oclshade.sun.SunField.bands`, the suns float32 (band cells, 2, 4) and the modes int32
    (band cells,) of :func:`_sun_rows`: the values a one-sun launch passes."""
    band, owner = field.bands
    suns, modes = _sun_rows(*field.angles, hm, curvature)
    return band, np.ascontiguousarray(suns[owner]), np.ascontiguousarray(modes[owner])


_ARRAYS = ("mask", "self_shadow", "coefficient")


_MODE_ARG = 11   # shadow_cells' mode argument (0: the sun traces)


def _column_step(item: Traced) -> int | None:
    return item.column_step if isinstance(item, SunField) else None


def _no_shadow_result(sun: Sun, outs: tuple[str, ...], shape: tuple[int, int]) -> ShadowResult:
    """What the kernel writes on a map without holes when no cell is shadowed: mask 0,
    self-shadow 0, coefficient 1 (see oclshade.analysis for when that is proven)."""
    return ShadowResult(sun,
                        np.zeros(shape, np.uint8) if "mask" in outs else None,
                        np.zeros(shape, np.uint8) if "self" in outs else None,
                        np.ones(shape, np.float32) if "coefficient" in outs else None)


def _frozen_result(res: ShadowResult) -> ShadowResult:
    """A read-only copy for the cache (the caller keeps the writable original)."""
    out = ShadowResult(res.sun)
    for name in _ARRAYS:
        a = getattr(res, name)
        if a is not None:
            a = a.copy()
            a.setflags(write=False)
            setattr(out, name, a)
    return out


def _copy_result(res: ShadowResult) -> ShadowResult:
    """Writable copies of a cached result's arrays."""
    return ShadowResult(res.sun, *(None if getattr(res, n) is None else getattr(res, n).copy() for n in _ARRAYS))


def _result_nbytes(res: ShadowResult) -> int:
    return sum(getattr(res, n).nbytes for n in _ARRAYS if getattr(res, n) is not None)


def cast_shadows(heights: object, cellsize: float | tuple[float, float] = 1.0,
                 sun: SunLike = (315.0, 45.0), *, method: str = "exact",
                 outputs: str | Sequence[str] = ("mask",), z_factor: float = 1.0,
                 nodata: float | None = None, k_dark: float = DEFAULT_K_DARK,
                 k_bright: float = DEFAULT_K_BRIGHT,
                 device: str | int | Runtime | None = None, cache: bool | None = None,
                 curvature: Curvature | None = None) -> ShadowResult:
    """One-call API: shadow outputs of a 2-D height array for one sun (pyramid and result
    reused from the process-wide caches when the same heights come again)."""
    hm = Heightmap.from_array(heights, cellsize, z_factor=z_factor, nodata=nodata)
    return ShadowCaster(hm, device, cache=cache, curvature=curvature).cast(sun, method, outputs, k_dark, k_bright)


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    hm = Heightmap.from_array(tuning.standard_heightmap(64).heights[:, :45], cellsize=30.0)
    # exact masks: the program users build most, so the parent's build is then a cache hit
    ShadowCaster(hm, rt, cache=False, analyse=False, knobs=knobs).cast((37.0, 20.0))


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    hm = tuning.standard_heightmap(1024 if quick else 4096)
    caster = ShadowCaster(hm, rt, cache=False, analyse=False, knobs=knobs)
    caster.pyramid
    return lambda: [caster.cast(sun) for sun in ((37.0, 20.0), (135.0, 20.0))]


#: the heightmap-space shadow kernels' knobs (kernels/shadow.cl)
TUNING = tuning.register(tuning.Family(
    "shadow",
    (tuning.Param("lanes", (0, 4, 8, 16), 0, "rays per work-item on vector lanes, exact / maxmip "
                  "(-D OCLS_LANES; 0 = one ray per work-item, shadow_cells)", vector=True,
                  rule="width"),
     tuning.OWN_BUILTINS_WHERE_CALLED,
     tuning.Param("gather", (0, 1), 0, "the 16-lane packets' reads as AVX-512 gather instructions "
                  "(-D OCLS_HW_GATHER; where the compiler defines __AVX512F__, else no effect)", vector=True,
                  rule="library_calls"),
     tuning.Param("cert_tile", (16, 32, 64), CERT_TILE, "cells per side of a far-field certificate tile "
                  "(-D OCLS_CERT, exact and maxmip)"),
     tuning.Param("run", (16, 64, 256, 1024), 1024, "cells per packet work-item (-D OCLS_PACKET)"),
     tuning.Param("group", (16, 64, 256), 64, "work-group size (work-items)"),
     tuning.Param("images", (0, 1), 0, "heights and extrema pyramid read from OpenCL images, one-ray kernel "
                  "(-D OCLS_IMAGES; buffers where the device cannot hold them, oclshade/pyramid_images.py)")),
    ("shadow.cl",), _smoke, _workload, "heightmap shadow masks (paper 000)"))
