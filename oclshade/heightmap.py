"""Validated heightmap input: the one place where user arrays become kernel data.

A :class:`Heightmap` holds the float64 heights (NaN = nodata), the cell sizes
in metres and a float32 copy relative to ``offset`` (the midpoint of the finite
heights, subtracted in float64), which is what kernels read: a DEM a million
metres above the datum keeps its millimetres.  Heights whose spread float32
cannot hold to :func:`float32_tolerance` (one stray 1e30 or undeclared
nodata cell) are refused, naming the extreme value.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .io import Raster

FLOAT32_MAX = float(np.finfo(np.float32).max)
# Values data sets use for "no data"; finding one in heights without declared nodata is suspicious.
NODATA_SENTINELS = (-32768.0, -9999.0, -99999.0, -FLOAT32_MAX, FLOAT32_MAX)


class InputWarning(UserWarning):
    """Input used as given but probably not as meant (an undeclared nodata value, band 1 of several, ...)."""


def positive_finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return v


def nodata_value(nodata: object) -> float | None:
    """``nodata`` as a float (None stays None); a TypeError names it when it is not a number."""
    if nodata is None:
        return None
    if isinstance(nodata, bool) or not isinstance(nodata, (int, float, np.integer, np.floating)):
        raise TypeError(f"nodata must be a number or None, got {nodata!r}")
    return float(nodata)


def as_heights(heights: object, nodata: float | None = None, name: str = "heights",
               copy: bool = False) -> np.ndarray:
    """A read-only float64 (rows, cols) array of ``heights`` with nodata, NaN and masked cells as NaN.

    ``heights`` may be a ``numpy.ma`` masked array (masked cells are nodata).
    Rejects non-numeric or boolean dtypes, ranks other than 2, empty arrays,
    infinities and a non-numeric ``nodata``, naming the argument.  Unless ``copy``,
    a float64 input with nothing to replace is a read-only view, not a copy.
    """
    nodata = nodata_value(nodata)
    mask = np.ma.getmask(heights)
    arr = np.asarray(np.ma.getdata(heights))
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a real numeric array (int or float), got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D (rows, cols), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    replace = nodata is not None and not math.isnan(nodata)
    if arr.dtype == np.float64 and not (replace or copy or mask is not np.ma.nomask):
        out = arr.view()
    else:
        out = arr.astype(np.float64)
        if replace:
            out[arr == nodata] = np.nan
        if mask is not np.ma.nomask:
            out[np.broadcast_to(mask, arr.shape)] = np.nan
    out.setflags(write=False)
    lo, hi = extrema(out)
    if np.isinf(lo) or np.isinf(hi):
        n = int(np.isinf(out).sum())
        raise ValueError(f"{name} contains {n} infinite value(s); expected finite heights or NaN/nodata for holes")
    return out


def extrema(heights: np.ndarray) -> tuple[float, float]:
    """(min, max) of the non-NaN heights; (nan, nan) when all are NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)    # all-NaN maps
        return float(np.nanmin(heights)), float(np.nanmax(heights))


def sentinels_within(lo: float, hi: float) -> list[tuple[float, float]]:
    """(value, how near counts as equal) of the :data:`NODATA_SENTINELS` within [lo, hi]."""
    near = [(value, 1e-7 * abs(value)) for value in NODATA_SENTINELS]   # float32 max written as text
    return [(value, d) for value, d in near if lo - d <= value <= hi + d]  # ("3.4028235e38") is not float32 max


