"""Quadrics on the device (kernels/quadric.cl): their G-buffer, the depth merge with the
terrain's, object normals, and their shadows.

>>> caster = QuadricCaster([Quadric.sphere(c, 40.0)], heightmap, device)
>>> objects = caster.cast(camera)                    # DeviceGBuffer + object ids of the quadrics
>>> ids = caster.merge(objects, terrain_gbuffer)     # terrain_gbuffer now shows the nearest hit
>>> caster.shadow(camera, terrain_gbuffer, ids, sun, coefficient)   # after the terrain's shadow pass

Shadows (docs/reflections.md "Shadows"): the terrain's own per-pixel pass (paper 000)
shades the terrain pixels; :meth:`QuadricCaster.shadow` then darkens every terrain pixel
whose sun ray meets a quadric, and decides each object pixel itself: its sun ray against
every quadric (closed form) and against the terrain (every patch under the ray, exact).
Twins: :mod:`oclshade.reference.quadrics`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pyopencl as cl

from ..camera import Camera, heightmap_from_world
from ..gbuffer import CHANNELS
from ..heightmap import Heightmap
from ..lights import PointLight
from ..runtime import Runtime, get_runtime
from ..sun import SunLike, as_sun
from ..terrain import DeviceGBuffer
from .objects import KIND_CODE, Quadric

#: most quadrics in one scene (each pixel loops over those whose screen rectangle holds it)
MAX_QUADRICS = 4096


@dataclass
class ObjectIds:
    """Per-pixel object ids on the device (int32: quadric index + 1, -(mesh index + 1) for
    meshes (oclshade.meshes), 0 none)."""

    buffer: cl.Buffer
    shape: tuple[int, int]

    def to_host(self, runtime: Runtime) -> np.ndarray:
        out = np.empty(self.shape, np.int32)
        cl.enqueue_copy(runtime.queue, out, self.buffer)
        runtime.queue.finish()
        return out


def _rows(m: np.ndarray) -> list[np.ndarray]:
    return [np.array(r, np.float32) for r in m[:3]]


class QuadricCaster:
    """Quadrics (and optionally the terrain they stand on, for uv and shadows) on one device."""

    def __init__(self, quadrics: Sequence[Quadric], heightmap: Heightmap | None = None,
                 device: str | int | Runtime | None = None, heights: cl.Buffer | None = None):
        """``heights``: the terrain's relative float32 heights already on the device (the ray
        caster's ``pyramid.heights``), else uploaded from ``heightmap`` when shadows need them."""
        quadrics = list(quadrics)
        if not 1 <= len(quadrics) <= MAX_QUADRICS or not all(isinstance(q, Quadric) for q in quadrics):
            raise ValueError(f"quadrics must be 1..{MAX_QUADRICS} oclshade.quadrics.Quadric objects")
        if heightmap is not None and not isinstance(heightmap, Heightmap):
            raise TypeError(f"heightmap must be an oclshade.Heightmap or None, got {type(heightmap).__name__}")
        self.quadrics = quadrics
        self.heightmap = heightmap
        self.runtime = get_runtime(device)
        self._heights = heights

    @property
    def heights(self) -> cl.Buffer:
        if self._heights is None:
            data = (self.heightmap.relative32 if self.heightmap is not None else np.zeros(1, np.float32))
            self._heights = self.runtime.to_device(np.ascontiguousarray(data, np.float32), "heights")
        return self._heights

    # --- per-camera tables ----------------------------------------------------------------
    def tables(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
        """(qf float4 x 5 per quadric, qi int4 x 2 per quadric) of kernels/quadric.cl."""
        rot, view = camera.rotation, camera.view
        qf = np.zeros((len(self.quadrics), 5, 4), np.float32)
        qi = np.zeros((len(self.quadrics), 2, 4), np.int32)
        for k, q in enumerate(self.quadrics):
            m = np.diag(1.0 / q.radii) @ (rot @ q.frame).T          # view -> unit frame
            c = view[:3, :3] @ q.centre + view[:3, 3]
            qf[k, :3, :3] = m
            qf[k, :3, 3] = -(m @ c)
            qf[k, 3] = (*q.material.colour, 1.0)
            centre, radius = q.bound
            qf[k, 4] = (*(view[:3, :3] @ centre + view[:3, 3]), radius)
            qi[k] = [[KIND_CODE[q.kind], 0, 0, 0], screen_rect(camera, view[:3, :3] @ centre + view[:3, 3], radius)]
        return qf, qi

    def _tables_on_device(self, camera: Camera) -> tuple[cl.Buffer, cl.Buffer]:
        qf, qi = self.tables(camera)
        return self.runtime.to_device(qf, "quadric table"), self.runtime.to_device(qi, "quadric kinds")


    # --- passes --------------------------------------------------------------------------
    def cast(self, camera: Camera, out: tuple[DeviceGBuffer, ObjectIds] | None = None
             ) -> tuple[DeviceGBuffer, ObjectIds]:
        """The quadrics' own G-buffer (layout of :mod:`oclshade.gbuffer`) and object ids."""
        rt = self.runtime
        shape = (camera.height, camera.width)
        n = camera.width * camera.height
        if out is None or out[0].shape != shape:
            gbuf = DeviceGBuffer(rt, shape, {name: rt.empty(4 * ch * n, f"quadric G-buffer {name}")
                                             for name, ch in CHANNELS.items()})
            out = (gbuf, ObjectIds(rt.empty(4 * n, "object ids"), shape))
        gbuf, ids = out
        sx, sy = camera.scale
        hm0, hm1, _ = heightmap_rows(camera, self.heightmap)
        kernel = rt.kernel("quadric.cl", "quadric_cast", {"OCLS_ORTHO": camera.projection == "orthographic"})
        tables = self._tables_on_device(camera)       # held until enqueued (a released buffer is freed at once)
        kernel.set_args(np.int32(len(self.quadrics)), *tables,
                        np.array([sx, sy, camera.near, camera.far], np.float32),
                        np.int32(camera.width), np.int32(camera.height), hm0, hm1,
                        *(gbuf.buffers[name] for name in CHANNELS), ids.buffer)
        cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, camera.width, camera.height))
        return gbuf, ids

    def merge(self, objects: tuple[DeviceGBuffer, ObjectIds], into: DeviceGBuffer,
              ids: ObjectIds | None = None) -> ObjectIds:
        """Depth-merge ``objects`` (from :meth:`cast`) into the G-buffer ``into`` in place: the
        nearest hit wins per pixel (a tie keeps ``into``).  ``ids``: the object ids of ``into``
        (None: a terrain G-buffer, all 0); returns them, updated."""
        return merge_gbuffers(self.runtime, objects, into, ids)

    def object_normals(self, gbuffer: DeviceGBuffer, ids: ObjectIds, shading: cl.Buffer) -> None:
        """Put the objects' own normals into a shading-normal buffer (in place)."""
        object_normals(self.runtime, gbuffer, ids, shading)

    def shadow(self, camera: Camera, gbuffer: DeviceGBuffer, ids: ObjectIds, sun: SunLike, coefficient: cl.Buffer,
               k_dark: float = 0.0, k_bright: float = 0.0) -> None:
        """Quadric shadows into a shadow-coefficient buffer (one float per pixel, 1 = lit) in
        place: see the module doc.  A shadowed pixel gets paper 000's eq. (1),
        k_dark + (k_bright - k_dark) max(sin elevation, 0).  A point light: :meth:`point_shadow`."""
        if isinstance(sun, PointLight):
            raise TypeError("sun: QuadricCaster.shadow is the sun's; for a point light use point_shadow (and "
                            "terrain_point_shadow for the terrain)")
        rt = self.runtime
        n = gbuffer.shape[0] * gbuffer.shape[1]
        tables = self._tables_on_device(camera)
        kernel = rt.kernel("quadric.cl", "quadric_shadow")
        kernel.set_args(np.int32(n), np.int32(len(self.quadrics)), *tables, gbuffer.buffers["position"], ids.buffer,
                        *terrain_shadow_args(camera, self.heightmap, self.heights, sun, k_dark, k_bright),
                        coefficient)
        launch_1d(rt, kernel, n)


    def point_shadow(self, camera: Camera, gbuffer: DeviceGBuffer, ids: ObjectIds, light: PointLight,
                     coefficient: cl.Buffer, k_dark: float = 0.0) -> None:
        """Quadric shadows of a point light, in place: every hit pixel whose segment to the
        light meets a quadric (its own closed shape excluded) gets ``k_dark``; the others keep
        theirs.  Run after :func:`terrain_point_shadow`, which sets every pixel."""
        if not isinstance(light, PointLight):
            raise TypeError(f"light must be an oclshade.meshes.lights.PointLight, got {type(light).__name__}")
        rt = self.runtime
        n = gbuffer.shape[0] * gbuffer.shape[1]
        tables = self._tables_on_device(camera)
        kernel = rt.kernel("quadric.cl", "quadric_point_shadow")
        kernel.set_args(np.int32(n), np.int32(len(self.quadrics)), *tables, gbuffer.buffers["position"], ids.buffer,
                        light_view(camera, light), np.float32(k_dark), coefficient)
        launch_1d(rt, kernel, n)


