"""Mesh shadows by shadow volumes (paper 003): silhouette, device counts against the float64
twin (shadow rays against every triangle), caching, precision far from the origin."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import HealthCheck, assume, given, settings, strategies as st

from oclshade.camera import Camera
from oclshade.gbuffer import CHANNELS
from oclshade.meshes.lights import PointLight
from oclshade.meshes.mesh import TriangleMesh
from oclshade.meshes.shadow_volumes import MeshShadows, build_volumes, visible_box, winding_number
from oclshade.meshes.silhouette import caster_faces, is_closed, silhouette_edges
from oclshade.reference import mesh_shadows as ref
from oclshade.runtime import get_runtime
from oclshade.sun import Sun
from oclshade.terrain import DeviceGBuffer, Heightfield, TerrainRenderer

ISS = Path("/work/shared/data/meshes/iss.obj")


# --- generated meshes ---------------------------------------------------------------------
def torus(centre, major: float, minor: float, n: int = 8, m: int = 5, tilt: float = 0.0,
          cast_shadows: bool = True, drop: int = 0) -> TriangleMesh:
    """A closed, non-convex torus (n x m quads), tilted ``tilt`` degrees about x; ``drop``
    faces left out make it open."""
    u, v = np.meshgrid(np.arange(n) * 2 * np.pi / n, np.arange(m) * 2 * np.pi / m, indexing="ij")
    pts = np.stack([(major + minor * np.cos(v)) * np.cos(u), (major + minor * np.cos(v)) * np.sin(u),
                    minor * np.sin(v)], -1).reshape(-1, 3)
    c, s = math.cos(math.radians(tilt)), math.sin(math.radians(tilt))
    pts = pts @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + np.asarray(centre, float)
    faces = []
    for i in range(n):
        for j in range(m):
            a, b = i * m + j, ((i + 1) % n) * m + j
            c_, d = ((i + 1) % n) * m + (j + 1) % m, i * m + (j + 1) % m
            faces += [[a, b, c_], [a, c_, d]]
    return TriangleMesh(pts, faces[drop:], cast_shadows=cast_shadows, name="torus")


def box(centre, half, turn: float = 0.0) -> TriangleMesh:
    """A closed box (outward winding), turned ``turn`` degrees about z."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * np.asarray(half, float)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    faces = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return TriangleMesh(v, faces).placed(translate=centre, rotate_z=turn)


def ground(z: float, half: float) -> TriangleMesh:
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], float)
    return TriangleMesh(v, [[0, 1, 2], [0, 2, 3]], cast_shadows=False, name="ground")


def load_obj(path: Path) -> TriangleMesh:
    """Vertices and fan-triangulated faces of an OBJ file (the test's own minimal reader)."""
    verts, faces = [], []
    for line in path.read_text(errors="replace").splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return TriangleMesh(np.array(verts), np.array(faces), name=path.stem)


# --- a float64 primary cast: the G-buffer the shadows are counted on ---------------------------
def cast(camera: Camera, meshes) -> tuple[np.ndarray, np.ndarray]:
    """(position float32 (H, W, 4) view space, depth float32 (H, W)) of the nearest triangle
    (two-sided) per pixel ray, near <= t <= far, float64."""
    o, d = camera.view_rays()
    rot = camera.view[:3, :3]
    ow, dw = o.reshape(-1, 3) @ rot + camera.position, d.reshape(-1, 3) @ rot
    tri = np.concatenate([m.vertices[m.faces] for m in meshes])
    best = np.full(len(ow), np.inf)
    for k in range(0, len(tri), 512):
        a, b, c = (tri[k:k + 512, i] for i in range(3))
        e1, e2 = b - a, c - a
        pv = np.cross(dw[:, None], e2[None])
        det = np.einsum("ptk,tk->pt", pv, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = ow[:, None] - a[None]
            u = np.einsum("ptk,ptk->pt", s, pv) * inv
            q = np.cross(s, e1[None])
            v = np.einsum("ptk,pk->pt", q, dw) * inv
            t = np.einsum("ptk,tk->pt", q, e2) * inv
        ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= camera.near) & (t <= camera.far)
        best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1))
    hit = np.isfinite(best)
    pos = np.zeros((len(ow), 4), np.float32)
    pos[hit, :3] = o.reshape(-1, 3)[hit] + best[hit, None] * d.reshape(-1, 3)[hit]
    pos[hit, 3] = 1.0
    shape = (camera.height, camera.width)
    return pos.reshape(*shape, 4), np.where(hit, best, np.inf).astype(np.float32).reshape(shape)


