"""Point lights (docs/meshes.md "Point lights"): the terrain's shadows along the segment to the
light (kernels/terrain_ray.h terrain_segment_blocks, via quadric.cl terrain_point_shadow) and
the quadrics' (quadric_point_shadow) against their float64 twins
(oclshade.reference.quadrics.terrain_segment_occludes, quadric_segment_occludes), exact off
the ties, counted apart."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
from hypothesis import assume, given, settings, strategies as st

from oclshade.camera import Camera, heightmap_from_world
from oclshade.gbuffer import CHANNELS
from oclshade.heightmap import Heightmap
from oclshade.lights import PointLight
from oclshade.quadrics import ObjectIds, Quadric, QuadricCaster
from oclshade.quadrics.caster import terrain_point_shadow
from oclshade.reference import quadrics as ref
from oclshade.runtime import get_runtime
from oclshade.terrain import DeviceGBuffer
from test_quadrics import random_quadric  # noqa: E402  (the same random shapes)

EPS = float(np.finfo(np.float32).eps)
CAMERA = Camera((60, -250, 150), (60, -90, 0), 8, 8, near=1, far=1e4)


def fake_gbuffer(points_view: np.ndarray, object_ids: np.ndarray) -> tuple[DeviceGBuffer, ObjectIds, cl.Buffer]:
    """A one-row G-buffer of chosen view-space points (only position is read), their ids and a
    coefficient buffer of 0.5 (so a pass that leaves a pixel alone shows)."""
    rt = get_runtime()
    n = len(points_view)
    pos = np.concatenate([points_view, np.ones((n, 1))], 1).astype(np.float32)
    bufs = {name: rt.empty(4 * ch * n, name) for name, ch in CHANNELS.items()}
    cl.enqueue_copy(rt.queue, bufs["position"], pos)
    ids = ObjectIds(rt.to_device(object_ids.astype(np.int32), "ids"), (1, n))
    return DeviceGBuffer(rt, (1, n), bufs), ids, rt.to_device(np.full(n, 0.5, np.float32), "coef")


def read(buf: cl.Buffer, n: int) -> np.ndarray:
    out = np.empty(n, np.float32)
    cl.enqueue_copy(get_runtime().queue, out, buf)
    get_runtime().queue.finish()
    return out


def bilinear(h: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Float64 bilinear surface at (u, v) (columns, rows)."""
    pc, pr = np.minimum(np.floor(u).astype(int), h.shape[1] - 2), np.minimum(np.floor(v).astype(int), h.shape[0] - 2)
    fx, fy = u - pc, v - pr
    h00, h01, h10, h11 = h[pr, pc], h[pr, pc + 1], h[pr + 1, pc], h[pr + 1, pc + 1]
    return h00 + (h01 - h00) * fx + (h10 - h00) * fy + (h00 - h01 - h10 + h11) * fx * fy


def run_terrain(hm: Heightmap, world: np.ndarray, ids: np.ndarray, light: PointLight) -> np.ndarray:
    """terrain_point_shadow on world points: 0 shadowed (k_dark 0), 1 lit."""
    view = world @ CAMERA.rotation.T + CAMERA.view[:3, 3]
    gbuf, obj, coef = fake_gbuffer(view, ids)
    rt = get_runtime()
    heights = rt.to_device(np.ascontiguousarray(hm.relative32, np.float32), "heights")
    terrain_point_shadow(rt, CAMERA, hm, heights, gbuf, obj, light, coef, 0.0)
    return read(coef, len(world))


def twin_terrain(hm: Heightmap, view32: np.ndarray, ids: np.ndarray, light: PointLight,
                 camera: Camera = CAMERA) -> tuple[np.ndarray, np.ndarray]:
    """(occluded, tie) per point from the float32 G-buffer positions as the device sees them:
    ties are the points whose float64 verdict changes when the start or the light moves by the
    float32 rounding of their heightmap coordinates (64 eps of the sizes involved)."""
    world = (view32.astype(float) - camera.view[:3, 3]) @ camera.rotation      # view -> world, float64
    m = heightmap_from_world(hm)
    q = world @ m[:3, :3].T + m[:3, 3]
    lq = m[:3, :3] @ light.position + m[:3, 3]
    rel = hm.relative32.astype(float)
    size = np.abs(q) + np.abs(lq) + np.linalg.norm(view32, axis=1)[:, None] / min(hm.dx, hm.dy) \
        + np.nanmax(np.abs(rel))
    out, tie = np.zeros(len(q), bool), np.zeros(len(q), bool)
    for i in range(len(q)):
        surface = ids[i] == 0
        want = ref.terrain_segment_occludes(rel, q[i], lq, surface)
        out[i] = want
        delta = 64 * EPS * size[i]
        for axis in range(3):
            for sign in (-1.0, 1.0):
                step = sign * delta[axis] * np.eye(3)[axis]
                if (axis < 2 or not surface) and ref.terrain_segment_occludes(rel, q[i] + step, lq, surface) != want:
                    tie[i] = True
                    break
                if ref.terrain_segment_occludes(rel, q[i], lq + step, surface) != want:
                    tie[i] = True
                    break
            if tie[i]:
                break
    return out, tie


