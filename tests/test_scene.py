"""Scene files and frames of a terrain with quadrics and an environment (oclshade.scene)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from oclshade.camera import frame_heightmap
from oclshade.cli import main
from oclshade.compose import Lighting, compose
from oclshade.envmap import CubeMap
from oclshade.envmap.files import save_cube
from oclshade.envmap.materials import Material
from oclshade.envmap.reflect import Reflections
from oclshade.envmap.sky import procedural_sky
from oclshade.frames import AOSettings, FrameSettings, TerrainScene
from oclshade.heightmap import Heightmap
from oclshade.quadrics import Quadric, QuadricCaster
from oclshade.scene import Environment, ObjectScene, SceneError, load_scene, render_scene
from oclshade.screen_shadows import ScreenShadowCaster
from oclshade.ssao import SSAO
from oclshade.sun import Sun
from oclshade.synthetic import canyon_crater
from oclshade.terrain import Heightfield, TerrainRenderer

SCENE = """
[terrain]
dem = "dem.npy"
cellsize = 30.0

[camera]
view = [200, 30]
size = [64, 40]

[sun]
azimuth = 135
elevation = 30

[render]
ao = 3

[environment]
file = "env/sky.exr"
size = 16

[[quadric]]
kind = "sphere"
centre = [700, -700, 900]
radius = 200
material = "mirror"

