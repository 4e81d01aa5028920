"""A projected grid's metre on the ground, measured directly: the float64 twin of
:meth:`oclshade.solar.MapPlaces.projected_scales` and its stretch by direction
(:mod:`oclshade.solar.scale`).  The tracing models a grid metre along grid azimuth a as
s sqrt(1 + p cos 2a + q sin 2a) from central differences along the grid's columns and rows;
this measures the length along a itself, by the ellipsoid's geodesic between the grid points
``step`` grid metres either side (pyproj alone), so the model is checked against a measure it
does not share."""
from __future__ import annotations

import math


def ground_metre(places, row: float, col: float, azimuth: float, step: float = 500.0) -> float:
    """True metres of one grid metre at cell coordinates (``row``, ``col``) of ``places`` (a
    projected :class:`oclshade.solar.MapPlaces`: its ``crs`` and ``transform``) along grid
    azimuth ``azimuth`` (degrees, clockwise from up the columns)."""
    from pyproj import Transformer

    crs = places.crs
    to_place = Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
    x0, xc, xr, y0, yc, yr = places.transform
    x, y = x0 + xc * col + xr * row, y0 + yc * col + yr * row
    dx, dy = step * math.sin(math.radians(azimuth)), step * math.cos(math.radians(azimuth))
    (lon0, lat0), (lon1, lat1) = to_place.transform(x - dx, y - dy), to_place.transform(x + dx, y + dy)
    return float(crs.get_geod().inv(lon0, lat0, lon1, lat1)[2] / (2.0 * step))
