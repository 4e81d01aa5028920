"""Horizon angles on the device (kernels/horizon.cl) against the float64 reference, closed forms and
the cast-shadow masks."""
from __future__ import annotations

import itertools
import math
import pathlib

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature, HorizonCaster, azimuth_grid
from oclshade import tuning
from oclshade.horizon import pilot
from oclshade.horizon.caster import sweeps

SRTM = pathlib.Path(__file__).resolve().parents[2] / "shared" / "data" / "dem" / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip"


def assert_matches_reference(hm: Heightmap, azimuths, curvature: Curvature | None = None,
                             max_distance: float | None = None, knobs: dict | None = None) -> None:
    """Every angle within the float32 band of the reference; nodata and 'sees nothing' (-90) alike."""
    caster = HorizonCaster(hm, curvature=curvature, max_distance=max_distance, knobs=knobs)
    c = caster.coefficient
    band = ref.angle_tolerance(hm, c)
    radius = math.inf if caster.radius is None else caster.radius
    for az, got in caster.iter_horizons(azimuths):
        expected = ref.horizon_angles(hm, az, c, max_distance=radius)
        assert np.array_equal(np.isnan(got), np.isnan(expected)), f"nodata differs at az {az}"
        assert np.array_equal(got == -90.0, expected == -90.0), f"'sees nothing' differs at az {az}"
        err = np.nanmax(np.abs(got - expected)) if np.isfinite(expected).any() else 0.0
        assert err <= band, f"az {az}: max |angle - reference| {err:.3g} deg > band {band:.3g} on {hm.shape}"


@st.composite
def terrains(draw) -> np.ndarray:
    rows, cols = draw(st.integers(1, 40)), draw(st.integers(1, 40))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([1e-3, 1.0, 50.0, 2000.0]))
    kind = draw(st.sampled_from(["noise", "smooth", "integer", "walk"]))
    h = rng.random((rows, cols)) * scale
    if kind == "smooth":
        y, x = np.mgrid[0:rows, 0:cols]
        h = scale * (np.sin(x / 5.0) + np.cos(y / 7.0)) + 0.1 * h
    elif kind == "integer":
        h = np.round(h)
    elif kind == "walk":
        h = np.cumsum(h - 0.5 * scale, axis=1)
    if draw(st.booleans()):
        h[rng.random((rows, cols)) < draw(st.sampled_from([0.02, 0.2]))] = np.nan
    return h + draw(st.sampled_from([0.0, -500.0, 1e4]))


azimuths = st.one_of(st.sampled_from([0.0, 90.0, 180.0, 270.0, 45.0, 135.0, 1e-6]), st.floats(0.0, 360.0))
cell_sizes = st.sampled_from([(1.0, 1.0), (30.0, 30.0), (2.0, 0.5)])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=azimuths, cell=cell_sizes)
def test_equal_to_reference(h, az, cell):
    assert_matches_reference(Heightmap.from_array(h, cell), [az])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=st.lists(azimuths, min_size=1, max_size=5), cell=cell_sizes, curved=st.booleans())
def test_batches_are_the_one_azimuth_walk(h, az, cell, curved):
    """Several azimuths per launch (kernels/horizon.cl, "Batches"): the angles and the sky-view
    sums of one azimuth per launch, bit for bit, on random maps (holes, flats, any size)."""
    hm = Heightmap.from_array(h, cell)
    curvature = Curvature() if curved else None
    one, batched = (HorizonCaster(hm, curvature=curvature, cache=False, knobs={"batch": b}) for b in (1, 8))
    assert np.array_equal(batched.horizons(az), one.horizons(az), equal_nan=True)
    assert np.array_equal(batched.sky_view_factor(az), one.sky_view_factor(az), equal_nan=True)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=st.lists(azimuths, min_size=1, max_size=3), cell=cell_sizes, curved=st.booleans(),
       radius=st.sampled_from([None, 3.0, 40.0]), elevation=st.floats(-5.0, 60.0))
