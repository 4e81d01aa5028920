"""Meshes on the device (kernels/mesh.cl, oclshade.meshes.MeshCaster) against the float64 twin
(oclshade.reference.meshes): hit/miss, depth and normals; far from the origin; alpha
cut-outs, textures, normal maps; the merge and ids; terrain shadows on mesh pixels and
any-hit shadow rays; an Embree cross-check on a shared mesh."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.camera import Camera
from oclshade.gbuffer import CHANNELS
from oclshade.heightmap import Heightmap
from oclshade.meshes import MeshCaster, MeshSurface, TriangleMesh, load_mesh
from oclshade.quadrics import ObjectIds, Quadric, QuadricCaster
from oclshade.reference import meshes as ref
from oclshade.reference.quadrics import terrain_margin
from oclshade.runtime import get_runtime
from oclshade.sun import Sun
from oclshade.terrain import DeviceGBuffer

SHARED = Path("/work/shared/data/meshes")
EPS = float(np.finfo(np.float32).eps)


def sphere(radius: float, subdivisions: int = 2) -> TriangleMesh:
    """An icosphere (closed, shared vertices), from subdividing an icosahedron."""
    t = (1 + 5 ** 0.5) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
         [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
         [8, 6, 7], [9, 8, 1]]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(subdivisions):
        mids, nf = {}, []
        for a, b, c in f:
            m = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in mids:
                    p = v[i] + v[j]
                    v.append(p / np.linalg.norm(p))
                    mids[key] = len(v) - 1
                m.append(mids[key])
            nf += [[a, m[0], m[2]], [b, m[1], m[0]], [c, m[2], m[1]], m]
        f = nf
    v = np.array(v)
    return TriangleMesh(radius * v, np.array(f), normals=v)


def grid(n: int, size: float, z=None) -> TriangleMesh:
    """An n x n grid of quads (two triangles each) over [0, size]^2, heights z(x, y), uvs 0..1."""
    x, y = np.meshgrid(np.linspace(0, size, n + 1), np.linspace(0, size, n + 1))
    h = np.zeros_like(x) if z is None else z(x, y)
    v = np.stack([x.ravel(), y.ravel(), h.ravel()], 1)
    i = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return TriangleMesh(v, faces, uvs=v[:, :2] / size)


def random_mesh(rng: np.random.Generator) -> TriangleMesh:
    """A closed bumpy sphere or a loose cloud of triangles (both kinds of edge)."""
    if rng.random() < 0.5:
        s = sphere(1.0, int(rng.integers(1, 3)))
        v = s.vertices * rng.uniform(0.6, 1.4, (len(s.vertices), 1)) * rng.uniform(0.5, 5)
        return TriangleMesh(v, s.faces)
    count = int(rng.integers(1, 40))
    centres = rng.normal(size=(count, 1, 3)) * 3
    v = (centres + rng.normal(size=(count, 3, 3))).reshape(-1, 3)
    return TriangleMesh(v, np.arange(3 * count).reshape(-1, 3))


def look_at_mesh(mesh: TriangleMesh, rng: np.random.Generator, size=(40, 30)) -> Camera:
    """A perspective (70 %) or orthographic camera looking at the mesh from outside its bound."""
    lo, hi = mesh.bounds
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    distance = radius * rng.uniform(1.5, 6)
    target = centre + rng.normal(size=3) * 0.2 * radius
    ortho = rng.random() < 0.3
    return Camera(centre + distance * direction, target, *size, fov=float(rng.uniform(20, 70)),
                  near=0.01 * radius, far=distance + 4 * radius, projection="orthographic" if ortho else "perspective",
                  ortho_height=float(rng.uniform(0.5, 3)) * radius)


def compare(meshes, camera, gbuf) -> dict:
    """Device vs twin: pixels differing in hit/miss off the band (must be none), the depth
    error bound off the band, normals."""
    want = ref.cast_meshes(meshes, camera)
    near = ref.near_edges(meshes, camera)
    hit = gbuf.hit
    off = hit != want["hit"]
    both = hit & want["hit"] & ~near
    rel = np.abs(gbuf.depth[both] - want["depth"][both]) / want["depth"][both]
    return {"cracks": int((off & ~near).sum()), "ties": int((off & near).sum()), "hits": int(want["hit"].sum()),
            "rel": rel, "cos": want["cos"][both], "normal": np.abs(gbuf.normal[both][:, :3] - want["normal"][both]),
            "want": want, "near": near}


# The depth bound: the float32 roundings of the band (metres, reference.meshes) moved along
# the face normal change t by band / (|d| cos), relative to t: about 32 u (R + |c| + t) / (t cos).
def depth_bound(meshes, camera, cosine: np.ndarray, depth: np.ndarray) -> np.ndarray:
    b = max(ref.band(m, camera, 0.0) for m in meshes) + ref.BAND * ref.U32 * depth * 2.0
    return b / (np.maximum(cosine, 1e-3) * depth)


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=15, deadline=None)
def test_cast_matches_the_twin(seed):
    rng = np.random.default_rng(seed)
    meshes = [random_mesh(rng) for _ in range(int(rng.integers(1, 3)))]
    camera = look_at_mesh(meshes[0], rng)
    caster = MeshCaster(meshes)
    gbuf, ids = caster.cast(camera)
    got = gbuf.to_host()
    c = compare(meshes, camera, got)
    assert c["cracks"] == 0
    both = got.hit & c["want"]["hit"] & ~c["near"]
    assert np.all(c["rel"] <= depth_bound(meshes, camera, c["cos"], c["want"]["depth"][both]))
    assert np.all(c["normal"] <= 1e-4)
    # ids: -(mesh + 1) on hits, 0 elsewhere; the twin's mesh where not tied
    want_ids = np.where(c["want"]["hit"], -(c["want"]["mesh"] + 1), 0)
    sure = ~c["near"]
    assert np.array_equal(ids.to_host(caster.runtime)[sure], want_ids[sure])
    assert np.all(got.depth[~got.hit] == np.inf) and np.all(got.albedo[got.hit, 3] == 1)


@pytest.mark.parametrize("distance", [1e6, 1e7])
def test_far_from_the_origin_no_cracks(distance):
    """A finely tessellated wavy sheet (800 triangles, 20 m) and a sphere 1e6 and 1e7 m from
    the world origin: every ray the twin sees hit off the band hits on the device (no cracks
    between triangles), depths within the bound."""
    shift = np.array([distance, -0.6 * distance, 120.0])
    sheet = grid(20, 20.0, lambda x, y: 0.5 * np.sin(x) * np.cos(y))
    sheet = TriangleMesh(sheet.vertices + shift, sheet.faces)
    ball = TriangleMesh(sphere(3.0).vertices + shift + [10, 10, 4], sphere(3.0).faces)
    camera = Camera(shift + [10, 9, 12], shift + [10, 10, 0], 64, 48, fov=50, near=0.5, far=100)
    got = MeshCaster([sheet, ball]).cast(camera)[0].to_host()
    c = compare([sheet, ball], camera, got)
    assert c["cracks"] == 0 and c["hits"] == 64 * 48 and got.hit.all()      # the sheet fills the frame
    both = got.hit & c["want"]["hit"] & ~c["near"]
    assert np.all(c["rel"] <= depth_bound([sheet, ball], camera, c["cos"], c["want"]["depth"][both]))
    # the float32 world coordinates a naive caster would use are ~1 m apart at 1e7 m: the
    # per-mesh origin is what makes this pass
    assert np.spacing(np.float32(distance)) >= 0.0625


@pytest.mark.skipif(not (SHARED / "iss.obj").is_file(), reason="shared meshes not present")
def test_iss_at_1e7_metres_matches_the_twin():
    iss = load_mesh(SHARED / "iss.obj").placed(translate=(1e7, 1e7, 400.0))
    lo, hi = iss.bounds
    centre = 0.5 * (lo + hi)
    camera = Camera(centre + [12, -15, 9], centre, 40, 30, fov=60, near=0.5, far=200)
    got = MeshCaster([iss]).cast(camera)[0].to_host()
    want = ref.cast_meshes([iss], camera)
    off = got.hit != want["hit"]
    assert not (off & ~ref.near_edges([iss], camera, off)).any() and want["hit"].sum() > 200


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=10, deadline=None)
def test_alpha_cut_outs_match_the_twin(seed):
    """A 6 x 6 grid of quads (uvs 0..3: the texture repeats) with a random 8 x 8 alpha
    pattern over a floor, random cameras: hit mesh, depth and uv equal the twin's off ties.
    A tie is a pixel whose twin uv lies within 1e-4 of a texel line, or near an edge: on these
    flat, well-shaped triangles uv is affine in the hit point, so the device's uv differs by
    the band (<= 1e-5 m here) over the 2 m quad plus a few float32 ulps of uv (< 1e-6)."""
    rng = np.random.default_rng(seed)
    tex = np.ones((8, 8, 4), np.float32)
    tex[..., 3] = rng.random((8, 8)) < 0.5
    sheet = grid(6, 12.0)
    sheet = TriangleMesh(sheet.vertices + [-6, -6, 2], sheet.faces, uvs=sheet.uvs * 3.0,
                         surface=MeshSurface(texture=tex))
    floor = TriangleMesh([[-20, -20, 0], [20, -20, 0], [20, 20, 0], [-20, 20, 0.0]], [[0, 1, 2], [0, 2, 3]])
    camera = Camera(rng.uniform(-4, 4, 3) + [0, 0, 14], rng.uniform(-2, 2, 3) * [1, 1, 0], 32, 32,
                    fov=float(rng.uniform(40, 80)), near=0.5, far=100)
    caster = MeshCaster([sheet, floor])
    gbuf, ids = caster.cast(camera)
    got, ids = gbuf.to_host(), ids.to_host(caster.runtime)
    want = ref.cast_meshes([sheet, floor], camera)
    texels = want["uv"] * 8.0
    tie = (np.abs(texels - np.round(texels)) < 8 * 1e-4).any(axis=2) & (want["mesh"] == 0)
    tie |= ref.near_edges([sheet, floor], camera)
    sure = ~tie
    assert np.array_equal(ids[sure], np.where(want["hit"], -(want["mesh"] + 1), 0)[sure])
    assert (ids[sure] == -1).any() and (ids[sure] == -2).any()       # the sheet and the floor through it
    assert np.allclose(got.depth[sure], want["depth"][sure], rtol=1e-5)
    assert np.allclose(got.uv[sure], want["uv"][sure], atol=1e-5)


def quad(z: float, surface: MeshSurface, size: float = 10.0) -> TriangleMesh:
    """A square [-size/2, size/2]^2 at height z, facing up, uv (0, 0) at the south-west corner."""
    h = size / 2
    v = np.array([[-h, -h, z], [h, -h, z], [h, h, z], [-h, h, z]])
    return TriangleMesh(v, [[0, 1, 2], [0, 2, 3]], uvs=[[0, 0], [1, 0], [1, 1], [0, 1]], surface=surface)


def top_camera(size=(32, 32)) -> Camera:
    return Camera((0, 0, 20), (0, 0, 0), *size, up=(0, 1, 0), fov=20, near=0.5, far=100)


def test_alpha_cut_outs_leave_no_trace():
    """A texture opaque in its east half, transparent (alpha 0) in its west half, over a red
    floor: west pixels show the floor (depth, colour and id), east ones the textured quad."""
    tex = np.ones((4, 4, 4), np.float32)
    tex[:, :2, 3] = 0.0
    tex[:, 2:, :3] = [0.0, 0.0, 1.0]
    top = quad(2.0, MeshSurface((1, 1, 1), texture=tex))
    floor = TriangleMesh(quad(0.0, MeshSurface()).vertices * [3, 3, 1], [[0, 1, 2], [0, 2, 3]],
                         surface=MeshSurface((1, 0, 0)))
    camera = top_camera()
    caster = MeshCaster([top, floor])
    gbuf, ids = caster.cast(camera)
    got, ids = gbuf.to_host(), ids.to_host(caster.runtime)
    inside = np.abs(np.arange(32) - 15.5) < 12                     # rows / cols on the quad, not its rim
    west, east = np.ix_(inside, np.arange(32) < 14), np.ix_(inside, (np.arange(32) > 17) & (np.arange(32) < 28))
    assert np.allclose(got.depth[west], 20.0, rtol=1e-5) and np.all(ids[west] == -2)
    assert np.allclose(got.albedo[west], [1, 0, 0, 1])
    assert np.allclose(got.depth[east], 18.0, rtol=1e-5) and np.all(ids[east] == -1)
    assert np.allclose(got.albedo[east], [0, 0, 1, 1])
    # uv on mesh pixels: the texture's (u grows east, v north), 0 on the floor (no uvs)
    assert np.all(np.diff(got.uv[east][..., 0], axis=1) > 0) and np.all(np.diff(got.uv[east][..., 1], axis=0) < 0)
    assert np.all(got.uv[west] == 0) and np.all(got.uv_grad == 0)
    # a cut-out also lets sun rays through: the floor under the west half is lit, under the east half dark
    hidden = caster.shadow_mask(camera, gbuf, Sun(0.0, 90.0))
    assert not hidden[west].any() and hidden[np.ix_(inside, (np.arange(32) > 17) & (np.arange(32) < 28))].sum() == 0
    floor_only = MeshCaster([floor])
    fg = floor_only.cast(camera)[0]
    blocked = caster.shadow_mask(camera, fg, Sun(0.0, 90.0))
    assert blocked[east].all() and not blocked[west].any()


@pytest.mark.parametrize("angle", [0.0, 30.0, -50.0])
def test_normal_maps_turn_the_normal_in_tangent_space(angle):
    """A constant normal map tilted by `angle` towards the tangent (growing u: east here, or
    north when the uvs are turned): the view normal is the world normal (sin a T + cos a N)."""
    a = np.radians(angle)
    nmap = np.tile(np.float32([np.sin(a), 0.0, np.cos(a)]), (2, 2, 1))
    camera = top_camera((8, 8))
    for uvs, tangent in (([[0, 0], [1, 0], [1, 1], [0, 1]], [1, 0, 0]), ([[0, 1], [0, 0], [1, 0], [1, 1]], [0, 1, 0])):
        m = quad(0.0, MeshSurface(normal_map=nmap))
        m = TriangleMesh(m.vertices, m.faces, uvs=uvs, surface=m.surface)
        got = MeshCaster([m]).cast(camera)[0].to_host()
        want = camera.rotation @ (np.sin(a) * np.array(tangent) + np.cos(a) * np.array([0, 0, 1.0]))
        assert np.allclose(got.normal[got.hit][:, :3], want, atol=1e-5)


def test_interpolated_normals_and_back_faces():
    """Vertex normals are interpolated; a triangle seen from its back shows the flipped normal."""
    v = np.array([[-5, -5, 0], [5, -5, 0], [0, 5, 0.0]])
    n = np.array([[-0.6, 0, 0.8], [0.6, 0, 0.8], [0, 0, 1.0]])
    up = MeshCaster([TriangleMesh(v, [[0, 1, 2]], normals=n)]).cast(top_camera((16, 16)))[0].to_host()
    x = up.normal[up.hit][:, 0]
    assert x.min() < -0.3 and x.max() > 0.3 and np.all(up.normal[up.hit][:, 2] > 0)
    below = Camera((0, 0, -20), (0, 0, 0), 16, 16, up=(0, 1, 0), fov=20, near=0.5, far=100)
    down = MeshCaster([TriangleMesh(v, [[0, 1, 2]], normals=n)]).cast(below)[0].to_host()
    assert np.all(down.normal[down.hit][:, 2] > 0)                  # view z: toward the camera


def test_merge_with_quadrics_keeps_ids_apart():
    """Terrain-free merge of a quadric G-buffer and a mesh one: the nearest hit wins, quadric
    ids stay > 0 and mesh ids < 0; object normals cover both."""
    camera = Camera((0, -30, 0), (0, 0, 0), 24, 16, fov=40, near=0.5, far=100)
    ball = Quadric.sphere((-3, 0, 0), 2.0)
    mesh = TriangleMesh(sphere(2.0).vertices + [3, 0, 0], sphere(2.0).faces)
    qc, mc = QuadricCaster([ball]), MeshCaster([mesh])
    rt = mc.runtime
    into, ids = qc.cast(camera)
    mc.merge(mc.cast(camera), into, ids)
    got, ids = into.to_host(), ids.to_host(rt)
    assert set(np.unique(ids)) == {-1, 0, 1}
    assert np.all(ids[:, :10][got.hit[:, :10]] == 1) and np.all(ids[:, 14:][got.hit[:, 14:]] == -1)
    shading = rt.to_device(np.zeros(16 * 24 * 4, np.float32), "shading")
    mc.object_normals(into, ObjectIds(rt.to_device(ids, "ids"), ids.shape), shading)
    out = np.empty((16, 24, 4), np.float32)
    cl.enqueue_copy(rt.queue, out, shading)
    rt.queue.finish()
    assert np.array_equal(out[ids != 0], got.normal[ids != 0]) and np.all(out[ids == 0] == 0)


def fake_gbuffer(view: np.ndarray, object_ids: np.ndarray):
    """A 1 x n G-buffer whose positions are `view` (all hits) and whose ids are given."""
    rt = get_runtime()
    n = len(view)
    pos = np.zeros((n, 4), np.float32)
    pos[:, :3], pos[:, 3] = view, 1.0
    bufs = {name: rt.empty(4 * ch * n, name) for name, ch in CHANNELS.items()}
    cl.enqueue_copy(rt.queue, bufs["position"], pos)
    ids = ObjectIds(rt.to_device(object_ids.astype(np.int32), "ids"), (1, n))
    coef = rt.to_device(np.full(n, 0.5, np.float32), "coef")
    return DeviceGBuffer(rt, (1, n), bufs), ids, coef


def read(buf: cl.Buffer, n: int) -> np.ndarray:
    out = np.empty(n, np.float32)
    cl.enqueue_copy(get_runtime().queue, out, buf)
    get_runtime().queue.finish()
    return out


@given(st.integers(0, 2**32 - 1), st.floats(3.0, 60.0), st.floats(0.0, 360.0))
@settings(max_examples=10, deadline=None)
def test_terrain_shadows_on_mesh_pixels_match_the_twin(seed, elevation, azimuth):
    """Mesh pixels (id < 0) against the terrain, exactly as quadric pixels (the shared
    terrain_ray.h; band as tests/test_quadrics.py); terrain pixels (id 0) keep the terrain
    pass's 0.5; the sun below the horizon darkens every mesh pixel."""
    rng = np.random.default_rng(seed)
    heights = rng.random((20, 17)) * 40.0
    hm = Heightmap.from_array(heights, (7.0, 9.0))
    camera = Camera((60, -250, 150), (60, -90, 0), 8, 8, near=1, far=1e4)
    n = 300
    world = np.stack([rng.uniform(-10, 130, n), rng.uniform(-190, 10, n), rng.uniform(-5, 60, n)], 1)
    view = world @ camera.rotation.T + camera.view[:3, 3]
    ids = -rng.integers(0, 3, n)
    caster = MeshCaster([sphere(1.0)], hm)
    gbuf, dev_ids, coef = fake_gbuffer(view, ids)
    sun = Sun(azimuth, elevation)
    caster.shadow(camera, gbuf, dev_ids, sun, coef, k_dark=0.2, k_bright=0.2)
    got = read(coef, n)
    rel = hm.relative32.astype(float)
    starts = np.stack([world[:, 0] / hm.dx, -world[:, 1] / hm.dy, world[:, 2] - hm.offset], 1)
    margin = np.array([terrain_margin(rel, tuple(s), sun.ray(hm.dx, hm.dy)) for s in starts])
    slope = np.nanmax(np.abs(np.diff(rel, axis=0))) + np.nanmax(np.abs(np.diff(rel, axis=1)))
    band = 64 * EPS * (np.abs(starts[:, 2]) + np.nanmax(np.abs(rel)) + slope * sum(rel.shape))
    sure = (np.abs(margin) > band) & (ids < 0)
    assert np.array_equal(got[sure], np.where(margin[sure] > 0, np.float32(0.2), 1.0))
    assert np.all(got[ids == 0] == 0.5)
    caster.shadow(camera, gbuf, dev_ids, Sun(azimuth, -2.0), coef, k_dark=0.3, k_bright=0.3)
    assert np.all(read(coef, n)[ids < 0] == np.float32(0.3))


