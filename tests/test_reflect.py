"""Reflections (kernels/reflect.cl, paper 002): programs specialised per condition vector,
the frame chain and the materials against the float64 twin (reference.envmap.reflect_frame)."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.camera import Camera
from oclshade.envmap import CubeMap, cube_frame
from oclshade.envmap.materials import Material
from oclshade.envmap.reflect import Reflections, reflect_program
from oclshade.quadrics import Quadric, QuadricCaster
from oclshade.reference import envmap as ref
from oclshade.runtime import get_runtime, kernel_source
from oclshade.specialize import specialize

EPS = float(np.finfo(np.float32).eps)
MATERIALS = [Material("mirror", (0.9, 0.8, 0.7)), Material("glossy", (0.3, 0.5, 0.2), fresnel=0.1),
             Material("glossy", roughness=0.3), Material("mirror", roughness=0.5), Material("diffuse")]


def scene(rotation: float = 30.0, seed: int = 0, orthographic: bool = False):
    rng = np.random.default_rng(seed)
    faces = np.zeros((6, 8, 8, 3), np.float32)
    for f in range(6):
        faces[f] = np.eye(3)[f % 3] * (0.5 + 0.5 * (f // 3))
    faces += 0.1 * rng.random(faces.shape).astype(np.float32)
    quadrics = [Quadric.sphere((-9, 0, 0), 3, MATERIALS[0]), Quadric.sphere((-3, 0, 0), 2.5, MATERIALS[1]),
                Quadric.ellipsoid((3, 0, 0), (2, 2, 3), material=MATERIALS[2]),
                Quadric.cylinder((9, 0, 0), 2, 5, axis=(0.3, 1, 1), material=MATERIALS[3]),
                Quadric.sphere((0, 6, 4), 2, MATERIALS[4])]
    camera = Camera((0, -30, 5), (0, 0, 0), 64, 32, fov=40, near=1, far=200,
                    projection="orthographic" if orthographic else "perspective", ortho_height=14.0)
    caster = QuadricCaster(quadrics)
    gbuf, ids = caster.cast(camera)
    return faces, caster, gbuf, ids, camera


def host(rt, buf, shape):
    out = np.empty(shape, np.float32)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    return out


def test_programs_hold_only_their_features():
    src = kernel_source("reflect.cl")
    mirror = specialize(src, "REFLECT")
    assert "schlick(mat" not in mirror and "OCLS_GOLDEN_ANGLE;" not in mirror and "view_dir" not in mirror
    glossy = specialize(src, "REFLECT FRESNEL ROUGH")
    assert "schlick(mat" in glossy and "phi = (float)s * OCLS_GOLDEN_ANGLE" in glossy
    assert not any(line.lstrip().startswith("@") for line in glossy.splitlines())     # every directive resolved
    background = specialize(src, "BACKGROUND")
    assert "view_dir" in background and "mat[3 * obj - 3]" not in background.split("reflect_apply")[1].split(
        "reflect_finish")[0]
    rt = get_runtime()
    assert reflect_program(rt, frozenset({"REFLECT"})) is reflect_program(rt, frozenset({"REFLECT"}))


@pytest.mark.parametrize("orthographic", [False, True])
def test_weights_and_reflections_match_the_twin(orthographic):
    """Albedo weights within 64 eps (Schlick's (1 - cos)^5 has slope <= 5 and cos carries a
    few eps); reflections within (64 N + 512) eps of the largest texel times the intensity:
    R and the cone's directions carry a few eps each, which moves the cube-map texel position
    by up to 16 eps N (N the face size) times the largest texel step, and the cone's angles
    k x golden angle (up to 36 rad) round to 36 eps of the cone."""
    faces, caster, gbuf, ids, camera = scene(orthographic=orthographic)
    rt = caster.runtime
    refl = Reflections(CubeMap(faces).to_device(rt), MATERIALS, rotation=30.0, intensity=1.5, background=True)
    weighted = refl.weights(gbuf, ids, camera)
    acc = refl.accumulate(gbuf, ids, camera)
    g, obj = gbuf.to_host(), ids.to_host(rt)
    want_albedo, want_acc = ref.reflect_frame(g.position, g.normal, g.albedo, obj, MATERIALS, camera, faces,
                                              cube_frame(30.0), 1, 1.5, True)
    got_albedo = host(rt, weighted.buffers["albedo"], g.albedo.shape)
    got_acc = host(rt, acc, (32, 64, 4))
    assert np.max(np.abs(got_albedo - want_albedo)) <= 64 * EPS
    assert np.max(np.abs(got_acc[..., :3] - want_acc)) <= (64 * 8 + 512) * EPS * faces.max() * 1.5
    assert np.all(got_acc[..., 3] == 0.0)
    for k, m in enumerate(MATERIALS):          # every material is in the view, and does what it says
        mask = obj == k + 1
        assert mask.sum() > 10
        if m.kind == "mirror":
            assert np.all(got_albedo[mask][:, :3] == 0.0)
        if m.kind == "diffuse":
            assert np.all(got_acc[mask][:, :3] == 0.0) and np.array_equal(got_albedo[mask], g.albedo[mask])
    assert np.all(got_acc[obj == 0][:, :3] > 0.0)       # the background shows the map
    assert np.array_equal(host(rt, gbuf.buffers["albedo"], g.albedo.shape), g.albedo)   # input untouched


def test_uber_programs_give_the_same_image():
    """Every feature compiled in, switched by the materials' parameters (a mirror is F0 = 1, a
    sharp reflection cone 0): bit for bit the specialised programs' result."""
    faces, caster, gbuf, ids, camera = scene()
    rt = caster.runtime
    cube = CubeMap(faces).to_device(rt)
    outs = []
    for uber in (False, True):
        refl = Reflections(cube, MATERIALS, background=True, uber=uber)
        outs.append((host(rt, refl.weights(gbuf, ids, camera).buffers["albedo"], (32, 64, 4)),
                     host(rt, refl.accumulate(gbuf, ids, camera), (32, 64, 4))))
    assert np.array_equal(outs[0][0], outs[1][0]) and np.array_equal(outs[0][1], outs[1][1])


