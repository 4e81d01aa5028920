"""Sky-view factor: closed forms on a V-shaped valley, the device sums against the float64 definition,
and the error of N azimuths."""
from __future__ import annotations

import math

import numpy as np
import pytest

from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.horizon import HorizonCaster, azimuth_grid


def valley(slope: float, dx: float = 10.0) -> Heightmap:
    """h = slope |x| across a north-south valley: bilinear exactly, so a floor cell's horizon at
    azimuth phi is atan(slope |sin phi|) wherever the ray starts inside the map."""
    x = (np.arange(61) - 30) * dx
    return Heightmap.from_array(np.tile(slope * np.abs(x), (21, 1)), dx)


@pytest.mark.parametrize("slope", [0.2, 1.0, 3.0])
def test_valley_floor_closed_forms(slope):
    """1/2pi int sin^2(atan(s |sin phi|)) dphi = 1 - 1/sqrt(1 + s^2), and
    1/2pi int sin(atan(s |sin phi|)) dphi = (2/pi) atan(s)."""
    hm = valley(slope)
    caster = HorizonCaster(hm)
    floor = (slice(1, -1), 30)
    angles = caster.horizons(16)[(slice(None),) + floor]
    phi = np.radians(azimuth_grid(16))[:, None]
    np.testing.assert_allclose(angles, np.broadcast_to(np.degrees(np.arctan(slope * np.abs(np.sin(phi)))), angles.shape), atol=1e-5)
    cosine = caster.sky_view_factor(64, "cosine")[floor]
    np.testing.assert_allclose(cosine, 1.0 / math.sqrt(1.0 + slope * slope), atol=1e-6)
    solid = caster.sky_view_factor(1024, "solid-angle")[floor]
    np.testing.assert_allclose(solid, 1.0 - 2.0 / math.pi * math.atan(slope), atol=2e-5)


def test_flat_ground_sees_the_whole_sky():
    hm = Heightmap.from_array(np.full((9, 11), 250.0), 30.0)
    for definition in ("cosine", "solid-angle"):
        svf = HorizonCaster(hm).sky_view_factor(8, definition)
        assert np.all(svf == 1.0)     # interior: horizons 0; edges: -90, counted as 0


def test_device_sums_equal_the_definition():
    """The device's Kahan sums against 1 - mean over azimuths of the terms of the float64 reference
    horizons (the definition), on rough terrain with holes."""
    rng = np.random.default_rng(8)
    h = np.cumsum(rng.normal(size=(31, 44)), axis=1) * 30.0
    h[10:13, 20:25] = np.nan
    hm = Heightmap.from_array(h, 30.0)
    caster = HorizonCaster(hm)
    azimuths = azimuth_grid(12)
    horizons = np.stack([ref.horizon_angles(hm, az) for az in azimuths])
    band = math.radians(ref.angle_tolerance(hm))          # |d sin h| and |d sin^2 h| <= |dh|
    for definition in ("cosine", "solid-angle"):
        svf = caster.sky_view_factor(12, definition)
        expected = ref.sky_view_factor(horizons, definition)
        assert np.array_equal(np.isnan(svf), np.isnan(expected))
        assert np.nanmax(np.abs(svf - expected)) <= band + 1e-6
        assert np.nanmin(svf) < 0.95 and np.nanmax(svf) <= 1.0


def test_error_shrinks_with_the_number_of_azimuths():
    """The azimuth sampling error against a fine reference (256) falls from 16 to 64 azimuths."""
    rng = np.random.default_rng(5)
    y, x = np.mgrid[0:48, 0:48]
    h = 400.0 * np.sin(x / 6.0) * np.cos(y / 8.0) + 30.0 * rng.random((48, 48))
    caster = HorizonCaster(Heightmap.from_array(h, 30.0))
    for definition in ("cosine", "solid-angle"):
        fine = caster.sky_view_factor(256, definition)
        errors = [float(np.mean(np.abs(caster.sky_view_factor(n, definition) - fine))) for n in (16, 64)]
        assert errors[1] < 0.5 * errors[0], f"{definition}: mean errors {errors}"


def test_reference_definition_checks_its_argument():
    with pytest.raises(ValueError, match="definition"):
        ref.sky_view_factor(np.zeros((4, 2, 2)), "hemisphere")