def device_gbuffer(rt, position: np.ndarray, depth: np.ndarray) -> DeviceGBuffer:
    h, w = depth.shape
    arrays = {"position": position, "depth": depth}
    bufs = {name: rt.to_device(np.ascontiguousarray(arrays.get(name, np.zeros((h, w, ch), np.float32))), name)
            for name, ch in CHANNELS.items()}
    return DeviceGBuffer(rt, (h, w), bufs)


def compare(camera, meshes, light, position, rt=None, bounds=None):
    """(device mask, twin mask, ties, hit) for one frame."""
    rt = rt or get_runtime(None)
    depth = np.where(position[..., 3] > 0.5, -position[..., 2], np.inf).astype(np.float32)
    shadows = MeshShadows(meshes, rt, bounds=bounds)
    got = shadows.mask_to_host(camera, device_gbuffer(rt, position, depth), light)
    hit = position[..., 3] > 0.5
    pts = ref.world_points(camera, position)
    want, grazing = ref.shadow_mask(meshes, light, pts, hit, ref.towards_viewer(camera, pts),
                                    ref.float32_band(camera, pts))
    ties = ref.tie_pixels(camera, shadows.volumes(light), pts, hit) | grazing
    return got, want, ties, hit


def assert_agree(got, want, ties, hit, what: str, max_ties: float = 0.01) -> None:
    bad = (got != want) & hit & ~ties
    assert not bad.any(), f"{what}: {int(bad.sum())} pixels differ from the float64 twin away from ties " \
                          f"(at {np.argwhere(bad)[:5].tolist()})"
    assert not (got & ~hit).any(), f"{what}: empty pixels marked shadowed"
    assert ties.sum() <= max(3, max_ties * hit.sum()), f"{what}: {int(ties.sum())} ties of {int(hit.sum())}"


# --- silhouette ------------------------------------------------------------------------------
@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*(st.integers(0, 7),) * 3).filter(lambda f: len(set(f)) == 3), min_size=1, max_size=30))
def test_silhouette_cancellation_equals_independent_edge_count(faces):
    got = silhouette_edges(np.array(faces))
    assert sorted(map(tuple, got.tolist())) == sorted(map(tuple, ref.boundary_edges(np.array(faces)).tolist()))


@pytest.mark.parametrize("light", [Sun(30, 40), Sun(250, 5), PointLight([3.0, -2.0, 1.5])])
def test_silhouette_of_a_closed_non_convex_mesh_is_closed_loops(light):
    mesh = torus([0, 0, 0], 2.0, 0.7, 10, 6, tilt=35.0)
    assert is_closed(mesh.faces)
    casters = caster_faces(mesh, light)
    edges = silhouette_edges(casters)
    assert 0 < len(edges) < 3 * len(casters)
    out_deg = np.bincount(edges[:, 0], minlength=len(mesh.vertices))
    in_deg = np.bincount(edges[:, 1], minlength=len(mesh.vertices))
    assert np.array_equal(out_deg, in_deg)        # the boundary of the caster set is a set of closed loops
    both = sorted(map(tuple, edges.tolist())) == sorted(map(tuple, ref.boundary_edges(casters).tolist()))
    assert both


def test_open_meshes_cast_from_both_sides():
    mesh = torus([0, 0, 0], 2.0, 0.7, drop=3)
    assert not is_closed(mesh.faces)
    casters = caster_faces(mesh, Sun(0, 60))
    assert len(casters) == len(mesh.faces) - np.sum(
        np.einsum("ij,j->i", mesh.face_normals, Sun(0, 60).vector()) == 0)
    nrm = TriangleMesh(mesh.vertices, casters).face_normals
    assert (nrm @ np.array(Sun(0, 60).vector()) > 0).all()
    assert len(caster_faces(TriangleMesh(mesh.vertices, mesh.faces, cast_shadows=False), Sun(0, 60))) == 0


def test_volumes_are_closed_and_wound_outwards():
    mesh = torus([0, 0, 5], 2.0, 0.7, 9, 5, tilt=20.0)
    for light in (Sun(100, 30), PointLight([1.0, 2.0, 12.0])):
        vol = build_volumes([mesh], light, 50.0)
        assert len(ref.boundary_edges(vol.faces[:, :3])) == 0
        centre_below = mesh.vertices.mean(axis=0) - 3.0 * np.array(light.vector() if isinstance(light, Sun) else
                                                                   [0, 0, 1.0])
        assert winding_number(vol.triangles, np.array([0.0, 0.0, 5.0]) + 1e3) == 0
        assert winding_number(vol.triangles, centre_below + [2.0, 0.0, 0.0]) >= 1