def test_mirror_sphere_reflects_the_right_faces():
    """Frame chain and cube_frame together: a camera south of a mirror sphere looking north
    sees, at the sphere's centre, the environment behind itself (south: F's +Z), and higher
    up the sky (+Y); with rotation 90 the south direction is F's -X."""
    faces = np.zeros((6, 4, 4, 3), np.float32)
    colours = np.eye(3)[[0, 0, 1, 1, 2, 2]] * np.array([1, 0.5, 1, 0.5, 1, 0.5])[:, None]
    faces[:] = colours[:, None, None, :]
    camera = Camera((0, -50, 0), (0, 0, 0), 41, 41, fov=12, near=1, far=200)
    caster = QuadricCaster([Quadric.sphere((0, 0, 0), 5.0, Material("mirror"))])
    gbuf, ids = caster.cast(camera)
    for rotation, centre_face in ((0.0, 4), (90.0, 1)):
        refl = Reflections(CubeMap(faces).to_device(caster.runtime), [Material("mirror")], rotation, background=False)
        acc = host(caster.runtime, refl.accumulate(gbuf, ids, camera), (41, 41, 4))
        assert np.allclose(acc[20, 20, :3], colours[centre_face], atol=1e-6)
        # 13 rows up the normal leans 42 degrees towards the sky: R = (0, sin 84, cos 84), world up,
        # F's +Y whatever the rotation
        assert ids.to_host(caster.runtime)[7, 20] == 1
        assert np.allclose(acc[7, 20, :3], colours[2], atol=1e-6)


@given(st.integers(0, 255), st.floats(0.0, 3.0))
@settings(max_examples=30, deadline=None)
def test_finish_adds_in_linear_light(value, add):
    """8-bit sRGB in, + the reflection in linear light, 8-bit sRGB out (within one step of
    the exact result); a pixel with nothing added stays bit for bit."""
    rt = get_runtime()
    frame = np.array([[[value, value // 2, 255 - value, 200], [value, 0, 0, 255]]], np.uint8)
    acc = np.zeros((1, 2, 4), np.float32)
    acc[0, 0, :3] = add
    k = cl.Kernel(reflect_program(rt, frozenset({"BACKGROUND"})), "reflect_finish")
    bufs = rt.to_device(frame, "frame"), rt.to_device(acc, "acc"), rt.empty(8, "out")   # held until run
    out_buf = bufs[2]
    k.set_args(np.int32(2), *bufs)
    cl.enqueue_nd_range_kernel(rt.queue, k, (2,), None)
    out = np.empty_like(frame)
    cl.enqueue_copy(rt.queue, out, out_buf)
    rt.queue.finish()
    c = frame[0, 0, :3] / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4) + add
    lin = np.clip(lin, 0, 1)
    want = 255 * np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    assert np.all(np.abs(out[0, 0, :3].astype(float) - want) <= 0.5 + 1e-3) and out[0, 0, 3] == 200
    assert np.array_equal(out[0, 1], frame[0, 1])


def test_arguments_are_checked():
    rt = get_runtime()
    cube = CubeMap(np.ones((6, 2, 2, 3), np.float32)).to_device(rt)
    with pytest.raises(TypeError, match="DeviceCubeMap"):
        Reflections(CubeMap(np.ones((6, 2, 2, 3), np.float32)), [])
    with pytest.raises(ValueError, match="intensity must be"):
        Reflections(cube, [], intensity=-1.0)
    assert not Reflections(cube, [Material()], background=False).active