def test_both_level_searches_are_one_walk(h, az, cell, curved, radius, elevation):
    """The knob scan (kernels/horizon.cl, "Levels"): the walk skips the same tiles whether it reads
    every level at once or moves from the last step's level, so the angles, the sky-view sums and
    the soft shadows' clamped walks are the same bits; with a search radius the walk (the sweep
    kept out) as well."""
    hm = Heightmap.from_array(h, cell)
    curvature = Curvature() if curved else None
    far = None if radius is None else radius * max(cell)
    walk_only = {} if far is None else {"sweep_cells": 0, "sweep_far": 0}
    moving, scanning = (HorizonCaster(hm, curvature=curvature, max_distance=far, cache=False,
                                      knobs={"scan": s, "batch": 1, **walk_only}) for s in (0, 1))
    assert np.array_equal(scanning.horizons(az), moving.horizons(az), equal_nan=True)
    assert np.array_equal(scanning.sky_view_factor(az), moving.sky_view_factor(az), equal_nan=True)
    if far is None:
        sun = (az[0], elevation)
        assert np.array_equal(scanning.sun_disc(sun, columns=8), moving.sun_disc(sun, columns=8), equal_nan=True)



def test_both_level_searches_are_one_walk_on_a_canyon():
    """As above on a 256^2 canyon at 8 azimuths, batched too: half a million walks, long ones among
    them (a search that skipped a tile failing the test, e.g. one level above the largest that passes,
    fails here and above)."""
    from oclshade.synthetic import canyon_crater
    hm = Heightmap.from_array(canyon_crater(256, 256, seed=0, relief=1500.0), 30.0)
    az = azimuth_grid(8)
    runs = [HorizonCaster(hm, cache=False, knobs={"scan": s, "batch": b}) for s in (0, 1) for b in (1, 8)]
    angles = runs[0].horizons(az)
    for caster in runs[1:]:
        assert np.array_equal(caster.horizons(az), angles, equal_nan=True), caster.knobs

@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=azimuths, radius=st.sampled_from([50.0, 2000.0, 6371008.8]),
       k=st.sampled_from([0.0, 0.13]))
def test_equal_to_reference_with_curvature(h, az, radius, k):
    assert_matches_reference(Heightmap.from_array(h, 30.0), [az], Curvature(radius, k))


def _atan_deg_ieee(x: np.ndarray) -> np.ndarray:
    """kernels/horizon.cl's ocls_atan_deg, step for step in numpy float32 (IEEE, no FMA)."""
    f = np.float32
    x = np.asarray(x, np.float32)
    a = np.abs(x)
    big, mid = a > f(2.414213562373095), a > f(0.4142135623730950)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(big, f(-1.0) / a, np.where(mid, (a - f(1.0)) / (a + f(1.0)), a))
    y0 = np.where(big, f(90.0), np.where(mid, f(45.0), f(0.0)))
    z = t * t
    p = (((f(8.053527798e-02) * z - f(1.387762118e-01)) * z + f(1.997770540e-01)) * z
         - f(3.333294907e-01)) * z * t + t
    deg = y0 + p * f(57.29577951308232)
    return np.where(x < 0, -deg, deg).astype(np.float32)


