"""Meshes in scenes: [[mesh]] tables in scene files, ObjectScene(meshes=...) frames (merge,
normals, terrain and quadric shadows on mesh pixels) and `oclshade render SCENE.toml`."""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest
from PIL import Image

from oclshade.camera import Camera
from oclshade.cli import main
from oclshade.frames import FrameSettings
from oclshade.heightmap import Heightmap
from oclshade.meshes import MeshCaster, MeshSurface, TriangleMesh
from oclshade.quadrics import Quadric
from oclshade.scene import ObjectScene, SceneError, load_scene, render_scene
from oclshade.sun import Sun
from oclshade.terrain import Heightfield

CUBE_OBJ = """v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
f 1/1 3/3 2/2
f 1/1 4/4 3/3
f 5/1 6/2 7/3
f 5/1 7/3 8/4
f 1/1 2/2 6/3
f 1/1 6/3 5/4
f 2/1 3/2 7/3
f 2/1 7/3 6/4
f 3/1 4/2 8/3
f 3/1 8/3 7/4
f 4/1 1/2 5/3
f 4/1 5/3 8/4
"""


def cube(lo, size: float, cast_shadows: bool = False, colour=(0.8, 0.8, 0.8)) -> TriangleMesh:
    """CUBE_OBJ's cube, scaled by size and moved to lo."""
    c = np.array([[float(x) for x in line.split()[1:]] for line in CUBE_OBJ.splitlines() if line.startswith("v ")])
    faces = np.array([[int(tok.split("/")[0]) - 1 for tok in line.split()[1:]]
                      for line in CUBE_OBJ.splitlines() if line.startswith("f ")])
    return TriangleMesh(np.asarray(lo, float) + size * c, faces, cast_shadows=cast_shadows,
                        surface=MeshSurface(colour))


def test_mesh_tables_are_read_and_placed(tmp_path):
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    Image.fromarray(np.full((2, 2, 4), 255, np.uint8), "RGBA").save(tmp_path / "t.png")
    np.save(tmp_path / "d.npy", np.zeros((4, 4)))
    (tmp_path / "s.toml").write_text("""[terrain]
dem = "d.npy"
cellsize = 10
[[mesh]]
file = "cube.obj"
translate = [10, -20, 5]
scale = 2.0
rotate_z = 90
cast_shadows = false
colour = [0.5, 0.25, 0.125]
texture = "t.png"
[[mesh]]
file = "cube.obj"
up = "y"
""")
    a, b = load_scene(tmp_path / "s.toml").meshes
    # scaled by 2, turned 90 degrees counter-clockwise ((x, y) -> (-y, x)), moved
    assert np.allclose(a.bounds[0], [8, -20, 5]) and np.allclose(a.bounds[1], [10, -18, 7])
    assert not a.cast_shadows and a.surface.colour == (0.5, 0.25, 0.125) and a.surface.texture.shape == (2, 2, 4)
    assert b.cast_shadows and np.allclose(b.bounds[0], [0, -1, 0]) and np.allclose(b.bounds[1], [1, 0, 1])


def test_render_mesh_shadows_key(tmp_path):
    """[render] mesh_shadows picks rays (default) or the shadow volumes; anything else is
    refused naming the key, and ObjectScene refuses it too."""
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    base = "[terrain]\ndem = 'd.npy'\n[[mesh]]\nfile = 'cube.obj'\n"
    (tmp_path / "s.toml").write_text(base)
    assert load_scene(tmp_path / "s.toml").render.mesh_shadows == "rays"
    (tmp_path / "s.toml").write_text(base + "[render]\nmesh_shadows = 'volumes'\n")
    assert load_scene(tmp_path / "s.toml").render.mesh_shadows == "volumes"
    (tmp_path / "s.toml").write_text(base + "[render]\nmesh_shadows = 'stencil'\n")
    with pytest.raises(SceneError, match=r"\[render\] mesh_shadows: must be \"rays\" or \"volumes\""):
        load_scene(tmp_path / "s.toml")
    with pytest.raises(ValueError, match="mesh_shadows must be one of rays, volumes"):
        ObjectScene(Heightfield(wall_map()), meshes=[cube((230, -210, 0), 30.0)], mesh_shadows="stencil")


@pytest.mark.parametrize("table, message", [
    ("file = 'none.obj'", "[[mesh]] 1 file: mesh file"),
    ("file = 'cube.obj'\nup = 'x'", "[[mesh]] 1 up: must be one of 'z', 'y'"),
    ("file = 'cube.obj'\nsize = 2", "[[mesh]] 1: unknown key 'size'"),
    ("file = 'cube.obj'\nscale = -1", "[[mesh]] 1 scale: must be a positive finite number"),
    ("file = 'cube.obj'\ntexture = 'none.png'", "[[mesh]] 1 texture:"),
    ("file = 'flat.obj'\ntexture = 't.png'", "a texture or normal map needs the mesh's uvs"),
    ("up = 'z'", "[[mesh]] 1 file: is required"),
])
def test_mesh_table_errors_name_the_key(tmp_path, table, message):
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    Image.fromarray(np.full((2, 2, 4), 255, np.uint8), "RGBA").save(tmp_path / "t.png")
    (tmp_path / "s.toml").write_text(f"[terrain]\ndem = 'd.npy'\n[[mesh]]\n{table}\n")
    with pytest.raises(SceneError) as info:
        load_scene(tmp_path / "s.toml")
    assert message in str(info.value) and str(tmp_path / "s.toml") in str(info.value)


