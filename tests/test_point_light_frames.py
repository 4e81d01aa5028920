"""Point lights in frames and scene files (docs/meshes.md "Point lights"): compose with a point
light against its float64 twin and by hand, the frame's shadows against the twins of every
caster, the pass keys, the sun's frames unchanged, [[light]] tables and `oclshade render`."""
from __future__ import annotations

import math

import numpy as np
import pyopencl as cl
import pytest
from hypothesis import given, settings, strategies as st
from PIL import Image

from oclshade import reference as ref
from oclshade.camera import Camera
from oclshade.cli import main
from oclshade.compose import Lighting, compose, compose_linear
from oclshade.frames import FrameSettings, TerrainScene
from oclshade.heightmap import Heightmap
from oclshade.lights import PointLight
from oclshade.meshes import MeshCaster
from oclshade.quadrics import Quadric
from oclshade.scene import ObjectScene, SceneError, load_scene
from oclshade.sun import Sun
from oclshade.terrain import Heightfield, TerrainRenderer
from test_mesh_scene import CUBE_OBJ, cube
from test_point_light import twin_terrain
from test_terrain_compose import scene  # noqa: F401  (the module's wavy terrain and its G-buffer)


def read(buf: cl.Buffer, shape: tuple[int, int], runtime) -> np.ndarray:
    out = np.empty(shape, np.float32)
    cl.enqueue_copy(runtime.queue, out, buf)
    runtime.queue.finish()
    return out


@pytest.mark.parametrize("distance,ssaa", [(None, 1), (40.0, 1), (40.0, 2)])
def test_compose_with_a_point_light_matches_the_twin(scene, distance, ssaa):
    """-D OCLS_POINT_LIGHT against the twin (per-sample direction, falloff), 8-bit and linear."""
    _, cam, renderer, g = scene
    rng = np.random.default_rng(4)
    shadow = (rng.random(g.shape) < 0.7).astype(np.float32)
    light = Lighting(sun=PointLight((150.0, -120.0, 60.0), distance), sun_intensity=1.5)
    got = compose(g, cam, light, shadow=shadow, device=renderer.runtime, ssaa=ssaa)
    args = (g.position, g.normal, g.albedo, cam.view[:3, :3] @ light.sun.position + cam.view[:3, 3],
            light.sun_intensity, np.array(light.sky), light.up_view(cam), np.array(light.background), shadow, None,
            ssaa)
    falloff = 0.0 if distance is None else distance ** 2
    want = ref.compose(*args, point=True, falloff=falloff)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    rt = renderer.runtime
    buf = compose_linear(g, cam, light, shadow=shadow, device=rt, ssaa=ssaa)
    lin = np.empty(got.shape, np.float32)
    cl.enqueue_copy(rt.queue, lin, buf)
    rt.queue.finish()
    assert np.allclose(lin[..., :3], ref.compose(*args, linear=True, point=True, falloff=falloff), rtol=1e-5, atol=1e-6)
    sun = compose(g, cam, Lighting(sun=(120.0, 30.0), sun_intensity=1.5), shadow=shadow, device=rt, ssaa=ssaa)
    assert not np.array_equal(got, sun)


def test_point_light_by_hand_on_flat_ground():
    """Flat ground (albedo a, normal up), a light h metres above the point (x0, y0) with reference
    distance r0: the irradiance at horizontal distance r is I (r0^2 / (r^2 + h^2)) h / sqrt(r^2 + h^2)
    (inverse square times the cosine), without falloff I h / sqrt(r^2 + h^2)."""
    field = Heightfield.from_array(np.zeros((41, 41)), 1.0)
    cam = Camera((20.0, -20.0, 200.0), (20.0, -20.0, 0.0), 41, 41, up=(0, 1, 0), fov=12.0, near=1.0, far=500.0)
    renderer = TerrainRenderer(field)
    g = renderer.render(cam)
    world = (g.position[..., :3].astype(float) - cam.view[:3, 3]) @ cam.rotation
    for distance in (None, 8.0):
        light = Lighting(sun=PointLight((20.0, -20.0, 10.0), distance), sun_intensity=0.5, sky=(0.0, 0.0, 0.0))
        lin = np.empty(g.shape + (4,), np.float32)
        cl.enqueue_copy(renderer.runtime.queue, lin, compose_linear(g, cam, light, device=renderer.runtime))
        renderer.runtime.queue.finish()
        r2 = (world[..., 0] - 20.0) ** 2 + (world[..., 1] + 20.0) ** 2
        d = np.sqrt(r2 + 100.0)
        gain = 1.0 if distance is None else distance ** 2 / d ** 2
        want = g.albedo[..., :3] * (0.5 * gain * 10.0 / d)[..., None]
        assert np.allclose(lin[..., :3][g.hit], want[g.hit], rtol=1e-4, atol=1e-6)


