"""The C host API's mesh entry points against the Python host, bit for bit
(host/tests/host_meshes.c; the build of host/ is the session fixture of tests/test_host_api.py).

* ``oclshade_mesh_tables_read`` of :func:`oclshade.meshes.tables.write_mesh_tables`'s file,
  ``oclshade_mesh_camera_table`` / ``oclshade_mesh_light_table`` + cast, depth merge, object
  normals, terrain shadows on mesh pixels, shadow rays and their application against
  :class:`oclshade.meshes.MeshCaster` (an icosphere, a textured sheet with alpha cut-outs and
  a normal map, a cube that casts no shadow; perspective and orthographic cameras; suns
  above and below the horizon, a point light; the scene 1e6 m and 1e7 m from the origin
  without a terrain); the C program also checks pitched fields at offsets.
* The reader on damaged files and the argument and contract checks of every mesh call.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from oclshade.camera import Camera
from oclshade.gbuffer import CHANNELS
from oclshade.heightmap import Heightmap
from oclshade.meshes import MeshSurface, TriangleMesh
from oclshade.meshes.caster import MeshCaster
from oclshade.meshes.lights import PointLight
from oclshade.meshes.tables import MAGIC, mesh_table_arrays, write_mesh_tables
from oclshade.quadrics.caster import ObjectIds
from oclshade.sun import Sun
from oclshade.terrain import DeviceGBuffer

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)
from test_host_objects import GB_NAMES, _camera_line, _read, _write_gbuffer
from test_mesh_gbuffer import grid, sphere


def _meshes(offset: np.ndarray, rng: np.random.Generator) -> list[TriangleMesh]:
    """An icosphere, a wavy textured sheet (alpha cut-outs, normal map, uvs wrapping twice) and a
    cube without normals that casts no shadow, moved by offset."""
    texture = rng.random((16, 16, 4)).astype(np.float32)
    nmap = rng.normal(size=(8, 8, 3)) * 0.3 + [0.0, 0.0, 1.0]
    nmap = (nmap / np.linalg.norm(nmap, axis=2, keepdims=True)).astype(np.float32)
    sheet = grid(8, 60.0, lambda x, y: 4.0 * np.sin(x / 9.0) * np.cos(y / 13.0))
    sheet = TriangleMesh(sheet.vertices, sheet.faces, uvs=2.0 * sheet.uvs, name="sheet",
                         surface=MeshSurface((0.7, 0.5, 0.3), texture=texture, normal_map=nmap, alpha_cutoff=0.3))
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [f for a, b, c, d in quads for f in ((a, b, c), (a, c, d))]
    cube = TriangleMesh(corners * 15.0, faces, cast_shadows=False, name="cube",
                        surface=MeshSurface((0.2, 0.6, 0.9)))
    ball = sphere(18.0, 3)
    ball = TriangleMesh(ball.vertices, ball.faces, normals=ball.normals, name="ball")
    return [ball.placed(offset + [140.0, -100.0, 40.0]), sheet.placed(offset + [60.0, -130.0, 30.0], rotate_z=20.0),
            cube.placed(offset + [90.0, -60.0, 10.0], rotate_z=35.0)]


CASES = {   # projection, sun, point light (None: the sun), the scene's offset from the origin, terrain
    "perspective sun": ("perspective", (135.0, 25.0), None, 0.0, True),
    "orthographic point": ("orthographic", (300.0, 8.0), (100.0, -80.0, 220.0), 0.0, True),
    "sun below": ("perspective", (40.0, -3.0), None, 0.0, True),
    "far point": ("perspective", (10.0, 60.0), (120.0, -60.0, 260.0), 1e6, False),
    "farther sun": ("orthographic", (200.0, 35.0), None, 1e7, False),
}


def _case(folder: Path, projection: str, sun: tuple[float, float], point, offset: float, terrain: bool):
    """Writes the inputs of host_meshes meshes to folder; returns the Python side's."""
    rng = np.random.default_rng(8)
    shift = np.array([offset, offset, 0.0])
    meshes = _meshes(shift, rng)
    write_mesh_tables(meshes, folder / "tables.bin")
    rows, cols, dx, dy = 33, 41, 6.0, 5.0
    h = np.cumsum(rng.normal(size=(rows, cols)), axis=1) * 1.5 + 5.0
    h[rng.random(h.shape) < 0.03] = np.nan
    h[20:24, 5:9] += 70.0                          # a ridge that shades the meshes from low suns
    hm = Heightmap.from_array(h, (dx, dy)) if terrain else None
    w, hh = 48, 36
    cam = Camera(shift + [-60.0, -300.0, 260.0], shift + [105.0, -95.0, 25.0], w, hh, fov=40.0, near=1.0,
                 far=5000.0, projection=projection, ortho_height=220.0)
    n = w * hh
    dst = {"position": np.concatenate([rng.normal(size=(n, 3)) * 50 + [0, 0, -300], np.ones((n, 1))], 1),
           "normal": rng.normal(size=(n, 4)), "uv": rng.random((n, 2)) * 30, "uv_grad": rng.normal(size=(n, 4)),
           "depth": rng.random(n) * 600.0 + 50.0, "albedo": rng.random((n, 4))}
    dst = {k: np.ascontiguousarray(v, np.float32) for k, v in dst.items()}
    dst["position"][rng.random(n) < 0.1, 3] = 0.0
    dst["object"] = np.where(rng.random(n) < 0.1, 3, 0).astype(np.int32)   # some quadric pixels
    shading = rng.normal(size=(n, 4)).astype(np.float32)
    coef = rng.random(n).astype(np.float32)
    k_dark, k_bright = 0.15, 0.6
    light = Sun(*sun) if point is None else PointLight(np.array(point) + shift)
    p = light.position if point is not None else np.zeros(3)
    lines = [_camera_line(cam), f"{rows if terrain else 0} {cols} {dx!r} {dy!r}",
             f"{sun[0]!r} {sun[1]!r} {k_dark!r} {k_bright!r}", f"{int(point is not None)} " + " ".join(map(repr, map(float, p)))]
    (folder / "scene.txt").write_text("\n".join(lines) + "\n")
    if terrain:
        hm.heights.astype(np.float64).tofile(folder / "heights.f64")
    _write_gbuffer(folder, "dst", dst)
    shading.tofile(folder / "shading.f32")
    coef.tofile(folder / "coef.f32")
    return meshes, hm, cam, light, dst, shading, coef, (k_dark, k_bright)


