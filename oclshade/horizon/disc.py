"""Soft shadows: the share of the sun's disc each cell sees, from its exact horizons.

The disc, of angular radius ``radius`` (default :data:`SUN_RADIUS`; uniform, without limb
darkening), is taken in the sky's tangent plane at the sun's centre: x = (azimuth - az)
cos(e) across, y = elevation - e up (exact to first order in the radius, ample for 0.27
degrees).  It is cut into ``columns`` vertical strips of equal width; in each, the part of
the strip's chord above the cell's exact horizon angle h at the strip's middle azimuth is
visible (the kernel's horizons, :class:`~oclshade.horizon.HorizonCaster`):

    f = sum_k clip(e + c_k - h_k, 0, 2 c_k) / sum_k 2 c_k,
    x_k = -r + (k + 1/2) w,  w = 2 r / columns,  c_k = sqrt(r^2 - x_k^2)

(the midpoint rule over x, normalised by the same rule's disc area, so a disc wholly
above the horizon reads exactly 1).  The only approximation is that rule across the disc: within a
strip the horizon is taken as its value at the middle.  A straight line through the
horizons at the disc's edges and centre was tried first and dropped: a nearby occluder's
edge makes the horizon jump inside the disc (errors up to 0.5 of the disc on the
generated canyon).  The error against the float64 reference with 256 strips
(:func:`oclshade.reference.sun_disc_fraction`), per number of strips, is in
docs/methods.md "Soft shadows"; the default, :data:`DEFAULT_COLUMNS`, is chosen there.
"""
from __future__ import annotations

import math

import numpy as np

from ..solar.scale import stretch_of
from ..sun import SunLike, as_sun, libm, unscaled

_cos = libm(math.cos)

#: mean apparent angular radius of the sun, degrees (diameter 31.99 arc minutes)
SUN_RADIUS = 0.2666
#: strips across the disc by default (docs/methods.md "Soft shadows")
DEFAULT_COLUMNS = 16


def check_disc(radius: float, columns: int) -> tuple[float, int]:
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and 0.0 < radius <= 5.0):
        raise ValueError(f"radius (the sun disc's angular radius) must be in (0, 5] degrees, got {radius!r}")
    if not isinstance(columns, (int, np.integer)) or isinstance(columns, bool) or not 1 <= columns <= 1024:
        raise ValueError(f"columns (strips across the sun's disc) must be an integer in 1..1024, got {columns!r}")
    return float(radius), int(columns)


def disc_columns(sun: SunLike, radius: float = SUN_RADIUS, columns: int = DEFAULT_COLUMNS
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(azimuths of the strips' middles in [0, 360), their half-chords c_k), degrees, float64."""
    sun = as_sun(sun)
    azimuths, half_chords = disc_columns_of(np.array([sun.azimuth]), np.array([sun.elevation]), radius, columns)
    return azimuths[0], half_chords


def disc_columns_of(azimuth: np.ndarray, elevation: np.ndarray, radius: float = SUN_RADIUS,
                    columns: int = DEFAULT_COLUMNS) -> tuple[np.ndarray, np.ndarray]:
    """:func:`disc_columns` of many suns (degrees, (n,) each): azimuths (n, columns), and the
    half-chords (columns,), the same for every sun."""
    radius, columns = check_disc(radius, columns)
    elevation = np.asarray(elevation, np.float64)
    if not np.all(np.abs(elevation) < 90.0 - radius):
        bad = float(elevation[~(np.abs(elevation) < 90.0 - radius)][0])
        raise ValueError(f"elevation must leave the whole disc between the nadir and the zenith "
                         f"(|elevation| < {90.0 - radius:g} degrees), got {bad!r}")
    width = 2.0 * radius / columns
    x = -radius + (np.arange(columns) + 0.5) * width
    azimuths = (np.asarray(azimuth, np.float64)[:, None] + x / _cos(np.radians(elevation))[:, None]) % 360.0
    return azimuths, np.sqrt(radius * radius - x * x)


def disc_stretch(scales: np.ndarray, azimuth: np.ndarray, elevation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(stretch, sky) per grid sun (degrees, (n,) each): how much taller the disc is on a
    scaled grid than on the sky, and the sun's elevation on the sky.  Where a grid metre along
    the sun's grid direction is s true metres (``scales``: (n, 2 or 4) east and north and a
    projected grid's stretch by direction, :attr:`oclshade.sun.SunField.scales`), the grid traces elevation e as e' = atan(s tan e)
    (:meth:`oclshade.solar.MapPlaces.on_grid`), so a chord of the disc c high is de'/de c =
    (s^2 cos^2 e' + sin^2 e') / s c on the grid (to first order in the radius), and the strips'
    azimuths are spread by the sky's e = atan(tan e' / s) (a projected grid's azimuths are the
    grid's, s its length that way; a geographic one's turns them by at most 1 % of the disc).  (1, e') where the scales are 1: the disc as on the sky, to the bit."""
    scales = np.asarray(scales, np.float64)
    elevation = np.asarray(elevation, np.float64)
    a, e = np.radians(azimuth), np.radians(elevation)
    sa, ca = np.sin(a), np.cos(a)
    s = np.hypot(scales[:, 0] * sa, scales[:, 1] * ca) * stretch_of(scales, sa, ca)
    same = unscaled(scales)
    stretch = np.where(same, 1.0, (s * s * np.cos(e) ** 2 + np.sin(e) ** 2) / s)
    return stretch, np.where(same, elevation, np.degrees(np.arctan(np.tan(e) / s)))


def visible_fraction(horizons, elevation: float, half_chords: np.ndarray) -> np.ndarray:
    """The visible share of the disc, float64, from the horizon angles (degrees; an iterable
    of per-strip arrays, one per :func:`disc_columns` azimuth; NaN stays NaN).  A half-chord
    may be an array (a scaled grid's disc, :func:`disc_stretch`, per cell)."""
    total, whole = None, 0.0
    for h, c in zip(horizons, half_chords):
        seen = np.clip((elevation + c) - np.asarray(h, np.float64), 0.0, 2.0 * c)   # exact at 0 and 2c
        total = seen if total is None else total + seen
        whole += 2.0 * c               # summed in the same order: a disc seen whole reads exactly 1
    return total / whole