def test_the_kernel_arctangent_is_portable_and_within_two_and_a_half_ulp():
    """Angles come from ocls_atan_deg (+, -, *, / only), not the driver's atan (allowed 4 ulp:
    PoCL's and NVIDIA's differed): the device's values equal an IEEE float32 emulation bit for
    bit, and are within 2.5 ulp of the float64 arctangent (2.14 measured over 880 000 values)."""
    import pyopencl as cl
    from oclshade import runtime
    rt = runtime.get_runtime()
    src = runtime.kernel_source("horizon.cl") + """
__kernel void atan_probe(__global const float *x, __global float *y)
{ const size_t i = get_global_id(0); y[i] = ocls_atan_deg(x[i]); }
"""
    prog = cl.Program(rt.context, src).build(options=["-cl-std=CL1.2", *runtime.rounding_options(rt.device)])
    rng = np.random.default_rng(7)
    mag = np.concatenate([np.logspace(-30, 30, 4001), rng.random(4000) * 4.0,
                          np.tan(np.pi / 8) * (1 + np.linspace(-1e-5, 1e-5, 101)),
                          np.tan(3 * np.pi / 8) * (1 + np.linspace(-1e-5, 1e-5, 101)), [0.0, 1.0, np.inf]])
    x = np.concatenate([mag, -mag]).astype(np.float32)
    y = np.empty_like(x)
    mf = cl.mem_flags
    xb = cl.Buffer(rt.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    yb = cl.Buffer(rt.context, mf.WRITE_ONLY, y.nbytes)
    prog.atan_probe(rt.queue, (x.size,), None, xb, yb)
    cl.enqueue_copy(rt.queue, y, yb)
    assert np.array_equal(y, _atan_deg_ieee(x))
    exact = np.degrees(np.arctan(x.astype(np.float64)))
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    err = np.abs(y - exact) / ulp
    assert err.max() <= 2.5, (float(err.max()), float(x[np.argmax(err)]))
    assert y[x == np.inf][0] == 90.0 and y[x == -np.inf][0] == -90.0


def test_inclined_plane_closed_form():
    """On h = g x (rising east) the horizon is atan(g) looking east, -atan(g) west, 0 north and south;
    -90 looking out of the map."""
    g, dx = 0.3, 10.0
    hm = Heightmap.from_array(np.tile(g * dx * np.arange(12.0), (9, 1)), dx)
    east, south, west, north = HorizonCaster(hm).horizons(4)[[1, 2, 3, 0]]
    deg = math.degrees(math.atan(g))
    np.testing.assert_allclose(east[:, :-1], deg, atol=1e-5)
    np.testing.assert_allclose(west[:, 1:], -deg, atol=1e-5)
    np.testing.assert_allclose(south[:-1], 0.0, atol=1e-5)
    np.testing.assert_allclose(north[1:], 0.0, atol=1e-5)
    assert np.all(east[:, -1] == -90.0) and np.all(west[:, 0] == -90.0)
    assert np.all(south[-1] == -90.0) and np.all(north[0] == -90.0)


def test_curvature_lowers_a_distant_tower():
    """A tower of height Z at distance D on flat ground is seen at atan((Z - (1 - k) D^2 / 2R) / D), or at
    0 (the ground at the cell's feet) when the curvature drops it below."""
    h = np.zeros((3, 200))
    h[1, 150] = 500.0
    hm = Heightmap.from_array(h, 100.0)
    for curvature in (None, Curvature(), Curvature(6371008.8, 0.13), Curvature(3e5), Curvature(1e5)):
        caster = HorizonCaster(hm, curvature=curvature)
        angle = caster.horizons([90.0])[0][1, 10]
        d = 140 * 100.0
        drop = 0.0 if curvature is None else (1.0 - curvature.refraction) * d * d / (2.0 * curvature.radius)
        assert angle == pytest.approx(max(0.0, math.degrees(math.atan((500.0 - drop) / d))), abs=2e-5)


def test_curvature_checks_its_arguments():
    for bad in (dict(radius=0.0), dict(radius=-1.0), dict(radius=math.inf), dict(refraction=1.0),
                dict(refraction=-0.1)):
        with pytest.raises(ValueError, match="radius|refraction"):
            Curvature(**bad)
    with pytest.raises(TypeError, match="curvature"):
        HorizonCaster(Heightmap.from_array(np.zeros((3, 3))), curvature=6371000.0)


def test_shadow_masks_agree_with_horizons_generated():
    """A cell is in cast shadow at (az, e) exactly when its horizon at az is above e, ties apart."""
    rng = np.random.default_rng(19)
    y, x = np.mgrid[0:90, 0:110]
    h = 300.0 * np.sin(x / 9.0) * np.cos(y / 13.0) + 40.0 * rng.random((90, 110))
    h[40:44, 50:57] = np.nan
    assert_masks_agree(Heightmap.from_array(h, 25.0), [(37.0, 10.0), (200.0, 25.0), (90.0, 5.0), (315.0, 45.0)])


def assert_masks_agree(hm: Heightmap, suns, limit: int = 0) -> None:
    horizons, shadows = HorizonCaster(hm), ShadowCaster(hm, cache=False)
    for az, el in suns:
        angle = horizons.horizons([az])[0]
        mask = shadows.cast((az, el)).mask
        assert np.array_equal(np.isnan(angle), mask == 255)
        differ = np.flatnonzero((angle > el) != (mask == 1))
        assert differ.size <= max(limit, 3), f"{differ.size} cells differ at {az}/{el}"
        if differ.size:      # each one a tie: the reference's T within float32 rounding of tan(el)
            rows, cols = np.unravel_index(differ, hm.shape)
            tangent = ref.horizon_tangents(hm, az, cells=(rows, cols))
            sun = Sun(az, el)
            band = ref.tie_tolerance(hm, sun) + ref.horizon_tolerance(hm)
            assert np.all(np.abs(tangent - sun.ray(hm.dx, hm.dy)[2]) <= band)


@pytest.mark.skipif(not SRTM.exists(), reason="shared SRTM tile not present")
def test_shadow_masks_agree_with_horizons_srtm():
    from oclshade.io import read_dem

    raster = read_dem(SRTM)
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    assert_masks_agree(hm, [(37.0, 10.0), (90.0, 20.0), (315.0, 2.0)])


def test_knobs_do_not_change_results():
    rng = np.random.default_rng(4)
    h = np.cumsum(rng.normal(size=(37, 53)), axis=0) * 20.0
    h[3:6, 7:9] = np.nan
    hm = Heightmap.from_array(h, 30.0)
    for radius in (None, 400.0, 1800.0):      # the whole map, the sweep, a walk within a radius
        base = HorizonCaster(hm, max_distance=radius, knobs={"group": 64, "own_builtins": 0, "lanes": 1,
                                                             "sweep_cells": 128, "width": 16})
        angles, svf = base.horizons(6), base.sky_view_factor(6)
        combos = [(group, own, 1, 128, 16) for group, own in itertools.product((16, 64, 256), (0, 1))]
        if radius == 400.0:                       # lanes are the sweep's alone
            combos += [(64, own, lanes, 128, 16) for own, lanes in itertools.product((0, 1), (4, 8, 16))]
        if radius is not None:                    # 13 and 60 cells: swept or walked, every azimuth or some
            combos += [(64, 0, lanes, cells, 16) for lanes, cells in itertools.product((1, 8), (0, 64, 192, 256))]
        combos += [(64, 0, 1, 128, width) for width in (4, 8, 32)]      # the work-group's width
        for group, own, lanes, cells, width in combos:
            knobs = {"group": group, "own_builtins": own, "lanes": lanes, "sweep_cells": cells, "width": width}
            caster = HorizonCaster(hm, max_distance=radius, knobs=knobs, curvature=None)
            assert np.array_equal(caster.horizons(6), angles, equal_nan=True), (radius, knobs)
            assert np.array_equal(caster.sky_view_factor(6), svf, equal_nan=True), (radius, knobs)
    # several azimuths per launch of the whole map's walk: one batch, a batch and a part (8 + 3); either
    # level search
    base = HorizonCaster(hm, knobs={"batch": 1, "scan": 0})
    angles, svf = base.horizons(11), base.sky_view_factor(11)
    for batch, group, width, scan in ((8, 16, 4, 0), (8, 256, 16, 1), (64, 64, 4, 1), (64, 256, 32, 0), (1, 64, 16, 1)):
        caster = HorizonCaster(hm, knobs={"batch": batch, "group": group, "width": width, "scan": scan})
        assert np.array_equal(caster.horizons(11), angles, equal_nan=True), caster.knobs
        assert np.array_equal(caster.sky_view_factor(11), svf, equal_nan=True), caster.knobs
        on_device = list(caster.angles_on_device(11))
        assert [az for az, _ in on_device] == list(azimuth_grid(11))
        for k, (_, buf) in enumerate(on_device):      # each band its own (sub-)buffer of rows * cols
            band = np.empty(hm.shape, np.float32)
            cl.enqueue_copy(caster.runtime.queue, band, buf)
            assert np.array_equal(band, angles[k], equal_nan=True), (batch, k)


def test_streaming_and_arguments():
    hm = Heightmap.from_array(np.random.default_rng(2).random((20, 30)) * 100.0, 10.0)
    caster = HorizonCaster(hm)
    seen = []
    bands = list(caster.iter_horizons(8, progress=lambda done, total: seen.append((done, total))))
    assert [az for az, _ in bands] == list(azimuth_grid(8)) == [45.0 * i for i in range(8)]
    assert seen == [(k, 8) for k in range(1, 9)]
    assert np.array_equal(np.stack([b for _, b in bands]), caster.horizons(8))
    assert np.array_equal(caster.horizons([90.0, 45.0])[0], caster.horizons(4)[1])
    for bad in (0, -3, 2.5, True, [], [math.nan], [[1.0]]):
        with pytest.raises(ValueError, match="azimuths"):
            caster.horizons(bad)
    with pytest.raises(ValueError, match="definition"):
        caster.sky_view_factor(4, "fisheye")


# --- search radius (max_distance) ------------------------------------------------------------

@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), az=azimuths, cell=cell_sizes, cells=st.floats(0.05, 30.0), curved=st.booleans())
def test_within_a_search_radius_equal_to_reference(h, az, cell, cells, curved):
    hm = Heightmap.from_array(h, cell)
    curvature = Curvature(radius=20000.0) if curved else None       # a small planet: visible drops
    assert_matches_reference(hm, [az], curvature, max_distance=cells * min(cell))


