"""The C host API's shadow volume entry points against the Python host, bit for bit
(host/tests/host_shadow_volumes.c; the build of host/ is the session fixture of tests/test_host_api.py).

* ``oclshade_shadow_volume_frame_read`` of :func:`write_frame_tables`'s file (the tables
  :meth:`MeshShadows.frame_tables` gives), bin, ``oclshade_shadow_volume_offsets``, mask and
  apply against :meth:`MeshShadows.mask` and :meth:`MeshShadows.shadow` (a sun, the eye inside
  a point light's shadow: a start count of 1, an orthographic camera 1e6 m from the origin
  whose view plane cuts a volume);
  the C program also checks pitched fields at offsets.
* The reader on damaged files, the offsets helper and the argument and contract checks.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade.camera import Camera
from oclshade.meshes.lights import PointLight
from oclshade.meshes.shadow_volumes import FRAME_MAGIC, MeshShadows, write_frame_tables
from oclshade.runtime import get_runtime
from oclshade.sun import Sun

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)
from test_host_objects import _camera_line
from test_shadow_volumes import box, cast, device_gbuffer, ground, torus


def _meshes(shift: np.ndarray) -> list:
    return [torus(shift + [0, 0, 10], 3.0, 1.2, 10, 6, tilt=30.0), box(shift + [8, -4, 4], [1.5, 2.5, 4], 20.0),
            ground(0.0, 60).placed(translate=shift)]


CASES = {   # camera (relative to the scene's offset), light, offset, start count
    "sun": (lambda s: Camera(s + [12, -18, 16], s + [-2, 2, 3], 96, 64, fov=50), lambda s: Sun(135, 40), 0.0, 0),
    "eye in a point light's shadow": (lambda s: Camera(s + [3.0, 0.1, 2], s + [6, 2, 0], 96, 64, fov=60, near=0.1),
                                      lambda s: PointLight(s + [3.0, 0.0, 30]), 0.0, 1),
    "orthographic 1e6 m away": (lambda s: Camera(s + [0.5, -0.3, 2], s + [10, 5, 1], 96, 64, projection="orthographic",
                                                 ortho_height=30), lambda s: Sun(135, 80), 1e6, 0),
}


def _frame(folder: Path, name: str):
    """The scene's G-buffer, MeshShadows and its frame tables written to folder."""
    make_camera, make_light, offset, start = CASES[name]
    shift = np.array([offset, -0.6 * offset, 0.0])
    meshes, camera, light = _meshes(shift), make_camera(shift), make_light(shift)
    rt = get_runtime(None)
    position, depth = cast(camera, meshes)
    gbuf = device_gbuffer(rt, position, depth)
    shadows = MeshShadows(meshes, rt)
    frame = shadows.frame_tables(camera, gbuf, light)
    assert frame.start_count == start
    if camera.projection == "orthographic":    # volume vertices behind the view plane: zs matters
        assert frame.start_height > 2.0, frame.start_height
    write_frame_tables(frame, folder / "frame.bin")
    return rt, camera, light, position, gbuf, shadows, frame