@settings(max_examples=25, deadline=None)
@given(az=st.floats(0, 360), el=st.floats(5, 89), point=st.booleans(), drop=st.integers(0, 3),
       seed=st.integers(0, 2 ** 16))
def test_winding_number_is_the_shadow_ray_count(az, el, point, drop, seed):
    """The start count (the eye's winding number about the volumes, float64) is nonzero exactly
    where the twin's shadow ray meets a caster, for points around and under a torus."""
    mesh = torus([0, 0, 10], 3.0, 1.2, 8, 5, tilt=25.0, drop=drop)
    sun = Sun(az, el)
    light = PointLight(np.array([0.0, 0.0, 10.0]) + 40.0 * np.array(sun.vector())) if point else sun
    vol = build_volumes([mesh], light, 200.0)
    points = np.random.default_rng(seed).uniform([-15, -15, -2], [15, 15, 22], (40, 3))
    keep = ~ref.near_triangles(points, vol.triangles, np.full(len(points), 1e-6)).any(axis=1)
    hidden, _ = ref.shadow_mask([mesh], light, points, np.ones(len(points), bool), viewer=points)
    counts = np.array([winding_number(vol.triangles, q) for q in points])
    assert (counts >= 0).all()
    assert np.array_equal((counts != 0)[keep], hidden[keep])


@settings(max_examples=30, deadline=None)
@given(pos=st.tuples(*(st.floats(-1e4, 1e4),) * 3), dx=st.floats(-1, 1), dy=st.floats(-1, 1), dz=st.floats(-1, 1),
       fov=st.floats(5, 150), depth=st.floats(1, 1e4), ortho=st.booleans())
def test_visible_box_holds_every_visible_point(pos, dx, dy, dz, fov, depth, ortho):
    assume(abs(dx) + abs(dy) + abs(dz) > 1e-3)
    camera = Camera(pos, np.array(pos) + [dx, dy, dz], 16, 9, fov=fov, near=0.1, far=2e4,
                    projection="orthographic" if ortho else "perspective", ortho_height=50.0)
    origins, dirs = camera.view_rays()
    t = np.random.default_rng(0).uniform(0, depth, origins.shape[:2])[..., None]
    world = (origins + t * dirs).reshape(-1, 3) @ camera.rotation + camera.position
    lo, hi = visible_box(camera, depth)
    spare = 1e-9 * (np.abs(world).max() + depth)
    assert np.all(world >= lo - spare) and np.all(world <= hi + spare)


def test_no_casting_faces_no_shadow():
    camera, light = SCENES["sun"]
    meshes = [torus([0, 0, 10], 3.0, 1.2, cast_shadows=False), ground(0.0, 60)]
    position, depth = cast(camera, meshes)
    rt = get_runtime(None)
    shadows = MeshShadows(meshes, rt)
    assert not shadows.mask_to_host(camera, device_gbuffer(rt, position, depth), light).any()
    assert shadows.volumes(light).casters == 0


# --- counts against the twin -------------------------------------------------------------------
SCENES = {
    "sun": (Camera([12, -18, 16], [-2, 2, 3], 96, 64, fov=50), Sun(135, 40)),
    "point light": (Camera([12, -18, 16], [-2, 2, 3], 96, 64, fov=50), PointLight([5, 5, 25])),
    "eye in shadow": (Camera([0.5, -0.3, 2], [10, 5, 1], 96, 64, fov=60, near=0.1), Sun(135, 80)),
    "eye in a point light's shadow": (Camera([3.0, 0.1, 2], [6, 2, 0], 96, 64, fov=60, near=0.1),
                                      PointLight([3.0, 0.0, 30])),
    "orthographic": (Camera([12, -18, 16], [-2, 2, 3], 96, 64, projection="orthographic", ortho_height=30),
                     Sun(135, 40)),
}


@pytest.mark.parametrize("name", SCENES)
def test_counts_equal_the_twin(name):
    camera, light = SCENES[name]
    meshes = [torus([0, 0, 10], 3.0, 1.2, 10, 6, tilt=30.0), box([8, -4, 4], [1.5, 2.5, 4], 20.0),
              torus([-9, 6, 6], 2.0, 0.8, drop=5), ground(0.0, 60)]
    position, _ = cast(camera, meshes)
    got, want, ties, hit = compare(camera, meshes, light, position)
    assert want.sum() > 20, "the scene must show shadows"
    if "eye" in name:
        vol = build_volumes(meshes, light, 1e3)
        assert winding_number(vol.triangles, camera.position) > 0
    assert_agree(got, want, ties, hit, name)