def test_a_search_radius_sees_only_the_terrain_within_it():
    """A wall on a flat plain, looking at it from the west: the surface rises from 0 to 100 m over
    the last 10 m cell before the wall, so within a radius R the horizon of a cell d metres away
    is atan(S(s) / s) at s = min(R, d), S(s) = 10 (s - d + 10), and 0 where R <= d - 10."""
    h = np.zeros((9, 60))
    h[:, 40] = 100.0
    hm = Heightmap.from_array(h, 10.0)
    d = (40 - np.arange(40)) * 10.0                                 # metres from each cell to the wall
    for radius in (105.0, 255.0, 385.0):
        east = HorizonCaster(hm, max_distance=radius).horizons([90.0])[0, 4, :40]
        s = np.minimum(radius, d)
        want = np.where(radius > d - 10.0, np.degrees(np.arctan(10.0 * (s - d + 10.0) / s)), 0.0)
        assert (d <= radius).any() and (radius <= d - 10.0).any() and ((d - 10.0 < radius) & (radius < d)).any()
        np.testing.assert_allclose(east, want, atol=1e-4)
        assert np.all(east[radius <= d - 10.0] == 0.0)              # the flat plain within the radius


def test_a_search_radius_on_a_real_dem_with_holes():
    from matplotlib import cbook

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    elev[100:130, 40:95] = np.nan
    elev[np.random.default_rng(7).random(elev.shape) < 0.01] = np.nan
    hm = Heightmap.from_array(elev, (90.0, 90.0))
    azimuths = [0.0, 37.0, 45.0, 90.0, 200.0, 315.0]
    assert_matches_reference(hm, azimuths, Curvature(), max_distance=3000.0)
    got = HorizonCaster(hm, max_distance=3000.0, curvature=Curvature()).horizons(azimuths)
    whole = HorizonCaster(hm, curvature=Curvature()).horizons(azimuths)
    assert np.all(got[np.isfinite(got)] <= whole[np.isfinite(got)] + ref.angle_tolerance(hm))
    assert (got < whole - 1.0).sum() > 1000          # the radius hides terrain: the two differ


