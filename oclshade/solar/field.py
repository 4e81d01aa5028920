"""The sun over a whole map at one instant: each cell's own sun, to a stated tolerance.

A map is not a point.  The sun's direction in a cell's local frame turns with the cell's
place: by the angle the two places subtend at the Earth's centre (about 0.009 degrees a
kilometre), plus, on a projected grid, the change of the meridian convergence between them.
At the corners of a 36 km map (a 1201^2 tile of 30 m cells) its sun is about 0.2 degrees
from the centre's, and at a low sun that moves shadow edges by several percent of their
length.  So a map's sun at a time is a :class:`SunField`: the map cut into rectangular
blocks, each traced with the sun (NREL SPA, turned to the grid through the CRS) of its
centre, the blocks small enough that every cell's own sun is within ``tolerance`` degrees
of its block's (angle between the unit vectors in the cell's grid-east, grid-north, up
frame).  Default 0.01 degrees: the accuracy the sun position itself is tested to (against
pvlib).  A map small enough is one block, traced exactly as a single sun.

How the blocks are sized: the sun's turn per row and per column is measured on a 9 x 9
lattice over the map; blocks are made that many cells tall and wide that half a block's
turn in each direction adds up to at most the tolerance; then the sun at every block corner
is computed and compared with its block's, and the blocks shrink until all are within the
tolerance (the turn is smooth and nearly linear over a block, so the largest difference
inside a rectangle is at a corner; tests/test_field.py checks every cell).  Blocks less than
16 cells on a side are checked at their outermost cells' centres instead (a cell's sun is its
centre's, so blocks of one cell hold any tolerance: where the sun or the grid's scale turns
by more across a cell, as on coarse geographic grids near the poles, each cell is its own
block).  The suns are the grid's (:meth:`MapPlaces.on_grid`): a block's sun also carries its
rows' cell size on the ground (a geographic grid's width, a projected grid's scale factor), so
that it casts the Earth's shadows rather than the grid's (docs/methods.md, "Geographic grids",
"Projected grids").  Block sides are
multiples of 16 cells where a 16 x 16 block holds the tolerance (of the sides that do, the
largest area; widths of 64 from 128 on): the packet kernels' runs then divide the block
widths and no 16 x 16 certificate tile crosses a block, so a field traces at the speed of one
sun (kernels/shadow.cl, "sun tables"; bench/results/sun_field.md).  Where the sun turns faster
than that (coarse cells, a tight tolerance) the sides are the balanced ones above, any
number of cells.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from datetime import datetime
from functools import cached_property
from typing import Any, Sequence

import numpy as np

from ..io import Raster, geotransform, metres_per_degree
from ..heightmap import Heightmap
from ..sun import DEFAULT_SUN_TOLERANCE as DEFAULT_TOLERANCE, BlockGrid, Sun, SunField, Traced
from .scale import (SEGMENT_SHARE, column_edges, height_factor, height_residual_of, max_column_bands,
                    scale_blocks, scale_share, stretch_of, stretch_share)
from .position import sun_position
from .site import STEP_METRES, grid_azimuths, projected_crs

LATTICE = 9                # points per side where the turn per cell is measured
SCALE_LATTICE = 33         # points per side where a projected grid's scale is measured
STRETCH_NOISE = 1e-7       # a projected grid's stretch by direction below this is its central differences' noise (0)
RESIDUAL_AZIMUTHS = 180    # grid azimuths over which scale_residual compares a grid metre's lengths
FAR_LATTICE = 17           # points per side where far_scale_rate differences a grid metre's lengths
ALIGN = 16                 # block sides are multiples of this where the tolerance allows (widths: 4x from 8x on)
MAX_SHRINK = 12            # tries to shrink the blocks into the tolerance


@dataclass(frozen=True)
class MapPlaces:
    """Where a map's cells lie: (row, col) in cell units (0 at the first cell's outer corner)
    to longitude and latitude, and the map's grid turn there.  ``crs``: the projected CRS
    (pyproj) of a projected map, None for a geographic one.  ``height``: the metres above the
    ellipsoid at which its ground metres are taken (:func:`map_places`: the middle of the map's
    heights), each (R + height) / R of the ellipsoid's (:func:`oclshade.solar.scale.height_factor`)."""

    transform: tuple[float, ...]
    shape: tuple[int, int]
    crs: Any = field(default=None, repr=False)
    height: float = 0.0

    def lonlat(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x0, xc, xr, y0, yc, yr = self.transform
        x = x0 + xc * cols + xr * rows
        y = y0 + yc * cols + yr * rows
        if self.crs is None:
            return np.mod(x + 180.0, 360.0) - 180.0, y
        lon, lat = (np.asarray(v, np.float64) for v in self._transformers[1].transform(x, y))
        if not (np.all(np.isfinite(lon)) and np.all(np.isfinite(lat))):
            raise ValueError("part of the map lies outside where its CRS is defined")
        return lon, lat

    def cells_of(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) in cell coordinates, as :meth:`lonlat` takes them, of geodetic places: its
        inverse (a geographic map's longitudes taken within 180 degrees of its centre's)."""
        x0, xc, xr, y0, yc, yr = self.transform
        lon, lat = np.asarray(lon, np.float64), np.asarray(lat, np.float64)
        if self.crs is None:
            middle = x0 + xc * self.shape[1] / 2.0 + xr * self.shape[0] / 2.0
            x, y = middle + np.mod(lon - middle + 180.0, 360.0) - 180.0, lat
        else:
            x, y = (np.asarray(v, np.float64) for v in self._transformers[0].transform(lon, lat))
        det = xc * yr - xr * yc
        return ((y - y0) * xc - (x - x0) * yc) / det, ((x - x0) * yr - (y - y0) * xr) / det

    @cached_property
    def geod(self) -> Any:
        """The map's ellipsoid as a pyproj ``Geod`` (WGS 84 on a geographic grid, as its cell
        sizes take it; the CRS's own on a projected one)."""
        from pyproj import Geod

        return Geod(ellps="WGS84") if self.crs is None else self.crs.get_geod()

    def grid_azimuths(self, lon: np.ndarray, lat: np.ndarray, true_azimuths: np.ndarray) -> np.ndarray:
        """The grid azimuths at these places of directions at these true azimuths (as
        :meth:`oclshade.solar.site.MapSite.grid_azimuths`, place by place)."""
        if self.crs is None:
            return np.mod(true_azimuths, 360.0)
        return grid_azimuths(self.crs, lon, lat, true_azimuths, self._transformers[0])

    @cached_property
    def centre_latitude(self) -> float:
        """The latitude of the map's centre: where a geographic raster's cell sizes in metres are
        taken (:mod:`oclshade.io`), so its grid is drawn at that latitude's scale."""
        return float(self.lonlat(np.array([self.shape[0] / 2.0]), np.array([self.shape[1] / 2.0]))[1][0])

    def grid_scales(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, ...]:
        """(east, north), and on a projected grid (east, north, p, q): the true metres of one grid
        metre along the grid's columns and rows at these places (cell coordinates, as
        :meth:`lonlat`), and its stretch by direction (:mod:`oclshade.solar.scale`).  A
        geographic cell's metres over the grid's (the centre latitude's), by the very formula
        the cell sizes come from (:func:`oclshade.io.metres_per_degree`, once per distinct
        latitude: on a north-up grid, one per row of the places), at :attr:`height`.  On a projected grid
        the CRS's own distortion
        (:meth:`projected_scales`): east = north = s, the root mean square of a grid metre's
        length over the directions, and p, q (0 on a conformal projection: UTM, Lambert
        conformal, polar stereographic), bilinear between their values on a
        :data:`SCALE_LATTICE`-square lattice over the map (a smooth field: within 2e-7 of it on a
        1-degree Web Mercator tile); (1, 1, 0, 0) where every direction's length is within half
        of :func:`scale_share` of 1 (as :func:`scale_blocks` takes a map: the angles move by at
        most 0.01 / sqrt(2) degree)."""
        rows, cols = np.asarray(rows, np.float64), np.asarray(cols, np.float64)
        if self.crs is not None:
            scale, p, q = np.moveaxis(_as_one(self._lattice_scale(rows, cols)), -1, 0)
            return scale, scale.copy(), p, q
        lat = self.lonlat(rows.ravel(), cols.ravel())[1].reshape(rows.shape)
        distinct, where = np.unique(lat, return_inverse=True)
        east, north = (np.asarray(v, np.float64) * height_factor(self.height) for v in _METRES_PER_DEGREE(distinct))
        centre = metres_per_degree(self.centre_latitude)
        return (east / centre[0])[where].reshape(np.shape(lat)), (north / centre[1])[where].reshape(np.shape(lat))

    def _lattice_scale(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """A projected grid's (s, p, q) at these places, (..., 3), bilinear on :attr:`_scale_lattice`."""
        r, c, lattice = self._scale_lattice
        i = np.clip(np.searchsorted(r, rows, side="right") - 1, 0, len(r) - 2)
        j = np.clip(np.searchsorted(c, cols, side="right") - 1, 0, len(c) - 2)
        fr, fc = ((rows - r[i]) / (r[i + 1] - r[i]))[..., None], ((cols - c[j]) / (c[j + 1] - c[j]))[..., None]
        return ((lattice[i, j] * (1.0 - fc) + lattice[i, j + 1] * fc) * (1.0 - fr)
                + (lattice[i + 1, j] * (1.0 - fc) + lattice[i + 1, j + 1] * fc) * fr)

    @cached_property
    def _scale_lattice(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row lines, column lines, (lines, lines, 3) (s, p, q)): :meth:`projected_scales` on the lattice."""
        rows, cols = self.shape
        r, c = np.linspace(0.0, rows, SCALE_LATTICE), np.linspace(0.0, cols, SCALE_LATTICE)
        rr, cc = np.meshgrid(r, c, indexing="ij")
        found = self.projected_scales(*self.lonlat(rr.ravel(), cc.ravel()))
        return r, c, np.stack(found, axis=-1).reshape(*rr.shape, 3)

    def projected_scales(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, p, q) of a projected grid at these places: a grid metre along grid azimuth a is
        s sqrt(1 + p cos 2a + q sin 2a) true metres (at :attr:`height` above the ellipsoid;
        :mod:`oclshade.solar.scale`), s the root mean square over the directions; p = q = 0 where that is within
        :data:`STRETCH_NOISE` of all directions' (a conformal projection).  From the metric of a
        grid metre, by central differences of :data:`STEP_METRES` along the grid's columns and
        rows through the CRS and the ellipsoid's geodesics (pyproj)."""
        lon, lat = np.asarray(lon, np.float64), np.asarray(lat, np.float64)
        to_grid, to_place = self._transformers
        step = STEP_METRES / self.crs.axis_info[0].unit_conversion_factor     # grid units
        geod = self.crs.get_geod()
        ground = []
        x, y = (np.asarray(v, np.float64) for v in to_grid.transform(lon, lat))
        ends = [(to_place.transform(x - dx, y - dy), to_place.transform(x + dx, y + dy))
                for dx, dy in ((step, 0.0), (0.0, step))]
        for (lon0, lat0), (lon1, lat1) in ends:
            forward, back, metres = (np.asarray(v, np.float64) for v in geod.inv(lon0, lat0, lon1, lat1))
            forward, back = np.radians(forward), np.radians(back)
            # the azimuth at the middle: the mean of the forward ones at both ends (back + 180 at the far end)
            middle = np.arctan2(np.sin(forward) - np.sin(back), np.cos(forward) - np.cos(back))
            ground.append((middle, metres / (2 * STEP_METRES)))
        (a_e, s_e), (a_n, s_n) = ground
        if not (np.all(np.isfinite(s_e)) and np.all(np.isfinite(s_n))):
            raise ValueError("part of the map lies outside where its CRS is defined")
        m_ee, m_nn, m_en = s_e * s_e, s_n * s_n, s_e * s_n * np.cos(a_n - a_e)   # the metric of a grid metre
        mean = (m_ee + m_nn) / 2.0          # s(a)^2 = mean (1 + p cos 2a + q sin 2a)
        p, q = (m_nn - m_ee) / (2.0 * mean), m_en / mean
        still = np.hypot(p, q) <= STRETCH_NOISE
        return np.sqrt(mean) * height_factor(self.height), np.where(still, 0.0, p), np.where(still, 0.0, q)

    @cached_property
    def _transformers(self) -> tuple[Any, Any]:
        """(to the grid, to the ground) of a projected grid; ValueError where PROJ cannot make them."""
        from pyproj import Transformer
        from pyproj.exceptions import ProjError

        try:
            return (Transformer.from_crs(self.crs.geodetic_crs, self.crs, always_xy=True),
                    Transformer.from_crs(self.crs, self.crs.geodetic_crs, always_xy=True))
        except ProjError as exc:
            raise ValueError(f"its CRS ({self.crs.name}) cannot carry places to the ground "
                             f"({' '.join(str(exc).split())})") from None

    def row_scales(self) -> np.ndarray:
        """:attr:`_row_scales` (made once per map; read-only)."""
        return self._row_scales

    @cached_property
    def _row_scales(self) -> np.ndarray:
        """float64 (rows, 2) (east, north) on a geographic grid, (rows, m, 4) (east, north, p, q)
        in m column bands (:func:`oclshade.solar.scale.column_edges`) on a projected one
        (:mod:`oclshade.solar.scale`): each row's scales, what :class:`oclshade.horizon.HorizonCaster`
        traces the horizons with and a sun given by its angles is blocked by (:func:`banded_field`):
        a geographic grid's :meth:`grid_scales` at the row's middle (all 1 where all are within
        half of :func:`scale_share` of 1: traced as it is); a projected grid's, in each column band,
        the middle of their extremes along the row's stretch of it (bilinear on the lattice: at
        its columns and the band's edges), m the fewest (up to
        :func:`oclshade.solar.scale.max_column_bands`) that keep every stretch's spread (the scales'
        share plus :func:`oclshade.solar.scale.stretch_share`) within
        :data:`oclshade.solar.scale.SEGMENT_SHARE` of the half share (UTM far from its meridian, or
        a whole equal-area tile, changes along the rows); all (1, 1, 0, 0) where the whole map is
        near 1 (traced as it is)."""
        rows, cols = self.shape
        middle = np.arange(rows) + 0.5
        if self.crs is None:     # all within half the share of 1: traced at the centre's width, as it is
            scales = np.stack(self.grid_scales(middle, np.full(rows, cols / 2.0)), axis=-1)
            scales = np.ones((rows, 2)) if np.all(_near_one(scales)) else scales
            scales.setflags(write=False)
            return scales
        lattice_cols = self._scale_lattice[1]
        along = self._lattice_scale(np.repeat(middle, SCALE_LATTICE), np.tile(lattice_cols, rows))
        along = along.reshape(rows, SCALE_LATTICE, 3)
        if np.all(_identity(along)):        # (bilinear: a row's extremes lie at the lattice's columns)
            scales = np.tile([1.0, 1.0, 0.0, 0.0], (rows, 1, 1))
            scales.setflags(write=False)
            return scales
        allowed, most, bands = SEGMENT_SHARE * scale_share() / 2.0, max_column_bands(cols), 1
        while True:
            lo, hi = _stretch_extremes(along, lattice_cols, column_edges(cols, bands))
            spread = ((hi[..., 0] - lo[..., 0]) / (hi[..., 0] + lo[..., 0])
                      + stretch_share(np.insert(lo, 0, lo[..., 0], axis=-1), np.insert(hi, 0, hi[..., 0], axis=-1)))
            over = float(spread.max()) / allowed
            if over <= 1.0 or bands == most:
                break
            bands = min(most, max(bands + 1, math.ceil(bands * over)))
        scale, p, q = np.moveaxis((lo + hi) / 2.0, -1, 0)
        scales = np.stack([scale, scale, p, q], axis=-1)
        scales.setflags(write=False)
        return scales

    @cached_property
    def scale_residual(self) -> float:
        """:meth:`residual_of` the map's own :meth:`row_scales`."""
        return self.residual_of(self.row_scales())

    def residual_of(self, row_scales: np.ndarray) -> float:
        """Degrees: what tracing each block at these row scales (float64 (rows[, column bands], 4),
        :func:`oclshade.solar.scale.scale_blocks`) leaves of the grid's own distortion, at most,
        over a 9 x 9 lattice: a grid metre's length in a direction a share d off its block's
        moves an angle by at most d / 2 radians (the scales' change within a block, and any
        stretch by direction they do not follow: the largest d over :data:`RESIDUAL_AZIMUTHS`
        grid azimuths).  0 on a geographic grid."""
        if self.crs is None:
            return 0.0
        rows, cols = self.shape
        r, c = np.meshgrid(np.linspace(0.5, rows - 0.5, LATTICE), np.linspace(0.5, cols - 0.5, LATTICE), indexing="ij")
        lon, lat = self.lonlat(r.ravel(), c.ravel())
        scale, p, q = self.projected_scales(lon, lat)
        here = np.stack([scale, scale, p, q], axis=-1)
        blocks = scale_blocks(self.shape, row_scales, DEFAULT_TOLERANCE)
        block = blocks.scales[blocks.block_of(r.ravel(), c.ravel())]
        azimuths = np.radians(np.arange(RESIDUAL_AZIMUTHS) * (180.0 / RESIDUAL_AZIMUTHS))[None, :]
        sin, cos = np.sin(azimuths), np.cos(azimuths)
        true = scale[:, None] * stretch_of(here[:, None, :], sin, cos)
        traced = block[:, None, 0] * stretch_of(block[:, None, :], sin, cos)
        return float(np.degrees(np.max(np.abs(true / traced - 1.0)) / 2.0))

    def far_scale_rate(self, dx: float, dy: float) -> float:
        """Per true metre: the most by which a grid metre's true length in a direction changes, as a
        share, along that direction (|d ln m(a) / dD|, m(a) the true metres of a grid metre at grid
        azimuth a, D the true distance), over a :data:`FAR_LATTICE`-square lattice over the map
        and :data:`RESIDUAL_AZIMUTHS` directions (central differences between the lattice's
        points; ``dx``, ``dy``: the grid metres of a cell east and north, the heightmap's).  A ray
        keeps its cell's block scale along its whole length (docs/methods.md, "Projected grids":
        "Far terrain"); this rate bounds what that leaves (:meth:`far_residual`).  Web Mercator
        at latitude f: tan f / R (the scale is sec f); a geographic grid's: 0.385 tan f / R
        (only its east width changes, with latitude); UTM at x from its meridian: about x / R^2."""
        rows, cols = self.shape
        r, c = np.linspace(0.0, rows, FAR_LATTICE), np.linspace(0.0, cols, FAR_LATTICE)
        rr, cc = np.meshgrid(r, c, indexing="ij")
        if self.crs is None:
            east, north = self.grid_scales(rr, cc)
            scales = np.stack([east, north], axis=-1)
        else:                                       # (not snapped to 1, as grid_scales is: no false steps)
            s, p, q = self.projected_scales(*self.lonlat(rr.ravel(), cc.ravel()))
            scales = np.stack([s, s, p, q], axis=-1).reshape(*rr.shape, 4)
        a = np.radians(np.arange(RESIDUAL_AZIMUTHS) * (180.0 / RESIDUAL_AZIMUTHS))
        sin, cos = np.sin(a), np.cos(a)
        sc = scales[..., None, :]
        metres = np.hypot(sc[..., 0] * sin, sc[..., 1] * cos) * stretch_of(sc, sin, cos)    # (r, c, a)
        log_m = np.log(metres)
        d_row, d_col = np.gradient(log_m, r * dy, c * dx, axis=(0, 1))       # per grid metre south, east
        along = d_col * sin - d_row * cos                                     # along grid azimuth a
        rate = float(np.max(np.abs(along) / metres))
        return rate if math.isfinite(rate) else math.inf           # (a cell of no width: a pole)

    def far_residual(self, relief: float, dx: float, dy: float, drop: float = 0.0) -> float:
        """Degrees: what a ray keeping its cell's block scale along its length leaves, at most, of
        an angle to terrain at most ``relief`` metres above the cell (first order): a point D
        true metres away is traced at a distance off by a share of at most rate D / 2
        (:meth:`far_scale_rate`), which moves its angle atan(dh / D) by at most
        rate dh cos^2 / 2 <= rate relief / 2 radians; with curvature (``drop``: its drop
        across the map, metres) :func:`far_residual_of`.  (Below the horizontal the depth, within
        the relief, takes its place; with curvature the bound is for angles at or above it: a
        sun's, and those the sky-view factors take.)"""
        return far_residual_of(self.far_scale_rate(dx, dy), relief, drop)

    def on_grid(self, rows: np.ndarray, cols: np.ndarray, azimuth: np.ndarray, elevation: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """Directions at these places (cell coordinates; grid azimuths, elevations in degrees)
        as the grid traces them (:func:`scaled_suns` at :meth:`grid_scales`).  A grid metre east
        is ``sx`` true metres and north ``sy``: the direction that runs over the same ground is
        turned to azimuth atan2(sin a / sx, cos a / sy) (on a projected grid, sx = sy: unturned)
        and, the grid distance being 1 / s of the true one (s = 1 / |(sin a / sx, cos a / sy)|,
        on a projected grid s(a) with its stretch by direction), raised to elevation atan(s tan e).
        A ray at that sun crosses the same cells at the same heights as the true one: the cast
        shadows are the Earth's, not the grid's (docs/methods.md, "Geographic grids" and
        "Projected grids")."""
        azimuth, elevation = np.asarray(azimuth, np.float64), np.asarray(elevation, np.float64)
        return scaled_suns(np.stack(self.grid_scales(rows, cols), axis=-1), azimuth, elevation)

    def suns(self, when: datetime | Sequence[datetime] | Sun, rows: np.ndarray, cols: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
        """(azimuth, elevation) in degrees, as the grid traces them (:meth:`on_grid`), of the sun
        at these places: at ``when`` (NREL SPA; flat arrays over the places for one time, (times,
        places) for a sequence of times), or the same ``Sun`` everywhere (a direction on the grid:
        on a geographic one, the true azimuth at each place)."""
        rows, cols = np.asarray(rows, np.float64).ravel(), np.asarray(cols, np.float64).ravel()
        if isinstance(when, Sun):
            return self.on_grid(rows, cols, np.full(rows.shape, when.azimuth), np.full(rows.shape, when.elevation))
        lon, lat = self.lonlat(rows, cols)
        many = not isinstance(when, datetime)
        times = np.array(list(when) if many else [when], dtype=object)[:, None]
        position = sun_position(times, lat, lon)
        shape = (len(times), len(lon))
        lat = np.broadcast_to(lat, shape)
        grid = self.grid_azimuths(np.broadcast_to(lon, shape).ravel(), lat.ravel(),
                                  np.broadcast_to(position.azimuth, shape).ravel()).reshape(shape)
        grid, elevation = self.on_grid(np.broadcast_to(rows, shape), np.broadcast_to(cols, shape), grid,
                                       np.broadcast_to(position.elevation, shape))
        return (grid, elevation) if many else (grid[0], elevation[0])


def far_residual_of(rate: float, relief: float, drop: float = 0.0) -> float:
    """Degrees: :meth:`MapPlaces.far_residual` of a map whose :meth:`MapPlaces.far_scale_rate` is
    ``rate`` (per true metre): rate relief / 2 radians, and with curvature, whose drop c D^2
    reaches ``drop`` metres across the map, rate (relief + min(relief, drop)) / 2: a tangent
    (dh - c D^2) / D traced at a distance a share d off moves by d (dh + c D^2) / D, and at or
    above the horizontal c D^2 <= dh."""
    relief = max(float(relief), 0.0)
    return float(np.degrees(rate * (relief + min(relief, max(float(drop), 0.0))) / 2.0))


def _near_one(scale: np.ndarray) -> np.ndarray:
    """Where a scale is within half of :func:`scale_share` of 1: traced as 1, the grid as it is
    (the angles move by at most 0.01 / sqrt(2) degree)."""
    return np.abs(scale - 1.0) <= scale_share() / 2.0


def _identity(scales: np.ndarray) -> np.ndarray:
    """Where a projected grid's (s, p, q) (..., 3) has every direction's length within half of
    :func:`scale_share` of 1 (|s - 1| plus half |(p, q)|): traced as the grid is."""
    return np.abs(scales[..., 0] - 1.0) + np.hypot(scales[..., 1], scales[..., 2]) / 2.0 <= scale_share() / 2.0


def _as_one(scales: np.ndarray) -> np.ndarray:
    """(s, p, q) (..., 3), (1, 0, 0) where :func:`_identity`."""
    return np.where(_identity(scales)[..., None], np.array([1.0, 0.0, 0.0]), scales)


def _stretch_extremes(along: np.ndarray, lattice_cols: np.ndarray, edges: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), float64 (rows, bands, 3): the extremes of each row's (s, p, q) over each column
    band [edges[b], edges[b + 1]], from its values at the lattice's columns (``along``: (rows,
    lattice columns, 3)), linear between them (bilinear at a fixed row): at the lattice columns
    within the band and at its edges."""
    j = np.clip(np.searchsorted(lattice_cols, edges, side="right") - 1, 0, len(lattice_cols) - 2)
    f = ((edges - lattice_cols[j]) / (lattice_cols[j + 1] - lattice_cols[j]))[None, :, None]
    at_edges = along[:, j] * (1.0 - f) + along[:, j + 1] * f
    bands = len(edges) - 1
    lo, hi = np.empty((len(along), bands, 3)), np.empty((len(along), bands, 3))
    for b in range(bands):
        inside = (lattice_cols > edges[b]) & (lattice_cols < edges[b + 1])
        samples = np.concatenate([at_edges[:, b:b + 2], along[:, inside]], axis=1)
        lo[:, b], hi[:, b] = samples.min(axis=1), samples.max(axis=1)
    return lo, hi


def scaled_suns(scales: np.ndarray, azimuth: np.ndarray, elevation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`MapPlaces.on_grid` where a grid metre has these ``scales`` (..., 2 or 4:
    (east, north) true metres, and a projected grid's stretch by direction (p, q),
    :mod:`oclshade.solar.scale`): the grid azimuth and elevation, degrees, of directions on the
    ground (a projected grid's azimuths are grid azimuths already)."""
    scales = np.asarray(scales, np.float64)
    sx, sy = scales[..., 0], scales[..., 1]
    a, e = np.radians(azimuth), np.radians(elevation)
    sa, ca = np.sin(a), np.cos(a)
    east, north = sa / sx, ca / sy
    stretch = stretch_of(scales, sa, ca)
    s = stretch / np.hypot(east, north)
    se, ce = np.sin(e), np.cos(e)
    same = (sx == 1.0) & (sy == 1.0) & (stretch == 1.0)      # the centre's own scale: the sun as given, to the bit
    return (np.where(sx == sy, azimuth, np.mod(np.degrees(np.arctan2(east, north)), 360.0)),
            np.where(same | (np.abs(elevation) >= 90.0), elevation, np.degrees(np.arctan2(s * se, ce))))


def scaled_sun_vectors(scales: np.ndarray, sun: Sun) -> np.ndarray:
    """(..., 3) :func:`unit_vectors` of :func:`scaled_suns` of one sun at these ``scales``, by
    algebra rather than through angles (no trigonometry per place: a field's deviation over
    every row and column band, :func:`banded_field`): the grid azimuth's sine and cosine are
    (sin a / sx, cos a / sy) over their length, and tan e' = s tan e gives cos e' = cos e / r,
    sin e' = s sin e / r with r = |(cos e, s sin e)|."""
    scales = np.asarray(scales, np.float64)
    a, e = math.radians(sun.azimuth), math.radians(sun.elevation)
    sa, ca, se, ce = math.sin(a), math.cos(a), math.sin(e), math.cos(e)
    east, north = sa / scales[..., 0], ca / scales[..., 1]
    length = np.hypot(east, north)
    s = stretch_of(scales, sa, ca) / length
    r = np.hypot(ce, s * se)
    return np.stack([east / length * (ce / r), north / length * (ce / r), s * se / r], axis=-1)


_METRES_PER_DEGREE = np.frompyfunc(metres_per_degree, 1, 2)


def map_places(raster: Raster, z_factor: float = 1.0) -> MapPlaces | None:
    """A raster's :class:`MapPlaces`: geographic or projected (pyproj identifies its CRS) and
    georeferenced, its ground metres at the middle of its heights (:meth:`Raster.extremes`,
    times ``z_factor``, as the heightmap takes them: metres); None otherwise.  Raises ValueError
    as :func:`oclshade.solar.site.projected_crs`."""
    transform = geotransform(raster.georef)
    if transform is None:
        return None
    found = projected_crs(raster)
    if found is None and not raster.geographic:
        return None
    lo, hi = raster.extremes()
    middle = float(z_factor) * (lo + hi) / 2.0 if hi >= lo else 0.0       # (all nodata: NaN, none)
    return MapPlaces(tuple(float(v) for v in transform), raster.heights.shape, found[0] if found else None, middle)


def checked_places(raster: Raster, z_factor: float = 1.0, curvature: float = 0.0
                   ) -> tuple[MapPlaces | None, list[str]]:
    """(:func:`map_places` with its row scales made, what to warn of): a projected raster whose
    CRS pyproj cannot identify or carry to the ground has none (its grid metres are the
    ground's), and a projection that one scale per band of rows cannot follow is named
    (:attr:`MapPlaces.scale_residual` past the tolerance), and so is a map whose relief (its
    heights times ``z_factor``: metres) moves angles past it: a grid whose scale changes fast
    enough along a ray (:meth:`MapPlaces.far_residual`), and ground metres taken at the map's
    middle height (:func:`oclshade.solar.scale.height_residual_of`); ``curvature``: the drop per
    square metre of a run with curvature (:attr:`oclshade.horizon.Curvature.coefficient`; 0: none),
    which raises the first.  A geographic raster's problem raises ValueError.  What the CLI and
    :meth:`oclshade.heightmap.Heightmap.from_raster` (without curvature) take."""
    lo, hi = raster.extremes()
    if raster.heights_range is None:            # (read once: map_places takes them from the raster)
        raster = dataclasses.replace(raster, heights_range=(lo, hi))
    try:
        places = map_places(raster, z_factor)
        residual = 0.0 if places is None else places.scale_residual      # (a projected grid's: through its CRS)
    except ValueError as exc:
        if raster.geographic:
            raise
        return None, [f"{exc}: its grid metres are taken as the ground's"]
    notes = []
    if residual > DEFAULT_TOLERANCE:
        notes.append(f"its projection stretches lengths by direction or along its rows by more than one scale "
                     f"per band of rows follows: angles within {residual:.3f} deg (docs/methods.md, "
                     f"\"Projected grids\")")
    if places is None:
        return places, notes
    relief = abs(float(z_factor)) * (hi - lo) if hi >= lo else 0.0              # (all nodata: NaN, none)
    rows, cols = places.shape
    diagonal = math.hypot(rows * raster.dy, cols * raster.dx) * float(np.max(places.row_scales()[..., :2]))
    drop = float(curvature) * diagonal ** 2                        # true metres
    rate = places.far_scale_rate(raster.dx, raster.dy)
    far, heights = far_residual_of(rate, relief, drop), height_residual_of(relief)
    if far + heights > DEFAULT_TOLERANCE:
        causes = [f"{heights:.3f} deg as ground metres are taken at the heights' middle, {places.height:.0f} m"]
        if far > 0.0:
            dropped = f", curvature's drop of up to {min(drop, relief):.0f} m with it" if drop > 0.0 else ""
            causes.insert(0, f"{far:.3f} deg as a ray keeps its cell's ground metre, whose length changes by "
                             f"{100.0 * rate * 1e5:.3g} % per 100 km{dropped}")
        if far > heights:
            causes.append("a grid whose scale changes less, such as a UTM zone, keeps them closer")
        notes.append(f"with {relief:.0f} m of relief, angles to terrain within {far + heights:.3f} deg beyond the "
                     f"scale's {DEFAULT_TOLERANCE:g} ({'; '.join(causes)}; docs/methods.md, \"Far terrain\")")
    return places, notes


def unit_vectors(azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
    """(..., 3) unit vectors (east, north, up) of directions in degrees."""
    az, el = np.radians(azimuth), np.radians(elevation)
    return np.stack([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)], axis=-1)


def angles_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles in degrees between unit vectors (..., 3): 2 asin(|a - b| / 2), the chord's form,
    exact for tiny angles (within 1e-6 degree of 180 it loses digits, which two suns' angles
    never come near) and a third of the cross product's time."""
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    half = np.sqrt(np.einsum("...i,...i->...", d, d)) / 2.0
    return np.degrees(2.0 * np.arcsin(np.minimum(half, 1.0)))


def sun_differences(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`angles_between` two suns' unit vectors, 0 where both are at or below the horizon
    (every cell is in shadow either way; SPA's refraction also jumps by 0.57 degrees where the
    sun's upper limb sets, :func:`oclshade.solar.refraction_correction`)."""
    both_down = (a[..., 2] <= 0.0) & (b[..., 2] <= 0.0)
    return np.where(both_down, 0.0, angles_between(a, b))


def sun_field(places: MapPlaces, when: datetime | Sun, tolerance: float = DEFAULT_TOLERANCE) -> SunField:
    """The sun over the map at ``when`` (timezone-aware; or a ``Sun``, the same direction on the
    grid at every cell: on a geographic grid, its scale is then all that varies), each cell's
    own within ``tolerance`` degrees of its block's (see the module docstring)."""
    if not (isinstance(tolerance, (int, float)) and tolerance > 0.0 and math.isfinite(tolerance)):
        raise ValueError(f"tolerance must be a positive number of degrees, got {tolerance!r}")
    if isinstance(when, Sun):
        return banded_field(places.row_scales(), places.shape[1], when, float(tolerance))
    rows, cols = places.shape
    centre, spread, r, c, v = _lattice(places, when)
    if spread <= tolerance:
        return SunField.single(centre, places.shape, spread, float(tolerance),
                               tuple(float(scale[0]) for scale in places.grid_scales([rows / 2.0], [cols / 2.0])))
    per_row = sun_differences(v[1:], v[:-1]).max() / (r[1] - r[0])
    per_col = sun_differences(v[:, 1:], v[:, :-1]).max() / (c[1] - c[0])
    budget, smallest = float(tolerance), (min(ALIGN, rows), min(ALIGN, cols))
    aligned = True            # multiples of ALIGN until the smallest such block has been tried
    for _ in range(MAX_SHRINK):
        shape = _aligned_shape(per_row, per_col, budget, rows, cols) if aligned else None
        if aligned and shape is None:
            shape = smallest
        if shape == smallest:
            aligned = False
        if shape is None:
            shape = _balanced_shape(per_row, per_col, budget, rows, cols)
        grid, deviation = _block_suns(places, when, *shape)
        if deviation <= tolerance:
            return SunField(places.shape, BlockGrid(*grid), centre, deviation, float(tolerance))
        budget *= 0.9 * tolerance / deviation
    grid, deviation = _block_suns(places, when, 1, 1)      # each cell its own sun: deviation 0
    return SunField(places.shape, BlockGrid(*grid), centre, deviation, float(tolerance))


def banded_field(row_scales: np.ndarray, cols: int, sun: Sun, tolerance: float = DEFAULT_TOLERANCE
                 ) -> SunField:
    """A sun given by its angles on a grid whose rows have these scales (float64 (rows, 2 or 4) or
    (rows, m, 2 or 4), :meth:`MapPlaces.row_scales`: geographic or projected), on a map ``cols``
    wide: one block per block of :func:`oclshade.solar.scale.scale_blocks` (the blocks a
    :class:`HorizonCaster` with these rows' scales traces: a mask and the horizons at its azimuth
    then see the same lines), each with the sun as the grid traces it at the block's scale."""
    rows = len(row_scales)
    blocks = scale_blocks((rows, cols), row_scales, tolerance)
    per_row = np.asarray(row_scales, np.float64).reshape(rows, -1, np.shape(row_scales)[-1])  # (rows, column bands, k)
    own = scaled_sun_vectors(per_row, sun)
    az, el = scaled_suns(blocks.scales, np.full(blocks.scales.shape[:2], sun.azimuth),
                         np.full(blocks.scales.shape[:2], sun.elevation))
    band = np.repeat(np.arange(len(az)), np.diff(blocks.row_edges))
    deviation = float(sun_differences(own, unit_vectors(az, el)[band]).max())
    if az.size == 1:
        return SunField.single(Sun(float(az[0, 0]), float(el[0, 0])), (rows, cols), deviation, tolerance,
                               tuple(float(v) for v in blocks.scales[0, 0]))
    return SunField((rows, cols), BlockGrid(blocks.row_edges, blocks.col_edges, az, el, blocks.scales),
                    sun, deviation, tolerance)


def on_heightmap(heightmap: Heightmap, sun: Traced) -> Traced:
    """What a caster traces for ``sun`` on ``heightmap``: a sun given by its angles on a heightmap
    with :attr:`~oclshade.heightmap.Heightmap.row_scales` (a georeferenced raster's) as its
    :func:`banded_field`; a field, or a sun on a heightmap without them, as it is."""
    if heightmap.row_scales is None or isinstance(sun, SunField):
        return sun
    return banded_field(heightmap.row_scales, heightmap.shape[1], sun)


def sun_spread(places: MapPlaces, times: Sequence[datetime]) -> float:
    """The largest angle in degrees between the sun at the map's centre and at its corners, over
    the times."""
    rows, cols = places.shape
    az, el = places.suns(times, np.array([rows / 2, 0, 0, rows, rows]), np.array([cols / 2, 0, cols, 0, cols]))
    v = unit_vectors(az, el)
    return float(sun_differences(v[:, 1:], v[:, :1]).max())


def _lattice(places: MapPlaces, when: datetime) -> tuple[Sun, float, np.ndarray, np.ndarray, np.ndarray]:
    """The centre's sun, the spread, and the lattice's rows, columns and (9, 9, 3) sun vectors."""
    rows, cols = places.shape
    az, el = places.suns(when, np.array([rows / 2]), np.array([cols / 2]))
    r = np.linspace(0.0, rows, LATTICE)
    c = np.linspace(0.0, cols, LATTICE)
    rr, cc = np.meshgrid(r, c, indexing="ij")
    v = unit_vectors(*places.suns(when, rr, cc)).reshape(LATTICE, LATTICE, 3)
    corners = v[[0, 0, -1, -1], [0, -1, 0, -1]]
    spread = float(sun_differences(corners, unit_vectors(az, el)).max())
    return Sun(float(az[0]), float(el[0])), spread, r, c, v


def _aligned_shape(per_row: float, per_col: float, budget: float, rows: int, cols: int) -> tuple[int, int] | None:
    """(block rows, block cols), multiples of :data:`ALIGN` (or the map's side), of the largest
    area whose half turns per_row rows / 2 and per_col cols / 2 add up as perpendicular vectors to
    at most ``budget`` degrees; None if none does.  A guess: the caller checks the corners."""
    best = (0, 0, 0)
    for h in range(ALIGN, rows + ALIGN, ALIGN):
        h = min(h, rows)
        rows_turn = per_row * h / 2.0
        if rows_turn >= budget:
            break
        left = math.sqrt(budget * budget - rows_turn * rows_turn)   # the half turn the columns may take
        if left < per_col * min(ALIGN, cols) / 2.0:
            break
        w = cols if per_col == 0.0 else min(cols, int(2.0 * left / per_col) // ALIGN * ALIGN)
        w = _long_run(w, cols)
        best = max(best, (h * w, h, w))
    return (best[1], best[2]) if best[0] else None


def _balanced_shape(per_row: float, per_col: float, budget: float, rows: int, cols: int) -> tuple[int, int]:
    """(block rows, block cols), any number of cells, whose half turns add up to ``budget``
    degrees even in line, each direction taking half."""
    height = budget / per_row if per_row > 0 else float(rows)
    width = budget / per_col if per_col > 0 else float(cols)
    return max(1, min(rows, int(height))), max(1, min(cols, int(width)))


def _long_run(width: int, cols: int) -> int:
    """A width that is a multiple of ALIGN, made a multiple of 4 ALIGN from 8 ALIGN on (long packet
    runs keep the lanes full), unless it is the whole map's."""
    return width if width >= cols or width < 8 * ALIGN else width // (4 * ALIGN) * (4 * ALIGN)


def _outermost(edges: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The centres of the first and last cells of the blocks between ``edges`` (sorted, once
    each), and for each block the index of its first's and its last's among them."""
    first, last = edges[:-1] + 0.5, edges[1:] - 0.5
    lines, where = np.unique(np.concatenate([first, last]), return_inverse=True)
    return lines, (where[:len(first)], where[len(first):])


def _block_suns(places: MapPlaces, when: datetime, block_rows: int, block_cols: int
                ) -> tuple[tuple[np.ndarray, ...], float]:
    """The blocks of this size, as :class:`BlockGrid`'s arrays (row edges, column edges, centre
    sun azimuths and elevations, and on a geographic grid the scales there), and the largest
    angle between a block's sun and the sun at any of its corners (small blocks: of its
    outermost cells' centres)."""
    rows, cols = places.shape
    edge_r = np.append(np.arange(0, rows, block_rows), rows)
    edge_c = np.append(np.arange(0, cols, block_cols), cols)
    mid_r, mid_c = np.meshgrid((edge_r[:-1] + edge_r[1:]) / 2.0, (edge_c[:-1] + edge_c[1:]) / 2.0, indexing="ij")
    az, el = places.suns(when, mid_r, mid_c)
    centres = unit_vectors(az, el).reshape(len(edge_r) - 1, len(edge_c) - 1, 3)
    if block_rows >= ALIGN and block_cols >= ALIGN:     # the blocks' corners: shared, a bound for their cells
        top, bottom = np.arange(len(edge_r) - 1), np.arange(1, len(edge_r))
        left, right = np.arange(len(edge_c) - 1), np.arange(1, len(edge_c))
        lines_r, lines_c = edge_r.astype(np.float64), edge_c.astype(np.float64)
    else:        # small blocks: their outermost cells' centres (a cell's sun is its centre's; 1 x 1 holds)
        lines_r, (top, bottom) = _outermost(edge_r)
        lines_c, (left, right) = _outermost(edge_c)
    er, ec = np.meshgrid(lines_r, lines_c, indexing="ij")
    v = unit_vectors(*places.suns(when, er, ec)).reshape(len(lines_r), len(lines_c), 3)
    deviation = max(float(sun_differences(centres, v[np.ix_(rows_at, cols_at)]).max())
                    for rows_at in (top, bottom) for cols_at in (left, right))
    grid = tuple(np.ascontiguousarray(np.reshape(a, centres.shape[:2]), np.float64) for a in (az, el))
    # each row of blocks' scale at its middle row, on the map's middle column (the sunshine's beam
    # reads it: kernels/sunshine.cl, "sun tables")
    scales = np.stack(places.grid_scales(mid_r[:, 0], np.full(len(mid_r), cols / 2.0)), axis=-1)
    return (edge_r, edge_c, *grid, scales), deviation