def small_scene(seed: int):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:16, 0:14]
    h = 12.0 * np.sin(x / 2.5 + rng.uniform(0, 6)) * np.cos(y / 3.0) + 3.0 * rng.random((16, 14))
    h[rng.random(h.shape) < 0.02] = np.nan
    hm = Heightmap.from_array(h, 10.0)
    sphere = Quadric.sphere((rng.uniform(40, 90), rng.uniform(-110, -50), 20.0), 8.0)
    box = cube((rng.uniform(30, 90), rng.uniform(-120, -40), 10.0), 10.0, cast_shadows=True, colour=(0.6, 0.5, 0.4))
    light = PointLight((rng.uniform(0, 130), rng.uniform(-150, 0), rng.uniform(20, 45)))
    camera = Camera((65.0, -260.0, 140.0), (65.0, -75.0, 0.0), 48, 36, near=1.0, far=1e3)
    return hm, sphere, box, light, camera


@pytest.mark.parametrize("method", ["rays", "volumes"])
@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=3, deadline=None)
def test_frame_shadows_of_a_point_light_match_the_twins(method, seed):
    """ObjectScene with a point light: each hit pixel's coefficient is k_dark (0) where the twin
    of the terrain (exact segment, terrain pixels from the surface) or of the quadrics (their
    own closed shape left out) or the meshes' shadow rays (MeshCaster.shadow_mask, tested
    against its own twin in tests/test_mesh_gbuffer.py) hide the light, else 1; ties apart."""
    hm, sphere, box, light, camera = small_scene(seed)
    scene = ObjectScene(Heightfield(hm), [sphere], meshes=[box], mesh_shadows=method)
    frame = scene.frame(camera, light, FrameSettings())
    rt = scene.runtime
    got = read(frame.shadow, frame.gbuffer.shape, rt)
    host = frame.gbuffer.to_host()
    ids = scene.ids.to_host(rt)
    hit = host.hit
    view32 = host.position[..., :3][hit]
    terrain, tie = twin_terrain(hm, view32, ids[hit], light, camera)
    world = (view32.astype(float) - camera.view[:3, 3]) @ camera.rotation
    quad = ref.quadric_segment_occludes([sphere], world, light.position, skip=ids[hit])
    reach = np.linalg.norm(light.position - world, axis=1)[:, None]
    for axis in range(3):
        for sign in (-1.0, 1.0):
            moved = light.position + sign * 1e-4 * reach * np.eye(3)[axis]
            for i in np.flatnonzero(~tie):
                tie[i] |= ref.quadric_segment_occludes([sphere], world[i:i + 1], moved[i], skip=ids[hit][i:i + 1])[0] \
                    != quad[i]
    meshes = MeshCaster([box]).shadow_mask(camera, frame.gbuffer, light)[hit]
    want = np.where(terrain | quad | meshes, 0.0, 1.0).astype(np.float32)
    assert np.array_equal(got[hit][~tie], want[~tie])
    assert tie.mean() < 0.05 and 0.0 < want.mean() < 1.0
    assert np.all(got[~hit] == 1.0)


