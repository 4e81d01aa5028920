"""Cube maps generated from an object's centre (paper 002's cases 2 and 3), on the device.

>>> faces = FaceScene(Heightfield(hm), environment=sky)             # frames in linear light
>>> cube = generate_cube(faces, centre, 256, sun, settings)        # a DeviceCubeMap

Six cameras at ``centre`` with a 90-degree field of view look along the cube-map frame's
axes (+X, -X, +Y, -Y, +Z, -Z of F, placed in the world by ``cube_frame(rotation)``); each
renders the scene (the terrain with its shadows and AO, and the environment map as the sky
when the scene has one) at ``size`` x ``size``.  The OpenGL face table's face images are
mirror images of a right-handed camera's view, so each render is flipped left-right:
pixel (row r, column c) of the camera looking along face f has exactly the direction of
texel (r, size - 1 - c) of face f (tests/test_generate.py checks it against the face
table).  A :class:`FaceScene` composes in linear light with its full range (compose.cl
-D OCLS_LINEAR, the sky added by the reflections' background pass into the same buffer),
and kernels/envmap.cl ``cube_face_store`` writes each frame straight into the cube map's
bordered device buffer: the map never leaves the device and keeps high dynamic range
(docs/reflections.md, "Generated cube maps").
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyopencl as cl

from ..camera import Camera
from ..compose import compose_linear
from ..envmap.cube import DeviceCubeMap, cube_frame
from ..envmap.reflect import Reflections
from ..frames import FrameSettings
from ..sun import SunLike
from .render import ObjectScene

#: per face of the cube-map frame F: the camera's forward and up directions
FACE_VIEWS = (((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, -1)),
              ((0, -1, 0), (0, 0, 1)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)))


class FaceScene(ObjectScene):
    """An :class:`~oclshade.scene.render.ObjectScene` whose frames stay on the device in linear
    light: ``frame(...).image`` is a ``cl.Buffer`` of float4 (r, g, b, 1) per pixel, row-major
    (compose_linear, plus the reflections and the environment's background added in place)."""

    compose_pass = staticmethod(compose_linear)

    def _add_reflections(self, refl: Reflections, image: cl.Buffer, gbuf, camera: Camera, ssaa: int) -> cl.Buffer:
        if refl.active:                           # into the linear frame, in place
            refl.accumulate(gbuf, self.ids, camera, ssaa, into=image)
        return image


def face_cameras(centre: object, size: int, rotation: float = 0.0, near: float = 1.0,
                 far: float = 1e6) -> list[Camera]:
    """The six face cameras (module doc), in face order +X, -X, +Y, -Y, +Z, -Z of F."""
    to_world = cube_frame(rotation).T
    c = np.asarray(centre, float)
    return [Camera(c, c + to_world @ np.array(fwd, float), size, size, up=to_world @ np.array(up, float),
                   fov=90.0, near=near, far=far) for fwd, up in FACE_VIEWS]


def generate_cube(scene: FaceScene, centre: object, size: int, sun: SunLike,
                  settings: FrameSettings = FrameSettings(), rotation: float = 0.0, near: float = 1.0,
                  far: float = 1e6) -> DeviceCubeMap:
    """A cube map on the device of what ``scene`` shows from ``centre`` (module doc); each
    face is rendered with ``settings`` at one sample per pixel."""
    if not isinstance(scene, FaceScene):
        raise TypeError(f"scene must be a FaceScene (frames in linear light on the device), got {type(scene).__name__}")
    rt = scene.runtime
    cube = DeviceCubeMap(rt, size, rt.empty(16 * 6 * (size + 2) ** 2, "generated cube map"))
    store = rt.kernel("envmap.cl", "cube_face_store")
    one = replace(settings, ssaa=1)
    for f, camera in enumerate(face_cameras(centre, size, rotation, near, far)):
        store.set_args(scene.frame(camera, sun, one).image, np.int32(size), np.int32(f), cube.buffer)
        cl.enqueue_nd_range_kernel(rt.queue, store, *rt.grid_2d(store, size, size))
    cube.fill_border()
    return cube