def varied_map() -> Heightmap:
    """Several seed squares with a hole, a flat and a cliff."""
    rng = np.random.default_rng(23)
    y, x = np.mgrid[0:150, 0:170]
    h = 400.0 * np.sin(x / 17.0) * np.cos(y / 11.0) + np.cumsum(rng.normal(0, 6, (150, 170)), axis=1)
    h[60:66, 80:91] = np.nan                  # a hole
    h[100:130, 10:40] = 12.5                  # a flat
    h[:, 140:] += 300.0                       # a cliff
    return Heightmap.from_array(h, (20.0, 30.0))


def random_walk_map() -> Heightmap:
    return Heightmap.from_array(np.random.default_rng(5).normal(0, 30, (50, 70)).cumsum(axis=1), 25.0)


def walk_from_nothing(hm: Heightmap, curvature: Curvature | None, n: int) -> np.ndarray:
    """The whole-map walk from -inf, with the seeded walk's own pruning: horizon_cells built with
    -D OCLS_CLAMP and the bounds (-inf, +inf) (exact everywhere, no seeds, no radius margins)."""
    import pyopencl as cl

    caster = HorizonCaster(hm, curvature=curvature, cache=False)
    enqueue = caster._enqueuer({"OCLS_OUT_ANGLE": True, "OCLS_CLAMP": True})
    buf = caster.runtime.empty(4 * hm.heights.size, "horizon angles")
    out = np.empty((n, *hm.shape), np.float32)
    for k, az in enumerate(azimuth_grid(n)):
        enqueue(float(az), buf, caster._dummy, (-math.inf, math.inf))
        cl.enqueue_copy(caster.runtime.queue, out[k], buf)
    return out