def test_eye_beyond_the_scene_bounds():
    """Receivers' bounds given (the scene's box) and the eye far outside them, looking back
    through the volume's far end: the eye joins the box, so no view segment meets a dark cap
    (dark caps are counted only before the near plane)."""
    camera = Camera([700, 63, -0.4], [0, 2.6, 11.5], 96, 64, fov=3)
    meshes = [torus([0, 0, 10], 3.0, 1.2, 10, 6, tilt=30.0), ground(0.0, 60)]
    position, _ = cast(camera, meshes)
    got, want, ties, hit = compare(camera, meshes, PointLight([-30, 0, 12]), position,
                                   bounds=([-60, -60, 0], [60, 60, 14]))
    assert want.sum() > 50
    assert_agree(got, want, ties, hit, "bounds", max_ties=0.03)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(centre=st.tuples(st.floats(-6, 6), st.floats(-6, 6), st.floats(4, 14)),
       major=st.floats(1.0, 4.0), ratio=st.floats(0.15, 0.6), tilt=st.floats(0, 90), drop=st.integers(0, 4),
       turn=st.floats(0, 90), az=st.floats(0, 360), el=st.floats(10, 89), point=st.booleans(),
       cam_az=st.floats(0, 360), cam_el=st.floats(8, 80), cam_dist=st.floats(12, 60),
       ortho=st.booleans())
def test_random_meshes_lights_and_cameras(centre, major, ratio, tilt, drop, turn, az, el, point, cam_az, cam_el,
                                          cam_dist, ortho):
    meshes = [torus(centre, major, major * ratio, 7, 4, tilt=tilt, drop=drop),
              box([centre[0] + 5, centre[1] - 3, 2.5], [1.0, 1.5, 2.5], turn), ground(0.0, 80)]
    sun = Sun(az, el)
    light = PointLight(np.array(centre) + 30.0 * np.array(sun.vector())) if point else sun
    a, e = math.radians(cam_az), math.radians(cam_el)
    eye = np.array(centre) + cam_dist * np.array([math.sin(a) * math.cos(e), math.cos(a) * math.cos(e),
                                                  math.sin(e)])
    camera = Camera(eye, centre, 40, 30, fov=55, near=0.05,
                    projection="orthographic" if ortho else "perspective", ortho_height=1.2 * cam_dist)
    vol = build_volumes(meshes, light, 500.0)
    assume(not ref.near_triangles(camera.position[None], vol.triangles, np.array([1e-3])).any())
    position, _ = cast(camera, meshes)
    got, want, ties, hit = compare(camera, meshes, light, position)
    # a face edge-on to the light (hypothesis finds boxes with the sun along an axis) lies in a
    # volume's side: all its pixels are ties, however large it looks
    assert_agree(got, want, ties, hit, "random", max_ties=0.25)


def test_meshes_shadow_the_terrain():
    """Meshes above a flat terrain rendered by the terrain ray caster: their shadow falls on it."""
    rt = get_runtime(None)
    field = Heightfield.from_array(np.full((65, 65), 2.0), cellsize=2.0)
    camera = Camera([64, -200, 90], [64, -64, 2], 64, 48, fov=50)
    gbuf = TerrainRenderer(field, rt).render(camera, on_device=True).to_host()
    meshes = [torus([60, -60, 22], 10.0, 3.5, 10, 6, tilt=25.0), box([90, -90, 12], [5, 8, 10], 30.0)]
    mesh_pos, mesh_depth = cast(camera, meshes)
    nearer = mesh_depth < gbuf.depth
    position = np.where(nearer[..., None], mesh_pos, gbuf.position)
    got, want, ties, hit = compare(camera, meshes, Sun(70, 30), position, rt)
    on_terrain = want & ~nearer
    assert on_terrain.sum() > 30, "the meshes must shadow the terrain"
    assert_agree(got, want, ties, hit, "terrain")


@pytest.mark.parametrize("offset", [1e6, 1e7])
def test_no_cracks_far_from_the_origin(offset):
    """Paper 003's space distances: the same scene 1e6 and 1e7 m from the origin."""
    shift = np.array([offset, -0.6 * offset, 0.3 * offset])
    meshes = [torus(shift + [0, 0, 10], 3.0, 1.2, 12, 6, tilt=30.0),
              box(shift + [8, -4, 4], [1.5, 2.5, 4], 20.0),
              ground(0.0, 60).placed(translate=shift)]
    camera = Camera(shift + [12, -18, 16], shift + [-2, 2, 3], 96, 64, fov=50)
    position, _ = cast(camera, meshes)
    got, want, ties, hit = compare(camera, meshes, Sun(135, 40), position)
    assert want.sum() > 50
    assert_agree(got, want, ties, hit, f"at {offset:g} m")