def light_view(camera: Camera, light: PointLight) -> np.ndarray:
    """The point light's view-space position (float64 product rounded once), float4 w = 0."""
    return np.array([*(camera.view[:3, :3] @ light.position + camera.view[:3, 3]), 0.0], np.float32)


def terrain_point_shadow(runtime: Runtime, camera: Camera, heightmap: Heightmap | None, heights: cl.Buffer,
                         gbuffer: DeviceGBuffer, ids: ObjectIds, light: PointLight, coefficient: cl.Buffer,
                         k_dark: float = 0.0) -> None:
    """The terrain's shadows of a point light on every pixel of a (merged) G-buffer, into
    ``coefficient`` (one float per pixel): ``k_dark`` where the terrain rises above the segment
    from the pixel's surface point to the light (exact, kernels/terrain_ray.h; terrain pixels,
    object id 0, start on the surface), else 1 (empty pixels too).  ``heights``: the
    relative float32 heights on the device; no heightmap: every pixel 1."""
    if not isinstance(light, PointLight):
        raise TypeError(f"light must be an oclshade.meshes.lights.PointLight, got {type(light).__name__}")
    hm = heightmap
    n = gbuffer.shape[0] * gbuffer.shape[1]
    rows, cols = hm.shape if hm is not None else (0, 0)
    zmax = 0.0 if hm is None else float(np.nanmax(hm.relative32)) if np.isfinite(hm.relative32).any() else 0.0
    at = heightmap_from_world(hm) @ np.array([*light.position, 1.0]) if hm is not None else np.zeros(4)
    kernel = runtime.kernel("quadric.cl", "terrain_point_shadow")
    kernel.set_args(np.int32(n), gbuffer.buffers["position"], ids.buffer, np.array([*at[:3], 0.0], np.float32),
                    heights, np.int32(rows), np.int32(cols), np.float32(zmax), *heightmap_rows(camera, hm),
                    np.float32(k_dark), coefficient)
    launch_1d(runtime, kernel, n)