@pytest.mark.parametrize("make_map, curved, radius", [(varied_map, False, 1e7), (varied_map, True, 1e7),
                                                      (random_walk_map, False, 1e6)])
def test_a_radius_beyond_the_map_equals_the_whole_map(make_map, curved, radius):
    """The whole-map walk starts from its seeds' bound (kernels/horizon.cl, "Seeds"); the same
    walk from -inf may differ from it only where a skipped tile changes the order of patch
    boundaries: in the last bits of a few cells, within the float32 band of the reference.  A
    radius beyond the map walks the same rays from -inf with the float32 margins that make a walk
    within a radius the sweep's bits ("A height margin"): it differs from the plain walk where a
    tile's bound ties the best tangent or the ray passes within rounding of a corner (0.16 % of
    the angles on the varied map's flats and cliffs), by a tenth of the band at most."""
    hm = make_map()
    curvature = Curvature() if curved else None
    c = 0.0 if curvature is None else curvature.coefficient
    seeded = HorizonCaster(hm, curvature=curvature).horizons(16)
    plain = walk_from_nothing(hm, curvature, 16)
    assert np.array_equal(np.isnan(seeded), np.isnan(plain))
    differ = (seeded != plain) & ~np.isnan(seeded)
    assert differ.sum() <= 1e-4 * seeded.size, f"{differ.sum()} angles differ from the walk from -inf"
    assert np.nanmax(np.abs(seeded - plain)) <= ref.angle_tolerance(hm, c)
    from_nothing = HorizonCaster(hm, curvature=curvature, max_distance=radius).horizons(16)
    assert np.array_equal(np.isnan(seeded), np.isnan(from_nothing))
    differ = (seeded != from_nothing) & ~np.isnan(seeded)
    assert differ.sum() <= 5e-3 * seeded.size, f"{differ.sum()} angles differ from the radius walk"
    assert np.nanmax(np.abs(seeded - from_nothing)) <= 0.1 * ref.angle_tolerance(hm, c)
    for k in (0, 5, 11):                      # and the seeded angles against the reference
        expected = ref.horizon_angles(hm, float(azimuth_grid(16)[k]), c)
        assert np.nanmax(np.abs(seeded[k] - expected)) <= ref.angle_tolerance(hm, c)