@pytest.mark.skipif(not ISS.exists(), reason="needs /work/shared/data/meshes/iss.obj")
@pytest.mark.parametrize("offset", [1e6, 1e7])
def test_iss_far_from_the_origin(offset):
    iss = load_obj(ISS)
    lo, hi = iss.bounds
    centre = (lo + hi) / 2
    shift = np.array([offset, 0.5 * offset, -0.2 * offset]) - centre
    mesh = iss.placed(translate=shift)
    size = float(np.linalg.norm(hi - lo))
    target = shift + centre
    camera = Camera(target + size * np.array([0.5, -0.6, 0.45]), target, 40, 25, fov=50, near=0.01 * size)
    position, _ = cast(camera, [mesh])
    got, want, ties, hit = compare(camera, [mesh], Sun(60, 50), position)
    assert want.sum() > 20
    assert_agree(got, want, ties, hit, f"ISS at {offset:g} m", max_ties=0.03)


# --- caching and cost ------------------------------------------------------------------------
def test_caching_and_shadows_off():
    rt = get_runtime(None)
    meshes = [torus([0, 0, 10], 3.0, 1.2), ground(0.0, 60)]
    builds = rt.build_misses + rt.build_hits
    shadows = MeshShadows(meshes, rt)
    assert shadows._volumes is None and rt.build_misses + rt.build_hits == builds   # nothing built or compiled
    camera, light = SCENES["sun"]
    position, depth = cast(camera, meshes)
    gbuf = device_gbuffer(rt, position, depth)
    first = shadows.mask_to_host(camera, gbuf, light, gbuffer_key="g1")
    assert shadows.ran == ("volumes", "mask")
    assert np.array_equal(shadows.mask_to_host(camera, gbuf, light, gbuffer_key="g1"), first)
    assert shadows.ran == () and shadows.counts == {"volumes": 1, "mask": 1}        # mask reused
    shadows.mask(camera, gbuf, light)                                               # no key: counted again
    assert shadows.ran == ("mask",)
    moved = Camera(camera.position + [5, 0, 2], camera.look_at, camera.width, camera.height, fov=50)
    position2, depth2 = cast(moved, meshes)
    shadows.mask(moved, device_gbuffer(rt, position2, depth2), light, gbuffer_key="g2")
    assert shadows.ran == ("mask",) and shadows.counts["volumes"] == 1              # volumes kept
    shadows.mask(moved, device_gbuffer(rt, position2, depth2), Sun(140, 40), gbuffer_key="g2")
    assert shadows.ran == ("volumes", "mask")                                       # the light moved


def test_shadow_writes_the_coefficient():
    rt = get_runtime(None)
    meshes = [torus([0, 0, 10], 3.0, 1.2), ground(0.0, 60)]
    camera, light = SCENES["sun"]
    position, depth = cast(camera, meshes)
    gbuf = device_gbuffer(rt, position, depth)
    shadows = MeshShadows(meshes, rt)
    coef = np.full(depth.shape, 0.75, np.float32)
    buf = rt.to_device(coef, "coefficient")
    shadows.shadow(camera, gbuf, None, light, buf, k_dark=0.2, k_bright=0.6)
    out = np.empty_like(coef)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    mask = shadows.mask_to_host(camera, gbuf, light)
    k = 0.2 + 0.4 * math.sin(math.radians(40))
    assert mask.sum() > 20
    assert np.allclose(out[mask], k) and np.all(out[~mask] == 0.75)


def test_silhouette_volumes_equal_all_face_volumes():
    rt = get_runtime(None)
    meshes = [torus([0, 0, 10], 3.0, 1.2, 10, 6, tilt=30.0), ground(0.0, 60)]
    camera, light = SCENES["sun"]
    position, depth = cast(camera, meshes)
    gbuf = device_gbuffer(rt, position, depth)
    sil = MeshShadows(meshes, rt).mask_to_host(camera, gbuf, light)
    per_face = MeshShadows(meshes, rt, per_face=True)
    assert np.array_equal(per_face.mask_to_host(camera, gbuf, light), sil)
    assert per_face.volumes(light).silhouette == 3 * per_face.volumes(light).casters


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="meshes"):
        MeshShadows([])
    with pytest.raises(ValueError, match="bounds"):
        MeshShadows([torus([0, 0, 0], 2, 1)], bounds=([1, 1, 1], [0, 0, 0]))
    with pytest.raises(ValueError, match="point light"):
        PointLight([0, 0])
