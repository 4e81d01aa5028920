"""The sun's topocentric azimuth and elevation by NREL's Solar Position Algorithm.

Reda & Andreas, "Solar Position Algorithm for Solar Radiation Applications",
NREL/TP-560-34302 (revised 2008); equation numbers below are the report's
(section 3). Stated uncertainty: +-0.0003 degrees for the years -2000..6000,
given the right Delta T. Vectorised over times and observers (numpy broadcasting).

=====================  ========================================================
quantity               convention
=====================  ========================================================
times                  timezone-aware ``datetime`` (one, or a sequence/array of
                       them), or ``numpy.datetime64`` values, read as UTC
                       (naive datetimes are refused); UTC is taken as UT1
                       (|UT1 - UTC| < 0.9 s: at most 0.004 degrees)
latitude               degrees north, [-90, 90]
longitude              degrees east, [-180, 180]
altitude               observer's height above sea level, metres (parallax)
pressure, temperature  hPa and degrees Celsius (refraction only)
delta_t                TT - UT1 in seconds; default ``delta_t_estimate``
azimuth (result)       degrees clockwise from north, [0, 360) (as ``oclshade.Sun``)
elevation (result)     degrees above the horizon, topocentric; apparent
                       (refracted) unless ``refraction=False``
=====================  ========================================================
"""
from __future__ import annotations

from datetime import datetime, timezone
from typing import Any, Iterable, NamedTuple, Union

import numpy as np
from numpy.typing import ArrayLike

from ..sun import Sun
from .spa_tables import EARTH, NUTATION

Times = Union[datetime, Iterable[datetime], np.datetime64, np.ndarray]

J2000 = datetime(2000, 1, 1, 12, tzinfo=timezone.utc)  # JD 2451545.0
EARTH_RADIUS_M = 6378140.0  # SPA eq. 38-39
SUN_RADIUS_DEG = 0.26667  # SPA's refraction cut-off: -(sun radius + refraction at the horizon)
HORIZON_REFRACTION_DEG = 0.5667
DEFAULT_PRESSURE_HPA = 1010.0  # with 10 C, the conditions the refraction formula is normalised to
DEFAULT_TEMPERATURE_C = 10.0

_EARTH = {name: np.array(rows, dtype=np.float64) for name, rows in EARTH.items()}
_NUT_Y = np.array([row[:5] for row in NUTATION], dtype=np.float64)
_NUT_ABCD = np.array([row[5:] for row in NUTATION], dtype=np.float64)


class SunPosition(NamedTuple):
    """Arrays of the broadcast shape of the times and the observer's arguments."""

    azimuth: np.ndarray    # degrees clockwise from north, [0, 360)
    elevation: np.ndarray  # degrees above the horizon