@pytest.mark.parametrize("curved, batch", [(False, 1), (True, 1), (False, 8)])
def test_the_seeds_fallback_is_the_walk_from_nothing(curved, batch, monkeypatch):
    """Where no tile beats a cell's seed bound (its margin was too thin), the cell walks again
    from -inf (kernels/horizon.cl, "Seeds", step 3).  Rare in real runs (a few hundred cells in
    millions), so here a test-only define makes every bound +inf: every cell falls back, and the
    angles are those of the walk from -inf bit for bit."""
    from oclshade.runtime import Runtime

    build, forced = Runtime.kernel, []

    def kernel(self, filename, name, defines=None):
        if filename == "horizon.cl" and name in ("horizon_cells", "horizon_cells_batch") and not (defines or {}).get("OCLS_MAX_DISTANCE"):
            forced.append(name)
            defines = {**(defines or {}), "OCLS_FORCE_SEED_FALLBACK": True}
        return build(self, filename, name, defines)

    monkeypatch.setattr(Runtime, "kernel", kernel)
    hm, curvature = varied_map(), Curvature() if curved else None
    fallen_back = HorizonCaster(hm, curvature=curvature, cache=False, knobs={"batch": batch}).horizons(16)
    assert forced, "the seeded walk was not built with the fallback forced"
    monkeypatch.setattr(Runtime, "kernel", build)
    assert np.array_equal(fallen_back, walk_from_nothing(hm, curvature, 16), equal_nan=True)


def square_map() -> Heightmap:
    """Square cells (rays at 45 degrees pass every patch corner), holes and an edge-hugging ridge."""
    rng = np.random.default_rng(31)
    h = np.cumsum(rng.normal(0, 8, (61, 83)), axis=0) + 50.0 * np.sin(np.arange(83) / 6.0)
    h[rng.random(h.shape) < 0.03] = np.nan
    h[20:24, 30:33] = np.nan
    h[:, -1] += 200.0
    return Heightmap.from_array(h, 30.0)


@pytest.mark.parametrize("make_map, curved", [(varied_map, False), (varied_map, True), (square_map, False)])
def test_the_sweep_equals_the_walk(make_map, curved):
    """Within a search radius the cells of a row can step through their patches together
    (kernels/horizon.cl, "The sweep") or walk the pyramid: the same angles and sky-view sums
    bit for bit, on maps with holes, flats, cliffs, square cells (corner passes at 45 degrees)
    and rays along the grid axes, flat and curved, so that the knob choosing between them
    (``sweep_cells``) is free to follow the device.  Before the walk's margins ("A height
    margin", and the step-by-step re-entry after a skipped tile) 0.23 % of the angles here
    differed in their last bits at 6.5 cells."""
    hm = make_map()
    curvature = Curvature() if curved else None
    azimuths = [0.0, 37.0, 45.0, 90.0, 135.0, 180.0, 200.0, 270.0, 315.0, 333.3]
    for cells in (1.0, 6.5, 20.0, 45.0):
        radius = cells * max(hm.dx, hm.dy)
        swept = HorizonCaster(hm, curvature=curvature, max_distance=radius, knobs={"sweep_cells": 256})
        walked = HorizonCaster(hm, curvature=curvature, max_distance=radius,
                               knobs={"sweep_cells": 0, "sweep_far": 0})
        for az in azimuths:
            ux, uy, _ = Sun(az, 0.0).ray(hm.dx, hm.dy)
            assert sweeps(ux, uy, swept.radius, 256) and not sweeps(ux, uy, walked.radius, 0), (cells, az)
            assert swept.takes_sweep(az) is True and walked.takes_sweep(az) is False, (cells, az)
        angles, walk_angles = swept.horizons(azimuths), walked.horizons(azimuths)
        assert angles.tobytes() == walk_angles.tobytes(), \
            f"{cells} cells: {np.sum(angles.view(np.uint32) != walk_angles.view(np.uint32))} angles differ"
        for definition in ("cosine", "solid-angle"):
            svf, walk_svf = swept.sky_view_factor(azimuths, definition), walked.sky_view_factor(azimuths, definition)
            assert svf.tobytes() == walk_svf.tobytes(), (cells, definition)
        assert (angles > -90.0).any() and (angles == -90.0).any() and np.isnan(angles).any()