def test_shadow_rays_match_a_float64_shadow():
    """Points on the ground under a floating 4 x 4 m square lit from the sun: hidden exactly
    where the float64 ray toward the sun crosses the square (off a 1e-4 m band of its rim);
    meshes without cast_shadows hide nothing; empty pixels read 0."""
    rng = np.random.default_rng(3)
    sun = Sun(150.0, 50.0)
    s = np.array(sun.vector())
    square = TriangleMesh([[-2, -2, 3], [2, -2, 3], [2, 2, 3], [-2, 2, 3.0]], [[0, 1, 2], [0, 2, 3]])
    camera = Camera((0, -30, 20), (0, 0, 0), 8, 8, near=0.5, far=100)
    world = np.concatenate([rng.uniform(-8, 8, (400, 2)), np.zeros((400, 1))], 1)
    view = world @ camera.rotation.T + camera.view[:3, 3]
    gbuf, _, _ = fake_gbuffer(view, np.zeros(400))
    hidden = MeshCaster([square]).shadow_mask(camera, gbuf, sun)[0]
    hit = world[:, :2] + (3.0 / s[2]) * s[:2]              # where the ray reaches z = 3
    inside = np.abs(hit).max(axis=1)
    sure = np.abs(inside - 2.0) > 1e-4
    assert np.array_equal(hidden[sure], inside[sure] < 2.0) and hidden.any()
    # a point light L 10 m above the square (z = 13): the ray from a ground point w crosses
    # the square's plane z = 3 at w + 3/13 (L - w)
    light = type("Point", (), {"position": np.array([0.5, -0.3, 13.0])})()
    hidden = MeshCaster([square]).shadow_mask(camera, gbuf, light)[0]
    foot = (world[:, :2] - light.position[:2]) * (10.0 / 13.0) + light.position[:2]   # where it crosses z = 3
    inside = np.abs(foot).max(axis=1)
    sure = np.abs(inside - 2.0) > 1e-4
    assert np.array_equal(hidden[sure], inside[sure] < 2.0) and hidden.any() and not hidden.all()
    # the light below the square: nothing in the way
    assert not MeshCaster([square]).shadow_mask(camera, gbuf, type("P", (), {"position": (0, 0, 2.0)})()).any()
    passive = TriangleMesh(square.vertices, square.faces, cast_shadows=False)
    assert not MeshCaster([passive]).shadow_mask(camera, gbuf, sun).any()
    empty, _, _ = fake_gbuffer(view, np.zeros(400))
    cl.enqueue_fill_buffer(get_runtime().queue, empty.buffers["position"], np.float32(0), 0, 400 * 16)
    assert not MeshCaster([square]).shadow_mask(camera, empty, sun).any()


