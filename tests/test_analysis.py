"""Scene analysis: the no-shadow bound is sound (float64 reference) and the skip is invisible
(every output identical to a full traversal)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.analysis import SceneAnalysis, slope_fronts
from oclshade.heightmap import Heightmap

ALL = ("mask", "self", "coefficient")


def brute_force_slope(hm: Heightmap, sun: Sun) -> float:
    """max over patches and their corners of grad S . (ux, uy), from the bilinear gradient
    (ex + k fy, ey + k fx) itself (not from edge differences)."""
    h = hm.relative32.astype(np.float64)
    ux, uy, _ = sun.ray(hm.dx, hm.dy)
    h00, h01, h10, h11 = h[:-1, :-1], h[:-1, 1:], h[1:, :-1], h[1:, 1:]
    ex, ey, k = h01 - h00, h10 - h00, h00 - h01 - h10 + h11
    return max(float(np.max((ex + k * fy) * ux + (ey + k * fx) * uy)) for fx in (0, 1) for fy in (0, 1))


def sun_at_tan(azimuth: float, tan_elevation: float) -> Sun:
    return Sun(azimuth, min(math.degrees(math.atan(tan_elevation)), 90.0))


def assert_same_as_traversal(hm: Heightmap, sun: Sun) -> None:
    fast = ShadowCaster(hm, cache=False).cast(sun, outputs=ALL, k_dark=0.1, k_bright=0.9)
    full = ShadowCaster(hm, cache=False, analyse=False).cast(sun, outputs=ALL, k_dark=0.1, k_bright=0.9)
    for name in ("mask", "self_shadow", "coefficient"):
        a, b = getattr(fast, name), getattr(full, name)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), name


@st.composite
def solid_terrains(draw) -> np.ndarray:
    """Maps without holes, at least 2 x 2 (where the bound applies)."""
    rows, cols = draw(st.integers(2, 40)), draw(st.integers(2, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([1e-3, 1.0, 50.0, 2000.0]))
    kind = draw(st.sampled_from(["noise", "smooth", "integer", "ramp"]))
    y, x = np.mgrid[0:rows, 0:cols]
    if kind == "noise":
        h = rng.random((rows, cols)) * scale
    elif kind == "smooth":
        h = scale * (np.sin(x / 4.0) + np.cos(y / 6.0)) + 0.05 * scale * rng.random((rows, cols))
    elif kind == "integer":
        h = np.round(rng.random((rows, cols)) * scale)
    else:
        h = scale * (rng.normal() * x + rng.normal() * y) / max(rows, cols)
    return h + draw(st.sampled_from([0.0, -500.0, 1e4, 1e6]))


azimuths = st.one_of(st.sampled_from([0.0, 45.0, 90.0, 135.0, 180.0, 270.0, 315.0]), st.floats(0.0, 360.0))
cells = st.sampled_from([(1.0, 1.0), (30.0, 30.0), (2.0, 0.5), (0.25, 3.0)])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=solid_terrains(), az=azimuths, cell=cells, rel=st.sampled_from([1e-6, 1e-3, 0.3]))
def test_skip_identical_to_traversal_around_the_bound(h, az, cell, rel):
    hm = Heightmap.from_array(h, cell)
    analysis = SceneAnalysis(hm, slope_fronts(hm))
    probe = Sun(az, 45.0)
    g = analysis.fronts.steepest_slope(*probe.ray(hm.dx, hm.dy)[:2])
    assert g == pytest.approx(brute_force_slope(hm, probe), rel=1e-12, abs=1e-300)
    lower, upper = analysis.fronts.slope_bounds(*probe.ray(hm.dx, hm.dy)[:2])
    assert lower <= g <= upper
    sampled = analysis.fronts.sampled_slope(*probe.ray(hm.dx, hm.dy)[:2])   # float32 differences
    assert sampled <= g + 1e-6 * abs(g) + 1e-30
    bound = analysis.no_shadow_bound(probe)
    above = sun_at_tan(az, max(bound + rel * abs(bound) + 1e-9, 1e-7))   # G may be < 0: downhill
    below = sun_at_tan(az, max(g - rel * abs(g), 1e-7))
    assert analysis.casts_nothing(above) or above.elevation >= 90.0 or above.ray(hm.dx, hm.dy)[2] <= \
        analysis.no_shadow_bound(above)       # float32 rounding of w may land just under
    for sun in (above, below):
        assert_same_as_traversal(hm, sun)
    if analysis.casts_nothing(above):
        # the bound is never violated: the float64 reference sees no shadow, no self-shadow
        expected = ref.cast_shadows(hm, above)
        assert np.nanmax(expected.margin) <= 0.0 and not expected.mask.any()
        assert not expected.self_shadow.any()
        assert analysis.margin(above.ray(hm.dx, hm.dy)[2]) >= ref.tie_tolerance(hm, above)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=solid_terrains(), az=azimuths, band=st.integers(1, 64))
def test_fronts_by_bands_give_the_one_band_slopes(h, az, band):
    """The fronts are computed over bands of rows and merged (bounded memory for tiled runs):
    every steepest slope equals the one of the fronts of the whole map at once, exactly."""
    import oclshade.analysis as analysis
    hm = Heightmap.from_array(h)
    whole = slope_fronts(hm)
    whole.fronts                                        # default band: one band for these sizes
    saved = analysis.FRONT_BAND_CELLS
    try:
        analysis.FRONT_BAND_CELLS = band
        banded = slope_fronts(hm)
        banded.fronts
    finally:
        analysis.FRONT_BAND_CELLS = saved
    for a in (az, az + 90.0, az + 180.0, az + 270.0):
        ux, uy = math.sin(math.radians(a)), math.cos(math.radians(a))
        assert banded.steepest_slope(ux, uy) == whole.steepest_slope(ux, uy)


def test_bound_is_tight_on_a_plane():
    """A plane rising toward the sun at slope s: shadowed just below s (beyond the tie band),
    skipped and lit just above."""
    y, x = np.mgrid[0:32, 0:48]
    s = 0.7
    hm = Heightmap.from_array(s * 10.0 * x, 10.0)       # rises eastward, slope 0.7 per metre
    analysis = SceneAnalysis(hm, slope_fronts(hm))
    east = Sun(90.0, 45.0)
    assert analysis.fronts.steepest_slope(*east.ray(10.0, 10.0)[:2]) == pytest.approx(s, rel=1e-6)
    low, high = sun_at_tan(90.0, s * 0.999), sun_at_tan(90.0, s * 1.001)
    assert not analysis.casts_nothing(low) and analysis.casts_nothing(high)
    assert ref.cast_shadows(hm, low).mask[:, :-1].all()   # every cell but the last column
    assert_same_as_traversal(hm, low)
    assert_same_as_traversal(hm, high)


def test_flat_map_casts_nothing_at_any_elevation():
    hm = Heightmap.from_array(np.full((20, 30), 123.0), 5.0)
    analysis = SceneAnalysis(hm, slope_fronts(hm))
    for elev in (0.01, 1.0, 30.0, 90.0):
        assert analysis.casts_nothing(Sun(200.0, elev))
    assert not analysis.casts_nothing(Sun(200.0, 0.0)) and not analysis.casts_nothing(Sun(200.0, -3.0))
    res = ShadowCaster(hm, cache=False).cast((200.0, 0.5), outputs=ALL)
    assert not res.mask.any() and not res.self_shadow.any() and (res.coefficient == 1.0).all()


@pytest.mark.parametrize("h", [np.array([[1.0, np.nan], [2.0, 3.0]]), np.arange(10.0)[None, :],
                               np.arange(10.0)[:, None]])
def test_no_bound_with_holes_or_one_row(h):
    hm = Heightmap.from_array(h, 1.0)
    analysis = SceneAnalysis(hm, slope_fronts(hm))
    assert analysis.fronts is None
    assert analysis.no_shadow_bound(Sun(10.0, 89.0)) == math.inf
    assert not analysis.casts_nothing(Sun(10.0, 89.9)) and not analysis.casts_nothing(Sun(10.0, 90.0))


def test_sun_above_bound_runs_no_kernel(monkeypatch):
    """The skip really skips: no launch when the analysis proves the sun casts nothing."""
    rng = np.random.default_rng(1)
    hm = Heightmap.from_array(rng.random((50, 60)) * 10.0, 30.0)    # gentle: slopes <= 1/3
    caster = ShadowCaster(hm, cache=False)
    caster.warm_up()

    def no_launch(*_a, **_k):
        raise AssertionError("a kernel was launched")

    monkeypatch.setattr(caster, "_launcher", no_launch)
    res = caster.cast((123.0, 30.0))
    assert res.mask.shape == (50, 60) and not res.mask.any()
    with pytest.raises(AssertionError, match="launched"):
        caster.cast((123.0, 5.0))


def test_jacksboro_real_dem_bound():
    """Real DEM: a sun above the bound is skipped and lit everywhere by the reference."""
    from matplotlib import cbook
    from oclshade.io import metres_per_degree

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    ew, ns = metres_per_degree(36.2)
    hm = Heightmap.from_array(elev, (ew / 1200.0, ns / 1200.0))
    caster = ShadowCaster(hm, cache=False)
    for az in (37.0, 135.0, 270.0):
        bound = caster.analysis.no_shadow_bound(Sun(az, 45.0))
        above = sun_at_tan(az, bound * 1.01)
        assert caster.analysis.casts_nothing(above)
        assert not ref.cast_shadows(hm, above).mask.any()
        assert_same_as_traversal(hm, above)
