"""Sun positions: gdaldem words (azimuth clockwise from north, elevation above
the horizon, degrees) and their exact direction vectors; a sun that varies over a map
(:class:`SunField`, made by :mod:`oclshade.solar.field`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Callable, Iterable, Iterator, Sequence, Union

import numpy as np

DEFAULT_AZIMUTH = 315.0
DEFAULT_ELEVATION = 45.0
DEFAULT_SUN_TOLERANCE = 0.01   # degrees between a cell's own sun and its block's (oclshade.solar.field)


def libm(function: Callable[[float], float]) -> Callable[[float | np.ndarray], np.ndarray]:
    """A math-module function on float64 arrays, element by element: the C library's values,
    as the C host computes them (numpy's own sin, cos and tan may differ in the last bit: its
    tan does on 0.5 % of arguments on an AVX-512 Xeon), at about 0.1 us an element."""
    elementwise = np.frompyfunc(function, 1, 1)
    return lambda x: np.asarray(elementwise(np.asarray(x, np.float64)), np.float64)


_sin, _cos = libm(math.sin), libm(math.cos)


def sincos_degrees(angle: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of angles in degrees (float64 arrays of the angles' shape), exact at multiples
    of 90 degrees (and of equal magnitude at odd multiples of 45), so that azimuths 0/90/180/270
    give rays exactly along the grid and 45/135/... exactly diagonal ones.  Elsewhere the C
    library's sin and cos of the radians (:func:`libm`)."""
    a = np.fmod(np.asarray(angle, np.float64), 360.0)
    a = np.where(a < 0.0, a + 360.0, a)
    a = np.where(a == 360.0, 0.0, a)    # a tiny negative angle rounds up to 360: it is north, not a diagonal
    r = np.radians(a)
    sin, cos = _sin(r), _cos(r)
    half = math.sqrt(0.5)               # odd multiples of 45: |sin| == |cos| exactly, diagonals stay diagonal
    diagonal = np.fmod(a, 45.0) == 0.0
    sin = np.where(diagonal, np.where(a < 180.0, half, -half), sin)
    cos = np.where(diagonal, np.where((a == 45.0) | (a == 315.0), half, -half), cos)
    for at, (s, c) in {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}.items():
        sin, cos = np.where(a == at, s, sin), np.where(a == at, c, cos)
    return sin, cos


