"""Cube maps on the host and on the device, lat-long <-> cube conversion (kernels/envmap.cl).

>>> cube = CubeMap.from_latlong(latlong_rgb, 256)      # resampled on the device
>>> dev = cube.to_device(runtime)                        # bordered, ready for reflect.cl
>>> panorama = cube.to_latlong(512, 1024)

A :class:`CubeMap` holds ``faces`` (6, N, N, 3) float32 linear RGB in the cube-map frame F
with the face table of kernels/cubemap.h (+X, -X, +Y, -Y, +Z, -Z; OpenGL's major-axis rule;
row 0 of a face at t = 0).  How F sits in the world (x east, y north, z up) is
:func:`cube_frame`.  Float64 twins: :mod:`oclshade.reference.envmap`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pyopencl as cl

from ..runtime import Runtime, get_runtime

#: faces in buffer order, named by their axis in the cube-map frame F
FACES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: the largest face side accepted (6 bordered faces of 8192^2 float4 are 6 GiB)
MAX_FACE = 8192


def _rgb(name: str, array: object, ndim: int) -> np.ndarray:
    a = np.asarray(array)
    if a.ndim != ndim or a.shape[-1] not in (3, 4) or a.dtype.kind not in "fiu":
        raise ValueError(f"{name} must be a {ndim}-D array of RGB or RGBA texels (last axis 3 or 4), "
                         f"got shape {a.shape} dtype {a.dtype}")
    a = a[..., :3].astype(np.float32)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} holds NaN or infinite values; an environment map must be finite")
    return np.ascontiguousarray(a)


def face_size(n: object) -> int:
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 1 <= n <= MAX_FACE:
        raise ValueError(f"cube face size must be an integer in 1..{MAX_FACE}, got {n!r}")
    return int(n)


def cube_frame(rotation: float = 0.0) -> np.ndarray:
    """3x3 rotation world -> cube-map frame F (paper 002's OWCS -> cube-map step).

    F's +Y is world up (+z), +X east, +Z south: a -90 degree rotation about the x (east)
    axis, (x, y, z) -> (x, z, -y).  Paper 002 rotates by +90 degrees because its face images
    hold the sky on -Y (images stored bottom row first); ours, and OpenEXR's, hold it on +Y.
    ``rotation`` (degrees) then turns the environment about world up, counter-clockwise seen
    from above: rotation 90 puts F's +Z (a lat-long map's centre column) in the east."""
    a = math.radians(float(rotation))
    if not math.isfinite(a):
        raise ValueError(f"rotation must be a finite number of degrees, got {rotation!r}")
    turn = np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    to_f = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    return to_f @ turn


@dataclass(frozen=True)
class CubeMap:
    """Six N x N faces, float32 linear RGB (6, N, N, 3), in the face table of kernels/cubemap.h."""

    faces: np.ndarray = field(repr=False)

    def __post_init__(self) -> None:
        faces = _rgb("faces", self.faces, 4)
        if faces.shape[0] != 6 or faces.shape[1] != faces.shape[2]:
            raise ValueError(f"faces must have shape (6, N, N, 3), got {faces.shape}")
        face_size(faces.shape[1])
        object.__setattr__(self, "faces", faces)

    @property
    def size(self) -> int:
        return self.faces.shape[1]

    @classmethod
    def from_latlong(cls, image: np.ndarray, size: int | None = None,
                     device: str | int | Runtime | None = None) -> "CubeMap":
        """Resample a lat-long map (H, W, 3|4) into a cube map of ``size`` (default W / 4: about
        one lat-long texel per cube texel at the equator)."""
        return latlong_to_cube(image, size, device).to_host()

    def to_device(self, device: str | int | Runtime | None = None) -> "DeviceCubeMap":
        rt = get_runtime(device)
        n = self.size
        bordered = np.zeros((6, n + 2, n + 2, 4), np.float32)
        bordered[:, 1:-1, 1:-1, :3] = self.faces
        dev = DeviceCubeMap(rt, n, rt.to_device(bordered, "cube map"))
        dev.fill_border()
        return dev

    def to_latlong(self, height: int, width: int, device: str | int | Runtime | None = None) -> np.ndarray:
        """A lat-long map (height, width, 3) float32 of this cube map (seam-continuous bilinear)."""
        return self.to_device(device).to_latlong(height, width)


@dataclass
class DeviceCubeMap:
    """Cube maps on the device in the bordered layout of kernels/cubemap.h: ``count`` of
    them back to back in ``buffer`` (one, unless made by :func:`stack_cubes`)."""

    runtime: Runtime
    size: int
    buffer: cl.Buffer
    count: int = 1

    @property
    def nbytes(self) -> int:
        """Bytes of one bordered cube map."""
        return 16 * 6 * (self.size + 2) ** 2

    def fill_border(self) -> None:
        if self.count != 1:
            raise ValueError("fill the borders of each cube map before stacking them")
        rt, n = self.runtime, self.size
        k = rt.kernel("envmap.cl", "cube_border")
        k.set_args(self.buffer, np.int32(n))
        cl.enqueue_nd_range_kernel(rt.queue, k, (n + 2, 4, 6), None)

    def bordered(self) -> np.ndarray:
        """The bordered faces (6 count, N + 2, N + 2, 4) on the host."""
        n = self.size
        out = np.empty((6 * self.count, n + 2, n + 2, 4), np.float32)
        cl.enqueue_copy(self.runtime.queue, out, self.buffer)
        self.runtime.queue.finish()
        return out

    def to_host(self) -> CubeMap:
        if self.count != 1:
            raise ValueError(f"this buffer holds {self.count} cube maps; to_host reads one")
        return CubeMap(self.bordered()[:, 1:-1, 1:-1, :3])

    def to_latlong(self, height: int, width: int) -> np.ndarray:
        for name, v in (("height", height), ("width", width)):
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 1 <= v <= 4 * MAX_FACE:
                raise ValueError(f"lat-long {name} must be an integer in 1..{4 * MAX_FACE}, got {v!r}")
        if self.count != 1:
            raise ValueError(f"this buffer holds {self.count} cube maps; to_latlong reads one")
        rt = self.runtime
        out = rt.empty(16 * height * width, "lat-long map")
        k = rt.kernel("envmap.cl", "cube_to_latlong")
        k.set_args(self.buffer, np.int32(self.size), out, np.int32(height), np.int32(width))
        cl.enqueue_nd_range_kernel(rt.queue, k, *rt.grid_2d(k, width, height))
        host = np.empty((height, width, 4), np.float32)
        cl.enqueue_copy(rt.queue, host, out)
        rt.queue.finish()
        return host[..., :3].copy()


def latlong_to_cube(image: np.ndarray, size: int | None = None,
                    device: str | int | Runtime | None = None) -> DeviceCubeMap:
    """A lat-long map (H, W, 3|4) resampled into a bordered device cube map of ``size``
    (default W / 4): each texel the map's bilinear sample in its centre's direction."""
    ll = _rgb("lat-long image", image, 3)
    h, w = ll.shape[:2]
    if h < 1 or w < 2:
        raise ValueError(f"a lat-long map needs at least 1 row and 2 columns, got {h}x{w}")
    n = face_size(max(1, w // 4) if size is None else size)
    rt = get_runtime(device)
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[..., :3] = ll
    src = rt.to_device(rgba, "lat-long map")
    dev = DeviceCubeMap(rt, n, rt.empty(16 * 6 * (n + 2) ** 2, "cube map"))
    k = rt.kernel("envmap.cl", "latlong_to_cube")
    k.set_args(src, np.int32(h), np.int32(w), dev.buffer, np.int32(n))
    (gx, gy), (lx, ly) = rt.grid_2d(k, n, n)
    cl.enqueue_nd_range_kernel(rt.queue, k, (gx, gy, 6), (lx, ly, 1))
    dev.fill_border()
    return dev


def stack_cubes(cubes: list[DeviceCubeMap]) -> DeviceCubeMap:
    """One buffer holding the given cube maps (same device and face size) back to back, in
    order: what kernels/reflect.cl reads when objects have maps of their own."""
    if not cubes or len({(c.runtime, c.size) for c in cubes}) != 1:
        raise ValueError("stack_cubes takes one or more cube maps of one device and one face size")
    rt, first = cubes[0].runtime, cubes[0]
    out = DeviceCubeMap(rt, first.size, rt.empty(first.nbytes * sum(c.count for c in cubes), "cube maps"),
                        sum(c.count for c in cubes))
    offset = 0
    for c in cubes:
        cl.enqueue_copy(rt.queue, out.buffer, c.buffer, byte_count=c.nbytes * c.count, dst_offset=offset)
        offset += c.nbytes * c.count
    return out
