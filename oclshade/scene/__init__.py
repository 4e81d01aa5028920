"""Scenes: a terrain with quadrics, triangle meshes and an environment map, from a TOML file
or from Python.

>>> desc = load_scene("scene.toml")                    # SceneDescription
>>> frame, scene, camera = render_scene(desc)          # frame.image: uint8 (H, W, 4)
>>> scene = ObjectScene(Heightfield(hm), [Quadric.sphere(c, 40, Material("mirror"))],
...                     Environment(CubeMap.from_latlong(sky)),   # the same objects from Python
...                     meshes=[load_mesh("bunny.obj").placed((500, -800, 240), 40.0)])
"""
from .description import (CameraSpec, EnvironmentSpec, RenderSpec, SceneDescription, SceneError, TerrainSpec,
                          load_scene)
from .render import Environment, ObjectScene, render_scene, scene_camera

__all__ = ["CameraSpec", "Environment", "EnvironmentSpec", "ObjectScene", "RenderSpec", "SceneDescription",
           "SceneError", "TerrainSpec", "load_scene", "render_scene", "scene_camera"]
