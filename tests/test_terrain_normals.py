"""Smooth shading normals (kernels/terrain.cl terrain_normals) against their float64 twin, and
what they are for: no per-cell facets where the terrain is smooth."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.camera import frame_heightmap
from oclshade.reference.terrain import sample_slopes, shading_normals
from oclshade.terrain import Heightfield, TerrainRenderer

EPS32 = 2.0 ** -24


def normal_tolerance(field) -> float:
    """Bound on |kernel - twin| per component of a unit normal: the kernel's slope rounds a
    difference of two relative float32 heights (one rounding of at most eps32 |h|max per sample,
    the 1/2 exact), then a bilinear sum of 4 (at most ~8 more roundings of the slope's size), so
    its slope error is at most 16 eps32 (|h|max + |slope|max) in height per cell; divided by the
    smaller cell size, plus the rotation and normalisation (a few eps32), for a unit vector."""
    hm = field.heightmap
    h = np.abs(hm.relative32[np.isfinite(hm.relative32)])
    hmax = float(h.max()) if h.size else 0.0
    return 16 * EPS32 * (2.0 * hmax / min(hm.dx, hm.dy) + 1.0) + 8 * EPS32


def render(field, w=96, h=64, az=160.0, el=40.0, projection="perspective"):
    cam = frame_heightmap(field.heightmap, w, h, azimuth=az, elevation=el, projection=projection, crop=0.0)
    r = TerrainRenderer(field)
    g = r.render(cam)
    return cam, r, g


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2 ** 16), holes=st.booleans(), sphere=st.booleans(),
       ortho=st.booleans(), az=st.floats(0.0, 360.0))
def test_kernel_equals_twin(seed, holes, sphere, ortho, az):
    rng = np.random.default_rng(seed)
    heights = 40.0 * rng.random((23, 31)) + 500.0
    if holes:
        heights[rng.random(heights.shape) < 0.08] = np.nan
    field = Heightfield.from_array(heights, (3.0, 4.0), radius=2000.0 if sphere else None)
    cam, r, g = render(field, az=az, projection="orthographic" if ortho else "perspective")
    got = r.shading_normals(cam, g)
    want = shading_normals(field, cam, g.uv, g.hit)
    assert g.hit.any() and np.all(np.isfinite(got))
    assert np.all(got[~g.hit] == 0.0) and np.all(got[..., 3] == 0.0)
    assert np.abs(got[..., :3] - want).max() <= normal_tolerance(field)
    assert np.allclose(np.linalg.norm(got[g.hit][:, :3], axis=1), 1.0, atol=1e-6)


def test_device_and_host_gbuffers_agree():
    field = Heightfield.from_array(np.random.default_rng(3).random((20, 20)) * 5.0, 1.0)
    cam, r, g = render(field)
    dev = r.render(cam, on_device=True)
    buf = r.shading_normals(cam, dev)
    host = np.empty(g.shape + (4,), np.float32)
    import pyopencl as cl
    cl.enqueue_copy(r.runtime.queue, host, buf)
    r.runtime.queue.finish()
    assert np.array_equal(host, r.shading_normals(cam, g))


def test_quadratic_terrain_shades_with_its_exact_normal():
    """Central differences are exact for a quadratic, and its slope is linear, so the bilinear
    interpolation of the samples' slopes is its exact slope everywhere inside the map (edges:
    one-sided); the geometric normal of the bilinear patches is not (facets)."""
    y, x = np.mgrid[0:40, 0:50].astype(float)
    a, b, c = 0.05, -0.03, 0.02
    field = Heightfield.from_array(a * (x - 20) ** 2 + b * (y - 15) ** 2 + c * x * y, 2.0)
    cam, r, g = render(field, 160, 120, el=50.0)
    u, v = (g.uv[..., k][g.hit].astype(float) for k in (0, 1))
    gu, gv = 2 * a * (u - 20) + c * v, 2 * b * (v - 15) + c * u          # dh/du, dh/dv per cell
    exact = np.stack([-gu / 2.0, gv / 2.0, np.ones_like(gu)], -1) @ cam.rotation.T
    exact /= np.linalg.norm(exact, axis=1, keepdims=True)
    inside = (u > 1) & (u < 48) & (v > 1) & (v < 38)
    assert inside.sum() > 2000
    smooth = r.shading_normals(cam, g)[g.hit][:, :3]
    assert np.abs(smooth[inside] - exact[inside]).max() < 2e-6
    assert np.abs(g.normal[g.hit][:, :3][inside] - exact[inside]).max() > 1e-2


def test_no_facets_on_smooth_terrain():
    """Seen from above at several pixels per cell, the shading normal of a smooth terrain changes
    little from one pixel to the next; the geometric one jumps at every cell edge."""
    y, x = np.mgrid[0:24, 0:24].astype(float)
    field = Heightfield.from_array(6.0 * np.sin(x / 3.0) * np.cos(y / 4.0), 1.0)
    cam, r, g = render(field, 192, 192, az=180.0, el=90.0, projection="orthographic")
    smooth = r.shading_normals(cam, g)

    def largest_step(n):
        both = g.hit[:, 1:] & g.hit[:, :-1]
        return np.linalg.norm(n[:, 1:, :3] - n[:, :-1, :3], axis=-1)[both].max()

    assert largest_step(smooth) < 0.35 * largest_step(g.normal)


def test_slopes_next_to_holes_and_edges():
    h = np.array([[0.0, 1.0, 3.0, np.nan],
                  [2.0, np.nan, 5.0, 9.0]])
    gu, gv = sample_slopes(h)
    assert gu[0, :3].tolist() == [1.0, 1.5, 2.0]            # one-sided at the map's edge and a hole
    assert gu[1, 0] == 0.0 and gu[1, 2] == 4.0 and gu[1, 3] == 4.0   # no neighbour: 0
    assert gv[:, 0].tolist() == [2.0, 2.0] and gv[0, 1] == 0.0


def test_arguments_are_checked():
    field = Heightfield.from_array(np.zeros((5, 5)), 1.0)
    cam, r, g = render(field, 16, 12)
    other = frame_heightmap(field.heightmap, 8, 6)
    with pytest.raises(ValueError, match="8x6|6x8"):
        r.shading_normals(other, g)
    with pytest.raises(TypeError, match="GBuffer"):
        r.shading_normals(cam, np.zeros((12, 16)))
