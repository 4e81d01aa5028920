"""Cube maps generated from objects' centres (oclshade.scene.generate) and per-object maps."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from oclshade.camera import Camera, frame_heightmap
from oclshade.compose import Lighting
from oclshade.envmap import CubeMap, cube_frame, stack_cubes
from oclshade.envmap.cube import DeviceCubeMap
from oclshade.envmap.materials import Material
from oclshade.envmap.reflect import Reflections
from oclshade.frames import FrameSettings
from oclshade.heightmap import Heightmap
from oclshade.quadrics import Quadric, QuadricCaster
from oclshade.reference import compose as ref_compose
from oclshade.reference import envmap as ref
from oclshade.scene import Environment, ObjectScene
from oclshade.scene.generate import FaceScene, face_cameras, generate_cube
from oclshade.synthetic import canyon_crater
from oclshade.terrain import Heightfield


@pytest.mark.parametrize("rotation", [0.0, 20.0, -135.0])
def test_face_cameras_follow_the_face_table(rotation):
    """Pixel (r, c) of face f's camera looks exactly along texel (r, N - 1 - c) of face f."""
    n = 6
    m = cube_frame(rotation)
    for f, camera in enumerate(face_cameras((10.0, 20.0, 30.0), n, rotation)):
        _, d = camera.view_rays()
        face, s, t = ref.face_st((d @ camera.rotation) @ m.T)
        r, c = np.mgrid[0:n, 0:n]
        assert np.all(face == f)
        assert np.allclose(s, (n - 1 - c + 0.5) / n, atol=1e-12) and np.allclose(t, (r + 0.5) / n, atol=1e-12)


def _linear(scene, camera, sun, settings) -> np.ndarray:
    """A FaceScene frame read back: float32 (h, w, 3) linear light."""
    buf = scene.frame(camera, sun, settings).image
    assert isinstance(buf, cl.Buffer)
    out = np.empty((camera.height, camera.width, 4), np.float32)
    cl.enqueue_copy(scene.runtime.queue, out, buf)
    scene.runtime.queue.finish()
    return out[..., :3]