[[quadric]]
kind = "cylinder"
centre = [300, -1000, 700]
radius = 80
height = 600
material = "glossy"
colour = [0.7, 0.2, 0.2]
roughness = 0.2
"""


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("scene")
    np.save(d / "dem.npy", canyon_crater(48, 48, seed=5))
    (d / "env").mkdir()
    save_cube(d / "env" / "sky.exr", CubeMap.from_latlong(procedural_sky(32, 64), 16), "latlong", 32)
    (d / "scene.toml").write_text(SCENE)
    return d


def test_load_scene_reads_every_section(scene_dir):
    desc = load_scene(scene_dir / "scene.toml")
    assert desc.terrain.dem == scene_dir / "dem.npy" and desc.terrain.cellsize == 30.0
    assert desc.camera.size == (64, 40) and desc.camera.view == (200.0, 30.0) and desc.camera.position is None
    assert desc.sun == Sun(135.0, 30.0) and desc.render.ao == 3.0 and desc.render.shadows
    assert desc.environment.file == scene_dir / "env" / "sky.exr" and desc.environment.size == 16
    sphere, cylinder = desc.quadrics
    assert sphere.kind == "sphere" and list(sphere.radii) == [200.0] * 3 and sphere.material.kind == "mirror"
    assert cylinder.material == Material("glossy", (0.7, 0.2, 0.2), roughness=0.2)
    assert list(cylinder.radii) == [80.0, 80.0, 300.0]


@pytest.mark.parametrize("text, message", [
    ("[terrain]\ndem = 'd.npy'\ncolor = 1\n", "[terrain]: unknown key 'color'"),
    ("[terrain]\ndem = 'd.npy'\n[[mesh]]\nfile = 'x.obj'\n", "[[mesh]] 1 file: mesh file"),
    ("[camera]\nfov = 30\n", "a [terrain] section with dem"),
    ("[terrain]\ndem = 'd.npy'\n[sun]\nelevation = 95\n", "elevation must be in [-90, 90]"),
    ("[terrain]\ndem = 'd.npy'\n[camera]\nposition = [0, 0, 1]\n", "position and look_at go together"),
    ("[terrain]\ndem = 'd.npy'\n[environment]\ngenerate = 0\n", "generate: must be \"once\" or a number"),
    ("[terrain]\ndem = 'd.npy'\n[environment]\nsize = 8\n", "needs file = \"...\", generate"),
    ("[terrain]\ndem = 'd.npy'\n[[quadric]]\nkind = 'sphere'\ncentre = [0, 0, 0]\n", "[[quadric]] 1 radius: a sphere needs radius"),
    ("[terrain]\ndem = 'd.npy'\n[[quadric]]\nkind = 'sphere'\ncentre = [0, 0, 0]\nradius = 1\nheight = 2\n",
     "a sphere takes radius, not height"),
    ("[terrain]\ndem = 'd.npy'\n[[quadric]]\nkind = 'cone'\n", "kind: must be one of"),
    ("[terrain]\ndem = 'd.npy'\n[[quadric]]\nkind = 'sphere'\ncentre = [0, 0]\nradius = 1\n",
     "centre: must be a list of 3 finite numbers"),
    ("[terrain]\ndem = 'd.npy'\n[[quadric]]\nkind = 'sphere'\ncentre = [0, 0, 0]\nradius = 1\nmaterial = 'gold'\n",
     "material must be one of diffuse, mirror, glossy"),
    ("[terrain]\ndem = 'd.npy'\n[render]\nssaa = 0\n", "[render] ssaa: must be an integer >= 1"),
    ("[terrain\n", "not valid TOML"),
])
def test_scene_errors_name_the_key(tmp_path, text, message):
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(SceneError, match=None) as info:
        load_scene(tmp_path / "s.toml")
    assert message in str(info.value) and str(tmp_path / "s.toml") in str(info.value)


def test_without_objects_the_frame_is_the_terrain_frame():
    hm = Heightmap.from_array(canyon_crater(40, 36, seed=2), 30.0)
    camera = frame_heightmap(hm, 48, 32, azimuth=210.0, elevation=35.0)
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=16))
    want = TerrainScene(Heightfield(hm)).frame(camera, (135.0, 20.0), settings).image
    got = ObjectScene(Heightfield(hm)).frame(camera, (135.0, 20.0), settings).image
    assert np.array_equal(got, want)


def test_frame_equals_the_passes_run_by_hand():
    """G-buffer + quadrics merged, shading normals with the objects', terrain shadows then
    quadric shadows, SSAO, compose of the weighted albedo, reflections added."""
    hm = Heightmap.from_array(canyon_crater(40, 36, seed=2), 30.0)
    camera = frame_heightmap(hm, 48, 32, azimuth=210.0, elevation=35.0)
    quadrics = [Quadric.sphere((500, -500, 700), 180.0, Material("mirror")),
                Quadric.cylinder((600, -800, 570), 60.0, 500.0, material=Material("glossy", roughness=0.3)),
                Quadric.ellipsoid((800, -300, 1240), (150, 80, 120), material=Material("diffuse", (0.2, 0.6, 0.3)))]
    cube = CubeMap.from_latlong(procedural_sky(16, 32), 8)
    sun = Sun(135.0, 25.0)
    lighting = Lighting(sun=sun, background=(0.0, 0.0, 0.0))
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=16), lighting=lighting)
    scene = ObjectScene(Heightfield(hm), quadrics, Environment(cube))
    frame = scene.frame(camera, sun, settings)
    assert frame.ran == ("gbuffer", "normals", "shadows", "ao", "compose")
    ids = scene.ids.to_host(scene.runtime)
    assert all((ids == k).any() for k in (0, 1, 2, 3)), "every object and the terrain must be in view"

    renderer = TerrainRenderer(Heightfield(hm))
    rt = renderer.runtime
    gbuf = renderer.render(camera, on_device=True)
    caster = QuadricCaster(quadrics, hm, rt)
    oids = caster.merge(caster.cast(camera), gbuf)
    normals = renderer.shading_normals(camera, gbuf)
    caster.object_normals(gbuf, oids, normals)
    shadow = ScreenShadowCaster(hm, device=rt).shade_to_device(gbuf, sun, outputs="coefficient", k_dark=0.0,
                                                               k_bright=0.0)["coefficient"]
    caster.shadow(camera, gbuf, oids, sun, shadow)
    host = gbuf.to_host()
    ao = SSAO(rt).compute(host, camera.projection_matrix, radius=90.0, m=16)
    refl = Reflections(cube.to_device(rt), [q.material for q in quadrics])
    image = compose(refl.weights(gbuf, oids, camera), camera, lighting, shadow=shadow, ao=ao, normal=normals)
    want = refl.apply(image, gbuf, oids, camera)
    assert np.array_equal(frame.image, want)
    assert np.array_equal(ids, oids.to_host(rt))


def test_passes_are_reused_and_sun_changes_redo_the_shadows():
    hm = Heightmap.from_array(canyon_crater(32, 32, seed=4), 30.0)
    camera = frame_heightmap(hm, 40, 30)
    scene = ObjectScene(Heightfield(hm), [Quadric.sphere((450, -450, 900), 150.0)])
    first = scene.frame(camera, (135.0, 25.0))
    assert scene.frame(camera, (135.0, 25.0)).ran == ()
    again = scene.frame(camera, (300.0, 15.0))
    assert again.ran == ("shadows", "compose") and not np.array_equal(again.image, first.image)
    shadow_moved = scene.frame(camera, (135.0, 25.0))
    assert np.array_equal(shadow_moved.image, first.image)


def test_render_scene_file_from_the_command_line(scene_dir, tmp_path, capsys):
    out, gb = tmp_path / "frame.png", tmp_path / "g.exr"
    assert main(["render", str(scene_dir / "scene.toml"), str(out), "--gbuffer", str(gb)]) == 0
    assert "2 quadrics, 64x40 pixels" in capsys.readouterr().err
    from PIL import Image
    img = np.asarray(Image.open(out))
    frame, scene, _ = render_scene(load_scene(scene_dir / "scene.toml"))
    assert np.array_equal(img, frame.image[..., :3]) and gb.is_file()


@pytest.mark.parametrize("extra, message", [
    (["--size", "32x32"], "--size is not used: set [camera] size in"),
    (["--sun", "10,10"], "set [sun] azimuth / elevation"),
    (["--no-shadows"], "set [render] shadows"),
])
def test_render_options_a_scene_file_replaces_are_refused(scene_dir, tmp_path, capsys, extra, message):
    assert main(["render", str(scene_dir / "scene.toml"), str(tmp_path / "f.png"), *extra]) == 2
    assert message in capsys.readouterr().err


def test_scene_output_must_be_png(scene_dir, tmp_path, capsys):
    assert main(["render", str(scene_dir / "scene.toml"), str(tmp_path / "f.exr")]) == 2
    assert "a scene renders a .png" in capsys.readouterr().err
