"""Quadrics (kernels/quadric.cl) against their float64 twins (oclshade.reference.quadrics):
the closed-form cast, the depth merge with the terrain, object normals and shadows."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.camera import Camera, frame_heightmap
from oclshade.envmap.materials import Material
from oclshade.heightmap import Heightmap
from oclshade.quadrics import Quadric, QuadricCaster
from oclshade.reference import quadrics as ref
from oclshade.runtime import get_runtime
from oclshade.sun import Sun
from oclshade.terrain import DeviceGBuffer, Heightfield, TerrainRenderer

EPS = float(np.finfo(np.float32).eps)


def random_quadric(rng: np.random.Generator, kind: str, spread: float) -> Quadric:
    centre = rng.uniform(-spread, spread, 3)
    axis = rng.normal(size=3)
    r = rng.uniform(0.5, 3.0, 3)
    if kind == "sphere":
        return Quadric.sphere(centre, r[0])
    if kind == "ellipsoid":
        return Quadric.ellipsoid(centre, r, axis)
    if kind == "cylinder":
        return Quadric.cylinder(centre, r[0], 2 * r[2], axis)
    return Quadric.paraboloid(centre, r[0], r[2], axis)


def ties(quadrics, camera: Camera, got: ref.ReferenceQuadrics) -> np.ndarray:
    """Pixels whose float64 outcome (which object, if any) changes under a float32-sized
    perturbation of the rays: the camera turned by +-32 eps about its x and y axes, or moved
    by +-8 eps D along x, y and z (D the distance to the target: the size of the rounding of
    the ray origin in each object's unit frame).  Silhouettes, caps' and rims' edges, depth
    ties between objects: float32 may decide them either way."""
    out = np.zeros(got.object.shape, bool)
    fwd = camera.look_at - camera.position
    step = 8 * EPS * np.linalg.norm(fwd)
    variants = [(np.zeros(3), axis, sign) for axis in (0, 1) for sign in (-1.0, 1.0)]
    variants += [(sign * step * np.eye(3)[k], None, 0.0) for k in range(3) for sign in (-1.0, 1.0)]
    for shift, axis, sign in variants:
        look = fwd
        if axis is not None:
            rot = np.eye(3)
            a, b = (1, 2) if axis == 0 else (0, 2)
            c, s = np.cos(sign * 32 * EPS), np.sin(sign * 32 * EPS)
            rot[a, a], rot[a, b], rot[b, a], rot[b, b] = c, -s, s, c
            look = camera.rotation.T @ rot @ camera.rotation @ fwd
        moved = Camera(camera.position + shift, camera.position + shift + look, camera.width, camera.height,
                       up=camera.up, fov=camera.fov, near=camera.near, far=camera.far)
        out |= ref.cast_quadrics(quadrics, moved).object != got.object
    return out


KIND_LISTS = st.lists(st.sampled_from(["sphere", "ellipsoid", "cylinder", "paraboloid"]), min_size=1, max_size=5)


@given(st.integers(0, 2**32 - 1), KIND_LISTS, st.sampled_from([1.0, 30.0, 3000.0]))
@settings(max_examples=25, deadline=None)
def test_cast_matches_the_twin(seed, kinds, distance):
    """Objects agree off the ties; depth within 16 eps (D + r) / |cos| of the twin, D the
    distance to the object's centre, r its largest radius, cos the incidence: the float32
    ray in the unit frame carries rounding ~ eps (D + r) in position, which moves the hit
    along the ray by that over the cosine; the stable formulas keep the roots from adding
    cancellation (a far object at 3000 radii is the case the naive formula loses)."""
    rng = np.random.default_rng(seed)
    quadrics = [random_quadric(rng, k, 6.0) for k in kinds]
    target = rng.uniform(-2, 2, 3)
    direction = rng.normal(size=3)
    position = target + (12.0 + distance) * direction / np.linalg.norm(direction)
    camera = Camera(position, target, 40, 30, fov=60.0 if distance < 100 else 1.0, near=0.5, far=1e5)
    caster = QuadricCaster(quadrics)
    gbuf, ids = caster.cast(camera)
    host, obj = gbuf.to_host(), ids.to_host(caster.runtime)
    want = ref.cast_quadrics(quadrics, camera)
    tie = ties(quadrics, camera, want)
    assert np.array_equal(obj[~tie], want.object[~tie])
    assert tie.mean() < 0.25
    both = (obj == want.object) & (obj > 0) & ~tie
    if not both.any():
        return
    k = obj[both] - 1
    d_centre = np.array([np.linalg.norm(q.centre - camera.position) + q.radii.max() for q in quadrics])[k]
    d_view = camera.view_rays()[1][both]
    cos = np.abs(np.sum(want.normal[both] * d_view, 1)) / np.linalg.norm(d_view, axis=1)
    err = np.abs(host.depth[both] - want.depth[both])
    bound = 16 * EPS * d_centre / np.maximum(cos, 1e-3)
    assert np.all(err <= bound), float(np.max(err / bound))
    assert np.all(host.position[..., 3][obj > 0] == 1.0) and np.all(host.depth[obj == 0] == np.inf)
    assert np.allclose(host.albedo[obj > 0][:, 3], 1.0)


def test_fields_of_a_hit_and_of_an_empty_pixel():
    q = Quadric.sphere((0, 0, 0), 2.0, Material("diffuse", (0.2, 0.4, 0.6)))
    camera = Camera((0, -10, 0), (0, 0, 0), 5, 5, fov=40, near=1, far=100)
    hm = Heightmap.from_array(np.zeros((4, 4)), 1.0)
    caster = QuadricCaster([q], hm)
    gbuf, ids = caster.cast(camera)
    h, obj = gbuf.to_host(), ids.to_host(caster.runtime)
    assert obj[2, 2] == 1 and obj[0, 0] == 0
    assert np.allclose(h.position[2, 2], [0, 0, -8, 1], atol=1e-5) and h.depth[2, 2] == pytest.approx(8.0, abs=1e-5)
    assert np.allclose(h.normal[2, 2], [0, 0, 1, 0], atol=1e-6)
    assert np.allclose(h.albedo[2, 2], [0.2, 0.4, 0.6, 1.0])
    assert np.allclose(h.uv[2, 2], [0.0, 2.0], atol=1e-5)          # world (0, -2, 0): column 0, row 2
    assert np.all(h.uv_grad[2, 2] == 0.0)
    assert np.all(h.position[0, 0] == 0) and h.depth[0, 0] == np.inf and np.all(h.albedo[0, 0] == 0)


def test_camera_inside_and_the_bowl_face_the_viewer():
    """A camera inside a sphere sees its inside (normal towards the camera); a paraboloid
    seen from above shows its bowl with the normal turned up to the viewer."""
    camera = Camera((0, 0, 0), (0, 1, 0), 3, 3, fov=30, near=0.1, far=100)
    caster = QuadricCaster([Quadric.sphere((0, 0, 0), 5.0)])
    h = caster.cast(camera)[0].to_host()
    assert h.depth[1, 1] == pytest.approx(5.0, rel=1e-6) and h.normal[1, 1, 2] > 0.99
    top = Camera((0, 0, 20), (0, 0, 0), 3, 3, up=(0, 1, 0), fov=10, near=0.1, far=100)
    h = QuadricCaster([Quadric.paraboloid((0, 0, 0), 4.0, 2.0)]).cast(top)[0].to_host()
    assert h.depth[1, 1] == pytest.approx(20.0, rel=1e-6) and h.normal[1, 1, 2] > 0.99


def test_merge_keeps_the_nearest_hit():
    field = Heightfield(Heightmap.from_array(np.random.default_rng(1).random((24, 24)) * 30.0, 10.0))
    camera = frame_heightmap(field.heightmap, 48, 32, azimuth=200.0, elevation=30.0)
    renderer = TerrainRenderer(field)
    terrain = renderer.render(camera, on_device=True)
    before = terrain.to_host()
    quadrics = [Quadric.sphere((115, -115, 20), 40.0), Quadric.cylinder((60, -180, 10), 12, 80)]
    caster = QuadricCaster(quadrics, field.heightmap, renderer.runtime)
    objects = caster.cast(camera)
    q_host, q_obj = objects[0].to_host(), objects[1].to_host(caster.runtime)
    ids = caster.merge(objects, terrain)
    after, obj = terrain.to_host(), ids.to_host(caster.runtime)
    nearer = q_host.depth < before.depth
    assert 0 < nearer.mean() < 1 and (q_obj > 0).sum() > nearer.sum()    # quadrics partly behind terrain
    assert np.array_equal(obj, np.where(nearer, q_obj, 0))
    for name in ("position", "normal", "uv", "uv_grad", "depth", "albedo"):
        a, b, c = getattr(after, name), getattr(q_host, name), getattr(before, name)
        mask = nearer if a.ndim == 2 else nearer[..., None]
        assert np.array_equal(a, np.where(mask, b, c)), name
    shading = renderer.shading_normals(camera, after)             # host G-buffer in, host array out
    dev = renderer.runtime.to_device(np.ascontiguousarray(shading), "shading")
    caster.object_normals(terrain, ids, dev)
    fixed = np.empty_like(shading)
    cl.enqueue_copy(renderer.runtime.queue, fixed, dev)
    assert np.array_equal(fixed, np.where((obj > 0)[..., None], after.normal, shading))


def fake_gbuffer(points_view: np.ndarray, object_ids: np.ndarray) -> tuple[DeviceGBuffer, object, cl.Buffer]:
    """A one-row G-buffer holding chosen view-space points (position field only is read)."""
    from oclshade.gbuffer import CHANNELS
    from oclshade.quadrics import ObjectIds
    rt = get_runtime()
    n = len(points_view)
    pos = np.concatenate([points_view, np.ones((n, 1))], 1).astype(np.float32)
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
@settings(max_examples=20, deadline=None)
def test_terrain_shadow_of_object_pixels_matches_the_twin(seed, elevation, azimuth):
    """Object pixels (points anywhere above or below the terrain) against the terrain: equal
    to the twin's exact margin test off a tie band of 64 eps (|z| + max|h| + S (W + H)), S the
    largest height step between samples: the start point (u, v, z) is rounded to float32
    (a few eps of its size), which moves the surface under it by the slope times that."""
    rng = np.random.default_rng(seed)
    heights = rng.random((20, 17)) * 40.0
    heights[rng.random(heights.shape) < 0.03] = np.nan
    hm = Heightmap.from_array(heights, (7.0, 9.0))
    camera = Camera((60, -250, 150), (60, -90, 0), 8, 8, near=1, far=1e4)
    n = 400
    world = np.stack([rng.uniform(-10, 130, n), rng.uniform(-190, 10, n), rng.uniform(-5, 60, n)], 1)
    view = world @ camera.rotation.T + camera.view[:3, 3]
    far_away = Quadric.sphere((1e4, 1e4, -1e4), 1.0)                 # never in the way
    caster = QuadricCaster([far_away], hm)
    gbuf, ids, coef = fake_gbuffer(view, np.ones(n))
    sun = Sun(azimuth, elevation)
    caster.shadow(camera, gbuf, ids, sun, coef)
    got = read(coef, n)
    ray = sun.ray(hm.dx, hm.dy)
    rel = hm.relative32.astype(float)
    starts = np.stack([world[:, 0] / hm.dx, -world[:, 1] / hm.dy, world[:, 2] - hm.offset], 1)
    margin = np.array([ref.terrain_margin(rel, tuple(s), ray) for s in starts])
    slope = np.nanmax(np.abs(np.diff(rel, axis=0))) + np.nanmax(np.abs(np.diff(rel, axis=1)))
    band = 64 * EPS * (np.abs(starts[:, 2]) + np.nanmax(np.abs(rel)) + slope * sum(rel.shape))
    sure = np.abs(margin) > band
    assert np.array_equal(got[sure], np.where(margin[sure] > 0, 0.0, 1.0))
    assert sure.mean() > 0.95


@given(st.integers(0, 2**32 - 1), st.floats(5.0, 80.0))
@settings(max_examples=15, deadline=None)
def test_quadric_shadows_on_terrain_pixels_match_the_twin(seed, elevation):
    """Terrain pixels (object id 0) whose sun ray meets a quadric get the shadow value; the
    others keep the terrain pass's coefficient (0.5 here).  Ties: points whose float64 answer
    changes when the sun turns by 1e-4 rad (rays grazing a silhouette or a cap's rim)."""
    rng = np.random.default_rng(seed)
    quadrics = [random_quadric(rng, k, 5.0) for k in ("sphere", "ellipsoid", "cylinder", "paraboloid")]
    camera = Camera((0, -40, 20), (0, 0, 0), 8, 8, near=0.5, far=1e3)
    n = 300
    world = rng.uniform(-8, 8, (n, 3)) - [0, 0, 6]
    view = world @ camera.rotation.T + camera.view[:3, 3]
    caster = QuadricCaster(quadrics)
    gbuf, ids, coef = fake_gbuffer(view, np.zeros(n))
    sun = Sun(float(rng.uniform(0, 360)), elevation)
    caster.shadow(camera, gbuf, ids, sun, coef, k_dark=0.2, k_bright=0.2)
    got = read(coef, n)
    s = np.array(sun.vector())
    want = ref.quadric_occludes(quadrics, world, s)
    tie = np.zeros(n, bool)
    for turned in (Sun(sun.azimuth + 0.006, elevation), Sun(sun.azimuth - 0.006, elevation),
                   Sun(sun.azimuth, elevation + 0.006), Sun(sun.azimuth, elevation - 0.006)):
        tie |= ref.quadric_occludes(quadrics, world, np.array(turned.vector())) != want
    assert np.array_equal(got[~tie], np.where(want[~tie], np.float32(0.2), np.float32(0.5)))
    assert want.any() and tie.mean() < 0.05


def test_object_pixels_shadow_rules():
    """An object pixel is lit (1) unless blocked: its own closed shape does not shadow it (its
    far side is dark by the Lambert term already), another quadric does; the rim of its own
    open paraboloid shades the inside of the bowl under a low sun; sun below the horizon: all
    hit pixels get the shadow value."""
    a, b = Quadric.sphere((0, 0, 10), 2.0), Quadric.sphere((0, 0, 20), 2.0)
    bowl = Quadric.paraboloid((50, 0, 0), 4.0, 4.0)           # z = ((x - 50)^2 + y^2) / 4 inside
    camera = Camera((0, -60, 30), (0, 0, 10), 4, 4, near=0.5, far=1e3)
    world = np.array([[0, 0, 8.0], [0, 0, 12.0], [0, 0, 18.0], [51.5, 0.0, 0.5625]])
    view = world @ camera.rotation.T + camera.view[:3, 3]
    caster = QuadricCaster([a, b, bowl])
    gbuf, ids, coef = fake_gbuffer(view, np.array([1, 1, 2, 3]))
    caster.shadow(camera, gbuf, ids, Sun(90.0, 85.0), coef)
    # a's bottom: through a (own, left out), then b; a's top: under b; b's bottom: through b (own) only;
    # the bowl under a high sun: lit
    assert list(read(coef, 4)) == [0.0, 0.0, 1.0, 1.0]
    caster.shadow(camera, gbuf, ids, Sun(270.0, 10.0), coef)    # low sun in the west: the west wall at d = 3.7
    assert read(coef, 4)[3] == 0.0
    caster.shadow(camera, gbuf, ids, Sun(90.0, -1.0), coef, k_dark=0.3, k_bright=0.3)
    assert np.all(read(coef, 4) == np.float32(0.3))


def test_quadric_arguments_are_checked():
    with pytest.raises(ValueError, match="kind must be one of"):
        Quadric("torus", (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="radii must be 3 positive"):
        Quadric.ellipsoid((0, 0, 0), (1, 0, 1))
    with pytest.raises(ValueError, match="a sphere has one radius"):
        Quadric("sphere", (0, 0, 0), (1, 2, 1))
    with pytest.raises(ValueError, match="axis must be a non-zero"):
        Quadric.cylinder((0, 0, 0), 1, 2, axis=(0, 0, 0))
    with pytest.raises(ValueError, match="centre must be 3 finite"):
        Quadric.sphere((0, np.nan, 0), 1)
    with pytest.raises(ValueError, match="quadrics must be 1.."):
        QuadricCaster([])
    with pytest.raises(ValueError, match="material must be one of"):
        Material("chrome")
    with pytest.raises(ValueError, match="roughness must be a number in"):
        Material("glossy", roughness=2.0)