def test_the_light_keys_the_passes():
    """The same light: shadows and compose reused; a moved light: both run again (the G-buffer
    not); a new reference distance: compose (and shadows: the light's key) again; a sun after a
    point light: both again."""
    hm, sphere, box, light, camera = small_scene(1)
    scene = ObjectScene(Heightfield(hm), [sphere], meshes=[box])
    assert scene.frame(camera, light).ran == ("gbuffer", "normals", "shadows", "compose")
    assert scene.frame(camera, PointLight(light.position.copy())).ran == ()
    moved = PointLight(light.position + [5.0, 0.0, 0.0])
    first = scene.frame(camera, moved)
    assert first.ran == ("shadows", "compose")
    assert "compose" in scene.frame(camera, PointLight(moved.position, 30.0)).ran
    assert scene.frame(camera, Sun(200.0, 30.0)).ran == ("shadows", "compose")


def test_sun_frames_are_the_sun_passes():
    """With a sun the frame is made by the sun's passes alone, as before point lights: its
    shadow coefficients are the terrain pass, MeshCaster.shadow, QuadricCaster.shadow and the
    meshes' rays run by hand, and its image is compose of those with the sun (programs without
    OCLS_POINT_LIGHT), bit for bit."""
    hm, sphere, box, _, camera = small_scene(2)
    sun = Sun(215.0, 24.0)
    settings_ = FrameSettings(shadow_k=(0.2, 0.5))
    scene = ObjectScene(Heightfield(hm), [sphere], meshes=[box])
    frame = scene.frame(camera, sun, settings_)
    rt = scene.runtime
    gbuf, ids = frame.gbuffer, scene.ids
    coef = scene.shadow_caster.shade_to_device(gbuf, sun, "exact", settings_.lod, "coefficient", k_dark=0.2,
                                               k_bright=0.5)["coefficient"]
    scene.mesh_caster.shadow(camera, gbuf, ids, sun, coef, 0.2, 0.5)
    scene.caster.shadow(camera, gbuf, ids, sun, coef, 0.2, 0.5)
    MeshCaster([box], None, rt).ray_shadow(camera, gbuf, sun, coef, 0.2, 0.5)
    want = read(coef, gbuf.shape, rt)
    assert np.array_equal(read(frame.shadow, gbuf.shape, rt), want)
    assert (want < 1).any()
    image = compose(gbuf, camera, Lighting(sun=sun), shadow=want, device=rt, normal=frame.normals)
    assert np.array_equal(frame.image, image)


def test_terrain_scene_refuses_a_point_light():
    hm, _, _, light, camera = small_scene(3)
    with pytest.raises(ValueError, match="ObjectScene"):
        TerrainScene(Heightfield(hm)).frame(camera, light)
    with pytest.raises(ValueError, match="curved map"):
        ObjectScene(Heightfield(hm, 6.371e6)).frame(camera, light)
    scene = ObjectScene(Heightfield(hm), [Quadric.sphere((50, -50, 20), 5.0)], meshes=[cube((30, -30, 5), 5.0)])
    frame = scene.frame(camera, Sun(100.0, 30.0))
    with pytest.raises(TypeError, match="terrain_point_shadow"):
        scene.mesh_caster.shadow(camera, frame.gbuffer, scene.ids, light, frame.shadow)
    with pytest.raises(TypeError, match="point_shadow"):
        scene.caster.shadow(camera, frame.gbuffer, scene.ids, light, frame.shadow)


SCENE = """[terrain]
dem = "d.npy"
cellsize = 10
[camera]
position = [60, -250, 160]
look_at = [60, -60, 0]
size = [40, 30]
"""