def heightmap_rows(camera: Camera, heightmap: Heightmap | None) -> list[np.ndarray]:
    """Rows of the affine map view -> (u, v, z - offset) of the heightmap (zeros without one)."""
    if heightmap is None:
        return [np.zeros(4, np.float32)] * 3
    return _rows(heightmap_from_world(heightmap) @ np.linalg.inv(camera.view))


def terrain_shadow_args(camera: Camera, heightmap: Heightmap | None, heights: cl.Buffer, sun: SunLike,
                        k_dark: float, k_bright: float) -> list:
    """The kernel arguments (sun, h, H, W, zmax, hm0, hm1, hm2, ray, kshadow) that every object
    pass shading its pixels against the terrain takes (kernels/terrain_ray.h; quadric_shadow,
    mesh.cl's mesh_terrain_shadow): sun = view-space vector to the sun, w = 1 when it is at or
    below the horizon; kshadow = paper 000's eq. (1)."""
    sun = as_sun(sun)
    s_view = camera.rotation @ np.array(sun.vector())
    kshadow = k_dark + (k_bright - k_dark) * max(math.sin(math.radians(sun.elevation)), 0.0)
    hm = heightmap
    rows, cols = hm.shape if hm is not None else (0, 0)
    ray = sun.ray(hm.dx, hm.dy) if hm is not None and not sun.below_horizon else (0.0, 0.0, 0.0)
    zmax = 0.0 if hm is None else float(np.nanmax(hm.relative32)) if np.isfinite(hm.relative32).any() else 0.0
    return [np.array([*s_view, 1.0 if sun.below_horizon else 0.0], np.float32), heights, np.int32(rows),
            np.int32(cols), np.float32(zmax), *heightmap_rows(camera, hm), np.array([*ray, 0.0], np.float32),
            np.float32(kshadow)]