@pytest.mark.parametrize("name", list(CASES))
def test_c_meshes_equal_python(host: dict, tmp_path: Path, name: str) -> None:
    """Camera and light tables, cast, merge, object normals, terrain shadows on mesh pixels,
    shadow rays and their coefficients from the C entry points equal MeshCaster's bit for bit."""
    projection, sun, point, offset, terrain = CASES[name]
    meshes, hm, cam, light, dst, shading, coef, (k_dark, k_bright) = _case(tmp_path, projection, sun, point, offset,
                                                                           terrain)
    w, hh = cam.width, cam.height
    n = w * hh
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_meshes", "meshes", out, tmp_path)

    caster = MeshCaster(meshes, hm)
    rt = caster.runtime
    assert (out / "mf.f32").read_bytes() == caster.table(cam).tobytes()
    assert (out / "light.f32").read_bytes() == caster.light_table(light).tobytes()
    objects = caster.cast(cam)
    got = {k: _read(rt, objects[0].buffers[k], 4 * CHANNELS[k] * n) for k in CHANNELS}
    got["object"] = objects[1].to_host(rt).tobytes()
    for field in GB_NAMES:
        assert (out / f"obj_{field}.bin").read_bytes() == got[field], field
    ids_seen = set(np.frombuffer(got["object"], np.int32).tolist())
    assert {-1, -2, -3} <= ids_seen, f"the frame must show every mesh, ids {sorted(ids_seen)}"
    into = DeviceGBuffer(rt, (hh, w), {k: rt.to_device(dst[k], k) for k in CHANNELS})
    ids = caster.merge(objects, into, ObjectIds(rt.to_device(dst["object"], "ids"), (hh, w)))
    shading_d = rt.to_device(shading, "shading")
    caster.object_normals(into, ids, shading_d)
    coef_d = rt.to_device(coef, "coef")
    caster.shadow(cam, into, ids, Sun(*sun), coef_d, k_dark, k_bright)
    for field in GB_NAMES:
        want = ids.to_host(rt).tobytes() if field == "object" else _read(rt, into.buffers[field], 4 * CHANNELS[field] * n)
        assert (out / f"mrg_{field}.bin").read_bytes() == want, field
    assert (out / "shading.out").read_bytes() == _read(rt, shading_d, 16 * n)
    coef_terrain = _read(rt, coef_d, 4 * n)
    assert (out / "coef_terrain.out").read_bytes() == coef_terrain
    assert coef_terrain != coef.tobytes(), "the terrain pass must set the mesh pixels' coefficients"
    hidden = _read(rt, caster.shadow_rays(cam, into, light), 4 * n)
    assert (out / "hidden.out").read_bytes() == hidden
    assert np.frombuffer(hidden, np.int32).any(), "some pixel must be in a mesh's shadow"
    if point is None:
        caster.ray_shadow(cam, into, Sun(*sun), coef_d, k_dark, k_bright)
        want = _read(rt, coef_d, 4 * n)
    else:   # mesh_shadow_apply with the point light's rays: eq. (1) of the sun where hidden
        kshadow = np.float32(k_dark + (k_bright - k_dark) * max(math.sin(math.radians(sun[1])), 0.0))
        want = np.where(np.frombuffer(hidden, np.int32) > 0, kshadow, np.frombuffer(coef_terrain, np.float32)).tobytes()
    assert (out / "coef.out").read_bytes() == want


