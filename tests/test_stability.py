"""The numerical-stability catalogue: each case a test; no NaN in outputs, no hang."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade import ShadowCaster, Sun, cast_shadows
from oclshade.heightmap import Heightmap

from test_shadows import assert_exact


def bumpy(rows: int = 40, cols: int = 50, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:rows, 0:cols]
    return 30.0 * np.sin(x / 4.0) * np.cos(y / 6.0) + 5.0 * rng.random((rows, cols))


def outputs_are_clean(hm: Heightmap, sun: Sun) -> None:
    res = ShadowCaster(hm).cast(sun, outputs="all")
    valid = hm.valid
    assert set(np.unique(res.mask[valid])) <= {0, 1}
    assert set(np.unique(res.self_shadow[valid])) <= {0, 1}
    assert np.isfinite(res.coefficient[valid]).all()
    assert (res.mask[~valid] == 255).all() and np.isnan(res.coefficient[~valid]).all()


@pytest.mark.parametrize("alt", [0.01, 89.99, 90.0])
def test_extreme_elevations(alt):
    hm = Heightmap.from_array(bumpy(), 10.0)
    assert_exact(hm, Sun(123.0, alt))
    outputs_are_clean(hm, Sun(123.0, alt))


def test_zenith_casts_nothing_and_grazing_sun_shadows_most():
    hm = Heightmap.from_array(bumpy(), 10.0)
    caster = ShadowCaster(hm)
    assert caster.cast((10.0, 90.0)).mask.sum() == 0
    assert caster.cast((10.0, 0.01)).mask.mean() > 0.5


@pytest.mark.parametrize("az", [0.0, 90.0, 180.0, 270.0, 1e-6, 90.0 + 1e-6, 180.0 - 1e-6, 270.0 + 1e-6, 360.0 - 1e-6])
def test_axis_aligned_and_nearly_aligned_azimuths(az):
    h = bumpy()
    h[10:13, 20:24] = np.nan
    assert_exact(Heightmap.from_array(h, 10.0), Sun(az, 15.0))


def test_axis_aligned_rays_use_the_grid_line_profile():
    # a wall one sample wide in column 5: rays exactly along row 2 from the west hit it
    h = np.zeros((5, 10))
    h[:, 5] = 100.0
    mask = cast_shadows(h, 1.0, (270.0, 30.0)).mask     # sun in the west: cells east of the wall
    assert mask[2, 6:8].tolist() == [1, 1] and mask[2, :5].sum() == 0


def test_large_offset_keeps_precision():
    h = bumpy()
    base = ShadowCaster(Heightmap.from_array(h, 10.0)).cast((200.0, 12.0)).mask
    hm = Heightmap.from_array(h + 1e6, 10.0)
    assert_exact(hm, Sun(200.0, 12.0))
    assert np.array_equal(ShadowCaster(hm).cast((200.0, 12.0)).mask, base)


def test_tiny_relief():
    h = bumpy() * 1e-3 / 35.0            # about 1 mm of relief
    hm = Heightmap.from_array(h, 1e-3)   # on 1 mm cells
    assert_exact(hm, Sun(80.0, 5.0))
    assert 0 < ShadowCaster(hm).cast((80.0, 5.0)).mask.sum()


def test_tiny_relief_on_huge_offset():
    hm = Heightmap.from_array(bumpy() * 1e-3 / 35.0 + 1e6, 1e-3)
    assert_exact(hm, Sun(80.0, 5.0))


@pytest.mark.parametrize("value", [0.0, 1e6, -400.0])
def test_flat_maps_are_lit(value):
    res = ShadowCaster(Heightmap.from_array(np.full((17, 23), value), 5.0)).cast((45.0, 0.01), outputs="all")
    assert res.mask.sum() == 0 and res.self_shadow.sum() == 0 and (res.coefficient == 1.0).all()


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (2, 2), (1, 2)])
@pytest.mark.parametrize("az", [0.0, 90.0, 180.0, 270.0, 33.0])
def test_degenerate_shapes(shape, az):
    h = np.arange(np.prod(shape), dtype=float).reshape(shape)[::-1, ::-1] * 3.0
    hm = Heightmap.from_array(h, 1.0)
    assert_exact(hm, Sun(az, 10.0))
    outputs_are_clean(hm, Sun(az, 10.0))


def test_single_row_profile_shadows_along_the_row():
    h = np.array([[0.0, 0.0, 50.0, 0.0, 0.0]])
    mask = cast_shadows(h, 1.0, (90.0, 20.0)).mask    # sun in the east
    assert mask.tolist() == [[1, 1, 0, 0, 0]]


def test_anisotropic_cells():
    hm = Heightmap.from_array(bumpy(), (3.0, 40.0))
    for az in (30.0, 100.0, 250.0):
        assert_exact(hm, Sun(az, 8.0))


def test_nan_holes_are_nodata_and_do_not_occlude():
    h = np.zeros((20, 20))
    h[8:12, 8:12] = np.nan
    h[10, 14] = 500.0                   # a spike east of the hole
    h[10, 2] = 5.0
    res = cast_shadows(h, 1.0, (90.0, 10.0), outputs="all")
    assert (res.mask[8:12, 8:12] == 255).all() and np.isnan(res.coefficient[8:12, 8:12]).all()
    assert res.mask[10, 13] == 1 and res.mask[10, 6] == 1     # the spike's shadow crosses the hole
    assert_exact(Heightmap.from_array(h, 1.0), Sun(90.0, 10.0))


def test_all_nodata_map():
    res = cast_shadows(np.full((4, 5), np.nan), 1.0, (10.0, 10.0), outputs="all")
    assert (res.mask == 255).all() and (res.self_shadow == 255).all()


@pytest.mark.parametrize("bad", [np.inf, -np.inf])
def test_infinities_rejected(bad):
    h = bumpy()
    h[3, 3] = bad
    with pytest.raises(ValueError, match="infinite"):
        cast_shadows(h, 1.0, (0.0, 10.0))


@pytest.mark.parametrize("bad", [np.array([["a", "b"]]), np.zeros((3, 3), bool), np.zeros((3, 3), complex)])
def test_non_numeric_dtypes_rejected(bad):
    with pytest.raises(TypeError, match="heights must be a real numeric array"):
        cast_shadows(bad, 1.0, (0.0, 10.0))


@pytest.mark.parametrize("bad", [np.zeros(5), np.zeros((2, 2, 2)), np.zeros((0, 4))])
def test_bad_shapes_rejected(bad):
    with pytest.raises(ValueError, match="heights must"):
        cast_shadows(bad, 1.0, (0.0, 10.0))


@pytest.mark.parametrize("alt", [0.0, -5.0])
def test_sun_at_or_below_horizon_shadows_everything(alt):
    h = bumpy()
    h[0, 0] = np.nan
    res = cast_shadows(h, 1.0, (0.0, alt), outputs="all", k_dark=0.3)
    valid = ~np.isnan(h)
    assert (res.mask[valid] == 1).all() and (res.self_shadow[valid] == 1).all()
    assert np.allclose(res.coefficient[valid], 0.3)


@pytest.mark.parametrize("kwargs,match", [
    ({"sun": (0.0, 91.0)}, "elevation"), ({"sun": (np.nan, 10.0)}, "azimuth"),
    ({"cellsize": 0.0}, "cellsize"), ({"cellsize": (1.0, -2.0)}, "dy"),
    ({"method": "fast"}, "method"), ({"outputs": "shade"}, "outputs"), ({"k_dark": 2.0}, "k_dark"),
])
def test_bad_arguments_name_themselves(kwargs, match):
    args = {"cellsize": 1.0, "sun": (0.0, 10.0)} | kwargs
    with pytest.raises(ValueError, match=match):
        cast_shadows(bumpy(), **args)