def merge_gbuffers(runtime: Runtime, objects: tuple[DeviceGBuffer, ObjectIds], into: DeviceGBuffer,
                   ids: ObjectIds | None = None) -> ObjectIds:
    """Depth-merge an object G-buffer and its ids into ``into`` (QuadricCaster.merge; any kind
    of object: kernels/quadric.cl gbuffer_merge)."""
    src, src_ids = objects
    if src.shape != into.shape:
        raise ValueError(f"G-buffers differ in size: {src.shape} and {into.shape}")
    n = into.shape[0] * into.shape[1]
    if ids is None:
        ids = ObjectIds(runtime.empty(4 * n, "object ids"), into.shape)
        cl.enqueue_fill_buffer(runtime.queue, ids.buffer, np.int32(0), 0, 4 * n)
    kernel = runtime.kernel("quadric.cl", "gbuffer_merge")
    kernel.set_args(np.int32(n), *(src.buffers[k] for k in CHANNELS), src_ids.buffer,
                    *(into.buffers[k] for k in CHANNELS), ids.buffer)
    launch_1d(runtime, kernel, n)
    return ids


def object_normals(runtime: Runtime, gbuffer: DeviceGBuffer, ids: ObjectIds, shading: cl.Buffer) -> None:
    """Every object pixel's (id != 0: quadrics and meshes) own normal into a shading-normal buffer."""
    n = gbuffer.shape[0] * gbuffer.shape[1]
    kernel = runtime.kernel("quadric.cl", "object_normals")
    kernel.set_args(np.int32(n), ids.buffer, gbuffer.buffers["normal"], shading)
    launch_1d(runtime, kernel, n)


def launch_1d(runtime: Runtime, kernel: cl.Kernel, n: int) -> None:
    """One work-item per i < n, local size up to 64."""
    local = runtime.local_size(kernel, 64)
    cl.enqueue_nd_range_kernel(runtime.queue, kernel, (-(-n // local) * local,), (local,))


def screen_rect(camera: Camera, centre_view: np.ndarray, radius: float) -> list[int]:
    """Pixels (x0, y0, x1, y1), x0 <= x < x1, that may see a view-space sphere: the corners of
    its bounding cube projected, one pixel of margin; the whole frame when the cube reaches
    the near plane of a pinhole camera."""
    w, h = camera.width, camera.height
    corners = centre_view + radius * np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    sx, sy = camera.scale
    if camera.projection == "perspective":
        depth = -corners[:, 2]
        if depth.min() <= camera.near:
            return [0, 0, w, h]
        ndc_x, ndc_y = corners[:, 0] / (depth * sx), corners[:, 1] / (depth * sy)
    else:
        ndc_x, ndc_y = corners[:, 0] / sx, corners[:, 1] / sy
    cols = ((ndc_x + 1.0) * w - 1.0) / 2.0                 # inverse of ndc = (2c + 1) / W - 1
    rows = ((1.0 - ndc_y) * h - 1.0) / 2.0
    x0, x1 = int(np.clip(math.floor(cols.min()) - 1, 0, w)), int(np.clip(math.ceil(cols.max()) + 2, 0, w))
    y0, y1 = int(np.clip(math.floor(rows.min()) - 1, 0, h)), int(np.clip(math.ceil(rows.max()) + 2, 0, h))
    return [x0, y0, x1, y1]
