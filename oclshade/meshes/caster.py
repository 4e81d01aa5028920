"""Triangle meshes on the device (kernels/mesh.cl): their G-buffer by BVH ray casting, the
depth merge with the terrain's, object normals, terrain shadows on their pixels, and
any-hit shadow rays.

>>> caster = MeshCaster([load_mesh("bunny.obj").placed((500, -800, 240), 40.0)], heightmap, device)
>>> objects = caster.cast(camera)                    # DeviceGBuffer + object ids of the meshes
>>> ids = caster.merge(objects, terrain_gbuffer)     # terrain_gbuffer now shows the nearest hit
>>> caster.shadow(camera, terrain_gbuffer, ids, sun, coefficient)   # the terrain on mesh pixels
>>> hidden = caster.shadow_rays(camera, terrain_gbuffer, sun)       # int32 per pixel, 1 = a mesh hides the light

Object ids: mesh k's pixels get -(k + 1) (quadrics keep k + 1, the terrain 0), so quadric
reflections (ids > 0) never see mesh pixels.  G-buffer fields on mesh pixels: uv is the
mesh's texture uv (0 without uvs), uv_grad is 0 (docs/meshes.md).  Precision: each mesh's
vertices are float32 relative to its own origin (the centre of its bounds, float64 on the
host) and the kernel gets the camera relative to it.  Twin: :mod:`oclshade.reference.meshes`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pyopencl as cl

from ..camera import Camera
from ..gbuffer import CHANNELS
from ..heightmap import Heightmap
from ..lights import LightLike, PointLight, as_light
from ..quadrics.caster import (ObjectIds, launch_1d, merge_gbuffers, object_normals, screen_rect,
                               terrain_shadow_args)
from ..runtime import Runtime, get_runtime
from ..sun import SunLike, as_sun
from ..terrain import DeviceGBuffer
from .bvh import build_bvh
from .mesh import TriangleMesh

TEXTURE, NORMAL_MAP, CASTS = 1, 2, 4


def face_tangents(mesh: TriangleMesh) -> np.ndarray:
    """Per face (tangent xyz, handedness): the unit direction of growing u on the face and
    +-1 as (normal x tangent) follows growing v or not; zeros without uvs or on a face whose
    uvs are degenerate."""
    out = np.zeros((len(mesh.faces), 4))
    if mesh.uvs is None:
        return out
    p = mesh.vertices[mesh.faces]
    t = mesh.uvs[mesh.faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    r = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = r != 0
    rs = np.where(ok, r, 1.0)[:, None]
    tangent = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / rs
    bitangent = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / rs
    length = np.linalg.norm(tangent, axis=1, keepdims=True)
    ok &= length[:, 0] > 0
    out[ok, :3] = tangent[ok] / length[ok]
    hand = np.sign(np.einsum("ij,ij->i", np.cross(mesh.face_normals, tangent), bitangent))
    out[ok, 3] = np.where(hand[ok] < 0, -1.0, 1.0)
    return out


@dataclass
class _Tables:
    """The meshes flattened into one set of arrays (kernels/mesh.cl ABI)."""

    box: np.ndarray
    info: np.ndarray
    tri: np.ndarray
    tvtx: np.ndarray
    tangent: np.ndarray
    vnrm: np.ndarray
    vuv: np.ndarray
    texel: np.ndarray
    mi: np.ndarray
    origins: np.ndarray          # float64 (nm, 3)
    reach: list[float]           # per mesh: the largest distance of a vertex from its origin


def _flatten(meshes: Sequence[TriangleMesh]) -> _Tables:
    boxes, infos, tris, tvtxs, tangents, vnrms, vuvs, texels, mi, origins = [], [], [], [], [], [], [], [], [], []
    nodes = slots = verts = texel_count = 0
    for mesh in meshes:
        lo, hi = mesh.bounds
        origin = 0.5 * (lo + hi)
        rel = (mesh.vertices - origin).astype(np.float32)
        tri = rel[mesh.faces]
        bvh = build_bvh(tri)
        info = bvh.info.copy()
        info[:, 0] += np.where(info[:, 1] > 0, slots, nodes)
        boxes.append(np.stack([np.pad(bvh.lo, ((0, 0), (0, 1))), np.pad(bvh.hi, ((0, 0), (0, 1)))], 1))
        infos.append(info)
        tris.append(np.pad(tri[bvh.order], ((0, 0), (0, 0), (0, 1))))
        tvtxs.append(np.pad(mesh.faces[bvh.order] + verts, ((0, 0), (0, 1))))
        tangents.append(face_tangents(mesh)[bvh.order])
        vnrms.append(np.pad(mesh.vertex_normals, ((0, 0), (0, 1))))
        vuvs.append(mesh.uvs if mesh.uvs is not None else np.zeros((len(mesh.vertices), 2)))
        s = mesh.surface
        flags = (TEXTURE if s.texture is not None else 0) | (NORMAL_MAP if s.normal_map is not None else 0) \
            | (CASTS if mesh.cast_shadows else 0)
        rows = [[nodes, flags, 0, 0]]
        for image in (s.texture, s.normal_map):
            if image is None:
                rows.append([0, 0, 0, 0])
                continue
            h, w = image.shape[:2]
            rows.append([texel_count, w, h, 0])
            texels.append(np.pad(image.reshape(-1, image.shape[2]), ((0, 0), (0, 4 - image.shape[2]))))
            texel_count += h * w
        mi.append(rows)
        origins.append(origin)
        nodes, slots, verts = nodes + len(info), slots + len(bvh.order), verts + len(mesh.vertices)
    f32 = np.float32
    return _Tables(np.concatenate(boxes).astype(f32), np.concatenate(infos).astype(np.int32),
                   np.concatenate(tris).astype(f32), np.concatenate(tvtxs).astype(np.int32),
                   np.concatenate(tangents).astype(f32), np.concatenate(vnrms).astype(f32),
                   np.concatenate(vuvs).astype(f32),
                   np.concatenate(texels).astype(f32) if texels else np.zeros((1, 4), f32),
                   np.array(mi, np.int32), np.array(origins),
                   [float(np.linalg.norm(m.vertices - o, axis=1).max()) for m, o in zip(meshes, origins)])


def _rows(m: np.ndarray) -> list[np.ndarray]:
    return [np.array([*r, 0.0], np.float32) for r in m]


class MeshCaster:
    """Triangle meshes (and optionally the terrain they stand on, for shadows) on one device."""

    def __init__(self, meshes: Sequence[TriangleMesh], heightmap: Heightmap | None = None,
                 device: str | int | Runtime | None = None, heights: cl.Buffer | None = None,
                 own_builtins: bool = True):
        """``heights``: the terrain's relative float32 heights already on the device (the ray
        caster's ``pyramid.heights``), else uploaded from ``heightmap`` when shadows need them.
        ``own_builtins``: kernels/common.h's inline fmin / fmax / fabs (OCLS_OWN_BUILTINS; the
        same frames either way: PyPI PoCL 3.0 on a Zen 3 cast twice as fast with them)."""
        meshes = list(meshes)
        if not meshes or not all(isinstance(m, TriangleMesh) for m in meshes):
            raise ValueError("meshes must be one or more oclshade.meshes.TriangleMesh objects")
        if heightmap is not None and not isinstance(heightmap, Heightmap):
            raise TypeError(f"heightmap must be an oclshade.Heightmap or None, got {type(heightmap).__name__}")
        self.meshes, self.heightmap = meshes, heightmap
        self.runtime = rt = get_runtime(device)
        self._heights = heights
        self._defines = {"OCLS_OWN_BUILTINS": bool(own_builtins)}
        t = _flatten(meshes)
        self.origins = t.origins
        self.reach = t.reach
        self._mi = t.mi
        self._buffers = [rt.to_device(a, f"mesh {name}") for name, a in
                         (("BVH boxes", t.box), ("BVH nodes", t.info), ("triangles", t.tri),
                          ("triangle vertices", t.tvtx), ("tangents", t.tangent), ("normals", t.vnrm),
                          ("uvs", t.vuv), ("texels", t.texel))]
        self._mi_buffer = rt.to_device(t.mi, "mesh table")

    @property
    def heights(self) -> cl.Buffer:
        if self._heights is None:
            data = (self.heightmap.relative32 if self.heightmap is not None else np.zeros(1, np.float32))
            self._heights = self.runtime.to_device(np.ascontiguousarray(data, np.float32), "heights")
        return self._heights

    def table(self, camera: Camera) -> np.ndarray:
        """mf of kernels/mesh.cl: per mesh (camera - origin, colour + cutoff, screen rectangle),
        float32 (nm, 3, 4)."""
        mf = np.zeros((len(self.meshes), 3, 4), np.float32)
        rot = camera.rotation
        for k, (mesh, origin, reach) in enumerate(zip(self.meshes, self.origins, self.reach)):
            mf[k, 0, :3] = camera.position - origin                  # float64 difference, rounded once
            mf[k, 1] = (*mesh.surface.colour, mesh.surface.alpha_cutoff)
            mf[k, 2] = screen_rect(camera, rot @ (origin - camera.position), reach)
        return mf

    def _mf(self, camera: Camera) -> cl.Buffer:
        return self.runtime.to_device(self.table(camera), "mesh camera table")

    # --- passes --------------------------------------------------------------------------
    def cast(self, camera: Camera, out: tuple[DeviceGBuffer, ObjectIds] | None = None
             ) -> tuple[DeviceGBuffer, ObjectIds]:
        """The meshes' own G-buffer (layout of :mod:`oclshade.gbuffer`) and object ids."""
        rt = self.runtime
        shape = (camera.height, camera.width)
        n = camera.width * camera.height
        if out is None or out[0].shape != shape:
            gbuf = DeviceGBuffer(rt, shape, {name: rt.empty(4 * ch * n, f"mesh G-buffer {name}")
                                             for name, ch in CHANNELS.items()})
            out = (gbuf, ObjectIds(rt.empty(4 * n, "object ids"), shape))
        gbuf, ids = out
        sx, sy = camera.scale
        rot = camera.rotation
        kernel = rt.kernel("mesh.cl", "mesh_cast", {**self._defines, "OCLS_ORTHO": camera.projection == "orthographic"})
        mf = self._mf(camera)              # held until enqueued (a released buffer is freed at once)
        kernel.set_args(np.int32(len(self.meshes)), mf, self._mi_buffer, *self._buffers,
                        np.array([sx, sy, camera.near, camera.far], np.float32),
                        np.int32(camera.width), np.int32(camera.height), *_rows(rot.T), *_rows(rot),
                        *(gbuf.buffers[name] for name in CHANNELS), ids.buffer)
        cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, camera.width, camera.height))
        return gbuf, ids

    def merge(self, objects: tuple[DeviceGBuffer, ObjectIds], into: DeviceGBuffer,
              ids: ObjectIds | None = None) -> ObjectIds:
        """Depth-merge ``objects`` (from :meth:`cast`) into ``into`` in place (nearest hit wins,
        a tie keeps ``into``); ``ids``: the object ids of ``into`` (None: all 0)."""
        return merge_gbuffers(self.runtime, objects, into, ids)

    def object_normals(self, gbuffer: DeviceGBuffer, ids: ObjectIds, shading: cl.Buffer) -> None:
        """Put every object's own normals (meshes and quadrics) into a shading-normal buffer."""
        object_normals(self.runtime, gbuffer, ids, shading)

    def shadow(self, camera: Camera, gbuffer: DeviceGBuffer, ids: ObjectIds, sun: SunLike, coefficient: cl.Buffer,
               k_dark: float = 0.0, k_bright: float = 0.0) -> None:
        """The terrain's shadows on mesh pixels, in place: each mesh pixel gets paper 000's
        eq. (1) coefficient when the terrain hides the sun from its surface point (exact:
        kernels/terrain_ray.h, as for quadric pixels), else 1.  Run it after the terrain's
        shadow pass and before the quadrics' and the meshes' own shadows, which only darken."""
        if isinstance(sun, PointLight):
            raise TypeError("sun: MeshCaster.shadow is the sun's; a point light's terrain shadows (every pixel) "
                            "are oclshade.quadrics.caster.terrain_point_shadow")
        n = gbuffer.shape[0] * gbuffer.shape[1]
        kernel = self.runtime.kernel("mesh.cl", "mesh_terrain_shadow", self._defines)
        kernel.set_args(np.int32(n), gbuffer.buffers["position"], ids.buffer,
                        *terrain_shadow_args(camera, self.heightmap, self.heights, sun, k_dark, k_bright),
                        coefficient)
        launch_1d(self.runtime, kernel, n)

    def shadow_rays(self, camera: Camera, gbuffer: DeviceGBuffer, light: object,
                    out: cl.Buffer | None = None) -> cl.Buffer:
        """Any-hit rays through the BVHs from each hit pixel's surface point toward the light:
        int32 per pixel on the device, 1 where a triangle of a mesh with ``cast_shadows``
        hides it (alpha cut-outs honoured), 0 lit or empty (kernels/mesh.cl).  ``light``: a
        sun (:class:`oclshade.sun.Sun` or (azimuth, elevation)) or a point light (an object
        with a float64 world ``position``, as :class:`oclshade.meshes.lights.PointLight`)."""
        rt = self.runtime
        n = gbuffer.shape[0] * gbuffer.shape[1]
        out = rt.empty(4 * n, "mesh shadow rays") if out is None else out
        kernel = rt.kernel("mesh.cl", "mesh_shadow_rays", self._defines)
        box, info, tri, tvtx, _, _, vuv, texel = self._buffers
        mf = self._mf(camera)
        lights = rt.to_device(self.light_table(light), "mesh light table")
        kernel.set_args(np.int32(n), np.int32(len(self.meshes)), mf, self._mi_buffer, box, info, tri, tvtx, vuv,
                        texel, gbuffer.buffers["position"], *_rows(camera.rotation.T), lights, out)
        launch_1d(rt, kernel, n)
        return out

    def ray_shadow(self, camera: Camera, gbuffer: DeviceGBuffer, light: LightLike, coefficient: cl.Buffer,
                   k_dark: float = 0.0, k_bright: float = 0.0) -> None:
        """The meshes' shadows by :meth:`shadow_rays` into a shadow-coefficient buffer, in
        place: every hit pixel a mesh with ``cast_shadows`` hides from the light gets paper 000's
        eq. (1), k_dark + (k_bright - k_dark) max(sin elevation, 0) (a point light: k_dark, as
        :class:`oclshade.meshes.MeshShadows`); the others keep theirs.  For casters with alpha
        cut-outs, which the shadow volumes would shade as solid triangles.  ``light``: a sun
        or a :class:`oclshade.lights.PointLight`."""
        light = as_light(light)
        n = gbuffer.shape[0] * gbuffer.shape[1]
        hidden = self.shadow_rays(camera, gbuffer, light)
        elevation = 0.0 if isinstance(light, PointLight) else light.elevation
        kshadow = k_dark + (k_bright - k_dark) * max(math.sin(math.radians(elevation)), 0.0)
        kernel = self.runtime.kernel("mesh.cl", "mesh_shadow_apply", self._defines)
        kernel.set_args(np.int32(n), hidden, np.float32(kshadow), coefficient)
        launch_1d(self.runtime, kernel, n)

    def light_table(self, light: object) -> np.ndarray:
        """The light argument of mesh_shadow_rays, float32 (nm, 4): (sun vector, 0) or (point
        light position - mesh origin, 1) per mesh."""
        position = getattr(light, "position", None)
        if position is None:
            return np.tile(np.array([*as_sun(light).vector(), 0.0], np.float32), (len(self.meshes), 1))
        p = np.asarray(position, np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"a point light's position must be 3 finite numbers, got {position!r}")
        table = np.ones((len(self.meshes), 4))
        table[:, :3] = p - self.origins                             # float64 difference, rounded once
        return table.astype(np.float32)

    def shadow_mask(self, camera: Camera, gbuffer: DeviceGBuffer, light: object) -> np.ndarray:
        """:meth:`shadow_rays` on the host: bool (height, width), True where a mesh hides the light."""
        hidden = np.empty(gbuffer.shape, np.int32)
        cl.enqueue_copy(self.runtime.queue, hidden, self.shadow_rays(camera, gbuffer, light))
        self.runtime.queue.finish()
        return hidden > 0
