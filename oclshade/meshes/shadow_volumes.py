"""Mesh shadows by shadow volumes (paper 003), counted per pixel on the device
(kernels/shadow_volume.cl; docs/shadow_volumes.md).

>>> shadows = MeshShadows([mesh], device)               # nothing built or compiled yet
>>> mask = shadows.mask(camera, gbuffer, sun)           # uint8 per pixel on the device, 1 = hidden
>>> shadows.shadow(camera, gbuffer, ids, sun, coefficient)   # like QuadricCaster.shadow

Volumes (host, float64 world, cached while the light and the casters stand still): the
casters and their silhouette (:mod:`oclshade.meshes.silhouette`), the silhouette edges
extruded away from the light to an automatic finite length (past every receiver: the
meshes, the camera and the frame's visible points, or the ``bounds`` given), closed by the
casters (light caps) and their copies at the far end (dark caps).  ``per_face=True`` builds
the classic all-face volumes instead (one prism per caster face; the benchmark's baseline).

Per frame: the volume vertices go to camera-relative float32 (view space, from float64 on the
host: paper 003's "space distances" remedy), the eye's winding number is counted exactly in
float64 (the exact start count that replaces the near caps), faces are binned into screen
tiles and each pixel counts the signed crossings of its view segment.  The mask is reused
while camera, light, volumes and the G-buffer (``gbuffer_key``) are unchanged; ``ran`` names
what ran in the last call and ``counts`` totals them.

The casters must be opaque in the G-buffer (their faces beyond the near plane are never
counted: no view segment crosses them before its end).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pyopencl as cl

from ..camera import Camera
from ..runtime import Runtime, get_runtime
from ..terrain import DeviceGBuffer
from .lights import Light, LightLike, PointLight, as_light, light_key, towards_light
from .mesh import TriangleMesh
from .silhouette import caster_faces, is_closed, silhouette_edges

#: screen tile side in pixels (faces are binned per tile)
TILE = 16
#: most tile-list entries before the tiles are made larger
MAX_ENTRIES = 1 << 25
KINDS = {"side": 0, "cap": 1}


@dataclass(frozen=True)
class Volumes:
    """The shadow volumes of every caster for one light, float64 world coordinates.

    ``vertices`` (2n, 3): the casters' vertices, then each moved ``extrusion`` metres away
    from the light; ``faces`` int32 (F, 4): vertex indices wound outwards and the kind
    (:data:`KINDS`); ``casters``: the number of caster faces; ``silhouette``: of edges."""

    vertices: np.ndarray
    faces: np.ndarray
    extrusion: float
    casters: int
    silhouette: int

    @property
    def triangles(self) -> np.ndarray:
        """(F, 3, 3) float64 corner positions of every volume face."""
        return self.vertices[self.faces[:, :3]]


def extrusion_directions(light: Light, points: np.ndarray) -> np.ndarray:
    """Unit float64 (n, 3) directions away from the light at ``points``."""
    away = -towards_light(light, points)
    return away / np.linalg.norm(away, axis=-1, keepdims=True)


def extrusion_length(light: Light, points: np.ndarray, box: tuple[np.ndarray, np.ndarray]) -> float:
    """A length that takes every extruded point past the receivers' ``box`` (lo, hi corners):
    along the sun's direction beyond the box's farthest corner, or (a point light) farther from
    the light than every corner, with 1 % and 1e-3 of the box's diagonal to spare."""
    lo, hi = (np.asarray(c, np.float64) for c in box)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    spare = 1e-3 * float(np.linalg.norm(hi - lo)) + 1e-6 * float(np.abs(corners).max())
    if isinstance(light, PointLight):
        need = float(np.linalg.norm(corners - light.position, axis=1).max())
    else:
        away = -np.array(light.vector())
        need = float((corners @ away).max() - (np.asarray(points) @ away).min())
    return 1.01 * max(need, 0.0) + spare + 1e-6