def ordinary_extrema(heights: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """(min, max) of ``heights`` (whose extrema are ``lo``, ``hi``) leaving out the cells that
    equal one of :data:`NODATA_SENTINELS`: the range a map's ground metres and scale bounds
    take (:func:`oclshade.solar.field.checked_places`), so that an undeclared sentinel, warned
    of (:func:`warn_sentinels`), does not move them too; (lo, hi) where none lies within."""
    found = sentinels_within(lo, hi)
    if not found:
        return lo, hi
    marked = np.zeros(np.shape(heights), bool)
    for value, near in found:
        marked |= np.abs(heights - value) <= near
    return extrema(np.where(marked, np.nan, heights))


def warn_sentinels(heights: np.ndarray, lo: float, hi: float, name: str = "heights") -> None:
    """Warn (:class:`InputWarning`) for each of :data:`NODATA_SENTINELS` found in ``heights``."""
    for value, near in sentinels_within(lo, hi):
        count = int(np.count_nonzero(np.abs(heights - value) <= near))
        if count:
            warnings.warn(f"{name}: {count} cell(s) equal {value:.8g}, a common nodata value, but it is not "
                          f"declared as nodata; if those cells are holes, declare it (--nodata {value:.8g} "
                          f"or nodata={value:.8g})", InputWarning, stacklevel=3)


def float32_tolerance(dx: float, dy: float) -> float:
    """The largest float32 rounding of relative heights accepted: max(0.001, 1e-4 x the smaller cell size).

    1 mm is below the vertical resolution of any DEM; 1e-4 of the cell size keeps
    the error of a slope to the next cell under 1e-4 rad (0.006 degrees)."""
    return max(1e-3, 1e-4 * min(dx, dy))


def check_float32(heights: np.ndarray, lo: float, hi: float, dx: float, dy: float) -> None:
    """Refuse heights whose float32 values relative to the midpoint round by more than
    :func:`float32_tolerance` (or overflow float32), naming the most extreme value."""
    span = 0.5 * hi - 0.5 * lo          # max |h - midpoint|, without overflowing float64
    with np.errstate(over="ignore"):
        rounding = 0.5 * float(np.spacing(np.float32(min(span, FLOAT32_MAX))))
    tol = float32_tolerance(dx, dy)
    if span <= FLOAT32_MAX and rounding <= tol:
        return
    median = float(np.nanmedian(heights))
    value = hi if hi - median >= median - lo else lo
    where = heights == value
    row, col = np.unravel_index(int(np.argmax(where)), heights.shape)
    problem = (f"exceed the float32 range (+-{FLOAT32_MAX:.3g}) the kernels use" if span > FLOAT32_MAX else
               f"round by up to {rounding:.3g} in the float32 the kernels use, more than the tolerance "
               f"{tol:.3g} (max(0.001, 1e-4 x cell size))")
    raise ValueError(f"heights from {lo:.9g} to {hi:.9g} relative to their midpoint {problem}: "
                     f"{int(np.count_nonzero(where))} cell(s) equal {value:.9g} (first at row {row}, col {col}; "
                     f"median height {median:.6g}); if that is a nodata value, declare it "
                     f"(--nodata {value:.9g} or nodata={value:.9g})")


def check_row_scales(row_scales: object, rows: int, cols: int) -> np.ndarray:
    """``row_scales`` as a read-only float64 (rows, 2 or 4) or (rows, m, 2 or 4) array (m column
    bands, :func:`oclshade.solar.scale.column_edges`: 1 to max(1, cols // 16)), or a ValueError
    naming it and what is expected: east and north (the last axis' first two) positive and
    finite; p, q (its last two, where given), a projected grid's stretch by direction
    (:mod:`oclshade.solar.scale`): finite, p^2 + q^2 < 1, and only where the two scales are equal."""
    from .solar.scale import max_column_bands       # (solar imports this module)

    scales = np.array(row_scales, np.float64)
    bands = max_column_bands(cols)
    if (scales.ndim not in (2, 3) or scales.shape[0] != rows or scales.shape[-1] not in (2, 4)
            or (scales.ndim == 3 and not 1 <= scales.shape[1] <= bands)
            or not np.all(np.isfinite(scales)) or not np.all(scales[..., :2] > 0.0)):
        raise ValueError(f"row_scales must be positive finite float64 ({rows}, 2 or 4) or ({rows}, m, 2 or 4) "
                         f"with m column bands from 1 to {bands} (rows[, column bands], then east, north[, p, q]), "
                         f"got shape {scales.shape}")
    if scales.shape[-1] == 4:
        stretched = (scales[..., 2] != 0.0) | (scales[..., 3] != 0.0)
        if (not np.all(np.hypot(scales[..., 2], scales[..., 3]) < 1.0)
                or np.any(stretched & (scales[..., 0] != scales[..., 1]))):
            raise ValueError("row_scales' p and q (a stretch by direction) must have p^2 + q^2 < 1, "
                             "and be 0 where the east and north scales differ")
    scales.setflags(write=False)
    return scales


def _relative_float32(heights: np.ndarray, offset: float, block_rows: int = 512) -> np.ndarray:
    """float32(heights - offset), subtracting in float64 block by block (no full-size temporary)."""
    out = np.empty(heights.shape, np.float32)
    for r in range(0, heights.shape[0], block_rows):
        out[r:r + block_rows] = heights[r:r + block_rows] - offset
    return out


@dataclass(frozen=True)
class Heightmap:
    """Heights in metres on a regular grid; row 0 = north, column 0 = west."""

    heights: np.ndarray          # float64, NaN = nodata
    dx: float                    # east-west cell size, metres
    dy: float                    # north-south cell size, metres
    offset: float = field(init=False)
    relative32: np.ndarray = field(init=False, repr=False)
    #: None, or float64 (rows, 2 or 4) or (rows, m, 2 or 4): each row's (in each of m column bands)
    #: true metres east and north of one grid metre, and a projected grid's stretch by direction
    #: (p, q) (:mod:`oclshade.solar.scale`; a georeferenced raster's, :meth:`from_raster`); the
    #: casters then trace a sun given by its angles per block at the block's own cell sizes (docs/methods.md, "Geographic grids",
    #: "Projected grids")
    row_scales: np.ndarray | None = field(default=None, repr=False, compare=False, kw_only=True)

    def __post_init__(self) -> None:
        if self.row_scales is not None:
            object.__setattr__(self, "row_scales", check_row_scales(self.row_scales, *self.heights.shape))
        lo, hi = extrema(self.heights)
        if not math.isnan(lo):
            check_float32(self.heights, lo, hi, self.dx, self.dy)
        offset = 0.5 * lo + 0.5 * hi if not math.isnan(lo) else 0.0
        object.__setattr__(self, "offset", offset)
        rel = _relative_float32(self.heights, offset)
        rel.setflags(write=False)
        object.__setattr__(self, "relative32", rel)

    @classmethod
    def from_array(cls, heights: object, cellsize: float | tuple[float, float] = 1.0,
                   z_factor: float = 1.0, nodata: float | None = None,
                   row_scales: np.ndarray | None = None) -> "Heightmap":
        """Validate ``heights`` and build a heightmap.

        heights: 2-D numbers, NaN (or ``nodata``, or masked cells of a
        ``numpy.ma`` array) for holes.  It is copied (8 bytes a cell), so
        editing the array afterwards does not change the heightmap.
        cellsize: one number (dx = dy) or (dx, dy), metres.  z_factor scales
        heights to the cell-size unit (as gdaldem's -z).  Warns
        (:class:`InputWarning`) when heights hold a common nodata value
        (:data:`NODATA_SENTINELS`).  row_scales: see :attr:`row_scales` (:meth:`from_raster`
        sets it from a raster's georeferencing).
        """
        z = float(z_factor)
        if not math.isfinite(z) or z == 0.0:
            raise ValueError(f"z_factor must be a finite non-zero number, got {z_factor!r}")
        h = as_heights(heights, nodata, copy=z == 1.0)     # scaling copies anyway
        lo, hi = extrema(h)
        if math.isfinite(lo):
            warn_sentinels(h, lo, hi)
        if isinstance(cellsize, (tuple, list, np.ndarray)):
            if len(cellsize) != 2:
                raise ValueError(f"cellsize must be a number or (dx, dy), got {cellsize!r}")
            dx = positive_finite("cellsize dx", cellsize[0])
            dy = positive_finite("cellsize dy", cellsize[1])
        else:
            dx = dy = positive_finite("cellsize", cellsize)
        if z != 1.0:
            peak = max(abs(lo), abs(hi)) if math.isfinite(lo) else 0.0
            if not math.isfinite(peak * z):
                raise ValueError(f"z_factor={z_factor!r} makes heights overflow: {peak:.9g} x {z:g} "
                                 f"exceeds the float64 range")
            h = h * z
            h.setflags(write=False)
        return cls(h, dx, dy, row_scales=row_scales)

    @classmethod
    def from_raster(cls, raster: "Raster", z_factor: float = 1.0) -> "Heightmap":
        """The heightmap of a DEM read with :func:`oclshade.io.read_dem`: its heights (nodata as
        NaN) and cell sizes, and where its place is known each row's own scale
        (:meth:`oclshade.solar.MapPlaces.row_scales`): a geographic grid's cells are metres at
        the centre latitude's scale, a projected grid's metres are its CRS's (UTM's 0.9996 to
        1.001 of the ground's, Web Mercator's sec(latitude)), so the casters trace a sun given by
        its angles, and the horizons, per band of rows with the band's true cell sizes, as the
        CLI does.  A raster without a CRS, or a projected one whose CRS pyproj cannot identify,
        has no :attr:`row_scales`; that, a projection one scale per band cannot follow, and a
        scale that changes too fast along the rays for the map's relief (far terrain's angles
        past 0.01 degree) come as an :class:`InputWarning`
        (:func:`oclshade.solar.field.checked_places`)."""
        from .solar.field import checked_places

        places, notes = checked_places(raster, z_factor)
        for note in notes:
            warnings.warn(f"{raster.path}: {note}" if raster.path else note, InputWarning, stacklevel=2)
        return cls.from_array(raster.heights, (raster.dx, raster.dy), z_factor,
                              row_scales=None if places is None else places.row_scales())

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape  # type: ignore[return-value]

    @property
    def valid(self) -> np.ndarray:
        return ~np.isnan(self.heights)

    @property
    def patch_shape(self) -> tuple[int, int]:
        """Patches between samples: max(rows-1, 1) x max(cols-1, 1)."""
        rows, cols = self.shape
        return max(rows - 1, 1), max(cols - 1, 1)