def test_the_pilot_times_both_and_keeps_the_bits():
    """Past the reach of ``sweep_cells`` the knob ``sweep_far`` 1 (the safe value) times the sweep
    and the walk on bands of rows at the first such azimuth and takes the faster for the rest
    (oclshade/horizon/pilot.py): the angles and sums are the bits of every azimuth walked and of
    every one swept, whichever it chose; a map under the pilot's size walks there untimed."""
    hm = tuning.standard_heightmap(512)              # 2^18 cells: the pilot's least
    radius = 100 * hm.dx                             # 100 crossings on the axes, 141 on the diagonals
    azimuths = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]
    casters = {far: HorizonCaster(hm, max_distance=radius, cache=False,
                                  knobs={"sweep_cells": 128 if far else 0, "sweep_far": far}) for far in (0, 1, 2)}
    piloted = casters[1]
    assert [piloted.takes_sweep(az) for az in azimuths] == [True, None] * 4 and piloted.pilot is None
    svf = {far: c.sky_view_factor(azimuths, "solid-angle") for far, c in casters.items()}
    pilot = piloted.pilot
    assert pilot is not None and pilot.crossings == pytest.approx(100 * math.sqrt(2), rel=1e-6)
    assert pilot.sweep_seconds > 0.0 and pilot.walk_seconds > 0.0
    assert [piloted.takes_sweep(az) for az in azimuths] == [True, pilot.sweeps] * 4
    assert [casters[2].takes_sweep(az) for az in azimuths] == [True] * 8
    assert [casters[0].takes_sweep(az) for az in azimuths] == [False] * 8
    angles = {far: c.horizons(azimuths) for far, c in casters.items()}
    for far in (1, 2):
        assert angles[far].tobytes() == angles[0].tobytes(), far
        assert svf[far].tobytes() == svf[0].tobytes(), far
    assert (angles[0] > 0.0).any() and np.nanmin(svf[0]) < 1.0
    small = HorizonCaster(Heightmap.from_array(hm.heights[:256, :512], (hm.dx, hm.dy)), max_distance=radius,
                          cache=False, knobs={"sweep_cells": 128, "sweep_far": 1})
    small.horizons([45.0])
    assert small.takes_sweep(45.0) is False and small.pilot is None


@pytest.mark.parametrize("rows, group_rows", [(64, 16), (300, 4), (1201, 4), (1024, 16), (4096, 4), (100000, 1)])
def test_the_pilots_bands(rows, group_rows):
    """Whole work-group rows, inside the map, apart and in order, spread down it, about a
    sixteenth of the rows in all (all of them on a map of a few work-group rows)."""
    spans = pilot.bands(rows, group_rows)
    assert 1 <= len(spans) <= pilot.BANDS
    ends = [0]
    for first, count in spans:
        assert first % group_rows == 0 and count % group_rows == 0 and count > 0
        assert first >= ends[-1] and first + count <= rows
        ends.append(first + count)
    total = sum(count for _, count in spans)
    assert total <= max(rows // pilot.ROW_SHARE, len(spans) * group_rows)
    assert total >= min(rows // pilot.ROW_SHARE - pilot.BANDS * group_rows, rows // group_rows * group_rows)
    if len(spans) == pilot.BANDS:
        assert spans[0][0] < rows // 8 and spans[-1][0] + spans[-1][1] > rows * 7 // 8


@pytest.mark.parametrize("bad", [0, 0.0, -30.0, math.nan, math.inf, 1e-60, True, "300"])
def test_a_bad_search_radius_is_named(bad):
    hm = Heightmap.from_array(np.zeros((4, 4)), 1.0)
    with pytest.raises(ValueError, match="max_distance must be None or a positive finite number of metres"):
        HorizonCaster(hm, max_distance=bad)