def build_volumes(meshes: Sequence[TriangleMesh], light: Light, extrusion: float, per_face: bool = False,
                  closed: Sequence[bool] | None = None) -> Volumes:
    """The volumes of ``meshes`` for ``light`` (module doc); ``closed``: :func:`is_closed`
    of each mesh when already known."""
    faces, base = [], 0
    vertices = []
    for k, mesh in enumerate(meshes):
        f = caster_faces(mesh, light, None if closed is None else closed[k])
        faces.append(f + base)
        vertices.append(mesh.vertices)
        base += len(mesh.vertices)
    casters = np.concatenate(faces) if faces else np.zeros((0, 3), np.int32)
    if per_face:
        edges = np.concatenate([casters[:, [0, 1]], casters[:, [1, 2]], casters[:, [2, 0]]])
    else:
        edges = silhouette_edges(casters)
    used, index = np.unique(casters, return_inverse=True)
    casters = index.reshape(-1, 3).astype(np.int32)
    if len(edges):
        edges = np.searchsorted(used, edges).astype(np.int32)
    n = len(used)
    top = np.concatenate(vertices)[used] if n else np.zeros((0, 3))
    bottom = top + extrusion * extrusion_directions(light, top) if n else top
    i, j = edges[:, 0], edges[:, 1]
    sides = np.concatenate([np.stack([j, i, i + n], 1), np.stack([j, i + n, j + n], 1)])
    caps = np.concatenate([casters, casters[:, [0, 2, 1]] + n])
    table = np.concatenate([np.column_stack([sides, np.full(len(sides), KINDS["side"])]),
                            np.column_stack([caps, np.full(len(caps), KINDS["cap"])])]).astype(np.int32)
    return Volumes(np.concatenate([top, bottom]), table, float(extrusion), len(casters), len(edges))