def random_map(rng: np.random.Generator) -> Heightmap:
    heights = rng.random((14, 12)) * 40.0
    heights[rng.random(heights.shape) < 0.04] = np.nan
    return Heightmap.from_array(heights, (7.0, 9.0))


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=8, deadline=None)
def test_terrain_segment_shadows_match_the_twin(seed):
    """Object pixels (anywhere above or below the terrain, ids 1 and -1) and terrain pixels (id 0,
    on the surface, a third of them on grid lines) against a point light over, inside or
    under the map: equal to the twin off the ties."""
    rng = np.random.default_rng(seed)
    hm = random_map(rng)
    rows, cols = hm.shape
    n = 150
    free = np.stack([rng.uniform(-10, 90, n), rng.uniform(-130, 10, n), rng.uniform(-5, 60, n)], 1)
    u, v = rng.uniform(0, cols - 1, n), rng.uniform(0, rows - 1, n)
    u[: n // 3] = np.round(u[: n // 3])
    v[n // 3: 2 * n // 3] = np.round(v[n // 3: 2 * n // 3])
    rel = hm.relative32.astype(float)
    z = bilinear(rel, u, v) + hm.offset
    on = np.isfinite(z)
    surf = np.stack([u * hm.dx, -v * hm.dy, np.where(on, z, 0.0)], 1)[on]
    world = np.concatenate([free, surf])
    ids = np.concatenate([rng.choice([1, -1], n), np.zeros(len(surf), int)])
    top = float(np.nanmax(hm.heights))
    light = PointLight((rng.uniform(-20, 100), rng.uniform(-140, 20), top + rng.uniform(-10, 40)))
    got = run_terrain(hm, world, ids, light)
    view32 = (world @ CAMERA.rotation.T + CAMERA.view[:3, 3]).astype(np.float32)
    want, tie = twin_terrain(hm, view32, ids, light)
    assert np.array_equal(got[~tie], np.where(want[~tie], 0.0, 1.0).astype(np.float32))
    # a start on a grid line is a tie where the patches on its two sides disagree (a kink in the
    # surface: float32 puts the start on either side); elsewhere ties are rare
    gridded = np.zeros(len(world), bool)
    gridded[n:] = np.flatnonzero(on) < 2 * n // 3
    assert tie[~gridded].mean() < 0.05 and tie.mean() < 0.15
    assert want.any()


def test_no_acne_on_a_tilted_plane():
    """Terrain pixels on a tilted plane (heights not exact in float32), many on grid lines or a
    hair's breadth off them: a light above the plane lights every one, a light below it
    shadows every one (the start is on the surface, f(0) = 0, carried within a cell)."""
    rows, cols = 12, 10
    vv, uu = np.mgrid[0:rows, 0:cols].astype(float)
    heights = 0.37 * uu * 7.0 + 0.11 * vv * 9.0 + 1234.567
    hm = Heightmap.from_array(heights, (7.0, 9.0))
    rng = np.random.default_rng(3)
    n = 600
    u, v = rng.uniform(0, cols - 1, n), rng.uniform(0, rows - 1, n)
    u[:200] = np.round(u[:200]) + rng.choice([-1, 1], 200) * rng.uniform(0, 1e-5, 200)
    v[200:400] = np.round(v[200:400]) + rng.choice([-1, 1], 200) * rng.uniform(0, 1e-5, 200)
    u, v = np.clip(u, 0, cols - 1), np.clip(v, 0, rows - 1)
    world = np.stack([u * 7.0, -v * 9.0, 0.37 * u * 7.0 + 0.11 * v * 9.0 + 1234.567], 1)
    ids = np.zeros(n, int)
    plane = lambda x, y: 0.37 * x + 0.11 * (-y) + 1234.567  # noqa: E731  (y = -v dy)
    for x, y, dz, lit in ((30.0, -50.0, 40.0, 1.0), (60.0, -20.0, 5.0, 1.0), (30.0, -50.0, -3.0, 0.0),
                          (-500.0, 300.0, 0.5, 1.0)):
        got = run_terrain(hm, world, ids, PointLight((x, y, plane(x, y) + dz)))
        assert np.all(got == lit), (x, y, dz, np.unique(got, return_counts=True))


def test_segment_ends_at_the_light():
    """A ridge between a point and the light shadows it; the same ridge beyond the light does
    not (the segment stops at the light, a sun ray would not); a light straight above / below
    a point over the terrain: lit / shadowed when the surface lies between."""
    heights = np.zeros((5, 21))
    heights[:, 10] = 50.0                                   # a wall along column 10 (x = 100 m)
    hm = Heightmap.from_array(heights, 10.0)
    world = np.array([[30.0, -20.0, 1.0], [30.0, -20.0, 1.0], [30.0, -20.0, 1.0], [30.0, -20.0, 1.0]])
    got = [run_terrain(hm, world[:1], np.array([1]), PointLight(p))[0]
           for p in ((160.0, -20.0, 10.0), (80.0, -20.0, 10.0), (30.0, -20.0, 40.0), (30.0, -20.0, -5.0))]
    assert got == [0.0, 1.0, 1.0, 0.0]


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=10, deadline=None)
def test_quadric_segment_shadows_match_the_twin(seed):
    """Terrain and mesh pixels (ids 0, -1) against quadrics of every kind and a point light
    among them: kshadow where the segment to the light meets one, else the coefficient the
    terrain pass left (0.5 here).  Ties: points whose float64 answer changes when the light
    moves by 1e-4 of its distance along an axis (segments grazing a silhouette or a rim)."""
    rng = np.random.default_rng(seed)
    quadrics = [random_quadric(rng, k, 5.0) for k in ("sphere", "ellipsoid", "cylinder", "paraboloid")]
    camera = Camera((0, -40, 20), (0, 0, 0), 8, 8, near=0.5, far=1e3)
    n = 300
    world = rng.uniform(-8, 8, (n, 3)) - [0, 0, 6]
    view = world @ camera.rotation.T + camera.view[:3, 3]
    ids = rng.choice([0, -1], n)
    gbuf, obj, coef = fake_gbuffer(view, ids)
    light = PointLight(rng.uniform(-6, 6, 3) + [0, 0, 8])
    QuadricCaster(quadrics).point_shadow(camera, gbuf, obj, light, coef, k_dark=0.2)
    got = read(coef, n)
    w32 = (view.astype(np.float32).astype(float) - camera.view[:3, 3]) @ camera.rotation
    want = ref.quadric_segment_occludes(quadrics, w32, light.position)
    tie = np.zeros(n, bool)
    reach = np.linalg.norm(light.position - w32, axis=1)[:, None]
    for axis in range(3):
        for sign in (-1.0, 1.0):
            moved = light.position + sign * 1e-4 * reach * np.eye(3)[axis]
            for i in np.flatnonzero(~tie):
                tie[i] |= ref.quadric_segment_occludes(quadrics, w32[i:i + 1], moved[i])[0] != want[i]
    assert np.array_equal(got[~tie], np.where(want[~tie], np.float32(0.2), np.float32(0.5)))
    assume(want.any() and (~want).any())   # a light inside a closed quadric shades every point (seed 252)
    assert tie.mean() < 0.05


def test_quadric_segment_rules():
    """The segment stops at the light: a sphere beyond the light casts nothing, one between
    casts; an object pixel is not shadowed by its own closed shape."""
    between, beyond = Quadric.sphere((0, 0, 10), 2.0), Quadric.sphere((0, 0, 30), 2.0)
    camera = Camera((0, -60, 30), (0, 0, 10), 4, 4, near=0.5, far=1e3)
    world = np.array([[0, 0, 0.0], [0, 0, 8.0], [0, 0, 12.0]])
    view = world @ camera.rotation.T + camera.view[:3, 3]
    gbuf, obj, coef = fake_gbuffer(view, np.array([0, 1, 1]))
    QuadricCaster([between, beyond]).point_shadow(camera, gbuf, obj, PointLight((0, 0, 20)), coef)
    # ground under both: between blocks; the bottom of `between`: own shape only, then up to the
    # light (beyond is past it): kept; its top: lit path to the light
    assert list(read(coef, 3)) == [0.0, 0.5, 0.5]