def sun_position(times: Times, latitude: ArrayLike, longitude: ArrayLike, *, altitude: ArrayLike = 0.0,
                 pressure: ArrayLike = DEFAULT_PRESSURE_HPA, temperature: ArrayLike = DEFAULT_TEMPERATURE_C,
                 refraction: bool = True, delta_t: ArrayLike | None = None) -> SunPosition:
    """Topocentric azimuth and elevation of the sun's centre (SPA; conventions in the module docstring).

    Refraction (``refraction=True``, as SPA) adds SPA eq. 42, Bennett's formula
    scaled to the local air:
    ``(pressure / 1010) * (283 / (273 + temperature)) * 1.02 / (60 * tan(e0 + 10.3 / (e0 + 5.11)))``
    degrees (e0: the unrefracted elevation in degrees), and, as SPA, only while
    e0 >= -(0.26667 + 0.5667) degrees (the sun's upper limb at the horizon).
    """
    seconds = _seconds_since_j2000(times)
    lat = _checked("latitude", latitude, -90.0, 90.0)
    lon = _checked("longitude", longitude, -180.0, 180.0)
    alt = _checked("altitude", altitude)
    dt = delta_t_estimate(2000.0 + seconds / (365.25 * 86400.0)) if delta_t is None else _checked("delta_t", delta_t)
    jd = seconds / 86400.0            # JD - 2451545 (UT), eq. 4
    jc = jd / 36525.0                 # eq. 5
    jce = (jd + dt / 86400.0) / 36525.0  # eqs. 5-7 (TT)
    jme = jce / 10.0

    # Earth's heliocentric position (eqs. 9-14) and the sun's geocentric one (eqs. 13-14)
    big_l = np.degrees(_series("L", jme)) % 360.0
    big_b = np.degrees(_series("B", jme))
    big_r = _series("R", jme)
    theta = (big_l + 180.0) % 360.0
    beta = -big_b

    # nutation (eqs. 15-23) and the true obliquity of the ecliptic (eqs. 24-25)
    x = np.stack([_polynomial(jce, c) for c in _NUTATION_ARGUMENTS], axis=-1)  # degrees, (..., 5)
    arg = np.radians(x @ _NUT_Y.T)  # (..., 63)
    a, b, c, d = _NUT_ABCD.T
    dpsi = np.sum((a + b * jce[..., None]) * np.sin(arg), axis=-1) / 36e6  # degrees
    deps = np.sum((c + d * jce[..., None]) * np.cos(arg), axis=-1) / 36e6
    eps = _polynomial(jme / 10.0, _OBLIQUITY_ARCSEC) / 3600.0 + deps

    # apparent sun longitude (eqs. 26-27), sidereal time (eqs. 28-29), right ascension and declination (eqs. 30-33)
    lam = theta + dpsi - 20.4898 / (3600.0 * big_r)
    nu = (280.46061837 + 360.98564736629 * jd + jc ** 2 * (0.000387933 - jc / 38710000.0)) % 360.0
    nu = nu + dpsi * np.cos(np.radians(eps))
    lam_r, eps_r, beta_r = np.radians(lam), np.radians(eps), np.radians(beta)
    alpha = np.degrees(np.arctan2(np.sin(lam_r) * np.cos(eps_r) - np.tan(beta_r) * np.sin(eps_r), np.cos(lam_r)))
    dec_r = np.arcsin(np.sin(beta_r) * np.cos(eps_r) + np.cos(beta_r) * np.sin(eps_r) * np.sin(lam_r))

    # topocentric hour angle and declination: parallax (eqs. 34-40)
    h_r = np.radians((nu + lon - alpha) % 360.0)
    xi_r = np.radians(8.794 / (3600.0 * big_r))
    lat_r = np.radians(lat)
    u = np.arctan(0.99664719 * np.tan(lat_r))
    px = np.cos(u) + alt / EARTH_RADIUS_M * np.cos(lat_r)
    py = 0.99664719 * np.sin(u) + alt / EARTH_RADIUS_M * np.sin(lat_r)
    denominator = np.cos(dec_r) - px * np.sin(xi_r) * np.cos(h_r)
    dalpha = np.arctan2(-px * np.sin(xi_r) * np.sin(h_r), denominator)
    dec_topo_r = np.arctan2((np.sin(dec_r) - py * np.sin(xi_r)) * np.cos(dalpha), denominator)
    h_t = h_r - dalpha

    # elevation (eqs. 41-43) and azimuth (eqs. 44-46)
    e0 = np.degrees(np.arcsin(np.sin(lat_r) * np.sin(dec_topo_r) + np.cos(lat_r) * np.cos(dec_topo_r) * np.cos(h_t)))
    elevation = e0 + refraction_correction(e0, pressure, temperature) if refraction else e0
    gamma = np.degrees(np.arctan2(np.sin(h_t), np.cos(h_t) * np.sin(lat_r) - np.tan(dec_topo_r) * np.cos(lat_r)))
    return SunPosition(np.asarray((gamma + 180.0) % 360.0), np.asarray(elevation))  # gamma in [-180, 180]


def refraction_correction(elevation: ArrayLike, pressure: ArrayLike = DEFAULT_PRESSURE_HPA,
                          temperature: ArrayLike = DEFAULT_TEMPERATURE_C) -> np.ndarray:
    """SPA eq. 42: degrees to add to an unrefracted elevation (degrees); 0 below
    -(0.26667 + 0.5667) degrees, where the whole sun is below the horizon."""
    cutoff = -(SUN_RADIUS_DEG + HORIZON_REFRACTION_DEG)
    e0 = np.asarray(elevation, dtype=np.float64)
    p = _checked("pressure", pressure, 0.0, np.inf, closed=False)
    t = _checked("temperature", temperature, -273.0, np.inf, closed=False)
    e = np.maximum(e0, cutoff)  # the formula's pole at -5.11 lies below the cut-off
    bent = (p / 1010.0) * (283.0 / (273.0 + t)) * 1.02 / (60.0 * np.tan(np.radians(e + 10.3 / (e + 5.11))))
    return np.where(e0 >= cutoff, bent, 0.0)


def suns_at(times: Times, latitude: float, longitude: float, **options: Any) -> list[Sun]:
    """``oclshade.Sun`` objects for the times at one place (options as ``sun_position``), in order."""
    position = sun_position(times, latitude, longitude, **options)
    return [Sun(float(az), float(el)) for az, el in zip(position.azimuth.ravel(), position.elevation.ravel())]