def winding_number(triangles: np.ndarray, point: np.ndarray) -> int:
    """The winding number of a closed outward-wound triangle surface ((F, 3, 3) float64) about
    ``point``: the sum of the faces' signed solid angles / 4 pi (Van Oosterom and Strackee),
    rounded.  The number of volumes holding the point."""
    if len(triangles) == 0:
        return 0
    a, b, c = (triangles[:, k] - point for k in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
    num = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", a, c) * lb \
        + np.einsum("ij,ij->i", b, c) * la
    return int(round(float(np.sum(2.0 * np.arctan2(num, den))) / (4.0 * math.pi)))


def visible_box(camera: Camera, max_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """A world box holding the camera and every point it sees up to depth ``max_depth``: the
    box of the view frustum's corners cut at that depth (and at the eye, or the view plane)."""
    sx, sy = camera.scale
    corners = np.array([[x, y] for x in (-sx, sx) for y in (-sy, sy)])
    if camera.projection == "perspective":
        view = np.vstack([np.zeros(3), np.column_stack([max_depth * corners, np.full(4, -max_depth)])])
    else:
        view = np.vstack([np.column_stack([corners, np.zeros(4)]),
                          np.column_stack([corners, np.full(4, -max_depth)])])
    world = view @ camera.rotation + camera.position
    return world.min(axis=0), world.max(axis=0)


class MeshShadows:
    """Shadow volumes of meshes (those with ``cast_shadows``) on one device; see the module doc.

    ``bounds``: the receivers' world box (lo, hi) when known (the scene's box); None: the
    frame's visible points, per frame.  The meshes and the camera are always added (a view
    segment must not meet a dark cap: they lie beyond the box).  ``per_face``: classic
    all-face volumes (no silhouette)."""

    def __init__(self, meshes: Sequence[TriangleMesh], device: str | int | Runtime | None = None,
                 bounds: tuple[Sequence[float], Sequence[float]] | None = None, per_face: bool = False):
        meshes = tuple(meshes)
        if not meshes or not all(isinstance(m, TriangleMesh) for m in meshes):
            raise ValueError("meshes must be one or more oclshade.meshes.TriangleMesh objects")
        if bounds is not None:
            lo, hi = (np.asarray(c, np.float64).reshape(-1) for c in bounds)
            if lo.shape != (3,) or hi.shape != (3,) or not (np.all(np.isfinite(lo)) and np.all(lo <= hi)):
                raise ValueError(f"bounds must be (lo, hi): two corners of 3 finite numbers, lo <= hi; got {bounds!r}")
            bounds = (lo, hi)
        self.meshes = meshes
        self.bounds = bounds
        self.per_face = per_face
        self._device = device
        self._runtime: Runtime | None = None
        self._closed: list[bool] | None = None
        self._volumes: tuple[tuple, Volumes, cl.Buffer] | None = None
        self._mask: tuple[tuple, cl.Buffer] | None = None
        self.ran: tuple[str, ...] = ()
        self.counts = {"volumes": 0, "mask": 0}

    @property
    def runtime(self) -> Runtime:
        if self._runtime is None:
            self._runtime = get_runtime(self._device)
        return self._runtime

    # --- volumes (light and casters) ------------------------------------------------------
    def volumes(self, light: LightLike, box: tuple[np.ndarray, np.ndarray] | None = None) -> Volumes:
        """The cached volumes for ``light``, rebuilt when the light changed or when they fall
        short of ``box`` (then extruded twice as far as needed, so a moving camera rarely
        rebuilds them)."""
        light = as_light(light)
        return self._volumes_on_device(light, box)[0]

    def _volumes_on_device(self, light: Light, box: tuple[np.ndarray, np.ndarray] | None
                           ) -> tuple[Volumes, cl.Buffer]:
        if self._closed is None:
            self._closed = [is_closed(m.faces) for m in self.meshes]
        lo = np.min([m.bounds[0] for m in self.meshes], axis=0)
        hi = np.max([m.bounds[1] for m in self.meshes], axis=0)
        if box is not None:
            lo, hi = np.minimum(lo, box[0]), np.maximum(hi, box[1])
        if self.bounds is not None:
            lo, hi = np.minimum(lo, self.bounds[0]), np.maximum(hi, self.bounds[1])
        points = np.concatenate([m.vertices for m in self.meshes])
        need = extrusion_length(light, points, (lo, hi))
        key = light_key(light)
        if self._volumes is not None and self._volumes[0] == key and self._volumes[1].extrusion >= need:
            return self._volumes[1], self._volumes[2]
        vol = build_volumes(self.meshes, light, 2.0 * need, self.per_face, self._closed)
        if isinstance(light, PointLight):      # a dark cap's plane may pass nearer the light than its
            for _ in range(10):                # corners: longer, at most 2^10 times (docs/shadow_volumes.md)
                if not vol.casters or _dark_cap_reach(vol, light) >= need:
                    break
                vol = build_volumes(self.meshes, light, 2.0 * vol.extrusion, self.per_face, self._closed)
        faces = self.runtime.to_device(np.ascontiguousarray(vol.faces if len(vol.faces) else
                                                            np.zeros((1, 4), np.int32)), "shadow volume faces")
        self._volumes = (key, vol, faces)
        self.counts["volumes"] += 1
        self.ran += ("volumes",)
        return vol, faces

    # --- per frame --------------------------------------------------------------------------
    def mask(self, camera: Camera, gbuffer: DeviceGBuffer, light: LightLike, gbuffer_key: str | None = None
             ) -> cl.Buffer:
        """The per-pixel shadow mask on the device (uint8, 1 = the light hidden by a caster,
        0 lit or empty pixel).  ``gbuffer_key``: a digest naming the G-buffer's content (as
        the frame passes key it); with it, the mask of the last call is reused while camera,
        light, volumes and key are unchanged."""
        light = as_light(light)
        self.ran = ()
        if gbuffer.shape != (camera.height, camera.width):
            raise ValueError(f"the G-buffer is {gbuffer.shape} pixels, the camera {(camera.height, camera.width)}")
        rt = self.runtime
        max_depth, vol, faces = self._frame_volumes(camera, gbuffer, light)
        key = (_camera_key(camera), light_key(light), id(vol), gbuffer_key)
        if gbuffer_key is not None and self._mask is not None and self._mask[0] == key:
            return self._mask[1]
        n = camera.width * camera.height
        out = self._mask[1] if self._mask is not None and self._mask[1].size == n else rt.empty(n, "shadow mask")
        self._count(camera, gbuffer, vol, faces, max_depth, out)
        self._mask = (key, out)
        self.counts["mask"] += 1
        self.ran += ("mask",)
        return out

    def frame_tables(self, camera: Camera, gbuffer: DeviceGBuffer, light: LightLike) -> FrameTables:
        """The per-frame tables :meth:`mask` counts with (for the C host: :func:`write_frame_tables`)."""
        max_depth, vol, _ = self._frame_volumes(camera, gbuffer, as_light(light))
        return frame_tables(camera, vol, max_depth)

    def _frame_volumes(self, camera: Camera, gbuffer: DeviceGBuffer, light: Light
                       ) -> tuple[float, Volumes, cl.Buffer]:
        """The frame's largest hit depth and the volumes that reach past its visible points."""
        rt = self.runtime
        depth = np.empty(gbuffer.shape, np.float32)
        cl.enqueue_copy(rt.queue, depth, gbuffer.buffers["depth"])
        rt.queue.finish()
        finite = depth[np.isfinite(depth)]
        max_depth = float(finite.max()) if finite.size else 0.0
        box = visible_box(camera, max_depth) if self.bounds is None else (camera.position, camera.position)
        vol, faces = self._volumes_on_device(light, box)
        return max_depth, vol, faces

    def shadow(self, camera: Camera, gbuffer: DeviceGBuffer, ids: object, sun: LightLike, coefficient: cl.Buffer,
               k_dark: float = 0.0, k_bright: float = 0.0, gbuffer_key: str | None = None) -> None:
        """Mesh shadows into a shadow-coefficient buffer (one float per pixel, 1 = lit) in
        place, as :meth:`QuadricCaster.shadow <oclshade.quadrics.caster.QuadricCaster.shadow>`
        does: every hit pixel the volumes hold gets paper 000's eq. (1), k_dark + (k_bright -
        k_dark) max(sin elevation, 0) (a point light: k_dark); the others keep theirs.  ``ids``
        (the object ids) are not needed: every hit pixel, mesh or terrain, is a receiver."""
        light = as_light(sun)
        mask = self.mask(camera, gbuffer, light, gbuffer_key)
        elevation = 0.0 if isinstance(light, PointLight) else light.elevation
        kshadow = k_dark + (k_bright - k_dark) * max(math.sin(math.radians(elevation)), 0.0)
        n = camera.width * camera.height
        kernel = self.runtime.kernel("shadow_volume.cl", "sv_apply")
        kernel.set_args(np.int32(n), mask, np.float32(kshadow), coefficient)
        local = self.runtime.local_size(kernel, 64)
        cl.enqueue_nd_range_kernel(self.runtime.queue, kernel, (-(-n // local) * local,), (local,))

    def mask_to_host(self, camera: Camera, gbuffer: DeviceGBuffer, light: LightLike,
                     gbuffer_key: str | None = None) -> np.ndarray:
        """:meth:`mask` copied to the host: bool (height, width)."""
        out = np.empty((camera.height, camera.width), np.uint8)
        cl.enqueue_copy(self.runtime.queue, out, self.mask(camera, gbuffer, light, gbuffer_key))
        self.runtime.queue.finish()
        return out.astype(bool)

    def _count(self, camera: Camera, gbuffer: DeviceGBuffer, vol: Volumes, faces: cl.Buffer, max_depth: float,
               out: cl.Buffer) -> None:
        rt = self.runtime
        w, h = camera.width, camera.height
        ortho = camera.projection == "orthographic"
        frame = frame_tables(camera, vol, max_depth)
        verts, w0, zs, cam = frame.vertices, frame.start_count, frame.start_height, frame.cam
        defines = {"OCLS_ORTHO": ortho}
        vbuf = rt.to_device(verts, "shadow volume vertices")
        ntri = len(vol.faces)
        tile = TILE
        while True:
            tw, th = -(-w // tile), -(-h // tile)
            counts = np.zeros(tw * th, np.int32)
            cbuf = rt.to_device(counts, "tile counts")
            offsets = np.zeros(tw * th + 1, np.int32)
            obuf = rt.to_device(offsets, "tile offsets")
            if ntri:
                self._bin(defines, ntri, faces, vbuf, cam, w, h, tile, tw, th, 0, cbuf, obuf, obuf)
                cl.enqueue_copy(rt.queue, counts, cbuf)
                rt.queue.finish()
            total = int(counts.astype(np.int64).sum())
            if total <= MAX_ENTRIES or tile >= max(w, h):
                break
            tile *= 2
        offsets[1:] = np.cumsum(counts)
        obuf = rt.to_device(offsets, "tile offsets")
        lbuf = rt.empty(4 * max(total, 1), "tile face lists")
        if total:
            cl.enqueue_fill_buffer(rt.queue, cbuf, np.int32(0), 0, 4 * tw * th)
            self._bin(defines, ntri, faces, vbuf, cam, w, h, tile, tw, th, 1, cbuf, obuf, lbuf)
        planes = vbuf
        if not ortho and ntri:
            planes = rt.empty(64 * ntri, "shadow volume planes")
            prepare = rt.kernel("shadow_volume.cl", "sv_prepare", defines)
            prepare.set_args(np.int32(ntri), faces, vbuf, planes)
            local = rt.local_size(prepare, 64)
            cl.enqueue_nd_range_kernel(rt.queue, prepare, (-(-ntri // local) * local,), (local,))
        kernel = rt.kernel("shadow_volume.cl", "sv_count", defines)
        kernel.set_args(vbuf, faces, planes, obuf, lbuf, gbuffer.buffers["position"], cam, np.float32(zs),
                        np.int32(w0), np.int32(w), np.int32(h), np.int32(tile), np.int32(tw), out)
        cl.enqueue_nd_range_kernel(rt.queue, kernel, *rt.grid_2d(kernel, w, h))
        rt.queue.finish()           # the uploads above are released on return

    def _bin(self, defines: dict, ntri: int, faces: cl.Buffer, vbuf: cl.Buffer, cam: np.ndarray, w: int, h: int,
             tile: int, tw: int, th: int, fill: int, cbuf: cl.Buffer, obuf: cl.Buffer, lbuf: cl.Buffer) -> None:
        rt = self.runtime
        kernel = rt.kernel("shadow_volume.cl", "sv_bin", defines)
        kernel.set_args(np.int32(ntri), faces, vbuf, cam, np.int32(w), np.int32(h), np.int32(tile), np.int32(tw),
                        np.int32(th), np.int32(fill), cbuf, obuf, lbuf)
        local = rt.local_size(kernel, 64)
        cl.enqueue_nd_range_kernel(rt.queue, kernel, (-(-ntri // local) * local,), (local,))


#: magic of the per-frame tables file (:func:`write_frame_tables`; host/README.md)
FRAME_MAGIC = b"OCLSSVF1"


@dataclass(frozen=True)
class FrameTables:
    """What kernels/shadow_volume.cl reads per frame besides the G-buffer (the C host reads
    them from :func:`write_frame_tables`'s file): ``vertices`` float32 (max(V, 1), 4) view
    space, w 0; ``faces`` int32 (max(F, 1), 4) (:attr:`Volumes.faces`; F = ``ntri``);
    ``start_count`` the eye's winding number (pinhole); ``start_height`` zs (orthographic);
    ``cam`` float32 (sx, sy, near, max_depth)."""

    vertices: np.ndarray
    faces: np.ndarray
    ntri: int
    start_count: int
    start_height: float
    cam: np.ndarray


def frame_tables(camera: Camera, vol: Volumes, max_depth: float) -> FrameTables:
    """The per-frame tables of ``vol`` seen by ``camera`` whose hit pixels lie no deeper than
    ``max_depth`` (the module doc's "per frame")."""
    ortho = camera.projection == "orthographic"
    view = camera.view
    verts = np.zeros((max(len(vol.vertices), 1), 4), np.float32)
    verts[:len(vol.vertices), :3] = vol.vertices @ view[:3, :3].T + view[:3, 3]
    inside = len(vol.vertices) and np.all(camera.position >= vol.vertices.min(axis=0)) and \
        np.all(camera.position <= vol.vertices.max(axis=0))
    w0 = winding_number(vol.triangles, camera.position) if inside and not ortho else 0
    zs = float(verts[:, 2].max()) if len(vol.vertices) else 0.0
    zs = float(np.float32(max(zs, 0.0) * 1.001 + 1.0))
    sx, sy = camera.scale
    cam = np.array([sx, sy, camera.near, max_depth], np.float32)
    faces = np.ascontiguousarray(vol.faces if len(vol.faces) else np.zeros((1, 4), np.int32), np.int32)
    return FrameTables(verts, faces, len(vol.faces), int(w0), zs, cam)


def write_frame_tables(frame: FrameTables, path: str | Path) -> None:
    """``frame`` as a little-endian file: FRAME_MAGIC, int32 (V, F, start_count, 0) (V, F the
    rows of vertices and faces, >= 1), float32 (start_height, max_depth), float32 (V, 4)
    vertices, int32 (F, 4) faces (host/README.md, oclshade_shadow_volume_frame_read)."""
    head = np.array([len(frame.vertices), len(frame.faces), frame.start_count, 0], "<i4")
    Path(path).write_bytes(FRAME_MAGIC + head.tobytes() + np.array([frame.start_height, frame.cam[3]], "<f4").tobytes()
                           + frame.vertices.astype("<f4").tobytes() + frame.faces.astype("<i4").tobytes())


def _dark_cap_reach(vol: Volumes, light: PointLight) -> float:
    """The smallest distance from the light to a dark cap's plane."""
    caps = vol.faces[vol.faces[:, 3] == KINDS["cap"]]
    dark = vol.vertices[caps[len(caps) // 2:, :3]]
    nrm = np.cross(dark[:, 1] - dark[:, 0], dark[:, 2] - dark[:, 0])
    length = np.linalg.norm(nrm, axis=1)
    keep = length > 0
    return float(np.min(np.abs(np.einsum("ij,ij->i", dark[keep, 0] - light.position, nrm[keep])) / length[keep],
                        initial=np.inf))


def _camera_key(camera: Camera) -> tuple:
    return (camera.position.tobytes(), camera.look_at.tobytes(), camera.up.tobytes(), camera.width, camera.height,
            camera.fov, camera.near, camera.far, camera.projection, camera.ortho_height)