def wall_heights() -> np.ndarray:
    """10 m cells, flat at 0 with a 200 m wall along columns 10-11 (x 100-110 m)."""
    h = np.zeros((40, 40))
    h[:, 10:12] = 200.0
    return h


def wall_map() -> Heightmap:
    return Heightmap.from_array(wall_heights(), 10.0)


def host(f, buf: cl.Buffer, channels: int = 1) -> np.ndarray:
    out = np.empty(f.gbuffer.shape + ((channels,) if channels > 1 else ()), np.float32)
    cl.enqueue_copy(f.gbuffer.runtime.queue, out, buf)
    f.gbuffer.runtime.queue.finish()
    return out


CAMERA = Camera((250, -250, 150), (250, -200, 10), 48, 32, fov=40, near=1, far=2000)


def frame(meshes, quadrics=(), sun=Sun(270.0, 20.0), camera=CAMERA, mesh_shadows="rays"):
    scene = ObjectScene(Heightfield(wall_map()), quadrics, meshes=meshes, mesh_shadows=mesh_shadows)
    f = scene.frame(camera, sun, FrameSettings(shadows=True, shadow_k=(0.2, 0.2)))
    return f, scene.ids.to_host(scene.runtime)


def test_meshes_merge_into_the_frame():
    """A cube on the ground east of the wall: its pixels carry id -1, the mesh's own depth
    and normals (also in the shading normals), and the rest is the terrain frame."""
    box = cube((230, -210, 0), 30.0)
    f, ids = frame([box])
    got = f.gbuffer.to_host()
    own = MeshCaster([box]).cast(CAMERA)[0].to_host()
    mine = ids == -1
    assert mine.sum() > 50 and set(np.unique(ids)) <= {-1, 0}
    assert np.array_equal(got.depth[mine], own.depth[mine]) and np.array_equal(got.normal[mine], own.normal[mine])
    terrain, _ = frame([])
    t = terrain.gbuffer.to_host()
    assert np.all(own.depth[mine] <= t.depth[mine]) and np.array_equal(got.depth[~mine], t.depth[~mine])
    assert np.array_equal(host(f, f.normals, 4)[mine], got.normal[mine])


def test_terrain_and_quadric_shadows_fall_on_mesh_pixels():
    """The cube (no shadow casting of its own) sits 20-50 m east of a 200 m wall: a low sun in
    the west puts every cube pixel in the wall's shadow; a sun in the east lights them all; a
    sphere right above the cube under a high sun darkens the cube's top."""
    box = cube((130, -210, 0), 30.0)
    near = Camera((175, -290, 120), (145, -195, 15), 48, 32, fov=40, near=1, far=2000)
    f, ids = frame([box], sun=Sun(270.0, 20.0), camera=near)
    coef = host(f, f.shadow)
    mine = ids == -1
    assert mine.sum() > 30 and np.all(coef[mine] == np.float32(0.2))
    f, ids = frame([box], sun=Sun(90.0, 20.0), camera=near)
    coef = host(f, f.shadow)
    assert np.all(coef[ids == -1] == 1.0)
    ball = Quadric.sphere((145, -195, 80), 10.0)
    f, ids = frame([box], [ball], sun=Sun(90.0, 89.0), camera=near)
    coef = host(f, f.shadow)
    top = (ids == -1) & (f.gbuffer.to_host().normal[..., 1] > 0.9)   # view-space up: the cube's top
    assert top.any() and (coef[top] == np.float32(0.2)).any() and (coef[ids == -1] == 1.0).any()


def test_render_a_scene_file_with_a_mesh(tmp_path, capsys):
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    np.save(tmp_path / "d.npy", wall_heights())
    (tmp_path / "s.toml").write_text("""[terrain]
dem = "d.npy"
cellsize = 10
[camera]
position = [250, -250, 150]
look_at = [250, -200, 10]
size = [48, 32]
[[mesh]]
file = "cube.obj"
translate = [230, -210, 0]
scale = 30
colour = [1, 0, 0]
""")
    desc = load_scene(tmp_path / "s.toml")
    f, scene, camera = render_scene(desc)
    assert camera.far >= np.linalg.norm(desc.meshes[0].vertices - camera.position, axis=1).max()
    ids = scene.ids.to_host(scene.runtime)
    assert (ids == -1).sum() > 50
    out = tmp_path / "f.png"
    assert main(["render", str(tmp_path / "s.toml"), str(out), "--quiet"]) == 0
    image = np.asarray(Image.open(out))
    red = image[..., 0].astype(int) - image[..., 1]
    assert (red[ids == -1] > 20).mean() > 0.8                # the red cube is in the PNG


