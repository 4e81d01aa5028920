"""Terrain ray casting (kernels/terrain.cl) against the float64 reference caster."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade.camera import Camera, frame_heightmap, map_bounds
from oclshade.reference import cast_terrain, dilated_max_levels
from oclshade.terrain import Heightfield, TerrainRenderer

sys.path.insert(0, str(Path(__file__).resolve().parent))
from terrain_util import agreement, compare  # noqa: E402

EARTH = 6.371e6
_RENDERERS: dict[int, TerrainRenderer] = {}


def renderer(field: Heightfield) -> TerrainRenderer:
    key = id(field)
    if key not in _RENDERERS:
        _RENDERERS.clear()
        _RENDERERS[key] = TerrainRenderer(field)
    return _RENDERERS[key]


# ----------------------------------------------------------------------------- cameras
def centre_and_size(field: Heightfield) -> tuple[np.ndarray, float]:
    lo, hi = map_bounds(field.heightmap)
    return 0.5 * (lo + hi), max(float(np.linalg.norm(hi - lo)), 1.0)


def camera_for(field: Heightfield, kind: str, w: int = 48, h: int = 32, az: float = 200.0) -> Camera:
    hm = field.heightmap
    centre, size = centre_and_size(field)
    lo, hi = map_bounds(hm)
    a = math.radians(az)
    away = np.array([math.sin(a), math.cos(a), 0.0])
    if kind == "framed":
        return frame_heightmap(hm, w, h, azimuth=az, elevation=30.0)
    if kind == "down":          # straight down (up vector parallel to the view: fallback to north)
        return Camera(centre + [0, 0, size], centre, w, h, fov=50.0, near=0.01 * size, far=4 * size)
    if kind == "ortho_down":
        return Camera(centre + [0, 0, size], centre, w, h, projection="orthographic",
                      ortho_height=1.2 * size, near=0.0, far=4 * size)
    if kind == "ortho_oblique":
        return frame_heightmap(hm, w, h, azimuth=az, elevation=40.0, projection="orthographic")
    if kind == "horizontal":    # rays parallel to the base plane, from outside the map looking in
        eye = centre + away * size
        return Camera(eye, centre, w, h, fov=60.0, near=1e-3 * size, far=4 * size)
    if kind == "grazing":       # low, just above the highest point, looking across
        eye = centre + away * 0.8 * size
        eye[2] = hi[2] + 1e-3 * size
        target = centre.copy()
        target[2] = hi[2]
        return Camera(eye, target, w, h, fov=40.0, near=1e-3 * size, far=4 * size)
    if kind == "below":         # under the terrain looking up and across: sees only back faces' far side
        eye = centre.copy()
        eye[2] = lo[2] - 0.3 * size
        return Camera(eye, centre + away * 0.5 * size, w, h, fov=90.0, near=1e-3 * size, far=4 * size)
    if kind == "inside":        # inside the map's box at mid height
        return Camera(centre, centre + away * size + [0, 0, -0.2 * size], w, h, fov=100.0,
                      near=1e-3 * size, far=4 * size)
    if kind == "fov1":
        cam = frame_heightmap(hm, w, h, azimuth=az, elevation=30.0)
        return Camera(cam.position, cam.look_at, w, h, fov=1.0, near=cam.near, far=cam.far)
    if kind == "fov170":
        return Camera(centre + [0, 0, 0.3 * size] + away * 0.2 * size, centre, w, h, fov=170.0,
                      near=1e-3 * size, far=4 * size)
    raise ValueError(kind)


KINDS = ("framed", "down", "ortho_down", "ortho_oblique", "horizontal", "grazing", "below", "inside",
         "fov1", "fov170")


# ----------------------------------------------------------------------------- terrains
@st.composite
def terrains(draw) -> np.ndarray:
    rows = draw(st.integers(1, 40))
    cols = draw(st.integers(1, 40))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = draw(st.sampled_from([1e-3, 1.0, 20.0, 300.0]))
    kind = draw(st.sampled_from(["noise", "smooth", "integer", "plateau"]))
    h = rng.random((rows, cols)) * scale
    if kind == "smooth":
        y, x = np.mgrid[0:rows, 0:cols]
        h = scale * (np.sin(x / 5.0 + seed % 7) + np.cos(y / 7.0)) + 0.1 * h
    elif kind == "integer":
        h = np.round(h)
    elif kind == "plateau":
        h = np.where(h > 0.5 * scale, 0.5 * scale, h)
    if draw(st.booleans()):
        h[rng.random((rows, cols)) < draw(st.sampled_from([0.02, 0.2]))] = np.nan
    if draw(st.booleans()):
        h = h + draw(st.sampled_from([-500.0, 1e4, 1e6]))
    return h


cell_sizes = st.sampled_from([(1.0, 1.0), (30.0, 30.0), (2.0, 0.5)])


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), cell=cell_sizes, kind=st.sampled_from(KINDS), az=st.floats(0.0, 360.0),
       sphere=st.sampled_from([None, None, EARTH, "small"]))
def test_bisect_equals_reference_on_random_terrain(h, cell, kind, az, sphere):
    hm_field = Heightfield.from_array(h, cell)
    radius = None
    if sphere is not None:
        _, size = centre_and_size(hm_field)
        radius = EARTH if sphere == EARTH else 5.0 * size    # "small": curvature visible in the frame
    field = Heightfield(hm_field.heightmap, radius)
    cam = camera_for(field, kind, az=az)
    got = compare(field, cam, renderer(field))
    got.assert_exact(f"{kind} {h.shape} radius={radius}")


def test_degenerate_maps_render_empty():
    """1 x 1 and 1 x N maps have no patch with an area: every pixel is empty, in both casters."""
    for shape in ((1, 1), (1, 7), (9, 1)):
        field = Heightfield.from_array(np.arange(np.prod(shape), dtype=float).reshape(shape), 1.0)
        for kind in ("framed", "down"):
            cam = camera_for(field, kind)
            g = TerrainRenderer(field).render(cam)
            assert not g.hit.any() and not cast_terrain(field, cam).hit.any()
            assert np.all(np.isinf(g.depth)) and not g.position.any() and not g.albedo.any()


def test_camera_inside_a_hole_sees_through_the_underside():
    """A camera in a hole, below the ground around it: rays that leave the hole under the ground
    see only back faces (culled: empty); rays that rise out of it hit the front of a far wall."""
    h = np.zeros((40, 40))
    h[:, 35:] = 100.0                                   # a steep wall in the east
    h[15:26, 15:26] = np.nan                            # the hole
    field = Heightfield.from_array(h, 1.0)
    eye = np.array([20.0, -20.0, -2.0])                 # in the hole, 2 m under the ground
    cam = Camera(eye, eye + [10.0, 0.0, 6.0], 64, 48, fov=90.0, near=0.01, far=200.0)
    got = compare(field, cam, TerrainRenderer(field))
    got.assert_exact("inside a hole")
    ref = cast_terrain(field, cam)
    assert 0 < ref.hit.sum() < ref.hit.size
    assert np.all(ref.cell[ref.hit][:, 1] >= 34)        # only the wall is seen


def jacksboro() -> Heightfield:
    from matplotlib import cbook
    from oclshade.io import metres_per_degree

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    ew, ns = metres_per_degree(36.2)
    return Heightfield.from_array(elev, (ew / 1200.0, ns / 1200.0))


def test_jacksboro_real_dem():
    field = jacksboro()
    r = TerrainRenderer(field)
    fractions = []
    for kind, az in (("framed", 200.0), ("framed", 45.0), ("grazing", 120.0), ("down", 0.0), ("fov1", 300.0)):
        cam = camera_for(field, kind, 160, 90, az=az)
        got = compare(field, cam, r)
        got.assert_exact(f"jacksboro {kind} {az}")
        fractions.append(got.same_cell_fraction)
    assert min(fractions) >= 0.999


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(1, 19), st.integers(1, 23), st.integers(0, 2**31 - 1), st.booleans(), st.integers(0, 4))
def test_dilated_max_levels_equal_reference(rows, cols, seed, holes, leaf):
    """terrain_dilate (the bisection's one-read bound) is bit-identical to its numpy twin on the
    levels the bisection reads (leaf level and up; the finer ones are not built)."""
    import pyopencl as cl

    rng = np.random.default_rng(seed)
    h = rng.normal(0.0, 50.0, (rows, cols))
    if holes:
        h[rng.random(h.shape) < 0.3] = np.nan
    field = Heightfield.from_array(h, 1.0)
    r = TerrainRenderer(field, leaf=leaf)
    buf, table = r.dilated
    want = dilated_max_levels(field.heightmap)
    lmin = r.leaf_level
    assert lmin == min(leaf, len(want) - 1)
    lev = np.empty((len(want), 2), np.int32)
    cl.enqueue_copy(r.runtime.queue, lev, table)
    flat = np.empty(buf.size // 4, np.float32)
    cl.enqueue_copy(r.runtime.queue, flat, buf)
    assert flat.size == sum(w.size for w in want[lmin:])
    for (off, ncols), w in zip(lev[lmin:], want[lmin:]):
        assert ncols == w.shape[1]
        np.testing.assert_array_equal(flat[off:off + w.size].reshape(w.shape), w)


def test_bisection_options_are_exact_too():
    """Other split depths (descend) and leaf levels (0: the paper's finest level) agree with the
    reference (and so with the default) on the real DEM."""
    field = jacksboro()
    for descend, leaf in ((1, 0), (5, 2), (3, 0), (2, 4)):
        r = TerrainRenderer(field, descend=descend, leaf=leaf)
        for kind, az in (("framed", 30.0), ("grazing", 250.0)):
            cam = camera_for(field, kind, 96, 64, az=az)
            compare(field, cam, r).assert_exact(f"descend={descend} leaf={leaf} {kind}")


def test_step_counts_profile_without_changing_the_frame():
    """The profiling build (-D OCLS_STATS) renders the same G-buffer, and its counters add up: every
    ray with a segment makes at least one test, every hit comes from an exact patch test, bisect
    tests no level finer than its leaf level, and the hit counter is the frame's hit count."""
    field = jacksboro()
    cam = camera_for(field, "framed", 96, 64, az=110.0)
    for leaf in (2, 0):
        r = TerrainRenderer(field, leaf=leaf)
        for method in ("bisect", "dda", "march"):
            plain = r.render(cam, method)
            out = r.render(cam, method, on_device=True)
            counts = r.step_counts(cam, method, band_pixels=1000, out=out)
            profiled = out.to_host()
            for name in ("position", "normal", "uv", "uv_grad", "depth", "albedo"):
                assert np.array_equal(getattr(profiled, name), getattr(plain, name)), (leaf, method, name)
            levels = counts["levels"]
            assert len(levels) == r.pyramid.levels
            assert counts["hits"] == int(plain.hit.sum()) > 0
            assert plain.hit.size >= counts["rays"] >= counts["hits"]
            assert levels.sum() >= counts["rays"] and counts["patches"] >= counts["hits"]
            if method == "bisect":
                assert not levels[:r.leaf_level].any() and levels[r.leaf_level] > 0
            if method == "march":
                assert not levels[1:].any()


def test_far_camera_stays_bounded():
    """Cameras so far away that a cell is about one float32 ulp of t, and then far below it: the
    work per ray stays small (no loop runs to its iteration bound) and hits stay in the map."""
    rng = np.random.default_rng(1)
    field = Heightfield.from_array(rng.random((30, 30)) * 5.0, 1.0)
    for dist in (1e5, 1e7, 1e9):
        cam = Camera([15 + 0.6 * dist, -15 - 0.6 * dist, 0.5 * dist], [15, -15, 0], 64, 48,
                     fov=min(3600.0 / dist, 60.0), near=0.5 * dist, far=2.0 * dist)
        r = TerrainRenderer(field)
        counts = r.step_counts(cam)
        assert counts["rays"] > 0
        assert counts["levels"].sum() < 20 * counts["rays"] and counts["patches"] < 20 * counts["rays"], dist
        g = r.render(cam)
        assert np.all((g.uv[g.hit] >= 0.0) & (g.uv[g.hit] <= 29.0))
        assert np.all((g.depth[g.hit] >= cam.near) & (g.depth[g.hit] <= cam.far))


def test_baselines_agree_where_exact():
    """dda is exact like bisect; march misses crossings between samples but never invents hits."""
    field = jacksboro()
    r = TerrainRenderer(field)
    cam = camera_for(field, "framed", 120, 80, az=150.0)
    ref = cast_terrain(field, cam)
    agreement(r.render(cam, "dda"), ref).assert_exact("dda")
    march = agreement(r.render(cam, "march"), ref)
    assert march.off_silhouette <= march.hit_mismatch


def test_gbuffer_fields_are_consistent():
    field = jacksboro()
    cam = camera_for(field, "framed", 96, 64, az=230.0)
    g = TerrainRenderer(field).render(cam)
    hit = g.hit
    assert 0.15 < hit.mean() < 1.0
    # depth is -z of the position; normals are unit and face the camera (back faces culled)
    np.testing.assert_allclose(g.depth[hit], -g.position[..., 2][hit], rtol=1e-6)
    n = g.normal[hit][:, :3]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", n, g.position[hit][:, :3]) <= 1e-3 * g.depth[hit])
    # positions are on the surface: world z of the hit = bilinear height at its uv
    world = np.linalg.inv(cam.view) @ np.c_[g.position[hit][:, :3], np.ones(hit.sum())].T
    u, v = g.uv[hit][:, 0].astype(float), g.uv[hit][:, 1].astype(float)
    hm = field.heightmap
    np.testing.assert_allclose(world[0] / hm.dx, u, atol=2e-3)
    np.testing.assert_allclose(-world[1] / hm.dy, v, atol=2e-3)
    # uv derivatives: on average the finite differences of uv between neighbouring pixels
    # (a pixel spans several cells here, so single pixels scatter around the tangent plane's value)
    with np.errstate(invalid="ignore"):                 # inf - inf between empty pixels
        smooth = np.abs(np.diff(g.depth, axis=1)) < 0.02 * g.depth[:, 1:]
    for axis, chans in ((1, (0, 1)), (0, (2, 3))):
        diff = np.diff(g.uv, axis=axis)
        mean = 0.5 * (g.uv_grad[1:] + g.uv_grad[:-1]) if axis == 0 else 0.5 * (g.uv_grad[:, 1:] + g.uv_grad[:, :-1])
        both = (hit[1:] & hit[:-1]) if axis == 0 else (hit[:, 1:] & hit[:, :-1] & smooth)
        for k, ch in enumerate(chans):
            ratio = diff[..., k][both] / mean[..., ch][both]
            assert 0.95 < np.median(ratio) < 1.05, (axis, k, np.median(ratio))
    # empty pixels follow the contract
    assert np.all(np.isinf(g.depth[~hit])) and not g.normal[~hit].any() and not g.uv_grad[~hit].any()
    assert np.all((g.albedo[hit] >= 0) & (g.albedo[hit] <= 1)) and np.all(g.albedo[hit][:, 3] == 1)


def test_device_buffers_match_host_copy():
    field = Heightfield.from_array(np.random.default_rng(2).random((20, 30)) * 5.0, 1.0)
    r = TerrainRenderer(field)
    cam = camera_for(field, "framed")
    dev = r.render(cam, on_device=True)
    host = r.render(cam)
    again = dev.to_host()
    for name in ("position", "normal", "uv", "uv_grad", "depth", "albedo"):
        assert np.array_equal(getattr(again, name), getattr(host, name))
    assert r.render(cam, on_device=True, out=dev) is dev


_DETERMINISM = """
import sys, numpy as np
from pathlib import Path
sys.path.insert(0, {tests!r})
from test_terrain import jacksboro, camera_for
from oclshade.terrain import TerrainRenderer
field = jacksboro()
cam = camera_for(field, "framed", 200, 120, az=200.0)
g = TerrainRenderer(field).render(cam)
np.savez({out!r}, **{{k: getattr(g, k) for k in ("position", "normal", "uv", "uv_grad", "depth", "albedo")}})
"""


@pytest.mark.parametrize("threads", ["1", "2"])
def test_deterministic_across_runs_and_thread_counts(tmp_path, threads):
    outs = []
    for k in range(2):
        out = tmp_path / f"g{k}.npz"
        env = dict(os.environ, POCL_MAX_PTHREAD_COUNT=threads, POCL_CPU_MAX_CU_COUNT=threads)
        code = _DETERMINISM.format(tests=str(Path(__file__).resolve().parent), out=str(out))
        proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr[-3000:]
        outs.append(np.load(out))
    field = jacksboro()
    here = TerrainRenderer(field).render(camera_for(field, "framed", 200, 120, az=200.0))
    for name in outs[0].files:
        assert np.array_equal(outs[0][name], outs[1][name], equal_nan=True), name
        assert np.array_equal(outs[0][name], getattr(here, name), equal_nan=True), name


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="fov"):
        Camera([0, 0, 10], [0, 0, 0], 10, 10, fov=180.0)
    with pytest.raises(ValueError, match="width"):
        Camera([0, 0, 10], [0, 0, 0], 0, 10)
    with pytest.raises(ValueError, match="far"):
        Camera([0, 0, 10], [0, 0, 0], 10, 10, near=5.0, far=1.0)
    with pytest.raises(ValueError, match="look_at"):
        Camera([0, 0, 10], [0, 0, 10], 10, 10)
    with pytest.raises(ValueError, match="radius"):
        Heightfield.from_array(np.zeros((3, 3)), radius=-1.0)
    with pytest.raises(ValueError, match="colour"):
        Heightfield.from_array(np.zeros((3, 3)), colour=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="descend"):
        TerrainRenderer(Heightfield.from_array(np.zeros((3, 3))), descend=0)
    with pytest.raises(ValueError, match="leaf"):
        TerrainRenderer(Heightfield.from_array(np.zeros((3, 3))), leaf=5)
    with pytest.raises(ValueError, match="method"):
        TerrainRenderer(Heightfield.from_array(np.zeros((3, 3)))).render(
            Camera([1, -1, 10], [1, -1, 0], 4, 4), method="nope")
