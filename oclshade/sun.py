"""Sun positions: gdaldem words (azimuth clockwise from north, elevation above
the horizon, degrees) and their exact direction vectors; a sun that varies over a map
(:class:`SunField`, made by :mod:`oclshade.solar.field`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence, Union

import numpy as np

DEFAULT_AZIMUTH = 315.0
DEFAULT_ELEVATION = 45.0
DEFAULT_SUN_TOLERANCE = 0.01   # degrees between a cell's own sun and its block's (oclshade.solar.field)


def sincos_degrees(angle: float) -> tuple[float, float]:
    """(sin, cos) of an angle in degrees, exact at multiples of 90 degrees (and
    of equal magnitude at odd multiples of 45), so that azimuths 0/90/180/270
    give rays exactly along the grid and 45/135/... exactly diagonal ones."""
    a = math.fmod(angle, 360.0)
    if a < 0.0:
        a += 360.0
        if a == 360.0:  # a tiny negative angle rounds up to 360: it is north, not a diagonal
            a = 0.0
    exact = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}
    if a in exact:
        return exact[a]
    if a % 45.0 == 0.0:  # odd multiples of 45: |sin| == |cos| exactly, diagonals stay diagonal
        r = math.sqrt(0.5)
        return (r if a < 180.0 else -r), (r if a in (45.0, 315.0) else -r)
    r = math.radians(a)
    return math.sin(r), math.cos(r)


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
        sa, ca = sincos_degrees(self.azimuth)
        se, ce = sincos_degrees(self.elevation)
        return sa * ce, ca * ce, se

    def ray(self, dx: float, dy: float) -> tuple[float, float, float]:
        """(ux, uy, w): cells per metre along x (east) and y (south, rows), and
        the rise per horizontal metre tan(elevation).

        Rounded to float32 (subnormals to 0) so that the kernels and the
        float64 reference trace the very same ray.
        """
        sa, ca = sincos_degrees(self.azimuth)
        se, ce = sincos_degrees(self.elevation)
        w = 1.0 if self.elevation == 45.0 else (se / ce if ce > 0.0 else math.inf)
        return _float32(sa / dx), _float32(-ca / dy), _float32(w)


def _float32(value: float) -> float:
    """value rounded to the nearest float32; subnormals (flushed by many devices) become 0."""
    v = float(np.float32(value))
    return 0.0 if abs(v) < float(np.finfo(np.float32).tiny) else v


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


@dataclass(frozen=True)
class SunField:
    """A map's sun at one instant, per block of cells (in raster order, covering the map once).

    ``centre``: the sun at the map's centre (in grid azimuth, as every sun here);
    ``deviation``: the largest angle in degrees found between a block's sun and the sun at its
    corners (for one block: between the centre's and the map corners'); ``tolerance``: the
    bound it was made to.  Checked: the blocks lie inside the map and their areas add up to
    it (they must tile it: a cell in no block would keep an earlier sun's output)."""

    shape: tuple[int, int]
    blocks: tuple[SunBlock, ...]
    centre: Sun
    deviation: float = 0.0
    tolerance: float = DEFAULT_SUN_TOLERANCE

    def __post_init__(self) -> None:
        rows, cols = self.shape
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
    def column_step(self) -> int:
        """The largest number dividing every block's first column (0 when all start at column 0)."""
        return math.gcd(*(b.col0 for b in self.blocks))

    def check_shape(self, shape: tuple[int, int]) -> None:
        if tuple(shape) != tuple(self.shape):
            raise ValueError(f"the sun field is for a {self.shape[1]}x{self.shape[0]} map, "
                             f"not this {shape[1]}x{shape[0]} one")

    @classmethod
    def single(cls, sun: Sun, shape: tuple[int, int], deviation: float = 0.0,
               tolerance: float = DEFAULT_SUN_TOLERANCE) -> "SunField":
        """One sun for the whole map (``deviation``: how far the cells' own suns are from it)."""
        return cls(shape, (SunBlock(0, shape[0], 0, shape[1], sun),), sun, deviation, tolerance)


Traced = Union[Sun, SunField]


def as_traced(values: SunLike | SunField | Iterable[SunLike | SunField]) -> list[Traced]:
    """As :func:`as_suns`, keeping each :class:`SunField` as it is."""
    if isinstance(values, (Sun, SunField)):
        return [values]
    seq = list(values)  # type: ignore[arg-type]
    if any(isinstance(v, SunField) for v in seq):
        return [v if isinstance(v, SunField) else as_sun(v) for v in seq]
    return as_suns(seq)
