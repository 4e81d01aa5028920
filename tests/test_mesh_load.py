"""Mesh files (oclshade.meshes.load), textures and the host BVH (oclshade.meshes.bvh)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from PIL import Image

from oclshade.meshes import MeshSurface, TriangleMesh, build_bvh, load_mesh, load_normal_map, load_texture
from oclshade.meshes.bvh import MAX_DEPTH

SHARED = Path("/work/shared/data/meshes")

QUAD_OBJ = """# a unit square in z = 0 as one quad, uvs and one normal
v 0 0 0
v 2 0 0
v 2 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
f 1/1/1 2/2/1 3/3/1 4/4/1
"""

# a square pyramid with its apex up; no normals in the file
PYRAMID_PLY = """ply
format ascii 1.0
element vertex 5
property float x
property float y
property float z
element face 6
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
0.5 0.5 1
3 0 2 1
3 0 3 2
3 0 1 4
3 1 2 4
3 2 3 4
3 3 0 4
"""


def test_obj_with_uvs_and_normals(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text(QUAD_OBJ)
    mesh = load_mesh(path)
    assert mesh.name == "quad" and mesh.faces.shape == (2, 3)
    assert np.allclose(mesh.normals, [0, 0, 1])
    # the quad split into two triangles covering area 2, counter-clockwise seen from +z
    assert np.isclose(0.5 * np.linalg.norm(mesh.face_normals, axis=1).sum(), 2.0)
    assert np.all(mesh.face_normals[:, 2] > 0)
    # each vertex keeps its own uv: u = x / 2, v = y
    assert np.allclose(mesh.uvs, np.stack([mesh.vertices[:, 0] / 2, mesh.vertices[:, 1]], 1))


def test_y_up_files_are_turned_to_z_up(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text(QUAD_OBJ)
    z_up, y_up = load_mesh(path), load_mesh(path, up="y")
    x, y, z = z_up.vertices.T
    assert np.allclose(y_up.vertices, np.stack([x, -z, y], 1))
    assert np.allclose(y_up.normals, [0, -1, 0])          # the file's +z (toward the viewer) is world -y
    assert np.allclose(np.cross(*(y_up.vertices[y_up.faces[:, 1:]] - y_up.vertices[y_up.faces[:, :1]])
                                .transpose(1, 0, 2)), y_up.face_normals)


def test_ply_without_normals_gets_area_weighted_normals(tmp_path):
    path = tmp_path / "pyramid.ply"
    path.write_text(PYRAMID_PLY)
    mesh = load_mesh(path)
    assert mesh.normals is None and mesh.uvs is None and len(mesh.faces) == 6
    n = mesh.vertex_normals
    assert np.allclose(n[4], [0, 0, 1])                  # the apex: four equal sides
    # corner 0: base (area 1/2 twice, normal -z) and two sides (x0: (0,-1,.5)/..., y0: (-1,0,.5)/...)
    side = 0.5 * np.array([[0, -1, 0.5], [-1, 0, 0.5]])
    want = np.array([0, 0, -1.0]) + side.sum(axis=0)
    assert np.allclose(n[0], want / np.linalg.norm(want))


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_mesh(tmp_path / "none.obj")
    (tmp_path / "a.obj").write_text(QUAD_OBJ)
    with pytest.raises(ValueError, match="up must be one of"):
        load_mesh(tmp_path / "a.obj", up="x")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    with pytest.raises(ValueError, match="empty.obj"):
        load_mesh(tmp_path / "empty.obj")


def test_textures_and_normal_maps(tmp_path):
    rgba = np.array([[[0, 128, 255, 0], [255, 255, 255, 255]]], np.uint8)
    Image.fromarray(rgba, "RGBA").save(tmp_path / "t.png")
    tex = load_texture(tmp_path / "t.png")
    assert tex.shape == (1, 2, 4) and tex.dtype == np.float32
    assert np.allclose(tex[0, 0], [0, ((128 / 255 + 0.055) / 1.055) ** 2.4, 1, 0], atol=1e-6)
    assert np.allclose(tex[0, 1], 1)
    Image.fromarray(np.array([[[128, 128, 255]]], np.uint8), "RGB").save(tmp_path / "n.png")
    assert np.allclose(load_normal_map(tmp_path / "n.png")[0, 0], [0, 0, 1], atol=0.01)


def test_surface_and_mesh_arguments_are_checked():
    v, f = [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]
    with pytest.raises(ValueError, match="needs the mesh's uvs"):
        TriangleMesh(v, f, surface=MeshSurface(texture=np.ones((2, 2, 4))))
    with pytest.raises(ValueError, match="texture must be"):
        MeshSurface(texture=np.ones((2, 2, 3)))
    with pytest.raises(ValueError, match="alpha_cutoff"):
        MeshSurface(alpha_cutoff=2.0)
    with pytest.raises(ValueError, match="colour"):
        MeshSurface(colour=(1, 2))


@pytest.mark.skipif(not (SHARED / "bunny_oded.obj").is_file(), reason="shared meshes not present")
def test_shared_meshes_load():
    bunny = load_mesh(SHARED / "bunny_oded.obj")
    assert bunny.faces.shape == (6598, 3)                  # PROVENANCE.md's count
    iss = load_mesh(SHARED / "iss.obj")
    assert iss.faces.shape == (6642, 3)
    assert np.allclose(np.linalg.norm(iss.vertex_normals, axis=1), 1.0)


@given(st.integers(0, 2**32 - 1), st.integers(1, 300), st.integers(1, 8))
@settings(max_examples=25, deadline=None)
def test_bvh_holds_every_triangle_once(seed, count, leaf):
    """Every triangle sits in exactly one leaf, every box holds its children and its triangles
    (float32 min / max: exact), leaves hold at most leaf_size."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(count, 1, 3)) * rng.uniform(0.1, 1e3)
    tri = (centres + rng.normal(size=(count, 3, 3)) * rng.uniform(1e-3, 10)).astype(np.float32)
    bvh = build_bvh(tri, leaf)
    assert sorted(bvh.order) == list(range(count)) and bvh.depth <= MAX_DEPTH
    seen = np.zeros(count, int)

    def walk(i: int) -> None:
        a, n = bvh.info[i]
        lo, hi = bvh.lo[i], bvh.hi[i]
        kids = [i + 1, a] if n == 0 else []
        for k in kids:
            assert np.all(bvh.lo[k] >= lo) and np.all(bvh.hi[k] <= hi)
            walk(k)
        if n:
            assert 1 <= n <= leaf
            t = tri[bvh.order[a:a + n]]
            assert np.all(t >= lo) and np.all(t <= hi)
            seen[bvh.order[a:a + n]] += 1

    walk(0)
    assert np.all(seen == 1)
