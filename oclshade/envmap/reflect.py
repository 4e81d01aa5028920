"""Environment reflections through a cube map (paper 002), around compose (kernels/reflect.cl).

>>> refl = Reflections(cube.to_device(rt), [q.material for q in quadrics], rotation=0.0)
>>> weighted = refl.weights(gbuffer, ids, camera)      # the G-buffer compose should read
>>> frame = compose(weighted, camera, ...)             # compose.cl unchanged
>>> frame = refl.apply(frame, gbuffer, ids, camera)    # + the reflections, 8-bit sRGB

Objects are grouped by their material's condition vector
(:attr:`oclshade.envmap.materials.Material.conditions`); each group is served by a program
specialised from kernels/reflect.cl with :func:`oclshade.specialize.specialize`, so a
feature no object uses is compiled nowhere.  ``uber=True`` builds every group from the full
vector instead (all features compiled in, the materials' parameters switching them at run
time: the same image; the benchmark's measure of what specialisation saves).  Twin:
:func:`oclshade.reference.envmap.reflect_frame`.
"""
from __future__ import annotations

import hashlib
import weakref
from typing import Sequence

import numpy as np
import pyopencl as cl

from ..camera import Camera
from ..quadrics.caster import ObjectIds
from ..runtime import Runtime, kernel_source
from ..specialize import specialize
from ..terrain import DeviceGBuffer
from .cube import DeviceCubeMap, cube_frame
from .materials import CONDITIONS, Material

BACKGROUND = frozenset({"BACKGROUND"})
UBER = frozenset(CONDITIONS)
_programs: "weakref.WeakKeyDictionary[Runtime, dict[str, cl.Program]]" = weakref.WeakKeyDictionary()


def reflect_program(runtime: Runtime, conditions: frozenset[str]) -> cl.Program:
    """kernels/reflect.cl specialised for a condition vector and built (cached per device and
    source digest; the build goes through the runtime's build path: its error messages,
    quiet compiler and pyopencl's disk cache)."""
    vector = " ".join(sorted(conditions))
    source = specialize(kernel_source("reflect.cl"), vector)
    key = hashlib.sha256(source.encode()).hexdigest()
    cache = _programs.setdefault(runtime, {})
    if key not in cache:
        cache[key] = runtime._build(f"reflect.cl [{vector}]", source, ("-cl-std=CL1.2",))
    return cache[key]


