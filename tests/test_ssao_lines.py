"""SSAO line samples (AOFeatures(distribution="lines"), -D OCLS_LINES): hand-made G-buffers with
analytic answers, the float64 twin reference.ssao_lines, the line-quadrature ground truth
reference.volume_ao_lines.  Determinism across runs and PoCL thread counts: tests/test_ssao.py
(its script runs line-sample settings too)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_ssao import (VALLEY_TS, cap_fraction, corner_scene, heightfield, ortho, perspective, pixel_xy,
                       random_extras, random_gbuffer, tilted_plane_view, valley_points)

from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.ssao import (AOFeatures, PAPER_M, PAPER_RECIPE, SSAO, disk_points, hemisphere_points, line_eye,
                           line_table)

LINES = AOFeatures(distribution="lines")


@pytest.fixture(scope="module")
def ssao() -> SSAO:
    return SSAO()


# ----------------------------------------------------------------------------- tables, eye
def test_disk_points_and_line_table() -> None:
    d = disk_points(400)
    r = np.linalg.norm(d, axis=1)
    assert d.shape == (400, 2) and r.max() < 1.0
    assert abs(np.mean(r < 0.5) - 0.25) < 0.005            # uniform in area
    assert np.abs(d.mean(axis=0)).max() < 0.01
    t = line_table(64)
    assert t.dtype == np.float32 and t.shape == (64, 3)
    np.testing.assert_allclose(t[:, 0] ** 2 + t[:, 1] ** 2 + t[:, 2] ** 2, 1.0, atol=1e-6)   # hs = chord half-length
    assert np.all(t[:, 2] > 0)
    with pytest.raises(ValueError, match="line_table"):
        hemisphere_points(8, "lines")


def test_line_eye_is_where_the_lines_of_sight_meet() -> None:
    P = perspective(60, 1.5)
    np.testing.assert_allclose(line_eye(P), [0, 0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(line_eye(ortho(32, 24, 0.5)), [0, 0, 1, 0], atol=1e-12)
    # a camera moved to C (the view transform folded into the matrix): E = (C, 1)
    view = np.eye(4)
    view[:3, 3] = [-3.0, 2.0, -7.0]
    np.testing.assert_allclose(line_eye(P @ view), [3.0, -2.0, 7.0, 1.0], atol=1e-9)
    # an orthographic view turned 30 degrees about x: the lines run along the turned view axis
    # (0, sin, cos), oriented towards the camera (+z)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    turn = np.array([[1.0, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(line_eye(ortho(32, 24, 0.5) @ turn), [0, s, c, 0], atol=1e-12)
    np.testing.assert_allclose(line_eye(-ortho(32, 24, 0.5) @ turn), [0, s, c, 0], atol=1e-12)
    with pytest.raises(ValueError, match="rank 3"):
        line_eye(np.zeros((4, 4)))


# ----------------------------------------------------------------------------- known answers
@pytest.mark.parametrize("plane_test", [False, True])
@pytest.mark.parametrize("range_check", [False, True])
def test_flat_plane_is_unoccluded(ssao: SSAO, plane_test: bool, range_check: bool) -> None:
    f = AOFeatures(distribution="lines", plane_test=plane_test, range_check=range_check)
    # ortho: the tilted plane z = -20 + 0.5 x; perspective: a plane through (0, 0, -10) tilted 30
    # degrees, positions on the pixel rays.  No delta: the depth cut on each pixel's line of sight and
    # the plane cut are both exact on a plane up to float32 rounding, 1e-6 (more views, radii and m:
    # test_ssao_planes.py)
    w, h, px = 48, 40, 1.0
    x, y = pixel_xy(w, h, px)
    pos, nrm = heightfield(-20 + 0.5 * x, np.full_like(x, 0.5), np.zeros_like(x), x, y)
    ao = ssao.compute(None, ortho(w, h, px), position=pos, normal=nrm, radius=6.0, m=32, features=f)
    assert ao.min() >= 1 - 1e-6
    P, pos, nrm, _ = tilted_plane_view(w, h)
    ao = ssao.compute(None, P, position=pos, normal=nrm, radius=2.0, m=32, features=f)
    assert ao.min() >= 1 - 1e-6


@pytest.mark.parametrize("plane_test", [False, True])
def test_right_angle_corner_matches_analytic_volume_fraction(ssao: SSAO, plane_test: bool) -> None:
    # the concave corner z = -50 + |y| seen from above: a pixel on one plane at distance d from the
    # crease has the cap beyond the other plane occluded, cap_fraction(d / R), the plane moved by
    # the bias (plane cut: delta off the plane; depth cut: delta in z, delta / sqrt 2 off the plane).
    # 64 lines give every pixel within 0.02 and the rows' means within 0.003 (point samples: 0.02 with 256)
    w, h, px, R = 96, 128, 1.0, 24.0
    delta, shift = (1e-3, 1e-3) if plane_test else (0.5, 0.5 / math.sqrt(2))
    (pos, nrm), x, y = corner_scene(w, h, px)
    f = AOFeatures(distribution="lines", plane_test=plane_test)
    ao = ssao.compute(None, ortho(w, h, px), position=pos, normal=nrm, radius=R, m=64, delta=delta,
                      features=f, seed=3)
    for row in range(h // 2 + 1, h // 2 + 30, 2):
        d = abs(y[row, 0]) * math.sqrt(2)
        want = 1 - cap_fraction(np.array((d + shift) / R))
        got = ao[row, int(R):-int(R)].astype(np.float64)   # away from the left/right border
        assert abs(got.mean() - want) < 0.003, (row, d / R, got.mean(), want)
        assert np.abs(got - want).max() < 0.02, (row, d / R, np.abs(got - want).max())
    far = np.abs(y) * math.sqrt(2) > R + 2
    np.testing.assert_array_equal(ao[far], 1.0)


def wall_scene(w: int, h: int, px: float, x_wall: float, top: float):
    """A floor z = -50 facing the camera and a block x >= x_wall whose top is ``top`` above it (ortho)."""
    x, y = pixel_xy(w, h, px)
    z = np.where(x >= x_wall, -50.0 + top, -50.0)
    return heightfield(z, np.zeros_like(x), np.zeros_like(x), x, y), x


@pytest.mark.parametrize("plane_test", [False, True])
def test_deep_wall_occludes_its_spherical_cap(ssao: SSAO, plane_test: bool) -> None:
    # a wall far higher than R at distance t R from the floor pixel: the occluded part of the
    # hemisphere is the cap beyond the wall's plane, cap_fraction(t) of its volume; the wall's
    # edge lies on a pixel edge, so every line through the block's pixels is solid along its
    # whole chord and the answer is exact up to the m-line quadrature
    w, h, px, R = 128, 128, 1.0, 20.0
    (pos, nrm), x = wall_scene(w, h, px, x_wall=0.0, top=1000.0)
    f = AOFeatures(distribution="lines", plane_test=plane_test)
    ao = ssao.compute(None, ortho(w, h, px), position=pos, normal=nrm, radius=R, m=64, delta=0.01,
                      features=f, seed=5)
    rows = slice(int(R), h - int(R))
    for col in range(w // 2 - int(R) - 2, w // 2):
        t = -x[0, col] / R
        got = ao[rows, col].astype(np.float64)
        want = 1 - cap_fraction(np.array(t))
        # the wall cuts the disk: a jump in the line integrand, so single pixels scatter more (0.04)
        assert abs(got.mean() - want) < 0.005 and np.abs(got - want).max() < 0.06, (t, got.mean(), want)
    # the paper's range check drops occluders more than R in front of P: the wall is ignored
    rc = ssao.compute(None, ortho(w, h, px), position=pos, normal=nrm, radius=R, m=64, delta=0.01,
                      features=AOFeatures(distribution="lines", plane_test=plane_test, range_check=True), seed=5)
    np.testing.assert_array_equal(rc[:, : w // 2], 1.0)


def test_empty_pixels_border_and_degenerate_normals(ssao: SSAO) -> None:
    w, h, px = 40, 32, 1.0
    (pos, nrm), x, y = corner_scene(w, h, px)
    nrm[0:4] = 0.0                        # zero normal: AO 1
    nrm[4:8, :, :3] = np.nan              # NaN normal: AO 1
    nrm[8:12, :, :3] = (1.0, 0.0, 0.0)    # edge-on: still a valid frame
    pos[20:22, :, 2] = np.inf             # a non-finite position is empty
    holes = np.random.default_rng(0).random((h, w)) < 0.2
    pos[holes, 3] = 0.0                   # empty pixels: AO 1, never occlude
    P = ortho(w, h, px)
    for pt in (False, True):
        ao = ssao.compute(None, P, position=pos, normal=nrm, radius=6.0, m=32, delta=0.5,
                          features=AOFeatures(distribution="lines", plane_test=pt), seed=9)
        assert np.all(np.isfinite(ao)) and ao.min() >= 0 and ao.max() <= 1
        np.testing.assert_array_equal(ao[0:8], 1.0)
        np.testing.assert_array_equal(ao[20:22], 1.0)
        np.testing.assert_array_equal(ao[holes], 1.0)
        tw = ref.ssao_lines(pos, nrm, P, 32, 6.0, 0.5, 9, plane_test=pt)
        assert_matches_twin(ao, tw)
    # all empty: 1 everywhere
    np.testing.assert_array_equal(ssao.compute(None, P, position=np.zeros_like(pos), normal=nrm, radius=6.0,
                                               features=LINES), 1.0)
    # the border: the crease runs across the whole width; lines off screen are not counted
    w, h, R = 96, 64, 12.0
    (pos, nrm), x, y = corner_scene(w, h, 1.0)
    ao = ssao.compute(None, ortho(w, h, 1.0), position=pos, normal=nrm, radius=R, m=64, delta=0.5,
                      features=LINES, seed=1)
    rows = slice(h // 2 - 3, h // 2 + 3)
    interior, edge = ao[rows, 24:-24].mean(), np.r_[ao[rows, :2].ravel(), ao[rows, -2:].ravel()].mean()
    assert interior < 0.75 and abs(edge - interior) < 0.02


# ----------------------------------------------------------------------------- kernel vs twin
def assert_matches_twin(ao: np.ndarray, tw: ref.ReferenceAO) -> None:
    """Within the twin's float32 bound everywhere, and the bound is not vacuous: tight (< 1e-3)
    on most pixels with lines on screen, where the image is not all border (a 34 x 2 one,
    every pixel on the border, had 0.49)."""
    diff = np.abs(ao.astype(np.float64) - tw.ao)
    bad = diff > tw.bound + 1e-6
    assert not bad.any(), (f"{bad.sum()} pixels beyond the bound, worst {diff[bad].max()} "
                           f"at {np.argwhere(bad)[:3].tolist()}")
    counted = tw.counted > 0
    if counted.sum() >= 20 and min(ao.shape) >= 4:
        assert np.mean(tw.bound[counted] < 1e-3) > 0.5


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), w=st.integers(2, 40), h=st.integers(2, 32), persp=st.booleans(),
       m=st.integers(4, 48), range_check=st.booleans(), plane_test=st.booleans(),
       radius=st.floats(0.05, 3.0), delta=st.floats(0.0, 0.2), normal_map=st.booleans(), alpha=st.booleans())
def test_kernel_matches_float64_twin(ssao: SSAO, seed, w, h, persp, m, range_check, plane_test, radius, delta,
                                     normal_map, alpha) -> None:
    rng = np.random.default_rng(seed)
    pos, nrm, P = random_gbuffer(rng, w, h, persp)
    extra = random_extras(rng, w, h, alpha, normal_map)
    f = AOFeatures(distribution="lines", normal_map=normal_map, alpha_map=alpha, range_check=range_check,
                   plane_test=plane_test)
    ao = ssao.compute(None, P, position=pos, normal=nrm, radius=radius, m=m, delta=delta, features=f,
                      seed=seed, alpha_eps=0.3, **extra)
    tw = ref.ssao_lines(pos, nrm, P, m, radius, delta, seed, range_check, plane_test, alpha_eps=0.3, **extra)
    assert_matches_twin(ao, tw)
    # the box blur on top (its own twin is tested in test_ssao.py): fed with the kernel's map
    fb = AOFeatures(distribution="lines", normal_map=normal_map, alpha_map=alpha, range_check=range_check,
                    plane_test=plane_test, blur="box", blur_size=3)
    got = ssao.compute(None, P, position=pos, normal=nrm, radius=radius, m=m, delta=delta, features=fb,
                       seed=seed, alpha_eps=0.3, **extra)
    np.testing.assert_allclose(got, ref.box_blur(ao, tw.hit, 1), atol=2e-6, rtol=0)


# ----------------------------------------------------------------------------- real terrain, ground truth
def jacksboro(rows: int = 120, cols: int = 160) -> Heightmap:
    cbook = pytest.importorskip("matplotlib.cbook")
    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    dem = (data if hasattr(data, "files") else np.load(data))["elevation"][:rows, :cols].astype(np.float64)
    return Heightmap.from_array(dem, 30.0)


def test_real_dem_kernel_vs_twin_and_against_the_paper_recipe(ssao: SSAO) -> None:
    hm = jacksboro()
    view = ref.topdown_gbuffer(hm, 120, 90, 10.0)   # 3 pixels per cell
    gb, R, delta = view.gbuffer, 90.0, 0.5
    for pt in (False, True):
        f = AOFeatures(distribution="lines", plane_test=pt)
        ao = ssao.compute(gb, view.projection, radius=R, m=16, delta=delta, features=f, seed=11)
        assert_matches_twin(ao, ref.ssao_lines(gb.position, gb.normal, view.projection, 16, R, delta, 11, plane_test=pt))
    # against ground truth (a) away from the border: 16 lines beat the paper's recipe (32 points,
    # 5 x 5 box) by far (measured: RMSE 0.0107 against 0.0351)
    inner = (slice(10, -10), slice(10, -10))
    truth = ref.volume_ao_lines(hm, view.world_position[inner].reshape(-1, 3),
                                view.world_normal[inner].reshape(-1, 3), R, n=1024)
    lines = ssao.compute(gb, view.projection, radius=R, m=16, delta=delta, features=LINES, seed=11)
    paper = ssao.compute(gb, view.projection, radius=R, m=PAPER_M, delta=delta, features=PAPER_RECIPE, seed=11)
    rmse = {k: float(np.sqrt(np.mean((a[inner].ravel() - truth) ** 2))) for k, a in (("lines", lines), ("paper", paper))}
    assert rmse["lines"] < 0.5 * rmse["paper"], rmse


def test_volume_truth_by_lines() -> None:
    # the right-angle valley: the cap beyond the other slope, to 1e-4 with 4096 lines (the point
    # quadrature of volume_ao needs 0.01)
    R, ts = 10.0, VALLEY_TS
    hm, pts, nrm = valley_points(R)
    np.testing.assert_allclose(1 - ref.volume_ao_lines(hm, pts, nrm, R, n=4096), cap_fraction(ts), atol=1e-4)
    # flat: exactly open; outside the map nothing is under
    flat = Heightmap.from_array(np.full((30, 30), 5.0), 2.0)
    up = np.array([[0.0, 0.0, 1.0]] * 3)
    pts = np.array([[30.0, -30.0, 5.0], [10.5, -20.25, 5.0], [0.0, 0.0, 5.0]])
    np.testing.assert_array_equal(ref.volume_ao_lines(flat, pts, up, 8.0, n=256), 1.0)
    # real terrain: the same quantity as the point quadrature, within its Monte Carlo error
    hm = jacksboro(60, 60)
    rng = np.random.default_rng(3)
    xy = rng.uniform(300, 1400, (200, 2)) * [1, -1]
    z, gx, gy = ref.bilinear(hm, xy[:, 0], xy[:, 1])
    pts = np.column_stack([xy, z])
    nrm = np.column_stack([-gx, -gy, np.ones_like(z)])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    by_lines = ref.volume_ao_lines(hm, pts, nrm, 120.0, n=1024)
    by_points = ref.volume_ao(hm, pts, nrm, 120.0, n=4096)
    err = np.sqrt(np.mean(by_points * (1 - by_points) / 4096))
    assert by_lines.min() < 0.9                      # some real occlusion in the sample
    assert np.sqrt(np.mean((by_lines - by_points) ** 2)) < 2 * err
    # and it converges: 1024 against 4096 lines
    assert np.abs(by_lines - ref.volume_ao_lines(hm, pts, nrm, 120.0, n=4096, seed=2)).max() < 2e-3


def test_validation(ssao: SSAO) -> None:
    (pos, nrm), x, y = corner_scene(16, 16, 1.0)
    inputs = ssao.upload(position=pos, normal=nrm)
    assert ssao.run(inputs, ortho(16, 16, 1.0), radius=4.0, m=8, features=LINES) is not None
    with pytest.raises(ValueError, match="view plane"):     # the lines of sight have no z component
        ssao.run(inputs, np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 0], [0, 0, 0, 1]]), radius=4.0,
                 features=LINES)
