"""The horizon of one site: at each true azimuth, the elevation angle of the highest terrain
along the geodesic leaving a point anywhere on a georeferenced map, at any height above its
surface (r.horizon's point mode; the horizon profile solar yield tools take), in float64 on the
host.

The map's kernels trace the grid's straight lines from every cell (docs/methods.md, "Rays along
the grid's lines, not geodesics"); one site can afford the vertical plane itself.  The path is
the geodesic on the map's ellipsoid (pyproj ``Geod.fwd``) at points :data:`STEP_SHARE` of the
smaller cell apart, joined by straight chords on the grid (each within a nanometre of the
geodesic: a chord's sagitta at 60 N is 1e-8 m for 45 m) and cut where they cross the grid's
lines, so that each piece lies in one patch of the bilinear surface.  Along a piece the surface
is a quadratic in the distance t, and so is ``f(t) = S(t) - z0 - c t^2`` (the eye at ``z0``, the
Earth's curvature and refraction as :class:`~oclshade.horizon.Curvature` has them), whose
``f / t`` the kernels' level 0 maximises in closed form (kernels/horizon.cl: the ends and the
interior critical point); here the float64 twin's (:mod:`oclshade.reference.horizons`), over
every piece, no pruning.  Distances are the ellipsoid's at the map's middle height
(:attr:`oclshade.solar.MapPlaces.height`), as the kernels' metres; the drop takes the
curvature's radius (the mean radius by default: the ellipsoid's own curvature along an azimuth
differs by up to 0.3 %, 0.003 degree at 150 km).  Holes (patches with a nodata corner) hide
nothing; the map's edge ends the path (from a site on the edge, a geodesic along it leaves the
map at once, where the kernels' grid line stays on it).  Measured against an ECEF brute force:
bench/geodesic_rays.py.
"""
from __future__ import annotations

import math

import numpy as np

from ..io import Raster
from ..reference.shadows import _segment_margin as segment_sup
from ..solar.field import map_places
from ..solar.scale import height_factor
from .caster import Curvature, as_azimuths, check_max_distance

#: geodesic points this share of the smaller cell apart: a chord then crosses at most one grid line
#: of each axis (a projected grid's scale moves a cell by well under the rest of the share)
STEP_SHARE = 0.5
#: points traced together (azimuths x points along a path: some 30 float64 arrays of them, 60 MB)
CHUNK_POINTS = 1 << 18
#: cells within which a site's row or column is taken on a grid line (a round trip's rounding, :func:`_on_line`)
SNAP = 1e-9
#: cells between two points of a path past which it has crossed a seam (a whole-Earth map's east edge onto its
#: west one, or the edge of a projection's domain): the path ends there, as it does at the map's edge
SEAM = 4.0