class Reflections:
    """The reflections of one environment map on objects with the given materials (object
    id k + 1 has ``materials[k]``).  ``rotation``: :func:`~oclshade.envmap.cube.cube_frame`;
    ``intensity`` scales the map's values; ``background``: empty samples show the map."""

    def __init__(self, cube: DeviceCubeMap, materials: Sequence[Material], rotation: float = 0.0,
                 intensity: float = 1.0, background: bool = True, uber: bool = False,
                 cube_of: Sequence[int] | None = None):
        """``cube_of``: per object, the index of its map in ``cube`` (:func:`stack_cubes`;
        default 0 for all); the background reads map 0."""
        if not isinstance(cube, DeviceCubeMap):
            raise TypeError(f"cube must be a DeviceCubeMap (CubeMap.to_device), got {type(cube).__name__}")
        cube_of = [0] * len(materials) if cube_of is None else list(cube_of)
        if len(cube_of) != len(materials) or not all(isinstance(k, int) and 0 <= k < cube.count for k in cube_of):
            raise ValueError(f"cube_of must give each of the {len(materials)} objects a map index in "
                             f"0..{cube.count - 1}, got {cube_of!r}")
        if not np.isfinite(intensity) or intensity < 0.0:
            raise ValueError(f"intensity must be a finite number >= 0, got {intensity!r}")
        self.cube, self.runtime = cube, cube.runtime
        self.materials = list(materials)
        self.world_to_cube = cube_frame(rotation)
        self.intensity = float(intensity)
        self.background = bool(background)
        self.uber = bool(uber)
        vectors = sorted({m.conditions for m in self.materials if m.conditions}, key=sorted)
        self.groups: list[frozenset[str]] = vectors
        table = np.zeros((max(len(self.materials), 1), 3, 4), np.float32)
        for k, m in enumerate(self.materials):
            group = vectors.index(m.conditions) if m.conditions else -1
            f0 = m.fresnel if m.kind == "glossy" else 1.0             # a mirror is F = 1 (uber builds)
            tint = m.colour if m.kind == "mirror" else (1.0, 1.0, 1.0)
            table[k] = [(*m.colour, f0), (m.cone, group, 0.0, 0.0), (*tint, cube_of[k])]
        self._table = self.runtime.to_device(table, "material table")
        self._kernels: dict[tuple[frozenset[str], str], cl.Kernel] = {}

    @property
    def active(self) -> bool:
        """Some object reflects, or the background shows the map: the passes have work."""
        return bool(self.groups) or self.background

    def _kernel(self, conditions: frozenset[str], name: str) -> cl.Kernel:
        vector = UBER if self.uber and conditions != BACKGROUND else conditions
        key = (vector, name)
        if key not in self._kernels:
            self._kernels[key] = cl.Kernel(reflect_program(self.runtime, vector), name)
        return self._kernels[key]

    @staticmethod
    def _cam(camera: Camera) -> np.ndarray:
        sx, sy = camera.scale
        return np.array([sx, sy, 1.0 if camera.projection == "orthographic" else 0.0, 0.0], np.float32)

    def weights(self, gbuffer: DeviceGBuffer, ids: ObjectIds, camera: Camera) -> DeviceGBuffer:
        """A G-buffer sharing ``gbuffer``'s fields but its albedo, weighted by what each
        reflective sample keeps of its diffuse colour (0 on mirrors, 1 - F on glossy ones);
        ``gbuffer`` itself is unchanged.  Without reflective objects, ``gbuffer``."""
        if not self.groups:
            return gbuffer
        rt = self.runtime
        ns = gbuffer.shape[0] * gbuffer.shape[1]
        albedo = rt.empty(16 * ns, "weighted albedo")
        cl.enqueue_copy(rt.queue, albedo, gbuffer.buffers["albedo"])
        for group, conditions in enumerate(self.groups):
            k = self._kernel(conditions, "reflect_weights")
            k.set_args(np.int32(ns), gbuffer.buffers["position"], gbuffer.buffers["normal"],
                       gbuffer.buffers["albedo"], ids.buffer, self._table, np.int32(group), self._cam(camera), albedo)
            self._launch(k, ns)
        return DeviceGBuffer(rt, gbuffer.shape, {**gbuffer.buffers, "albedo": albedo})

    def accumulate(self, gbuffer: DeviceGBuffer, ids: ObjectIds, camera: Camera, ssaa: int = 1,
                   into: cl.Buffer | None = None) -> cl.Buffer:
        """The reflections per output pixel, linear rgb (float4, a = 0) on the device:
        ``camera`` is the G-buffer's (its samples), ``ssaa`` samples per pixel along each axis.
        ``into``: add them to this buffer of float4 per output pixel instead (a linear frame,
        :func:`oclshade.compose.compose_linear`), which is returned."""
        rt = self.runtime
        hs, ws = gbuffer.shape
        if hs % ssaa or ws % ssaa:
            raise ValueError(f"ssaa {ssaa} must divide the G-buffer's size {hs}x{ws}")
        h, w = hs // ssaa, ws // ssaa
        if into is not None and into.size != 16 * h * w:
            raise ValueError(f"into must hold {h}x{w} float4 pixels ({16 * h * w} bytes), got {into.size} bytes")
        acc = into
        if acc is None:
            acc = rt.empty(16 * h * w, "reflections")
            cl.enqueue_fill_buffer(rt.queue, acc, np.float32(0.0), 0, 16 * h * w)
        v2w = [np.array([*row, 0.0], np.float32) for row in camera.rotation.T]
        w2c = [np.array([*row, 0.0], np.float32) for row in self.world_to_cube]
        passes = [(g, c) for g, c in enumerate(self.groups)] + ([(-1, BACKGROUND)] if self.background else [])
        for group, conditions in passes:
            k = self._kernel(conditions, "reflect_apply")
            k.set_args(np.int32(w), np.int32(h), np.int32(ssaa), gbuffer.buffers["position"],
                       gbuffer.buffers["normal"], ids.buffer, self._table, np.int32(group), self._cam(camera),
                       *v2w, *w2c, self.cube.buffer, np.int32(self.cube.size), np.float32(self.intensity), acc)
            self._launch(k, h * w)
        return acc

    def apply(self, frame: np.ndarray, gbuffer: DeviceGBuffer, ids: ObjectIds, camera: Camera,
              ssaa: int = 1) -> np.ndarray:
        """compose's uint8 frame (h, w, 4) plus the reflections, 8-bit sRGB (a new array)."""
        if not self.active:
            return frame
        rt = self.runtime
        frame = np.ascontiguousarray(frame, np.uint8)
        acc = self.accumulate(gbuffer, ids, camera, ssaa)
        n = frame.shape[0] * frame.shape[1]
        src = rt.to_device(frame, "composed frame")
        out = rt.empty(4 * n, "frame with reflections")
        k = self._kernel(BACKGROUND, "reflect_finish")
        k.set_args(np.int32(n), src, acc, out)
        self._launch(k, n)
        result = np.empty_like(frame)
        cl.enqueue_copy(rt.queue, result, out)
        rt.queue.finish()
        return result

    def _launch(self, kernel: cl.Kernel, n: int) -> None:
        local = self.runtime.local_size(kernel, 64)
        cl.enqueue_nd_range_kernel(self.runtime.queue, kernel, (-(-n // local) * local,), (local,))
