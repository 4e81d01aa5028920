"""The C host API's environment-map entry points (oclshade_enqueue_cube_border,
oclshade_enqueue_latlong_to_cube, oclshade_enqueue_cube_to_latlong,
oclshade_enqueue_cube_face_store) against the Python host
(oclshade.envmap) bit for bit on generated maps, faces of 1 to 12 texels and lat-long maps
down to 1 x 1.  The C side is host/tests/host_passes.c (subcommand envmap, which also checks
pitched lat-long fields); the build of host/ is the session fixture of tests/test_host_api.py.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from oclshade.envmap.cube import CubeMap, latlong_to_cube

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)


@pytest.mark.parametrize("shape,face,out", [((24, 48), 12, (17, 35)), ((5, 2), 1, (1, 1)), ((31, 64), 7, (40, 80))])
def test_c_envmap_equals_python(host: dict, tmp_path: Path, shape: tuple[int, int], face: int,
                                out: tuple[int, int]) -> None:
    """cube_border of given faces, lat-long -> cube and cube -> lat-long equal the Python host's
    device buffers bit for bit (oclshade.envmap: CubeMap.to_device, latlong_to_cube,
    DeviceCubeMap.to_latlong)."""
    rng = np.random.default_rng(face)
    h, w = shape
    rgb = (rng.random((h, w, 3)) * 4.0).astype(np.float32)
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[..., :3] = rgb
    rgba.tofile(tmp_path / "ll.f32")
    faces = (rng.random((6, face, face, 3)) * 2.0).astype(np.float32)
    bordered = np.full((6, face + 2, face + 2, 4), np.nan, np.float32)   # the border must be written over
    bordered[:, 1:-1, 1:-1, :3] = faces
    bordered[:, 1:-1, 1:-1, 3] = 0.0
    bordered.tofile(tmp_path / "faces.f32")
    run_program(host, "host_passes", "envmap", tmp_path, tmp_path / "ll.f32", h, w, face, *out, tmp_path / "faces.f32")
    want_border = CubeMap(faces).to_device().bordered()
    assert np.fromfile(tmp_path / "border.f32", np.float32).tobytes() == want_border.tobytes()
    dev = latlong_to_cube(rgb, face)
    assert np.fromfile(tmp_path / "cube.f32", np.float32).tobytes() == dev.bordered().tobytes()
    got = np.fromfile(tmp_path / "latlong.f32", np.float32).reshape(*out, 4)
    assert got[..., :3].tobytes() == dev.to_latlong(*out).tobytes()


@pytest.mark.parametrize("face,index", [(1, 0), (5, 3), (12, 5)])
def test_c_face_store_equals_python(host: dict, tmp_path: Path, face: int, index: int) -> None:
    """cube_face_store (a generated cube map's face from a linear frame) writes the frame,
    mirrored left-right, into face `index`'s interior and nothing else: the C entry point's cube
    equals the Python host's kernel launch (oclshade.scene.generate) bit for bit, and both
    equal the mirrored frame."""
    import pyopencl as cl

    from oclshade.runtime import get_runtime

    rng = np.random.default_rng(face)
    frame = (rng.random((face, face, 4)) * 9.0).astype(np.float32)
    frame.tofile(tmp_path / "frame.f32")
    run_program(host, "host_passes", "face_store", tmp_path, tmp_path / "frame.f32", face, index)
    got = np.fromfile(tmp_path / "face.f32", np.float32).reshape(6, face + 2, face + 2, 4)
    rt = get_runtime()
    cube = rt.to_device(np.full((6, face + 2, face + 2, 4), np.nan, np.float32), "cube")
    k = rt.kernel("envmap.cl", "cube_face_store")
    source = rt.to_device(frame, "frame")                     # kept alive until the launch ran
    k.set_args(source, np.int32(face), np.int32(index), cube)
    cl.enqueue_nd_range_kernel(rt.queue, k, *rt.grid_2d(k, face, face))
    want = np.empty_like(got)
    cl.enqueue_copy(rt.queue, want, cube)
    rt.queue.finish()
    assert got.tobytes() == want.tobytes()
    assert np.array_equal(got[index, 1:-1, 1:-1], frame[:, ::-1])
    others = np.ones(6, bool)
    others[index] = False
    assert np.isnan(got[others]).all() and np.isnan(got[index, 0]).all() and np.isnan(got[index, :, -1]).all()
