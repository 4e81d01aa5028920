"""Validated heightmap input: the one place where user arrays become kernel data.

A :class:`Heightmap` holds the float64 heights (NaN = nodata), the cell sizes
in metres and a float32 copy relative to ``offset`` (the mean of the finite
heights, subtracted in float64), which is what kernels read: a DEM a million
metres above the datum keeps its millimetres.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np


def positive_finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return v


def as_heights(heights: object, nodata: float | None = None, name: str = "heights") -> np.ndarray:
    """A float64 (rows, cols) array of ``heights`` with nodata (and NaN) as NaN.

    Rejects non-numeric or boolean dtypes, ranks other than 2, empty arrays and
    infinities, naming the argument.  A float64 input without a nodata value
    to replace is used as is (read-only view), not copied.
    """
    arr = np.asarray(heights)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be a real numeric array (int or float), got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D (rows, cols), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    replace = nodata is not None and not (isinstance(nodata, float) and math.isnan(nodata))
    if arr.dtype == np.float64 and not replace:
        out = arr.view()
    else:
        out = arr.astype(np.float64)
        if replace:
            out[arr == nodata] = np.nan
    out.setflags(write=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)    # all-NaN maps
        lo, hi = np.nanmin(out), np.nanmax(out)
    if np.isinf(lo) or np.isinf(hi):
        n = int(np.isinf(out).sum())
        raise ValueError(f"{name} contains {n} infinite value(s); expected finite heights or NaN/nodata for holes")
    return out


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

    def __post_init__(self) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)    # all-NaN maps
            lo, hi = np.nanmin(self.heights), np.nanmax(self.heights)
        offset = float(0.5 * (lo + hi)) if np.isfinite(lo) else 0.0
        object.__setattr__(self, "offset", offset)
        rel = _relative_float32(self.heights, offset)
        rel.setflags(write=False)
        object.__setattr__(self, "relative32", rel)

    @classmethod
    def from_array(cls, heights: object, cellsize: float | tuple[float, float] = 1.0,
                   z_factor: float = 1.0, nodata: float | None = None) -> "Heightmap":
        """Validate ``heights`` and build a heightmap.

        cellsize: one number (dx = dy) or (dx, dy), metres.  z_factor scales
        heights to the cell-size unit (as gdaldem's -z).
        """
        h = as_heights(heights, nodata)
        if isinstance(cellsize, (tuple, list, np.ndarray)):
            if len(cellsize) != 2:
                raise ValueError(f"cellsize must be a number or (dx, dy), got {cellsize!r}")
            dx = positive_finite("cellsize dx", cellsize[0])
            dy = positive_finite("cellsize dy", cellsize[1])
        else:
            dx = dy = positive_finite("cellsize", cellsize)
        z = float(z_factor)
        if not math.isfinite(z) or z == 0.0:
            raise ValueError(f"z_factor must be a finite non-zero number, got {z_factor!r}")
        if z != 1.0:
            h = h * z
        return cls(h, dx, dy)

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