def delta_t_estimate(year: ArrayLike) -> np.ndarray:
    """TT - UT1 in seconds for decimal years: Espenak & Meeus (2006), "Polynomial
    expressions for Delta T" (NASA Five Millennium Canon of Solar Eclipses), the
    pieces from 1900 to 2150, and their long-term parabola outside.

    Against the observed values it is within 1 s from 1900 to 2005 and drifts
    above them after (2024: 73.9 s against 69.2 s observed); after today it is a
    forecast. Each second of error moves the sun by 0.0000114 degrees (only the
    sun's orbital motion uses TT), so 250 s of error cost at most 0.003 degrees.
    """
    y = np.asarray(year, dtype=np.float64)
    u = (y - 1820.0) / 100.0
    pieces = [
        (y < 1900.0, -20.0 + 32.0 * u ** 2),
        (y < 1920.0, _polynomial(y - 1900.0, (-2.79, 1.494119, -0.0598939, 0.0061966, -0.000197))),
        (y < 1941.0, _polynomial(y - 1920.0, (21.20, 0.84493, -0.076100, 0.0020936))),
        (y < 1961.0, _polynomial(y - 1950.0, (29.07, 0.407, -1.0 / 233.0, 1.0 / 2547.0))),
        (y < 1986.0, _polynomial(y - 1975.0, (45.45, 1.067, -1.0 / 260.0, -1.0 / 718.0))),
        (y < 2005.0, _polynomial(y - 2000.0, (63.86, 0.3345, -0.060374, 0.0017275, 0.000651814, 0.00002373599))),
        (y < 2050.0, _polynomial(y - 2000.0, (62.92, 0.32217, 0.005589))),
        (y < 2150.0, -20.0 + 32.0 * u ** 2 - 0.5628 * (2150.0 - y)),
    ]
    return np.select([p[0] for p in pieces], [p[1] for p in pieces], default=-20.0 + 32.0 * u ** 2)


# --- helpers ------------------------------------------------------------------------------

# X0..X4 in degrees as cubic polynomials of JCE (eqs. 15-19) and the mean obliquity in arcseconds (eq. 24)
_NUTATION_ARGUMENTS = (
    (297.85036, 445267.111480, -0.0019142, 1.0 / 189474.0),
    (357.52772, 35999.050340, -0.0001603, -1.0 / 300000.0),
    (134.96298, 477198.867398, 0.0086972, 1.0 / 56250.0),
    (93.27191, 483202.017538, -0.0036825, 1.0 / 327270.0),
    (125.04452, -1934.136261, 0.0020708, 1.0 / 450000.0),
)
_OBLIQUITY_ARCSEC = (84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45)


def _polynomial(x: np.ndarray, coefficients: tuple[float, ...]) -> np.ndarray:
    """sum(c_k * x**k), lowest power first."""
    return np.polynomial.polynomial.polyval(x, coefficients)


def _series(letter: str, jme: np.ndarray) -> np.ndarray:
    """SPA eqs. 9-11: sum_i jme**i * sum(A cos(B + C jme)) over the tables L0.., B0.., R0.., / 1e8."""
    total = np.zeros_like(jme)
    for power in reversed(range(sum(name[0] == letter for name in _EARTH))):
        table = _EARTH[f"{letter}{power}"]
        term = np.sum(table[:, 0] * np.cos(table[:, 1] + table[:, 2] * jme[..., None]), axis=-1)
        total = total * jme + term
    return total / 1e8


def _checked(name: str, value: ArrayLike, low: float = -np.inf, high: float = np.inf, *,
             closed: bool = True) -> np.ndarray:
    """value as a float array, or ValueError naming the argument and its range."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or an array of numbers, got {value!r}") from None
    inside = (array >= low) & (array <= high) if closed else (array > low) & (array < high)
    if not np.all(np.isfinite(array) & inside):
        bad = float(array[~(np.isfinite(array) & inside)].ravel()[0])
        bounds = f"{'[' if closed else '('}{low:g}, {high:g}{']' if closed else ')'}"
        raise ValueError(f"{name} must be finite" + ("" if np.isinf([low, high]).all() else f" and in {bounds}")
                         + f", got {bad:g}")
    return array


def _seconds_since_j2000(times: Times) -> np.ndarray:
    """UTC seconds since 2000-01-01T12:00Z (leap seconds not counted, as POSIX time)."""
    array = np.asarray(times)
    if array.dtype.kind == "M":
        if np.isnat(array).any():
            raise ValueError("times must not contain NaT")
        since = array.astype("datetime64[us]") - np.datetime64("2000-01-01T12:00:00", "us")
        return since.astype(np.int64) / 1e6
    if array.dtype != object:
        raise TypeError(f"times must be timezone-aware datetimes or numpy datetime64 (UTC), got {array.dtype} values")
    seconds = np.empty(array.shape, dtype=np.float64)
    for index, value in np.ndenumerate(array):
        if not isinstance(value, datetime) or value.utcoffset() is None:
            raise ValueError(f"times must be timezone-aware datetimes (e.g. tzinfo=timezone.utc) or numpy "
                             f"datetime64 (UTC), got {value!r}")
        seconds[index] = (value - J2000).total_seconds()
    return seconds