@pytest.mark.parametrize("name", list(CASES))
def test_c_shadow_volumes_equal_python(host: dict, tmp_path: Path, name: str) -> None:
    """Bin, offsets, mask and apply from the C entry points equal MeshShadows' mask and
    shadow coefficients bit for bit (packed and pitched fields)."""
    rt, camera, light, position, gbuf, shadows, frame = _frame(tmp_path, name)
    n = camera.width * camera.height
    k_dark, k_bright = 0.2, 0.6
    elevation = 0.0 if isinstance(light, PointLight) else light.elevation
    (tmp_path / "scene.txt").write_text(f"{_camera_line(camera)}\n{elevation!r} {k_dark!r} {k_bright!r} 16\n")
    position.astype(np.float32).tofile(tmp_path / "position.f32")
    coef = np.random.default_rng(5).random(n).astype(np.float32)
    coef.tofile(tmp_path / "coef.f32")
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_shadow_volumes", "volumes", out, tmp_path)

    mask = np.empty(n, np.uint8)
    cl.enqueue_copy(rt.queue, mask, shadows.mask(camera, gbuf, light))
    rt.queue.finish()
    assert 50 < mask.sum() < n - 50, "the frame must show shadows and light"
    assert (out / "mask.out").read_bytes() == mask.tobytes()
    counts = np.fromfile(out / "counts.out", np.int32)
    assert counts.shape == (6 * 4,) and counts.sum() > frame.ntri, "faces binned to their tiles"
    buf = rt.to_device(coef, "coefficient")
    shadows.shadow(camera, gbuf, None, light, buf, k_dark, k_bright)
    want = np.empty_like(coef)
    cl.enqueue_copy(rt.queue, want, buf)
    rt.queue.finish()
    assert (out / "coef.out").read_bytes() == want.tobytes()
    kshadow = np.float32(k_dark + (k_bright - k_dark) * max(math.sin(math.radians(elevation)), 0.0))
    assert np.array_equal(want, np.where(mask > 0, kshadow, coef)), "apply: eq. (1) where masked, else unchanged"


def test_frame_tables_file_layout(tmp_path: Path) -> None:
    """write_frame_tables: magic, counts, the two floats and the arrays MeshShadows counts with."""
    rt, camera, light, position, gbuf, shadows, frame = _frame(tmp_path, "eye in a point light's shadow")
    data = (tmp_path / "frame.bin").read_bytes()
    assert data[:8] == FRAME_MAGIC
    v, f, w0, reserved = np.frombuffer(data[8:24], "<i4")
    assert (v, f, w0, reserved) == (len(frame.vertices), len(frame.faces), 1, 0) and f == frame.ntri > 0
    zs, max_depth = np.frombuffer(data[24:32], "<f4")
    assert zs == np.float32(frame.start_height) and max_depth == np.float32(position[..., 2].min() * -1)
    assert data[32:32 + 16 * v] == frame.vertices.tobytes() and data[32 + 16 * v:] == frame.faces.tobytes()
    assert np.array_equal(frame.faces, shadows.volumes(light).faces)


def _damaged(folder: Path) -> None:
    good = (folder / "frame.bin").read_bytes()
    v, f = np.frombuffer(good[8:16], "<i4")
    (folder / "magic.bin").write_bytes(b"OCLSSVF2" + good[8:])
    (folder / "short.bin").write_bytes(good[:-4])
    (folder / "long.bin").write_bytes(good + b"\0")
    (folder / "counts.bin").write_bytes(good[:8] + np.array([0, f, 0, 0], "<i4").tobytes() + good[24:])
    faces = np.frombuffer(good[32 + 16 * v:], "<i4").reshape(-1, 4).copy()
    for name, (row, col, value) in {"index.bin": (3, 1, v), "kind.bin": (2, 3, 2)}.items():
        bad = faces.copy()
        bad[row, col] = value
        (folder / name).write_bytes(good[:32 + 16 * v] + bad.tobytes())
    empty = np.array([1, 1, 0, 0], "<i4").tobytes() + np.zeros(2, "<f4").tobytes() + bytes(32)
    (folder / "empty.bin").write_bytes(FRAME_MAGIC + empty)


def test_c_shadow_volumes_argument_and_contract_checks(host: dict, tmp_path: Path) -> None:
    """The reader refuses damaged files (naming what is wrong, the frame cleared), the offsets
    helper refuses bad counts, and every call refuses bad arguments and buffers with a message
    naming the argument (host_shadow_volumes errors: one line per check)."""
    _frame(tmp_path, "sun")
    _damaged(tmp_path)
    stdout = run_program(host, "host_shadow_volumes", "errors", tmp_path, tmp_path)
    lines = stdout.splitlines()
    assert not [line for line in lines if line.startswith("FAIL")], stdout
    assert sum(line.startswith("ok ") for line in lines) >= 40, stdout
