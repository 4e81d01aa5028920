"""A grid's scale: a geographic grid's cells are metres at the centre latitude's scale
(oclshade.io), so a row's true cell width differs from the grid's, and a projected grid's metre
is 1 / k of the ground's; what traces each block of cells with its own (docs/methods.md,
"Geographic grids", "Projected grids").

A row's scales (:meth:`oclshade.solar.MapPlaces.row_scales`) are float64 (east, north) or
(east, north, p, q): the true metres of one grid metre along the grid's columns and rows, and,
on a projected grid that is not conformal (Albers, Lambert azimuthal equal-area, Web Mercator
on the ellipsoid), its stretch by direction: a grid metre along grid azimuth a is

    s(a) = s sqrt(1 + p cos 2a + q sin 2a)

true metres, s (east = north) the root mean square over the directions (p = q = 0: the same
every way, a conformal projection's k; p, q only with east = north)."""
from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass

import numpy as np

from ..heightmap import check_row_scales
from ..sun import sincos_degrees

#: degrees: a scaled grid's blocks (:func:`scale_blocks`) keep every cell's directions and angles
#: within this of its block's (the horizons' default; the sun fields take their tolerance)
SCALE_TOLERANCE = 0.01
#: rows: the bands' edges are multiples of this where the tolerance allows; columns: the column
#: bands' inner edges always are (:func:`column_edges`)
SCALE_ALIGN = 16
#: the multiples a projected grid's column bands' inner edges may be at, largest first
#: (:func:`column_alignment`): the packet kernels' run lengths (shadows.py's knob ``run``)
COLUMN_ALIGNMENTS = (1024, 256, 64, 16)
#: the share of the tolerance's budget that a (row, column band)'s scales leave to the spread of
#: its cells' own (row_scales (rows, m, k): :meth:`oclshade.solar.MapPlaces.row_scales` picks m so);
#: their blocks keep the rest (:func:`scale_blocks`)
SEGMENT_SHARE = 0.5
#: metres: the Earth's mean radius (IUGG), for curvature's drop (:class:`oclshade.horizon.Curvature`;
#: r.horizon and HORAYZON use about this) and a ground metre's length at a height
#: (:func:`height_factor`)
EARTH_RADIUS = 6371008.8


def scale_share(tolerance: float = SCALE_TOLERANCE) -> float:
    """The share by which cell sizes may differ from their block's (2 sqrt(2) tolerance in
    radians, :func:`scale_blocks`); a map whose scales are all within half of it of 1 is traced
    as it is (:meth:`oclshade.solar.MapPlaces.row_scales`)."""
    return 2.0 * math.sqrt(2.0) * math.radians(tolerance)


def height_factor(height: float) -> float:
    """How much longer a ground metre is at ``height`` metres above the ellipsoid than on it,
    (R + h) / R (:data:`EARTH_RADIUS`): a georeferenced grid's metres are the ellipsoid's, and
    terrain at height h is that much further apart (HORAYZON counts it; r.horizon does not)."""
    return 1.0 + float(height) / EARTH_RADIUS


def height_residual_of(relief: float) -> float:
    """Degrees: what taking every ground metre at the map's middle height (:func:`height_factor`)
    leaves, at most, of an angle, ``relief`` being the map's range of heights: terrain h from the
    middle is at a distance off by a share of |h| / R <= relief / 2R, which moves its angle
    atan(T) by T share / (1 + T^2) <= share / 2, so relief / 4R radians (first order)."""
    return math.degrees(max(float(relief), 0.0) / (4.0 * EARTH_RADIUS))