def site_horizon(raster: Raster, latitude: float, longitude: float, azimuths: int | np.ndarray,
                 above: float = 0.0, curvature: Curvature | None = None, max_distance: float | None = None,
                 z_factor: float = 1.0) -> np.ndarray:
    """Horizon angles (degrees, float64, one per azimuth; -90 where no terrain is seen) of the
    site at ``latitude``, ``longitude`` (degrees, WGS 84 on a geographic map, the CRS's
    geodetic datum on a projected one), ``above`` metres over the bilinear surface there,
    at these true azimuths (a count N: 360 i / N; degrees clockwise from north), along the
    geodesics (module docstring).  ``curvature`` as the kernels'; ``max_distance``: metres,
    terrain farther is not seen; ``z_factor`` scales the heights to metres.  Raises
    ValueError naming the argument: a raster with no place on the Earth, a site outside the
    map or on nodata."""
    az = as_azimuths(azimuths)
    above = float(above)
    if not math.isfinite(above) or above < 0.0:
        raise ValueError(f"above must be a finite number of metres >= 0, got {above!r}")
    for name, value, limit in (("latitude", latitude, 90.0), ("longitude", longitude, 360.0)):
        if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value) and abs(value) <= limit):
            raise ValueError(f"{name} must be finite degrees within +-{limit:g}, got {value!r}")
    places = map_places(raster, z_factor)
    if places is None:
        raise ValueError(f"raster {raster.path or ''!s}: a site needs a georeferenced raster (a geographic grid or a "
                         "projected CRS pyproj identifies)")
    heights = np.asarray(raster.heights, np.float64) * float(z_factor)
    rows, cols = heights.shape
    if rows < 2 or cols < 2:
        raise ValueError(f"raster: a site needs a map of 2 x 2 samples at least, got {rows} x {cols}")
    row, col = (_on_line(float(v[0]) - 0.5) for v in places.cells_of(np.array([longitude]), np.array([latitude])))
    if not (0.0 <= row <= rows - 1 and 0.0 <= col <= cols - 1):
        raise ValueError(f"latitude {latitude!r}, longitude {longitude!r}: the site lies outside the map "
                         f"(sample row {row:.1f} of 0..{rows - 1}, column {col:.1f} of 0..{cols - 1})")
    eye = float(_bilinear(heights, np.array([row]), np.array([col]))[0])
    if math.isnan(eye):
        raise ValueError(f"latitude {latitude!r}, longitude {longitude!r}: the site lies on nodata")
    scale = height_factor(places.height)                 # ellipsoid metres to the kernels' metres
    radius = check_max_distance(max_distance)
    reach = _reach(places, longitude, latitude)
    if radius is not None:
        reach = min(reach, float(radius) / scale)
    c = 0.0 if curvature is None else curvature.coefficient
    out = np.empty(az.size)
    step = STEP_SHARE * min(raster.dx, raster.dy) * float(np.min(places.row_scales()[..., :2]))
    k = 0
    while k < az.size:
        s = step * np.arange(int(math.ceil(reach / step)) + 1)
        chunk = az[k:k + max(1, CHUNK_POINTS // s.size)]
        path = _grid_paths(places, longitude, latitude, chunk, s, (row, col), heights.shape)
        if path is None:                                 # a chord crossing two lines of an axis: closer points
            if step < 1e-3 * min(raster.dx, raster.dy):
                raise RuntimeError(f"site_horizon: the paths from latitude {latitude!r}, longitude {longitude!r} "
                                   "cross more than a cell between points 1e-3 cell apart")
            step /= 2.0
            continue
        tangents = _path_tangents(heights, *path, s * scale, eye, above, c, None if radius is None else float(radius))
        out[k:k + chunk.size] = np.degrees(np.arctan(tangents))
        k += chunk.size
    return out


def _grid_paths(places, longitude: float, latitude: float, azimuths: np.ndarray, s: np.ndarray,
                site: tuple[float, float], shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray] | None:
    """(y, x): (azimuths, points) sample units of the geodesics from the site at distances ``s``
    (ellipsoid metres), NaN past a seam (:data:`SEAM`); None where two points on the map lie a
    grid line or more apart on an axis (the caller takes closer points)."""
    rows, cols = shape
    size = (azimuths.size, s.size)
    lon, lat, _ = places.geod.fwd(np.full(size, float(longitude)), np.full(size, float(latitude)),
                                  np.repeat(azimuths[:, None], s.size, axis=1), np.tile(s, (azimuths.size, 1)))
    y, x = (v - 0.5 for v in places.cells_of(lon, lat))
    y[:, 0], x[:, 0] = site                              # (the site itself, not its round trip)
    with np.errstate(invalid="ignore"):
        jump = np.fmax(np.abs(np.diff(y, axis=1)), np.abs(np.diff(x, axis=1)))
        seam = np.cumsum(~(jump <= SEAM), axis=1) > 0   # past a global map's seam or the CRS's domain:
        y[:, 1:][seam], x[:, 1:][seam] = np.nan, np.nan  # off the map, where the path ends
        near = (y >= -1.0) & (y <= rows) & (x >= -1.0) & (x <= cols)
    return None if np.any(near[:, 1:] & near[:, :-1] & ~seam & (jump >= 1.0)) else (y, x)


def _on_line(position: float) -> float:
    """A site's row or column (sample units) on the grid line it lies within :data:`SNAP` of.
    A cell centre's coordinates come back through PROJ some 1e-11 cell off, and a horizon from
    the surface is that sensitive there: from 1e-9 m before a patch whose profile starts
    concave (f = A + B t + C t^2, C < 0) the sup falls by 2 sqrt(A C), 3e-4 degree on a hillside."""
    nearest = round(position)
    return float(nearest) if abs(position - nearest) <= SNAP else position


def _reach(places, longitude: float, latitude: float) -> float:
    """Metres past which every geodesic from the site has left the map: the farthest corner's
    distance, plus a tenth for the paths' bend and a margin."""
    rows, cols = places.shape
    lon, lat = places.lonlat(np.array([0.0, 0.0, rows, rows]), np.array([0.0, cols, 0.0, cols]))
    far = float(np.max(places.geod.inv(np.full(4, float(longitude)), np.full(4, float(latitude)), lon, lat)[2]))
    return 1.1 * far + 1.0


def _bilinear(h: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The bilinear surface at (row y, column x) in sample units (NaN on a hole's patch)."""
    rows, cols = h.shape
    i = np.clip(np.floor(y).astype(np.int64), 0, max(rows - 2, 0))
    j = np.clip(np.floor(x).astype(np.int64), 0, max(cols - 2, 0))
    fy, fx = y - i, x - j
    i1, j1 = np.minimum(i + 1, rows - 1), np.minimum(j + 1, cols - 1)
    return (h[i, j] * (1 - fx) + h[i, j1] * fx) * (1 - fy) + (h[i1, j] * (1 - fx) + h[i1, j1] * fx) * fy


def _path_tangents(h: np.ndarray, y: np.ndarray, x: np.ndarray, t: np.ndarray, ground: float, above: float,
                   c: float, radius: float | None) -> np.ndarray:
    """Per path (row of ``y``, ``x``: sample units of its points from the site's, ``t`` their
    distances in metres), the sup over t > 0 of (S(t) - z0 - c t^2) / t along its chords, z0 =
    ``ground`` (the surface at the site) + ``above``, each chord cut at the grid's lines, at the
    map's edge (where the path ends) and at ``radius``; -inf where nothing is seen."""
    rows, cols = h.shape
    lost = ~(np.isfinite(y) & np.isfinite(x))           # past a seam: off the map, no chord into it
    y, x = np.where(lost, -2.0, y), np.where(lost, -2.0, x)
    inside = (y >= 0.0) & (y <= rows - 1) & (x >= 0.0) & (x <= cols - 1)
    ends = np.where(np.all(inside, axis=1), inside.shape[1], np.argmin(inside, axis=1))   # the first point outside
    y0, x0, y1, x1 = y[:, :-1], x[:, :-1], y[:, 1:], x[:, 1:]
    t0, span = t[:-1], np.diff(t)
    k = np.arange(y0.shape[1])
    live = k[None, :] < ends[:, None] - 1                 # both ends inside
    last = k[None, :] == ends[:, None] - 1                # leaves the map (or the radius) within the chord
    dy, dx = y1 - y0, x1 - x0
    with np.errstate(divide="ignore", invalid="ignore"):
        exit_u = np.fmin(np.where(dy > 0, (rows - 1 - y0) / dy, np.where(dy < 0, -y0 / dy, np.inf)),
                         np.where(dx > 0, (cols - 1 - x0) / dx, np.where(dx < 0, -x0 / dx, np.inf)))
        top = np.where(live, 1.0, np.where(last & ~lost[:, 1:], np.clip(exit_u, 0.0, 1.0), 0.0))
        if radius is not None:
            top = np.minimum(top, np.clip((radius - t0) / span, 0.0, 1.0)[None, :])
        cuts = [np.zeros_like(top), top]
        for p0, dp in ((x0, dx), (y0, dy)):              # the one line of each axis a chord may cross
            line = np.where(dp > 0, np.floor(p0) + 1.0, np.ceil(p0) - 1.0)
            u = (line - p0) / dp
            cuts.append(np.where((u > 0.0) & (u < top), u, top))
    cuts = np.sort(np.stack(cuts, axis=-1), axis=-1)
    best = np.full(y.shape[0], -np.inf)
    first = np.full(y.shape[0], -above)            # f where the first chord's next piece starts
    for piece in range(cuts.shape[-1] - 1):
        ua, ub = cuts[..., piece], cuts[..., piece + 1]
        sup, end = _piece_sup(h, y0, x0, dy, dx, t0, span, ua, ub, ground + above, first, c)
        first = np.where(ub[:, 0] > ua[:, 0], end, first)
        best = np.fmax(best, np.fmax.reduce(np.where(ub > ua, sup, -np.inf), axis=1))   # (NaN: a hole's patch)
    return best


def _piece_sup(h, y0, x0, dy, dx, t0, span, ua, ub, z0, first, c) -> tuple[np.ndarray, np.ndarray]:
    """(sup of f(t) / t over each piece [ua, ub] of its chord (NaN on a hole: ignored by the
    caller's fmax), f at the pieces' ends of the first chord), f the surface less z0 and the
    drop c t^2 (the kernels' closed form).  On the first chord f at the piece's start is
    ``first`` (-above at the site, then the previous pieces' ends), not S - z0 there: within a
    hair of the site that difference is all rounding, which f / t would magnify; the sum of the
    pieces' rises keeps it exact (a hole's NaN falls back to S - z0)."""
    rows, cols = h.shape
    um = (ua + ub) / 2.0
    i = np.clip(np.floor(y0 + um * dy).astype(np.int64), 0, rows - 2)
    j = np.clip(np.floor(x0 + um * dx).astype(np.int64), 0, cols - 2)
    h00, h01, h10, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
    ex, ey, kxy = h01 - h00, h10 - h00, h11 - h01 - h10 + h00
    fx, fy = x0 + ua * dx - j, y0 + ua * dy - i            # the piece's start in its patch
    rate = 1.0 / span[None, :]                              # chord parameter per metre
    s_a = h00 + ex * fx + ey * fy + kxy * fx * fy           # S at the start, its slope and curvature per metre
    s1 = ((ex + kxy * fy) * dx + (ey + kxy * fx) * dy) * rate
    s2 = kxy * dx * dy * rate * rate
    ta = t0[None, :] + ua * span[None, :]
    length = (ub - ua) * span[None, :]
    a, b = s1 - 2.0 * c * ta, s2 - c                        # f(ta + tau) = f_a + a tau + b tau^2
    f_a = (s_a - z0) - c * ta * ta
    f_a[:, 0] = np.where(np.isnan(first), f_a[:, 0], first)
    sup = segment_sup(f_a, a, b, ta, length, (ta == 0.0) & (f_a == 0.0))     # (the eye on the surface: its slope)
    return sup, f_a[:, 0] + (a[:, 0] + b[:, 0] * length[:, 0]) * length[:, 0]
