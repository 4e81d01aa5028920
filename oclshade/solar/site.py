"""Where a raster lies on the Earth and which way its grid faces.

A sun from a date and time (NREL SPA) has a *true* azimuth: clockwise from north along the
meridian.  Every kernel traces *grid* azimuths: clockwise from up the raster's columns (the
heights are held north-up, :func:`oclshade.io.require_north_up`).  The two agree on a
geographic grid, whose columns are meridians, but not on a projected one: up its columns is
the CRS's grid north, turned from true north by the meridian convergence (UTM: up to about
3 degrees at a zone's edge), and on a projection that is not conformal the turn also depends
on the direction.  :class:`MapSite` converts each true azimuth through the CRS (pyproj): the
grid direction of a 10 m step along that azimuth from the site.

The site is the map's centre, or the place given.  One sun serves the whole map (its rays are
parallel), so one conversion at the site does too.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..heightmap import InputWarning
from ..io import Raster, crs_text, geokey, geotransform
from ..sun import Sun

STEP_METRES = 10.0   # the step whose grid direction gives a true azimuth's grid azimuth


@dataclass(frozen=True)
class MapSite:
    """The place of a map's suns (degrees; longitude east) and the projected CRS its grid is
    laid out in (None: a geographic grid, or no CRS, where grid azimuths are true azimuths)."""

    latitude: float
    longitude: float
    crs: Any = field(default=None, repr=False)
    crs_name: str = ""

    def grid_azimuths(self, true_azimuths: Sequence[float] | np.ndarray) -> np.ndarray:
        """The grid azimuths (degrees in [0, 360)) of directions at these true azimuths here."""
        az = np.asarray(true_azimuths, dtype=np.float64)
        if self.crs is None:
            return np.mod(az, 360.0)
        grid = grid_azimuths(self.crs, np.full(az.shape, self.longitude), np.full(az.shape, self.latitude), az)
        if not np.all(np.isfinite(grid)):
            raise ValueError(f"latitude {self.latitude:.6f}, longitude {self.longitude:.6f} lies outside where "
                             f"the map's CRS ({self.crs_name}) is defined")
        return grid

    def grid_suns(self, suns: Sequence[Sun]) -> list[Sun]:
        """The suns with their true azimuths turned to grid azimuths (elevations unchanged)."""
        if self.crs is None:
            return list(suns)
        grid = self.grid_azimuths([sun.azimuth for sun in suns])
        return [Sun(float(az), sun.elevation) for az, sun in zip(grid, suns)]


def grid_azimuths(crs: Any, lon: np.ndarray, lat: np.ndarray, true_azimuths: np.ndarray,
                  to_grid: Any = None) -> np.ndarray:
    """Place by place, the grid azimuth in a projected ``crs`` (pyproj) of the direction at
    ``true_azimuths`` (degrees) from (``lon``, ``lat``): that of a 10 m geodesic step along it,
    in [0, 360); NaN where the place lies outside the CRS's domain.  ``to_grid``: the CRS's
    transformer from its geodetic CRS, if the caller keeps one (None: made here)."""
    from pyproj import Transformer

    if to_grid is None:
        to_grid = Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True)
    lon2, lat2, _ = crs.get_geod().fwd(lon, lat, true_azimuths, np.full(np.shape(lon), STEP_METRES))
    x0, y0 = to_grid.transform(lon, lat)
    x1, y1 = to_grid.transform(lon2, lat2)
    return np.mod(np.degrees(np.arctan2(np.asarray(x1) - np.asarray(x0), np.asarray(y1) - np.asarray(y0))), 360.0)


def projected_crs(raster: Raster) -> tuple[Any, str] | None:
    """(pyproj CRS, its name) of a raster laid out in a projected CRS that pyproj identifies
    (the WKT the reader kept, else the EPSG code of its GeoTIFF keys); None for a geographic
    raster or one without a CRS.  Raises ValueError for a projected CRS that cannot be
    identified (GeoTIFF keys without an EPSG code, or WKT pyproj cannot read)."""
    if raster.geographic:
        return None
    text = crs_text(raster)
    if text is None:
        if geokey(raster.georef.get(34735, ()), 1024) == 1:      # projected, but no code
            raise ValueError("its projected CRS has no EPSG code or WKT oclshade can read, so the turn of "
                             "its grid from true north is not known")
        return None
    import pyproj

    try:
        crs = pyproj.CRS.from_user_input(text)
    except pyproj.exceptions.CRSError as exc:
        raise ValueError(f"its CRS cannot be read by pyproj ({' '.join(str(exc).split())})") from None
    if crs.is_geographic:
        return None
    if not crs.is_projected:
        raise ValueError(f"its CRS ({crs.name}) is neither geographic nor projected")
    return crs, (crs.to_string() if crs.to_epsg() is not None else crs.name)


def map_centre(raster: Raster) -> tuple[float, float] | None:
    """(x, y) of the raster's centre in its CRS's units, from its georeferencing; else None."""
    transform = geotransform(raster.georef)
    if transform is None:
        return None
    x0, xc, xr, y0, yc, yr = transform
    rows, cols = raster.heights.shape
    return x0 + xc * cols / 2 + xr * rows / 2, y0 + yc * cols / 2 + yr * rows / 2


def map_site(raster: Raster, latitude: float | None = None, longitude: float | None = None) -> MapSite | None:
    """The site of a raster's suns: (``latitude``, ``longitude``) when given, else the raster's
    centre (a geographic raster's, or a projected one's through its CRS); None when neither is
    known.  A projected CRS that cannot be identified raises ValueError, unless the place is
    given: its grid azimuths are then taken as true ones, with an :class:`InputWarning`."""
    try:
        found = projected_crs(raster)
    except ValueError as exc:
        if latitude is None:
            raise
        warnings.warn(f"{raster.path}: {exc}: sun azimuths are used as grid azimuths", InputWarning, stacklevel=2)
        found = None
    crs, name = found if found is not None else (None, "")
    if latitude is not None and longitude is not None:
        return MapSite(float(latitude), float(longitude), crs, name)
    centre = map_centre(raster)
    if centre is None or not (raster.geographic or crs is not None):
        return None
    x, y = centre
    if crs is None:
        return MapSite(y, x)
    from pyproj import Transformer

    lon, lat = Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True).transform(x, y)
    if not (np.isfinite(lon) and np.isfinite(lat)):
        raise ValueError(f"its centre ({x:.6g}, {y:.6g}) lies outside where its CRS ({name}) is defined")
    return MapSite(float(lat), float(lon), crs, name)