def sun_vectors(azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
    """Unit vectors towards suns (degrees) in (east, north, up), float64 (..., 3)."""
    sa, ca = sincos_degrees(azimuth)
    se, ce = sincos_degrees(elevation)
    return _vectors(sa, ca, se, ce)


def sun_rays(azimuth: np.ndarray, elevation: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """(ux, uy, w) of suns (degrees) as :meth:`Sun.ray`, float32 (..., 3), subnormals 0."""
    return sun_directions(azimuth, elevation, dx, dy)[0]


def sun_directions(azimuth: np.ndarray, elevation: np.ndarray, dx: float, dy: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`sun_rays`, :func:`sun_vectors`) of suns, their sines and cosines taken once."""
    sa, ca = sincos_degrees(azimuth)
    el = np.asarray(elevation, np.float64)
    se, ce = sincos_degrees(el)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(el == 45.0, 1.0, np.where(ce > 0.0, se / np.where(ce > 0.0, ce, 1.0), np.inf))
    rays = np.stack([sa / dx, -ca / dy, w], axis=-1).astype(np.float32)
    return np.where(np.abs(rays) < np.finfo(np.float32).tiny, np.float32(0.0), rays), _vectors(sa, ca, se, ce)


def true_directions(azimuth: np.ndarray, elevation: np.ndarray, scales: np.ndarray, dx: float, dy: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(vectors float64 (n, 3), cells float64 (n, 2)): the unit vectors on the ground of grid
    suns (degrees) in blocks of these ``scales`` (:attr:`SunField.scales`), and the blocks' true
    cell sizes (dx, dy times the east and north scales).  A grid metre east is ``sx`` true
    metres, so the grid sun's vector (east, north, up) is (sx east, sy north, up) on the ground,
    its horizontal part times a projected grid's stretch that way
    (:func:`oclshade.solar.scale.stretch_of`), normalised.  (The cell sizes take no
    stretch: a slope's normal is the grid's at the mean scale, docs/methods.md "Projected
    grids".)  Where the scales are 1: :func:`sun_vectors` and (dx, dy), to the bit."""
    from .solar.scale import stretch_of

    sa, ca = sincos_degrees(azimuth)        # sun_vectors', shared with the stretch
    vectors = _vectors(sa, ca, *sincos_degrees(elevation))
    scales = np.asarray(scales, np.float64)
    stretch = stretch_of(scales, sa, ca)[:, None]
    scaled = np.concatenate([vectors[:, :2] * scales[:, :2] * stretch, vectors[:, 2:]], axis=1)
    unit = scaled / np.linalg.norm(scaled, axis=1, keepdims=True)
    same = np.all(scales[:, :2] == 1.0, axis=1, keepdims=True) & (stretch == 1.0)
    return np.where(same, vectors, unit), scales[:, :2] * np.array([dx, dy])


def unscaled(scales: np.ndarray) -> np.ndarray:
    """Per row of ``scales`` (..., 2 or 4: :attr:`SunField.scales`), whether it is the grid's
    own: east and north 1, no stretch by direction."""
    scales = np.asarray(scales, np.float64)
    return np.all(scales[..., :2] == 1.0, axis=-1) & np.all(scales[..., 2:] == 0.0, axis=-1)


def _vectors(sa: np.ndarray, ca: np.ndarray, se: np.ndarray, ce: np.ndarray) -> np.ndarray:
    return np.stack([sa * ce, ca * ce, se], axis=-1)


@dataclass(frozen=True)
class Sun:
    azimuth: float = DEFAULT_AZIMUTH      # degrees clockwise from north
    elevation: float = DEFAULT_ELEVATION  # degrees above the horizon

    def __post_init__(self) -> None:
        for name in ("azimuth", "elevation"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"sun {name} must be a finite number of degrees, got {v!r}")
        if not -90.0 <= self.elevation <= 90.0:
            raise ValueError(f"sun elevation must be in [-90, 90] degrees, got {self.elevation!r}")

    @property
    def below_horizon(self) -> bool:
        """At or below the horizon: every cell is in shadow, no traversal."""
        return self.elevation <= 0.0

    @property
    def at_zenith(self) -> bool:
        """Straight overhead: nothing casts a shadow, no traversal."""
        return self.elevation >= 90.0

    def vector(self) -> tuple[float, float, float]:
        """Unit vector towards the sun in (east, north, up)."""
        return tuple(float(v) for v in sun_vectors(self.azimuth, self.elevation))

    def ray(self, dx: float, dy: float) -> tuple[float, float, float]:
        """(ux, uy, w): cells per metre along x (east) and y (south, rows), and
        the rise per horizontal metre tan(elevation).

        Rounded to float32 (subnormals to 0) so that the kernels and the
        float64 reference trace the very same ray.
        """
        return tuple(float(v) for v in sun_rays(self.azimuth, self.elevation, dx, dy))


SunLike = Union[Sun, Sequence[float]]


def as_sun(value: SunLike) -> Sun:
    if isinstance(value, Sun):
        return value
    try:
        az, alt = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"a sun must be Sun(azimuth, elevation) or an (azimuth, elevation) pair, got {value!r}") from None
    return Sun(float(az), float(alt))


def as_suns(values: SunLike | Iterable[SunLike]) -> list[Sun]:
    """One sun or many: a Sun, an (az, alt) pair, or an iterable of those."""
    if isinstance(values, Sun):
        return [values]
    seq = list(values)  # type: ignore[arg-type]
    if len(seq) == 2 and all(isinstance(v, (int, float)) for v in seq):
        return [as_sun(seq)]
    if not seq:
        raise ValueError("suns must not be empty")
    return [as_sun(v) for v in seq]


@dataclass(frozen=True)
class SunBlock:
    """Rows [row0, row1) and columns [col0, col1) of a map, traced with ``sun``."""

    row0: int
    row1: int
    col0: int
    col1: int
    sun: Sun


@dataclass(frozen=True, eq=False)
class BlockGrid(Sequence[SunBlock]):
    """A field's blocks on a grid, held as arrays: block (a, b), number a * columns + b in raster
    order, covers rows [row_edges[a], row_edges[a + 1]) and columns [col_edges[b],
    col_edges[b + 1]) with the sun (azimuth[a, b], elevation[a, b]).  Its :class:`SunBlock` s are
    made when asked for, not kept: a month of 10-minute fields of thousands of blocks each holds
    arrays, not millions of objects."""

    row_edges: np.ndarray    # int64, from 0 to the map's rows, increasing
    col_edges: np.ndarray    # int64, from 0 to the map's columns, increasing
    azimuth: np.ndarray      # float64 (row blocks, column blocks), degrees
    elevation: np.ndarray
    scales: np.ndarray | None = None   # float64 (row blocks[, column blocks], 2 or 4): SunField.scales,
                                       # one per row of blocks (a geographic grid's scale follows the
                                       # latitude) or per block (a projected one's); None: 1

    def __post_init__(self) -> None:
        shape = (len(self.row_edges) - 1, len(self.col_edges) - 1)
        if self.scales is not None and np.shape(self.scales) not in (
                (shape[0], 2), (shape[0], 4), (*shape, 2), (*shape, 4)):
            raise ValueError(f"a block grid's scales must be (row blocks[, column blocks], 2 or 4) with {shape[0]} "
                             f"row and {shape[1]} column blocks, got {np.shape(self.scales)}")
        if (np.shape(self.azimuth) != shape or np.shape(self.elevation) != shape or min(shape) < 1
                or np.any(np.diff(self.row_edges) < 1) or np.any(np.diff(self.col_edges) < 1)
                or self.row_edges[0] != 0 or self.col_edges[0] != 0):
            raise ValueError(f"a block grid needs increasing edges from 0 and one sun per block, got "
                             f"{len(self.row_edges)} row and {len(self.col_edges)} column edges and suns of "
                             f"shape {np.shape(self.azimuth)}")

    def __len__(self) -> int:
        return self.azimuth.size

    def __getitem__(self, k):  # type: ignore[override]
        if isinstance(k, slice):
            return tuple(self[i] for i in range(len(self))[k])
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"block {k} of {n}")
        a, b = divmod(k % n, self.azimuth.shape[1])
        return SunBlock(int(self.row_edges[a]), int(self.row_edges[a + 1]), int(self.col_edges[b]),
                        int(self.col_edges[b + 1]), Sun(float(self.azimuth[a, b]), float(self.elevation[a, b])))

    def __iter__(self) -> Iterator[SunBlock]:
        return (self[k] for k in range(len(self)))

    def __eq__(self, other: object) -> bool:
        if isinstance(other, BlockGrid):
            return all(np.array_equal(getattr(self, f), getattr(other, f))
                       for f in ("row_edges", "col_edges", "azimuth", "elevation")) and \
                np.array_equal(self.block_scales, other.block_scales)
        return isinstance(other, Sequence) and tuple(self) == tuple(other) and bool(np.all(unscaled(self.block_scales)))

    def __hash__(self) -> int:
        return hash(tuple(np.ascontiguousarray(getattr(self, f)).tobytes()
                          for f in ("row_edges", "col_edges", "azimuth", "elevation")))

    @property
    def block_scales(self) -> np.ndarray:
        """float64 (blocks, 2 or 4) in raster order: :attr:`SunField.scales`."""
        if self.scales is None:
            return np.ones((len(self), 2))
        scales = np.asarray(self.scales, np.float64)
        if scales.ndim == 3:
            return scales.reshape(-1, scales.shape[-1])
        return np.repeat(scales, self.azimuth.shape[1], axis=0)

    def bands(self) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`SunField.bands` of the grid: its own rows and columns of blocks."""
        columns = self.azimuth.shape[1]
        row_band = np.repeat(np.arange(self.azimuth.shape[0]) * columns, np.diff(self.row_edges))
        col_band = np.repeat(np.arange(columns), np.diff(self.col_edges))
        return np.concatenate([row_band, col_band]).astype(np.int32), np.arange(len(self))


@dataclass(frozen=True)
class SunField:
    """A map's sun at one instant, per block of cells (in raster order, covering the map once).

    ``blocks``: :class:`SunBlock` s, or a :class:`BlockGrid` (how
    :func:`oclshade.solar.sun_field` makes them); ``centre``: the sun at the map's centre (in
    grid azimuth, as every sun here); ``deviation``: the largest angle in degrees found between
    a block's sun and the sun at its corners (for one block: between the centre's and the map
    corners'); ``tolerance``: the bound it was made to.  Checked: the blocks lie inside the map
    and their areas add up to it (they must tile it: a cell in no block would keep an earlier
    sun's output; :attr:`bands` finds any overlap)."""

    shape: tuple[int, int]
    blocks: Sequence[SunBlock]
    centre: Sun
    deviation: float = 0.0
    tolerance: float = DEFAULT_SUN_TOLERANCE

    def __post_init__(self) -> None:
        rows, cols = self.shape
        if isinstance(self.blocks, BlockGrid):
            if (int(self.blocks.row_edges[-1]), int(self.blocks.col_edges[-1])) != (rows, cols):
                raise ValueError(f"sun field block grid ends at row {self.blocks.row_edges[-1]}, column "
                                 f"{self.blocks.col_edges[-1]}: it must cover the {cols}x{rows} map")
            return
        area = 0
        for b in self.blocks:
            if not (0 <= b.row0 < b.row1 <= rows and 0 <= b.col0 < b.col1 <= cols):
                raise ValueError(f"sun field block rows [{b.row0}, {b.row1}) x columns [{b.col0}, {b.col1}) "
                                 f"must be non-empty and inside the {cols}x{rows} map")
            area += (b.row1 - b.row0) * (b.col1 - b.col0)
        if area != rows * cols:
            raise ValueError(f"sun field blocks must tile the {cols}x{rows} map once: their areas add up to "
                             f"{area} cells, not {rows * cols}")

    @property
    def uniform(self) -> bool:
        """One sun for the whole map."""
        return len(self.blocks) == 1

    @property
    def plain(self) -> "Sun | None":
        """The field's one sun where it is :attr:`uniform` at scale 1, what every caster may trace
        in its place; None where it is not (blocks, or one block of a scaled grid, whose scale the
        sunshine's beam and the soft shadows' disc need)."""
        return self.blocks[0].sun if self.uniform and bool(np.all(unscaled(self.scales))) else None

    @cached_property
    def column_step(self) -> int:
        """The largest number dividing every block's first column (0 when all start at column 0)."""
        if isinstance(self.blocks, BlockGrid):
            return int(np.gcd.reduce(self.blocks.col_edges[:-1]))
        return math.gcd(*(b.col0 for b in self.blocks))

    @cached_property
    def angles(self) -> tuple[np.ndarray, np.ndarray]:
        """The blocks' sun azimuths and elevations in degrees, float64 (blocks,) each."""
        if isinstance(self.blocks, BlockGrid):
            return self.blocks.azimuth.ravel(), self.blocks.elevation.ravel()
        return (np.array([b.sun.azimuth for b in self.blocks], np.float64),
                np.array([b.sun.elevation for b in self.blocks], np.float64))

    @property
    def scales(self) -> np.ndarray:
        """float64 (blocks, 2 or 4): the true metres east and north of one grid metre in each
        block, and a projected grid's stretch by direction (:mod:`oclshade.solar.scale`): a
        scaled grid's, drawn at its centre latitude's or its grid's scale (a :class:`BlockGrid`'s
        ``scales``, :func:`oclshade.solar.sun_field`); 1 elsewhere.  The blocks' suns are the
        grid's (:meth:`oclshade.solar.MapPlaces.on_grid`): they cast the true shadows; the scales
        give the true sun vectors and cell sizes for what needs lengths and angles on the
        ground (the sunshine's beam, :func:`true_directions`)."""
        if isinstance(self.blocks, BlockGrid):
            return self.blocks.block_scales
        return np.ones((len(self.blocks), 2))

    @property
    def bands(self) -> tuple[np.ndarray, np.ndarray]:
        """The blocks as a grid of row bands and column bands, as the kernels' sun tables read
        them (kernels/shadow.cl, "sun tables"): ``band`` int32 (rows + cols,), the row band of
        row i times the number of column bands at [i] and the column band of column j at
        [rows + j]; ``owner`` int64, for each band cell in raster order the index of the block
        holding it.  The band edges are every block's first and last rows and columns, so each
        band cell lies in one block (a :class:`BlockGrid`: its own blocks, made on each call;
        other blocks: found once and kept)."""
        return self.blocks.bands() if isinstance(self.blocks, BlockGrid) else self._tiling_bands

    @cached_property
    def _tiling_bands(self) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = self.shape
        r0, r1, c0, c1 = (np.array([getattr(b, k) for b in self.blocks], np.int64)
                          for k in ("row0", "row1", "col0", "col1"))
        row_edges = np.unique(np.concatenate([[0, rows], r0, r1]))
        col_edges = np.unique(np.concatenate([[0, cols], c0, c1]))
        a0, a1 = np.searchsorted(row_edges, r0), np.searchsorted(row_edges, r1)
        b0, b1 = np.searchsorted(col_edges, c0), np.searchsorted(col_edges, c1)
        owner = np.full((len(row_edges) - 1, len(col_edges) - 1), -1, np.int64)
        if np.all(a1 - a0 == 1) and np.all(b1 - b0 == 1):
            owner[a0, b0] = np.arange(len(self.blocks))
        else:
            for k in range(len(self.blocks)):
                owner[a0[k]:a1[k], b0[k]:b1[k]] = k
        if np.any(owner < 0):
            raise ValueError(f"sun field blocks must tile the {cols}x{rows} map once: some cells are in no block")
        ncb = owner.shape[1]
        row_band = np.searchsorted(row_edges, np.arange(rows), side="right") - 1
        col_band = np.searchsorted(col_edges, np.arange(cols), side="right") - 1
        band = np.concatenate([row_band * ncb, col_band]).astype(np.int32)
        return band, owner.ravel()

    def check_shape(self, shape: tuple[int, int]) -> None:
        if tuple(shape) != tuple(self.shape):
            raise ValueError(f"the sun field is for a {self.shape[1]}x{self.shape[0]} map, "
                             f"not this {shape[1]}x{shape[0]} one")

    @classmethod
    def single(cls, sun: Sun, shape: tuple[int, int], deviation: float = 0.0,
               tolerance: float = DEFAULT_SUN_TOLERANCE, scale: tuple[float, ...] = (1.0, 1.0)) -> "SunField":
        """One sun for the whole map (``deviation``: how far the cells' own suns are from it;
        ``scale``: its :attr:`scales`, the true metres of a grid metre east and north, and a
        projected grid's stretch by direction (p, q) where given)."""
        if tuple(scale) in ((1.0, 1.0), (1.0, 1.0, 0.0, 0.0)):
            return cls(shape, (SunBlock(0, shape[0], 0, shape[1], sun),), sun, deviation, tolerance)
        grid = BlockGrid(np.array([0, shape[0]]), np.array([0, shape[1]]), np.array([[sun.azimuth]]),
                         np.array([[sun.elevation]]), np.array([scale], np.float64))
        return cls(shape, grid, sun, deviation, tolerance)


Traced = Union[Sun, SunField]


def as_traced(values: SunLike | SunField | Iterable[SunLike | SunField]) -> list[Traced]:
    """As :func:`as_suns`, keeping each :class:`SunField` as it is."""
    if isinstance(values, (Sun, SunField)):
        return [values]
    seq = list(values)  # type: ignore[arg-type]
    if any(isinstance(v, SunField) for v in seq):
        return [v if isinstance(v, SunField) else as_sun(v) for v in seq]
    return as_suns(seq)
