"""Cube maps generated from an object's centre (paper 002's cases 2 and 3).

>>> cube = generate_cube(scene, centre, 256, sun, settings)     # six 90-degree terrain renders

Six cameras at ``centre`` with a 90-degree field of view look along the cube-map frame's
axes (+X, -X, +Y, -Y, +Z, -Z of F, placed in the world by ``cube_frame(rotation)``); each
renders the scene (the terrain with its shadows and AO, and the environment map as the sky
when the scene has one) at ``size`` x ``size``.  The OpenGL face table's face images are
mirror images of a right-handed camera's view, so each render is flipped left-right:
pixel (row r, column c) of the camera looking along face f has exactly the direction of
texel (r, size - 1 - c) of face f (tests/test_generate.py checks it against the face
table).  The frames come back as 8-bit sRGB (compose's output) and are decoded to linear
light: a generated map is low dynamic range (values <= 1, 8-bit steps) and takes a trip
through the host (docs/reflections.md, "Generated cube maps").
"""
from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..envmap.cube import CubeMap, cube_frame
from ..envmap.files import srgb_to_linear
from ..frames import FrameSettings, TerrainScene
from ..sun import SunLike

#: per face of the cube-map frame F: the camera's forward and up directions
FACE_VIEWS = (((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, -1)),
              ((0, -1, 0), (0, 0, 1)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)))


def face_cameras(centre: object, size: int, rotation: float = 0.0, near: float = 1.0,
                 far: float = 1e6) -> list[Camera]:
    """The six face cameras (module doc), in face order +X, -X, +Y, -Y, +Z, -Z of F."""
    to_world = cube_frame(rotation).T
    c = np.asarray(centre, float)
    return [Camera(c, c + to_world @ np.array(fwd, float), size, size, up=to_world @ np.array(up, float),
                   fov=90.0, near=near, far=far) for fwd, up in FACE_VIEWS]


def generate_cube(scene: TerrainScene, centre: object, size: int, sun: SunLike,
                  settings: FrameSettings = FrameSettings(), rotation: float = 0.0, near: float = 1.0,
                  far: float = 1e6) -> CubeMap:
    """A cube map of what ``scene`` shows from ``centre`` (module doc)."""
    faces = np.empty((6, size, size, 3), np.float32)
    for f, camera in enumerate(face_cameras(centre, size, rotation, near, far)):
        image = scene.frame(camera, sun, settings).image
        faces[f] = srgb_to_linear(image[:, ::-1, :3].astype(np.float64) / 255.0)
    return CubeMap(faces)