def test_generated_map_of_a_flat_map_from_above():
    """From above the middle of a flat map: the down face is terrain everywhere, the up face
    the background colour everywhere (exactly: linear light, no 8-bit step), the side faces
    sky above their middle row; each face is the face camera's frame mirrored left-right, bit
    for bit; the twin of compose's linear mode gives the down face's values."""
    hm = Heightmap.from_array(np.zeros((33, 33)), 10.0)
    scene = FaceScene(Heightfield(hm))
    lighting = Lighting(sun=(135.0, 40.0), background=(0.2, 0.4, 0.8))
    settings = FrameSettings(shadows=False, lighting=lighting)
    n, centre = 8, (160.0, -160.0, 20.0)
    cube = generate_cube(scene, centre, n, (135.0, 40.0), settings, near=0.5, far=1e4)
    assert isinstance(cube, DeviceCubeMap)
    faces = cube.to_host().faces
    sky = np.float32([0.2, 0.4, 0.8])
    assert np.all(faces[2] == sky)                                            # +Y: up, all sky
    camera = face_cameras(centre, n, 0.0, 0.5, 1e4)[3]
    down = _linear(scene, camera, (135.0, 40.0), settings)
    frame = scene.frame(camera, (135.0, 40.0), settings)
    g = frame.gbuffer.to_host()
    assert g.hit.all()                                                        # -Y: all terrain
    assert np.array_equal(faces[3], down[:, ::-1])
    shading = np.empty((n, n, 4), np.float32)
    cl.enqueue_copy(scene.runtime.queue, shading, frame.normals)
    want = ref_compose(g.position, shading, g.albedo, lighting.sun_view(camera), lighting.sun_intensity,
                               np.array(lighting.sky), lighting.up_view(camera), np.array(lighting.background),
                               linear=True)
    assert np.allclose(down, want, rtol=1e-5, atol=1e-6)
    for f in (0, 1, 4, 5):
        assert np.all(faces[f][: n // 2] == sky)                             # above the horizon: sky
        assert not np.allclose(faces[f][-1], sky)                            # just below: terrain


def test_generated_map_keeps_high_dynamic_range():
    """A sun of intensity 8 and a sky map of values up to 40: the generated map keeps them
    (an 8-bit frame would stop at 1), and its sky texels are the file map's, scaled by the
    environment's intensity, sampled exactly (face-aligned directions: texel centres)."""
    hm = Heightmap.from_array(np.zeros((17, 17)), 10.0)
    n = 4
    sky_faces = np.full((6, n, n, 3), 0.5, np.float32)
    sky_faces[2] = 40.0                                                       # +Y of F: world up
    env = Environment(CubeMap(sky_faces), intensity=0.5)
    scene = FaceScene(Heightfield(hm), (), env)
    lighting = Lighting(sun=(135.0, 60.0), sun_intensity=8.0, background=(0.0, 0.0, 0.0))
    settings = FrameSettings(shadows=False, lighting=lighting)
    cube = generate_cube(scene, (80.0, -80.0, 10.0), n, (135.0, 60.0), settings, near=0.5, far=1e4).to_host()
    assert np.all(cube.faces[2] == np.float32(20.0))                          # the sky, at intensity 0.5
    assert cube.faces[3].max(axis=-1).min() > 1.0                             # lit ground above 1


def test_generated_maps_are_read_at_intensity_one():
    """A mirror in a scene whose environment has intensity 2: the reflection of the sky in
    the generated map is the sky at 2 (not 4), like the same mirror reading the file map."""
    hm = Heightmap.from_array(np.zeros((17, 17)), 10.0)
    sky_faces = np.full((6, 4, 4, 3), 0.25, np.float32)
    mirror = Quadric.sphere((80.0, -80.0, 200.0), 10.0, Material("mirror"))
    camera = Camera((80.0, -80.0, 400.0), (80.0, -80.0, 200.0), 16, 16, up=(0, 1, 0), fov=4.0, near=1, far=1e4)
    settings = FrameSettings(shadows=False, lighting=Lighting(sun=(135.0, 60.0), background=(0.0, 0.0, 0.0)))
    images = {}
    for generate in (None, "once"):
        env = Environment(CubeMap(sky_faces), intensity=2.0, generate=generate)
        images[generate] = ObjectScene(Heightfield(hm), [mirror], env).frame(camera, (135.0, 60.0), settings).image
    centre = images[None][6:10, 6:10, :3].astype(int)                         # the sphere's top: sky
    assert np.abs(images["once"][6:10, 6:10, :3].astype(int) - centre).max() <= 1


def test_each_object_reads_its_own_map():
    camera = Camera((0, -40, 0), (0, 0, 0), 48, 24, fov=30, near=1, far=100)
    quadrics = [Quadric.sphere((-6, 0, 0), 3.0, Material("mirror")), Quadric.sphere((6, 0, 0), 3.0, Material("mirror"))]
    caster = QuadricCaster(quadrics)
    gbuf, ids = caster.cast(camera)
    red, blue = (np.zeros((6, 2, 2, 3), np.float32) for _ in range(2))
    red[..., 0], blue[..., 2] = 0.8, 0.6
    cubes = stack_cubes([CubeMap(red).to_device(caster.runtime), CubeMap(blue).to_device(caster.runtime)])
    refl = Reflections(cubes, [q.material for q in quadrics], background=False, cube_of=[1, 0])
    acc = np.empty((24, 48, 4), np.float32)
    cl.enqueue_copy(caster.runtime.queue, acc, refl.accumulate(gbuf, ids, camera))
    caster.runtime.queue.finish()
    obj = ids.to_host(caster.runtime)
    assert np.allclose(acc[obj == 1][:, :3], [0, 0, 0.6]) and np.allclose(acc[obj == 2][:, :3], [0.8, 0, 0])
    with pytest.raises(ValueError, match="cube_of must give each"):
        Reflections(cubes, [q.material for q in quadrics], cube_of=[0, 2])


@pytest.mark.parametrize("generate, expected", [("once", 1), (2, 3), (1, 5)])
def test_maps_are_regenerated_every_n_frames(generate, expected):
    hm = Heightmap.from_array(canyon_crater(24, 24, seed=1), 30.0)
    camera = frame_heightmap(hm, 32, 24)
    mirror = Quadric.sphere((350, -350, 1700), 120.0, Material("mirror"))
    scene = ObjectScene(Heightfield(hm), [mirror], Environment(generate=generate, size=4))
    ran = [scene.frame(camera, (135.0, 30.0)).ran for _ in range(5)]
    assert scene.generations == expected
    regenerated = [k for k in range(5) if k == 0 or (generate != "once" and k % generate == 0)]
    assert [("compose" in r) for r in ran] == [k in regenerated for k in range(5)]
    assert [r[:1] == ("generate",) for r in ran] == [k in regenerated for k in range(5)]
    obj = scene.ids.to_host(scene.runtime) == 1
    assert obj.any() and not np.array_equal(scene.frame(camera, (135.0, 30.0)).image[obj],
                                            np.zeros_like(scene.frame(camera, (135.0, 30.0)).image[obj]))


def test_environment_arguments():
    with pytest.raises(ValueError, match="needs a cube map, generate"):
        Environment()
    with pytest.raises(ValueError, match="generate must be 'once' or a number"):
        Environment(generate=0)
