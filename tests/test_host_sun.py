"""The C host's sun position (host/src/sun.c oclshade_sun_position, oclshade_delta_t_estimate)
against the Python host's NREL SPA (oclshade.solar.sun_position) on random times from 1950 to
2100 and places, with and without refraction, through ctypes on the session's shared build of
host/; its periodic terms generated from the one Python table; its argument checks."""
from __future__ import annotations

import ctypes
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from oclshade.solar import delta_t_estimate, sun_position

from test_host_api import host  # noqa: F401  (the session build of host/)

REPO = Path(__file__).resolve().parents[1]
TOLERANCE_DEG = 1e-8    # host/src/sun.c: the time's float64 rounding and the last bits of the sums


class Options(ctypes.Structure):
    _fields_ = [("altitude", ctypes.c_double), ("pressure", ctypes.c_double), ("temperature", ctypes.c_double),
                ("delta_t", ctypes.c_double), ("refraction", ctypes.c_int)]


@pytest.fixture(scope="module")
def library(host):  # noqa: F811
    found = sorted(Path(host["build"]).glob("liboclshade.so*")) + sorted(Path(host["build"]).glob("*.dylib"))
    if not found:
        pytest.skip("the session build of host/ made no shared library here")
    lib = ctypes.CDLL(str(found[0]))
    lib.oclshade_sun_options_init.argtypes = [ctypes.POINTER(Options)]
    lib.oclshade_sun_position.argtypes = [ctypes.c_double] * 3 + [ctypes.POINTER(Options),
                                                                  ctypes.POINTER(ctypes.c_double),
                                                                  ctypes.POINTER(ctypes.c_double)]
    lib.oclshade_sun_position.restype = ctypes.c_int
    lib.oclshade_delta_t_estimate.argtypes = [ctypes.c_double]
    lib.oclshade_delta_t_estimate.restype = ctypes.c_double
    return lib


def c_sun(lib, seconds, lat, lon, options=None):
    az, el = ctypes.c_double(), ctypes.c_double()
    status = lib.oclshade_sun_position(seconds, lat, lon, None if options is None else ctypes.byref(options),
                                       ctypes.byref(az), ctypes.byref(el))
    return status, az.value, el.value


@pytest.mark.parametrize("refraction", [True, False])
def test_the_c_sun_is_the_python_sun(library, refraction):
    rng = np.random.default_rng(5)
    n = 1500
    micro = rng.integers(-631152000, 4102444800, n) * 1_000_000 + rng.integers(0, 1_000_000, n)   # 1950-2100
    lat, lon = rng.uniform(-89.0, 89.0, n), rng.uniform(-180.0, 180.0, n)
    altitude, pressure, temperature = rng.uniform(0.0, 4000.0, n), rng.uniform(600.0, 1050.0, n), rng.uniform(-30, 40, n)
    times = np.datetime64("1970-01-01T00:00:00", "us") + micro.astype("timedelta64[us]")
    expected = sun_position(times, lat, lon, altitude=altitude, pressure=pressure, temperature=temperature,
                            refraction=refraction)
    worst = 0.0
    for k in range(n):
        options = Options()
        library.oclshade_sun_options_init(ctypes.byref(options))
        options.altitude, options.pressure, options.temperature = altitude[k], pressure[k], temperature[k]
        options.refraction = int(refraction)
        status, az, el = c_sun(library, micro[k] / 1e6, lat[k], lon[k], options)
        assert status == 0
        assert 0.0 <= az < 360.0
        # the azimuth's error as an angle on the sky (it is ill-conditioned at the zenith)
        d_az = abs((az - expected.azimuth[k] + 180.0) % 360.0 - 180.0) * math.cos(math.radians(el))
        worst = max(worst, d_az, abs(el - expected.elevation[k]))
    assert worst <= TOLERANCE_DEG, worst


def test_defaults_and_delta_t(library):
    noon = 1718971200.0          # 2024-06-21T12:00Z
    options = Options()
    library.oclshade_sun_options_init(ctypes.byref(options))
    assert (options.altitude, options.pressure, options.temperature, options.refraction) == (0.0, 1010.0, 10.0, 1)
    assert math.isnan(options.delta_t)
    assert c_sun(library, noon, 47.4, 8.5, options) == c_sun(library, noon, 47.4, 8.5)   # NULL: the defaults
    options.delta_t = float(delta_t_estimate(2024.47))
    given = c_sun(library, noon, 47.4, 8.5, options)
    assert abs(given[2] - c_sun(library, noon, 47.4, 8.5)[2]) < 1e-6
    years = np.array([1850.0, 1910.0, 1930.0, 1950.0, 1980.0, 2000.0, 2020.0, 2100.0, 2200.0])
    got = np.array([library.oclshade_delta_t_estimate(y) for y in years])
    assert np.allclose(got, delta_t_estimate(years), rtol=0.0, atol=1e-9)


def test_arguments_out_of_range_are_refused(library):
    bad_options = [("pressure", 0.0), ("pressure", math.inf), ("temperature", -273.0), ("altitude", math.nan),
                   ("delta_t", math.inf), ("refraction", 2)]
    for name, value in bad_options:
        options = Options()
        library.oclshade_sun_options_init(ctypes.byref(options))
        setattr(options, name, value)
        assert c_sun(library, 0.0, 10.0, 10.0, options)[0] == 1, name
    for seconds, lat, lon in ((math.nan, 0.0, 0.0), (0.0, 90.5, 0.0), (0.0, -91.0, 0.0), (0.0, 0.0, 180.5),
                              (0.0, math.nan, 0.0)):
        assert c_sun(library, seconds, lat, lon)[0] == 1
    az = ctypes.c_double()
    assert library.oclshade_sun_position(0.0, 0.0, 0.0, None, ctypes.byref(az), None) == 1


def test_the_c_tables_are_generated_from_the_python_ones():
    check = subprocess.run([sys.executable, str(REPO / "host" / "tools" / "make_spa_tables.py"), "--check"])
    assert check.returncode == 0, "host/src/spa_tables.h is stale: run python host/tools/make_spa_tables.py"
