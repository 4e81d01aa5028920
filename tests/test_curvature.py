"""Earth curvature along the shadow rays (issue 19): heights drop by (1 - k) d^2 / (2 R) at
distance d from the cell (or pixel) along its ray, in the kernels (-D OCLS_CURVATURE) and in the
float64 references alike."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature
from oclshade.screen_shadows import LodOptions, ScreenShadowCaster
from oclshade.shadows import ShadowFeatures
from oclshade.synthetic import canyon_crater

from test_screen_shadows import gbuffer, near_grid_points

EARTH = Curvature()
HAZY = Curvature(refraction=0.13)


def wall(height: float = 2000.0, cols: int = 300, cell: float = 500.0) -> Heightmap:
    """A wall ``height`` m high along column 2 of flat ground, 500 m cells: 150 km of plain east of it."""
    h = np.zeros((16, cols))
    h[:, 2] = height
    return Heightmap.from_array(h, cell)


def shadow_end(wall_height: float, w: float, c: float) -> float:
    """Distance at which the wall's top sinks below the ray of a ground cell: H - c d^2 = w d."""
    return (-w + math.sqrt(w * w + 4.0 * c * wall_height)) / (2.0 * c)


def assert_equals_reference(hm: Heightmap, sun: Sun, curvature: Curvature, **caster_args) -> np.ndarray:
    """Every exact method with curvature equals the float64 reference with the same drop, but
    for ties; returns the mask."""
    c = curvature.coefficient
    expected = ref.cast_shadows(hm, sun, curvature=c)
    ties = expected.ties(ref.tie_tolerance(hm, sun, c))
    caster = ShadowCaster(hm, cache=False, curvature=curvature, **caster_args)
    for method in ("exact", "maxmip", "dda"):
        got = caster.cast(sun, method).mask
        bad = (got != expected.mask) & ~ties
        assert not bad.any(), (method, sun, curvature, int(bad.sum()))
        assert ((got != expected.mask) & ties).sum() <= max(3, got.size // 100)
    return expected.mask


def test_wall_shadow_ends_where_the_earth_hides_the_wall():
    """A 2 km wall at sun elevation 0.5 degrees: on a flat Earth its shadow runs 229 km (past
    the map's 150 km); on the Earth's sphere it ends at d* = 113.4 km, where the wall's top has
    sunk below the cell's sun ray (H - d^2 / 2R = d tan e).  The kernel draws it there."""
    hm = wall()
    sun = Sun(270.0, 0.5)                      # in the west: rays run west, to the wall
    w = sun.ray(hm.dx, hm.dy)[2]
    d_end = shadow_end(2000.0, w, EARTH.coefficient)
    assert 113_000 < d_end < 114_000
    distance = (np.arange(hm.shape[1]) - 2) * hm.dx
    flat = ShadowCaster(hm, cache=False).cast(sun).mask
    curved = assert_equals_reference(hm, sun, EARTH)
    east = distance > 0
    assert (flat[:, east] == 1).all()          # the flat Earth shadows the whole plain
    assert (curved[:, east & (distance < d_end - hm.dx)] == 1).all()
    assert (curved[:, distance > d_end + hm.dx] == 0).all()
    assert (curved != flat).sum() >= 16 * 70   # 35+ km of plain, every row
    # refraction bends light down: an effective radius R / (1 - k), a longer shadow
    hazy = ShadowCaster(hm, cache=False, curvature=HAZY).cast(sun).mask
    d_hazy = shadow_end(2000.0, w, HAZY.coefficient)
    assert d_hazy > d_end + 5_000
    assert (hazy[:, east & (distance < d_hazy - hm.dx)] == 1).all() and (hazy[:, distance > d_hazy + hm.dx] == 0).all()


def test_long_shadows_of_a_large_cell_map():
    """Generated terrain 192 x 256 at 600 m cells (115 x 154 km), low suns: curvature changes
    thousands of cells, and every method (scalar, packets of 4/8/16 lanes, with and without
    far-field certificates) equals the float64 reference with the same drop."""
    hm = Heightmap.from_array(canyon_crater(192, 256, seed=11, relief=3000.0), 600.0)
    changed = 0
    for sun in (Sun(280.0, 0.7), Sun(37.0, 1.5), Sun(135.0, 3.0), Sun(0.0, 1.0)):
        curved = assert_equals_reference(hm, sun, EARTH)
        changed += int((curved != ShadowCaster(hm, cache=False).cast(sun).mask).sum())
        scalar = ShadowCaster(hm, cache=False, curvature=EARTH, certificates=False, knobs={"lanes": 0}).cast(sun)
        for lanes in (4, 8, 16):
            got = ShadowCaster(hm, cache=False, curvature=EARTH, knobs={"lanes": lanes}).cast(sun)
            assert np.array_equal(got.mask, scalar.mask), (sun, lanes)
    assert changed > 1000


@st.composite
def far_terrains(draw) -> tuple[np.ndarray, tuple[float, float]]:
    rows, cols = draw(st.integers(2, 60)), draw(st.integers(2, 60))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    relief = draw(st.sampled_from([50.0, 1500.0, 6000.0]))
    h = rng.random((rows, cols)) * relief
    if draw(st.booleans()):
        y, x = np.mgrid[0:rows, 0:cols]
        h = relief * (np.sin(x / 4.0) + np.cos(y / 6.0)) + 0.05 * h
    if draw(st.booleans()):
        h[rng.random((rows, cols)) < 0.1] = np.nan
    cell = draw(st.sampled_from([(100.0, 100.0), (900.0, 900.0), (500.0, 1500.0), (3000.0, 2000.0)]))
    return h, cell


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(terrain=far_terrains(), az=st.floats(0.0, 360.0), alt=st.sampled_from([0.05, 0.5, 2.0, 10.0]),
       curvature=st.sampled_from([EARTH, HAZY, Curvature(radius=1.0e6)]))
def test_kernel_equals_reference_with_curvature(terrain, az, alt, curvature):
    h, cell = terrain
    assert_equals_reference(Heightmap.from_array(h, cell), Sun(az, alt), curvature)


def test_pixels_with_curvature_equal_the_reference():
    """The per-pixel pass at q = 0 with curvature: every exact method equals
    reference.pixel_shadows with the same drop (ties counted by its rounding bound, which
    includes the drop's), on starts near grid lines of a large-cell map; curvature changes
    verdicts there."""
    hm = Heightmap.from_array(canyon_crater(128, seed=12, relief=3000.0), 700.0)
    gb = gbuffer(near_grid_points(np.random.default_rng(3), hm.shape, 6000))
    caster = ScreenShadowCaster(hm, curvature=EARTH)
    flat = ScreenShadowCaster(hm)
    changed = tests = ties = 0
    for sun in (Sun(250.0, 0.6), Sun(90.0, 1.0), Sun(17.0, 2.0)):
        expected = ref.pixel_shadows(hm, sun, gb.uv, gb.hit, curvature=EARTH.coefficient)
        valid = expected.mask != 255
        tie = expected.ties() & valid
        for method in ("exact", "maxmip", "dda"):
            got = caster.shade(gb, sun, method, LodOptions(force_q=0)).flag
            assert not ((got != expected.mask) & valid & ~tie).any(), (sun, method)
        changed += int((flat.shade(gb, sun, "exact", LodOptions(force_q=0)).flag != expected.mask).sum())
        tests += int(valid.sum())
        ties += int(tie.sum())
    assert changed > 100 and ties <= 1e-3 * tests


def test_curvature_compiles_to_nothing_when_off():
    """The drop is a -D option: without it the kernels are the flat ones (the ray's 4th value,
    where the drop rides, is not read), so a flat caster gives the flat reference exactly."""
    assert ShadowFeatures().defines()["OCLS_CURVATURE"] is False
    assert ShadowFeatures(curvature=True).defines()["OCLS_CURVATURE"] is True
    hm = wall()
    sun = Sun(270.0, 0.5)
    assert np.array_equal(ShadowCaster(hm, cache=False).cast(sun).mask, ref.cast_shadows(hm, sun).mask)
    # the cache keeps curved and flat results apart
    cached_flat = ShadowCaster(hm, cache=True).cast(sun).mask
    cached_curved = ShadowCaster(hm, cache=True, curvature=EARTH).cast(sun).mask
    assert not np.array_equal(cached_flat, cached_curved)


def test_bad_curvature_arguments():
    hm = wall()
    with pytest.raises(TypeError, match="curvature"):
        ShadowCaster(hm, curvature=6371008.8)
    with pytest.raises(TypeError, match="curvature"):
        ScreenShadowCaster(hm, curvature="earth")
    with pytest.raises(ValueError, match="radius"):
        Curvature(radius=-1.0)


def test_cli_shadow_curvature(tmp_path):
    """``oclshade shadow --curvature [--radius R] [--refraction K]`` writes the curved mask;
    --radius without --curvature and --curvature with a tiled run are usage errors."""
    dem = tmp_path / "wall.npy"
    np.save(dem, wall().heights)

    def run(*extra):
        return subprocess.run([sys.executable, "-m", "oclshade", "shadow", str(dem), *extra, "--cellsize", "500",
                               "-az", "270", "-alt", "0.5", "-q"], capture_output=True, text=True)

    out = tmp_path / "curved.npy"
    proc = run(str(out), "--curvature", "--radius", "6000000", "--refraction", "0.1")
    assert proc.returncode == 0, proc.stderr
    want = ShadowCaster(wall(), cache=False, curvature=Curvature(6.0e6, 0.1)).cast(Sun(270.0, 0.5)).mask
    assert np.array_equal(np.load(out), want)
    assert not np.array_equal(want, ShadowCaster(wall(), cache=False).cast(Sun(270.0, 0.5)).mask)
    proc = run(str(tmp_path / "x.npy"), "--radius", "6000000")
    assert proc.returncode == 2 and "--radius and --refraction go with --curvature" in proc.stderr
    proc = run(str(tmp_path / "x.npy"), "--curvature", "--tile", "64")
    assert proc.returncode == 2 and "--curvature does not work with tiled runs" in proc.stderr