def test_light_tables(tmp_path):
    np.save(tmp_path / "d.npy", np.zeros((12, 12)))
    path = tmp_path / "s.toml"
    path.write_text(SCENE + '[[light]]\nkind = "point"\nposition = [50, -60, 30]\nintensity = 3.0\ndistance = 25\n')
    desc = load_scene(path)
    assert isinstance(desc.light, PointLight) and desc.light.position.tolist() == [50.0, -60.0, 30.0]
    assert desc.light.distance == 25.0 and desc.intensity == 3.0
    path.write_text(SCENE + '[[light]]\nkind = "sun"\nazimuth = 100\nelevation = 20\n')
    desc = load_scene(path)
    assert desc.light == Sun(100.0, 20.0) and desc.intensity is None and desc.sun == desc.light
    bad = {
        '[[light]]\nkind = "point"\nposition = [0, 0, 1]\n[[light]]\nkind = "point"\nposition = [0, 0, 2]\n':
            "exactly one light",
        '[sun]\nazimuth = 10\n[[light]]\nkind = "point"\nposition = [0, 0, 1]\n': r"\[sun\] and \[\[light\]\]",
        '[[light]]\nkind = "spot"\nposition = [0, 0, 1]\n': "kind",
        '[[light]]\nkind = "point"\n': "position",
        '[[light]]\nkind = "point"\nposition = [0, 0, 1]\nazimuth = 3\n': "azimuth",
        '[[light]]\nkind = "sun"\nposition = [0, 0, 1]\n': "position",
        '[[light]]\nkind = "point"\nposition = [0, 0, 1]\ndistance = -2\n': "distance",
        '[[light]]\nkind = "point"\nposition = [0, 0, 1]\nintensity = -1\n': "intensity",
        '[[light]]\nkind = "point"\nposition = [0, 0, 1]\ncolour = [1, 1, 1]\n': "colour",
        '[light]\nkind = "point"\n': r"\[\[light\]\]",
    }
    for text, match in bad.items():
        path.write_text(SCENE + text)
        with pytest.raises(SceneError, match=match):
            load_scene(path)
    for position, distance, match in (((0, 0), None, "position"), ((0, 0, math.nan), None, "position"),
                                      ((0, 0, 1), 0.0, "distance"), ((0, 0, 1), math.inf, "distance")):
        with pytest.raises(ValueError, match=match):
            PointLight(position, distance)
    assert repr(PointLight((1, 2, 3), 4)) == "PointLight([1.0, 2.0, 3.0], distance=4.0)"


def pixel(camera: Camera, world) -> tuple[int, int]:
    """(row, column) of the pixel that sees a world point (perspective camera)."""
    p = camera.view[:3, :3] @ np.asarray(world, float) + camera.view[:3, 3]
    sx, sy = camera.scale
    ndc_x, ndc_y = p[0] / (-p[2] * sx), p[1] / (-p[2] * sy)
    row, col = ((1.0 - ndc_y) * camera.height - 1.0) / 2.0, ((ndc_x + 1.0) * camera.width - 1.0) / 2.0
    return int(round(row)), int(round(col))


def test_render_a_scene_with_a_point_light(tmp_path):
    """`oclshade render SCENE.toml OUT.png` with a point light low over flat ground and a cube
    beside it: the ground near the light is brighter than far from it (the falloff), and
    behind the cube (seen from the light) darker than at the same distance on the other side."""
    from oclshade.scene.render import load_heightmap, scene_camera
    np.save(tmp_path / "d.npy", np.zeros((13, 13)))
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    path = tmp_path / "s.toml"
    path.write_text("""[terrain]
dem = "d.npy"
cellsize = 10
[camera]
position = [60, -200, 160]
look_at = [60, -60, 0]
size = [80, 60]
[[light]]
kind = "point"
position = [60, -60, 12]
intensity = 20.0
distance = 15
[[mesh]]
file = "cube.obj"
translate = [80, -65, 0]
scale = 10
""")
    out = tmp_path / "out.png"
    assert main(["render", str(path), str(out), "--quiet"]) == 0
    img = np.asarray(Image.open(out).convert("RGB")).astype(int).sum(axis=2)
    assert img.shape == (60, 80)
    desc = load_scene(path)
    camera = scene_camera(desc, load_heightmap(desc))
    at = lambda x, y: img[pixel(camera, (x, y, 0.0))]  # noqa: E731
    assert at(50, -60) > at(10, -110) + 100                      # near the light / far from it
    assert at(95, -60) < at(25, -60) - 100                      # behind the cube / in the open