def test_own_builtins_change_nothing():
    rng = np.random.default_rng(11)
    meshes = [random_mesh(rng), random_mesh(rng)]
    camera = look_at_mesh(meshes[0], rng)
    a = MeshCaster(meshes, own_builtins=True).cast(camera)[0].to_host()
    b = MeshCaster(meshes, own_builtins=False).cast(camera)[0].to_host()
    assert a.hit.any() and all(np.array_equal(getattr(a, k), getattr(b, k)) for k in CHANNELS)


def test_caster_arguments_are_checked():
    with pytest.raises(ValueError, match="TriangleMesh"):
        MeshCaster([])
    with pytest.raises(TypeError, match="heightmap must be"):
        MeshCaster([sphere(1.0)], heightmap=np.zeros((3, 3)))


@pytest.mark.skipif(not (SHARED / "bunny_oded.obj").is_file(), reason="shared meshes not present")
def test_embree_agrees_on_the_bunny():
    """Embree (embreex, float32, its own BVH and test) against the device on the bunny: at most
    0.1 % of hit pixels differ in hit/miss, depths agree to 1e-4 relative off the silhouettes."""
    rtcore = pytest.importorskip("embreex.rtcore_scene")
    construction = pytest.importorskip("embreex.mesh_construction")
    bunny = load_mesh(SHARED / "bunny_oded.obj").placed(scale=10.0)
    camera = Camera((18, -22, 10), (0, 0, 0), 96, 72, fov=35, near=0.5, far=100)
    got = MeshCaster([bunny]).cast(camera)[0].to_host()
    scene = rtcore.EmbreeScene()
    construction.TriangleMesh(scene, bunny.vertices[bunny.faces].astype(np.float32))
    o, d = ref.world_rays(camera)
    res = scene.run(o.astype(np.float32), d.astype(np.float32), output=1)
    ehit = (res["geomID"] >= 0).reshape(got.hit.shape)
    edepth = np.where(ehit, res["tfar"].reshape(got.hit.shape), np.inf)
    differ = ehit != got.hit
    assert differ.sum() <= 0.001 * ehit.sum() + 1 and ehit.sum() > 1000
    both = ehit & got.hit
    rel = np.abs(edepth[both] - got.depth[both]) / got.depth[both]
    assert np.mean(rel < 1e-4) > 0.99
