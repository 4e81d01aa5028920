"""``oclshade render SCENE.toml OUT.png --gbuffer G.exr``: the reflection direction channels
(reflection.x/y/z, oclshade/scene/cli.py) read back from the EXR against R = U - 2 (N.U) N
computed here from the file's own position and normal channels, on the pixels of the
reflective objects only (found independently: their world points lie on the mirror sphere
and the glossy cylinder's side)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR
import pytest

from oclshade.cli import GBUFFER_NAMES, main
from oclshade.envmap import CubeMap
from oclshade.envmap.files import save_cube
from oclshade.envmap.sky import procedural_sky
from oclshade.scene import load_scene
from oclshade.scene.cli import REFLECTION_NAMES
from oclshade.scene.render import load_heightmap, scene_camera
from oclshade.synthetic import canyon_crater

SCENE = """
[terrain]
dem = "dem.npy"
cellsize = 30.0

[camera]
{camera}
size = [64, 40]

[sun]
azimuth = 135
elevation = 30

[environment]
file = "sky.exr"
size = 16

[[quadric]]
kind = "sphere"
centre = [700, -700, 900]
radius = 200
material = "mirror"

[[quadric]]
kind = "sphere"
centre = [1050, -950, 900]
radius = 150
material = "diffuse"

[[quadric]]
kind = "cylinder"
centre = [400, -900, 1100]
radius = 100
height = 400
material = "glossy"
colour = [0.7, 0.2, 0.2]
"""


def _read_exr(path: Path) -> dict[str, np.ndarray]:
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(c.pixels, np.float64) for name, c in f.channels().items()}


@pytest.mark.parametrize("camera", ["view = [200, 30]", "position = [300, -2200, 1500]\nlook_at = [600, -700, 1000]"])
def test_gbuffer_holds_the_reflection_direction(tmp_path: Path, camera: str) -> None:
    np.save(tmp_path / "dem.npy", canyon_crater(48, 48, seed=5))
    save_cube(tmp_path / "sky.exr", CubeMap.from_latlong(procedural_sky(32, 64), 16), "latlong", 32)
    (tmp_path / "scene.toml").write_text(SCENE.format(camera=camera))
    gb = tmp_path / "g.exr"
    assert main(["render", str(tmp_path / "scene.toml"), str(tmp_path / "f.png"), "--gbuffer", str(gb), "--quiet"]) == 0
    ch = _read_exr(gb)
    assert set(ch) == set(GBUFFER_NAMES) | set(REFLECTION_NAMES) | {"shadow"}
    p = np.stack([ch[f"position.{a}"] for a in "xyz"], -1)
    n = np.stack([ch[f"normal.{a}"] for a in "xyz"], -1)
    r = np.stack([ch[f"reflection.{a}"] for a in "xyz"], -1)
    # which object each pixel shows, from its world point (the camera the scene file gives)
    desc = load_scene(tmp_path / "scene.toml")
    cam = scene_camera(desc, load_heightmap(desc))
    world = (np.linalg.inv(cam.view) @ np.concatenate([p, np.ones(p.shape[:2] + (1,))], -1)[..., None])[..., :3, 0]
    hit = ch["position.w"] > 0.5
    rgb = np.stack([ch["R"], ch["G"], ch["B"]], -1)      # the material colours tell objects from terrain they touch
    on_mirror = hit & (np.abs(np.linalg.norm(world - [700, -700, 900], axis=-1) - 200) < 0.05) & np.all(rgb == 1.0, -1)
    on_diffuse = hit & (np.abs(np.linalg.norm(world - [1050, -950, 900], axis=-1) - 150) < 0.05)
    side = np.abs(np.hypot(world[..., 0] - 400, world[..., 1] + 900) - 100) < 0.05
    cap = (np.abs(np.abs(world[..., 2] - 1100) - 200) < 0.05) & (np.hypot(world[..., 0] - 400, world[..., 1] + 900) <= 100.05)
    on_glossy = hit & (side | cap) & np.all(rgb == np.float32([0.7, 0.2, 0.2]), -1)
    assert on_mirror.sum() > 20 and on_glossy.sum() > 5 and on_diffuse.sum() > 5
    reflective = on_mirror | on_glossy
    pm, nm = p[reflective], n[reflective]
    u = pm / np.linalg.norm(pm, axis=-1, keepdims=True)
    want = u - 2.0 * np.sum(nm * u, -1, keepdims=True) * nm
    assert np.allclose(r[reflective], want, rtol=0, atol=1e-6)
    assert np.allclose(np.linalg.norm(r[reflective], axis=-1), 1.0, atol=1e-5)   # a unit direction
    assert np.all(r[~reflective] == 0.0)                                          # terrain, sky, diffuse: 0
    # a mirror reflects away from its surface: R.N = -U.N > 0 on every pixel seen from outside
    assert np.all(np.sum(r[on_mirror] * n[on_mirror], -1) > 0.0)


def test_no_reflection_channels_without_reflective_objects(tmp_path: Path) -> None:
    np.save(tmp_path / "dem.npy", canyon_crater(32, 32, seed=2))
    text = ("[terrain]\ndem = 'dem.npy'\ncellsize = 30.0\n[camera]\nsize = [32, 20]\n"
            "[[quadric]]\nkind = 'sphere'\ncentre = [450, -450, 900]\nradius = 150\n")
    (tmp_path / "scene.toml").write_text(text)
    gb = tmp_path / "g.exr"
    assert main(["render", str(tmp_path / "scene.toml"), str(tmp_path / "f.png"), "--gbuffer", str(gb), "--quiet"]) == 0
    assert set(_read_exr(gb)) == set(GBUFFER_NAMES) | {"shadow"}