@pytest.mark.parametrize("method", ["rays", "volumes"])
def test_mesh_shadows_fall_on_terrain_and_meshes(method):
    """Two cubes with cast_shadows on the flat ground east of the wall, the sun in the south:
    the shadows pass darkens the ground and the second cube where the meshes hide the sun
    (by BVH rays or by the shadow volumes, as wired in the frame) and nowhere else: as the
    BVH's own any-hit rays (MeshCaster.shadow_rays) say, away from 1 px of their boundaries."""
    a, b = cube((240, -260, 0), 20.0, cast_shadows=True), cube((245, -225, 0), 10.0, cast_shadows=True)
    sun = Sun(180.0, 25.0)
    camera = Camera((330, -230, 100), (250, -230, 0), 64, 48, fov=45, near=1, far=2000)
    f, ids = frame([a, b], sun=sun, camera=camera, mesh_shadows=method)
    coef = host(f, f.shadow)
    hidden = MeshCaster([a, b]).shadow_mask(camera, f.gbuffer, sun)
    hit = f.gbuffer.to_host().hit
    pad = np.pad(hidden, 1, mode="edge")
    window = np.stack([pad[1 + dy:pad.shape[0] - 1 + dy, 1 + dx:pad.shape[1] - 1 + dx]
                       for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
    inner, outer = window.all(axis=0) & hit, ~window.any(axis=0) & hit
    assert (inner & (ids == 0)).sum() > 20 and (inner & (ids == -2)).any()      # ground and the second cube
    assert np.all(coef[inner] == np.float32(0.2))
    lit_faces = outer & ((ids == 0) | (host(f, f.normals, 4)[..., :3] @ (camera.rotation @ np.array(sun.vector()))
                                       > 0.05))
    assert np.all(coef[lit_faces] == 1.0)


def test_casters_with_cut_outs_shadow_through_their_holes():
    """A 40 m square 30 m above the ground, its west half cut out (alpha 0), casting shadows
    under a near-zenith sun: the ground under the east half is dark, under the west half lit
    (the shadow volumes would shade the whole square: such casters go by BVH rays)."""
    tex = np.ones((2, 2, 4), np.float32)
    tex[:, 0, 3] = 0.0
    v = np.array([[230, -250, 30], [270, -250, 30], [270, -210, 30], [230, -210, 30.0]])
    sheet = TriangleMesh(v, [[0, 1, 2], [0, 2, 3]], uvs=[[0, 0], [1, 0], [1, 1], [0, 1]],
                         surface=MeshSurface(texture=tex))
    assert sheet.surface.cuts_out and sheet.cast_shadows
    camera = Camera((250, -330, 60), (250, -230, 0), 64, 48, fov=50, near=1, far=2000)
    f, ids = frame([sheet], sun=Sun(180.0, 88.0), camera=camera)
    coef = host(f, f.shadow)
    p = f.gbuffer.to_host().position[..., :3] @ camera.rotation + camera.position    # view -> world
    ground = (ids == 0) & (np.abs(p[..., 1] + 230) < 15)
    east = ground & (p[..., 0] > 253) & (p[..., 0] < 268)
    west = ground & (p[..., 0] > 232) & (p[..., 0] < 247)
    assert east.sum() > 10 and west.sum() > 10
    assert np.all(coef[east] == np.float32(0.2)) and np.all(coef[west] == 1.0)


def test_a_scene_without_terrain(tmp_path, capsys):
    """[terrain] is optional with objects: the mesh alone in the frame (the rest empty), its
    camera from position / look_at; without objects or without a camera position, an error."""
    (tmp_path / "cube.obj").write_text(CUBE_OBJ)
    (tmp_path / "s.toml").write_text("""[camera]
position = [40, -30, 25]
look_at = [5, 5, 5]
size = [48, 32]
[[mesh]]
file = "cube.obj"
scale = 10
""")
    desc = load_scene(tmp_path / "s.toml")
    assert desc.terrain is None
    f, scene, camera = render_scene(desc)
    ids, hit = scene.ids.to_host(scene.runtime), f.gbuffer.to_host().hit
    assert (ids == -1).sum() > 50 and np.array_equal(hit, ids == -1)
    assert main(["render", str(tmp_path / "s.toml"), str(tmp_path / "f.png")]) == 0
    assert "0 quadrics, 1 meshes" in capsys.readouterr().err
    (tmp_path / "e.toml").write_text("[camera]\nfov = 30\n")
    with pytest.raises(SceneError, match=r"or at least one \[\[mesh\]\] or \[\[quadric\]\]"):
        load_scene(tmp_path / "e.toml")
    (tmp_path / "v.toml").write_text("[[mesh]]\nfile = 'cube.obj'\n")
    with pytest.raises(SceneError, match=r"\[camera\]: a scene without \[terrain\] needs position and look_at"):
        load_scene(tmp_path / "v.toml")