def stretch_of(scales: np.ndarray, sin: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """sqrt(1 + p cos 2a + q sin 2a) of scales (..., 2 or 4) along grid azimuths a given by their
    sines and cosines (broadcast against ``scales[..., 0]``; cos 2a = cos^2 - sin^2, sin 2a =
    2 sin cos: no trigonometry of its own): how much longer a grid metre is that way than
    ``s``; exactly 1 where p = q = 0 (or there are no such columns)."""
    scales = np.asarray(scales, np.float64)
    if scales.shape[-1] == 2:
        return np.ones(np.broadcast_shapes(scales.shape[:-1], np.shape(sin)))
    return np.sqrt(1.0 + scales[..., 2] * (cos * cos - sin * sin) + scales[..., 3] * (2.0 * sin * cos))


def direction_factor(scales: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """:func:`stretch_of` at grid azimuths in degrees, through :func:`oclshade.sun.sincos_degrees`
    (the C library's sine and cosine: the rays' stretch, host/src/shadows.c
    ocls_direction_factor, bit for bit)."""
    return stretch_of(scales, *sincos_degrees(azimuth))


def stretch_share(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The most by which a grid metre's stretch by direction, sqrt(1 + p cos 2a + q sin 2a), may
    differ as a share from that of the middle of these extremes of (p, q) (``lo``, ``hi``: (..., 2
    or 4); 0 without p, q): a quarter of |(dp, dq)| (half the range, half the root's slope at 1),
    over 1 - |(p, q)|: |sqrt(1 + x) - sqrt(1 + m)| / sqrt(1 + m) = |x - m| / (sqrt(1 + m) (sqrt(1 +
    x) + sqrt(1 + m))), and 1 + x, 1 + m >= 1 - |(p, q)| (bounded by the larger ends')."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    if lo.shape[-1] == 2:
        return np.zeros(lo.shape[:-1])
    most = np.hypot(np.maximum(np.abs(lo[..., 2]), np.abs(hi[..., 2])), np.maximum(np.abs(lo[..., 3]), np.abs(hi[..., 3])))
    with np.errstate(divide="ignore", invalid="ignore"):     # (a box reaching |(p, q)| >= 1: no bound)
        return np.where(most < 1.0, np.hypot(hi[..., 2] - lo[..., 2], hi[..., 3] - lo[..., 3]) / (4.0 * (1.0 - most)),
                        np.inf)


def column_alignment(cols: int, bands: int) -> int:
    """The multiple the inner edges of ``bands`` column bands of a map ``cols`` wide are at: the
    largest of :data:`COLUMN_ALIGNMENTS` that bands at least twice as wide leave (the nearest
    multiples of j cols / bands are then distinct), else :data:`SCALE_ALIGN`.  A sun given by
    its angles is traced in packet runs that divide every block's first column
    (:attr:`oclshade.sun.SunField.column_step`): 16-cell runs cost 1.29-1.38x one sun on a
    1201^2 tile, 64-cell 1.13-1.28x, 256-cell 1.07-1.11x (docs/solar.md)."""
    return next((a for a in COLUMN_ALIGNMENTS if 2 * a * bands <= cols), SCALE_ALIGN)


def column_edges(cols: int, bands: int) -> np.ndarray:
    """int64 (bands + 1,): the edges of ``bands`` column bands of a map ``cols`` wide, the inner
    ones the multiples of :func:`column_alignment` nearest to j cols / bands (integer
    arithmetic: host/src/horizon.c, the same); ``bands`` from 1 to max(1, cols // SCALE_ALIGN)."""
    if not 1 <= bands <= max_column_bands(cols):
        raise ValueError(f"column bands must be 1 to {max_column_bands(cols)} on a map {cols} wide, got {bands}")
    a = column_alignment(cols, bands)
    inner = [(j * cols + a // 2 * bands) // (a * bands) * a for j in range(1, bands)]
    return np.array([0, *inner, cols], np.int64)


def max_column_bands(cols: int) -> int:
    """The most column bands a map ``cols`` wide is cut into (each at least :data:`SCALE_ALIGN` wide)."""
    return max(1, cols // SCALE_ALIGN)


@dataclass(frozen=True)
class ScaleBlocks:
    """A map cut into blocks each traced at its own scales: block (a, b) holds rows
    [row_edges[a], row_edges[a + 1]) and columns [col_edges[b], col_edges[b + 1]), its scales
    ``scales[a, b]`` (2 or 4,: the module docstring's)."""

    row_edges: np.ndarray     # int64, 0 .. rows
    col_edges: np.ndarray     # int64, 0 .. cols
    scales: np.ndarray        # float64 (row bands, column bands, 2 or 4)

    @property
    def as_drawn(self) -> bool:
        """Whether the map is one block of scale 1: traced with its own cell sizes."""
        one = self.scales.reshape(-1, self.scales.shape[-1])
        return len(one) == 1 and bool(np.all(one[0, :2] == 1.0) and np.all(one[0, 2:] == 0.0))

    def block_of(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(a, b): the block of each cell (row, col) (integers, or cell coordinates: floors)."""
        a = np.searchsorted(self.row_edges, np.floor(rows), side="right") - 1
        b = np.searchsorted(self.col_edges, np.floor(cols), side="right") - 1
        return a, b

    def middle(self) -> np.ndarray:
        """The scales of the block holding the map's middle cell (rows // 2, cols // 2)."""
        a, b = self.block_of(np.array(self.row_edges[-1] // 2), np.array(self.col_edges[-1] // 2))
        return self.scales[int(a), int(b)]


def scale_blocks(shape: tuple[int, int], row_scales: np.ndarray | None, tolerance: float = SCALE_TOLERANCE
                 ) -> ScaleBlocks:
    """The blocks a map of ``shape`` with these scales is traced in (``row_scales``: float64
    (rows, 2 or 4), each row's scales (the module docstring's), or (rows, m, 2 or 4), each row's in
    m column bands (:func:`column_edges`), :meth:`oclshade.solar.MapPlaces.row_scales`; None: one
    block of scale 1): the column bands, times bands of rows common to all of them, each block's
    scales the middle of its rows'.  A row's cell sizes in any direction differ from its block's
    by a share d of at most sqrt(2) tolerance (radians): a direction then turns by at most d / 2
    (sin a cos a d) and an elevation angle moves by at most d / 2 (sin e cos e d), together at
    most the tolerance.  (With p, q: d is at most the east and north scales' share plus
    :func:`stretch_share`, each from the extremes in the block; with column bands, the blocks keep
    1 - :data:`SEGMENT_SHARE` of it, the rest being the cells' own spread about their row's
    scales in the band.)  Bands are the most rows that hold it in every column band, in
    multiples of :data:`SCALE_ALIGN` where that many do (a fine grid), any number where not
    (coarse cells near the poles: down to one row).  (Rows near enough to 1 to be traced as they
    are come as 1: :meth:`oclshade.solar.MapPlaces.row_scales`.)  The blocks of a read-only
    ``row_scales`` array (a heightmap's, a map's places') are remembered for the last
    :data:`REMEMBERED_BLOCKS` such arrays: every sun given by its angles on a map cuts the same
    (6 ms on a whole EU-DEM tile); their arrays are read-only."""
    rows, cols = shape
    if row_scales is None:
        return _read_only(ScaleBlocks(np.array([0, rows]), np.array([0, cols]), np.ones((1, 1, 2))))
    remembered = isinstance(row_scales, np.ndarray) and not row_scales.flags.writeable
    key = (id(row_scales), tuple(shape), float(tolerance))
    with _REMEMBERED_LOCK:
        found = _REMEMBERED.get(key) if remembered else None
    if found is not None and found[0]() is row_scales:
        return found[1]
    blocks = _read_only(_cut_blocks(shape, row_scales, tolerance))
    if remembered:
        with _REMEMBERED_LOCK:          # (casters in threads: the tiles' pipeline)
            while len(_REMEMBERED) >= REMEMBERED_BLOCKS:
                del _REMEMBERED[next(iter(_REMEMBERED))]
            _REMEMBERED[key] = (weakref.ref(row_scales), blocks)
    return blocks


#: how many read-only row-scale arrays' blocks :func:`scale_blocks` remembers
REMEMBERED_BLOCKS = 8
_REMEMBERED: dict[tuple, tuple[weakref.ref, ScaleBlocks]] = {}
_REMEMBERED_LOCK = threading.Lock()


def _read_only(blocks: ScaleBlocks) -> ScaleBlocks:
    for array in (blocks.row_edges, blocks.col_edges, blocks.scales):
        array.setflags(write=False)
    return blocks


def _cut_blocks(shape: tuple[int, int], row_scales: np.ndarray, tolerance: float) -> ScaleBlocks:
    """:func:`scale_blocks`' work."""
    rows, cols = shape
    scales = check_row_scales(row_scales, rows, cols)
    share = scale_share(tolerance)
    if scales.ndim == 2:
        scales = scales[:, None, :]
    else:
        share *= 1.0 - SEGMENT_SHARE

    def holds(lo: np.ndarray, hi: np.ndarray) -> bool:
        # (hi - lo) / (hi + lo), the scales' share, plus the stretch's, at most half the share, in every column band
        stretch = stretch_share(lo, hi)[:, None]
        return bool(np.all(hi[:, :2] - lo[:, :2] + stretch * (hi[:, :2] + lo[:, :2])
                           <= share * (hi[:, :2] + lo[:, :2]) / 2.0))

    # each band from its first row, its rows' extremes kept as it grows (host/src/horizon.c: the same)
    edges, middles, r0 = [0], [], 0
    while r0 < rows:
        end = min(rows, r0 + SCALE_ALIGN)
        lo, hi = scales[r0:end].min(axis=0), scales[r0:end].max(axis=0)
        step, r1 = (SCALE_ALIGN, end) if holds(lo, hi) else (1, r0 + 1)
        if step == 1:
            lo = hi = scales[r0]
        while r1 < rows:
            stop = min(rows, r1 + step)
            wider_lo, wider_hi = np.minimum(lo, scales[r1:stop].min(axis=0)), np.maximum(hi, scales[r1:stop].max(axis=0))
            if not holds(wider_lo, wider_hi):
                break
            lo, hi, r1 = wider_lo, wider_hi, stop
        edges.append(r1)
        middles.append((lo + hi) / 2.0)
        r0 = r1
    return ScaleBlocks(np.array(edges), column_edges(cols, scales.shape[1]), np.array(middles))
