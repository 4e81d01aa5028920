"""Cube maps generated from objects' centres (oclshade.scene.generate) and per-object maps."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from oclshade.camera import Camera, frame_heightmap
from oclshade.compose import Lighting
from oclshade.envmap import CubeMap, cube_frame, stack_cubes
from oclshade.envmap.files import srgb_to_linear
from oclshade.envmap.materials import Material
from oclshade.envmap.reflect import Reflections
from oclshade.frames import FrameSettings, TerrainScene
from oclshade.heightmap import Heightmap
from oclshade.quadrics import Quadric, QuadricCaster
from oclshade.reference import envmap as ref
from oclshade.scene import Environment, ObjectScene
from oclshade.scene.generate import face_cameras, generate_cube
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


def test_generated_map_of_a_flat_map_from_above():
    """From above the middle of a flat map: the down face is terrain everywhere, the up face
    the background colour everywhere, the side faces sky above their middle row; each face is
    the face camera's frame mirrored left-right."""
    hm = Heightmap.from_array(np.zeros((33, 33)), 10.0)
    scene = TerrainScene(Heightfield(hm))
    lighting = Lighting(sun=(135.0, 40.0), background=(0.2, 0.4, 0.8))
    settings = FrameSettings(shadows=False, lighting=lighting)
    n, centre = 8, (160.0, -160.0, 20.0)
    cube = generate_cube(scene, centre, n, (135.0, 40.0), settings, near=0.5, far=1e4)
    bg = np.array([0.2, 0.4, 0.8])
    sky = srgb_to_linear(np.round(255 * (1.055 * bg ** (1 / 2.4) - 0.055)) / 255)   # compose's 8-bit background
    assert np.allclose(sky, bg, atol=0.01)
    assert np.allclose(cube.faces[2], sky)                                   # +Y: up, all sky
    down = scene.frame(face_cameras(centre, n, 0.0, 0.5, 1e4)[3], (135.0, 40.0), settings)
    assert down.gbuffer.to_host().hit.all()                                  # -Y: all terrain
    assert np.array_equal(cube.faces[3], srgb_to_linear(down.image[:, ::-1, :3] / 255.0).astype(np.float32))
    for f in (0, 1, 4, 5):
        assert np.allclose(cube.faces[f][: n // 2], sky)                     # above the horizon: sky
        assert not np.allclose(cube.faces[f][-1], sky)                       # just below: terrain


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