# ----------------------------------------------------------------------- damaged tables files
def _file(arrays: list[np.ndarray], counts: list[int] | None = None) -> bytes:
    """The tables file of arrays (oclshade/meshes/tables.py's format, written out here)."""
    counts = counts or [len(arrays[0]), len(arrays[5]), len(arrays[7]), len(arrays[9]), len(arrays[11]), 0]
    return MAGIC + np.array(counts, "<i4").tobytes() + b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)


def _damaged(folder: Path, meshes: list[TriangleMesh]) -> None:
    arrays = mesh_table_arrays(meshes)
    good = _file(arrays)
    assert (folder / "tables.bin").read_bytes() == good     # the format as tables.py writes it
    (folder / "magic.bin").write_bytes(b"OCLSMSH2" + good[8:])
    (folder / "short.bin").write_bytes(good[:-4])
    (folder / "long.bin").write_bytes(good + b"\0")
    counts = [len(arrays[0]), len(arrays[5]), len(arrays[7]), len(arrays[9]), len(arrays[11]), 0]
    (folder / "counts.bin").write_bytes(_file(arrays, [0, *counts[1:]]))

    def damaged(name: str, index: int, change) -> None:
        copy = [a.copy() for a in arrays]
        change(copy[index])
        (folder / name).write_bytes(_file(copy))

    vertices = len(arrays[9])
    damaged("index.bin", 7, lambda tvtx: tvtx.__setitem__((5, 1), vertices))
    info = arrays[5]
    interior = int(np.flatnonzero(info[:, 1] == 0)[0])
    leaf = int(np.flatnonzero(info[:, 1] > 0)[0])
    damaged("child.bin", 5, lambda a: a.__setitem__((interior, 0), interior + 1))
    damaged("leaf.bin", 5, lambda a: a.__setitem__((leaf, 1), len(arrays[7]) + 1))
    damaged("root.bin", 0, lambda mi: mi.__setitem__((0, 0, 0), len(info)))
    damaged("texture.bin", 0, lambda mi: mi.__setitem__((1, 1, 1), 1000))
    # a chain of 64 interior nodes: node i has children i + 1 and 65 + i; node 64 is 65 deep
    depth = 64
    chain = np.zeros((2 * depth + 1, 2), "<i4")
    chain[:depth, 0] = np.arange(depth) + depth + 1
    chain[depth:] = (0, 1)
    boxes = np.zeros((len(chain), 2, 4), "<f4")
    mi = arrays[0].copy()
    mi[:, 0, 0] = 0
    deep = [mi, *arrays[1:4], boxes, chain, *arrays[6:]]
    (folder / "deep.bin").write_bytes(_file(deep))


def test_c_meshes_argument_and_contract_checks(host: dict, tmp_path: Path) -> None:
    """The tables reader refuses damaged files (naming what is wrong, the tables cleared) and
    every mesh call and host helper refuses bad arguments and buffers with a message naming
    the argument and the expected value (host_meshes errors: one line per check)."""
    meshes = _meshes(np.zeros(3), np.random.default_rng(3))[:2]
    write_mesh_tables(meshes, tmp_path / "tables.bin")
    _damaged(tmp_path, meshes)
    stdout = run_program(host, "host_meshes", "errors", tmp_path, tmp_path)
    lines = stdout.splitlines()
    assert not [line for line in lines if line.startswith("FAIL")], stdout
    assert sum(line.startswith("ok ") for line in lines) >= 39, stdout


def test_tables_file_holds_the_casters_arrays(tmp_path: Path) -> None:
    """write_mesh_tables: header counts, and the arrays MeshCaster uploads (read back)."""
    meshes = _meshes(np.array([1e6, -2e6, 0.0]), np.random.default_rng(1))
    write_mesh_tables(meshes, tmp_path / "t.bin")
    data = (tmp_path / "t.bin").read_bytes()
    assert data[:8] == MAGIC
    counts = np.frombuffer(data[8:32], "<i4")
    caster = MeshCaster(meshes)
    assert counts[0] == 3 and counts[5] == 0
    assert counts[2] == sum(len(m.faces) for m in meshes) and counts[3] == sum(len(m.vertices) for m in meshes)
    origins = np.frombuffer(data[32 + 144:32 + 144 + 72], "<f8").reshape(3, 3)
    assert origins.tobytes() == caster.origins.tobytes()
    assert np.all(np.abs(origins[:, 0] - 1e6) < 300)
    tri = np.empty(48 * counts[2], np.uint8)
    import pyopencl as cl
    cl.enqueue_copy(caster.runtime.queue, tri, caster._buffers[2])
    caster.runtime.queue.finish()
    assert tri.tobytes() in data
    with pytest.raises(ValueError, match="meshes must be one or more"):
        write_mesh_tables([], tmp_path / "x.bin")
