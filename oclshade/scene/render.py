"""Frames of a terrain with quadrics, triangle meshes and an environment map: :class:`ObjectScene`.

>>> scene = ObjectScene(Heightfield(hm), quadrics, environment=Environment(cube, rotation=0.0),
...                     meshes=[load_mesh("bunny.obj").placed((500, -800, 240), 40.0)])
>>> frame = scene.frame(camera, sun, FrameSettings())     # TerrainScene's passes, plus:

=========  =================================================================================
pass       what the objects add (kernels/quadric.cl, mesh.cl, reflect.cl)
=========  =================================================================================
generate   with ``Environment(generate=...)``: a cube map from each reflective object's
           centre (:mod:`oclshade.scene.generate`: rendered in linear light into device
           cube maps), on the first frame or every N frames (the maps show the terrain and
           the sky, not the meshes)
gbuffer    the quadrics, then the meshes, cast and depth-merged into the terrain's G-buffer
           (object ids kept: quadric k + 1, mesh -(k + 1))
normals    the objects' own normals put into the smooth shading normals
shadows    the terrain's exact shadows on mesh pixels (MeshCaster.shadow), then quadric
           shadows on everything and terrain and quadric shadows on the quadrics, then the
           meshes with cast_shadows on every pixel: by any-hit BVH rays (MeshCaster.ray_shadow,
           the default) or with ``mesh_shadows="volumes"`` by shadow volumes (MeshShadows;
           casters with alpha cut-outs still by rays).  A point light
           (:class:`oclshade.lights.PointLight`): the terrain's on every pixel along the segment
           to the light (quadrics.caster.terrain_point_shadow: exact, in place of the
           screen-space pass), the quadrics' (QuadricCaster.point_shadow), then the meshes' as
           for the sun (docs/meshes.md "Point lights")
compose    compose reads the albedo weighted for reflection; the reflections are added after
=========  =================================================================================

:class:`ObjectScene` is a :class:`~oclshade.frames.TerrainScene`: the same caching (the
objects and the environment are fixed per scene, like the heights), the same settings.
With an environment shown as the background, ``lighting.background`` should be black
(:func:`render_scene` does that).  :func:`render_scene` renders a
:class:`~oclshade.scene.description.SceneDescription` (a scene file).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
import pyopencl as cl

from ..camera import Camera, frame_heightmap, map_bounds
from ..compose import Lighting, compose
from ..envmap.cube import CubeMap, stack_cubes
from ..envmap.files import load_cube
from ..envmap.reflect import Reflections
from ..frames import AOSettings, Frame, FrameSettings, TerrainScene
from ..heightmap import Heightmap
from ..io import read_dem
from ..lights import LightLike, PointLight
from ..meshes import MeshCaster, MeshShadows, TriangleMesh
from ..quadrics import ObjectIds, Quadric, QuadricCaster
from ..quadrics.caster import object_normals, terrain_point_shadow
from ..runtime import Runtime
from ..sun import Sun, SunLike
from ..terrain import Heightfield
from .description import SceneDescription, SceneError

#: how meshes with cast_shadows shadow the frame (ObjectScene mesh_shadows)
MESH_SHADOW_METHODS = ("rays", "volumes")


@dataclass(frozen=True)
class Environment:
    """An environment for reflections: a map (``cube``, the sky and the background; see
    :class:`oclshade.envmap.reflect.Reflections` for the other arguments) and/or maps
    generated from each reflective object's centre (``generate``: ``"once"``, on the first
    frame, or every N frames; :mod:`oclshade.scene.generate`) of ``size`` x ``size`` faces
    (the map's face size when there is a map)."""

    cube: CubeMap | None = None
    rotation: float = 0.0
    intensity: float = 1.0
    background: bool = True
    generate: str | int | None = None
    size: int = 128

    def __post_init__(self) -> None:
        g = self.generate
        if g is not None and g != "once" and (not isinstance(g, int) or isinstance(g, bool) or g < 1):
            raise ValueError(f"generate must be 'once' or a number of frames >= 1, got {g!r}")
        if self.cube is None and g is None:
            raise ValueError("an environment needs a cube map, generate = 'once' | N, or both")
        if not isinstance(self.size, int) or not 1 <= self.size <= 4096:
            raise ValueError(f"size (generated faces) must be an integer in 1..4096, got {self.size!r}")


class ObjectScene(TerrainScene):
    """A heightfield with quadrics and triangle meshes standing on it, and optionally an
    environment the quadrics reflect; lit by the sun or a point light."""

    POINT_LIGHTS = True

    def __init__(self, heightfield: Heightfield, quadrics: Sequence[Quadric] = (),
                 environment: Environment | None = None, device: str | int | Runtime | None = None,
                 caching: bool = True, uber: bool = False, meshes: Sequence[TriangleMesh] = (),
                 mesh_shadows: str = "rays"):
        """``uber``: reflection programs with every feature compiled in (benchmarks only);
        ``meshes``: :class:`oclshade.meshes.TriangleMesh` objects in world coordinates;
        ``mesh_shadows``: how meshes with cast_shadows shadow the frame, ``"rays"`` (default:
        any-hit rays through their BVH, :meth:`MeshCaster.ray_shadow`) or ``"volumes"``
        (paper 003's shadow volumes, :class:`MeshShadows`; casters with alpha cut-outs still go
        by rays).  Both are exact against the float64 twin (ties apart); on the CPUs measured
        the rays are far faster (docs/shadow_volumes.md "Which one renders")."""
        if mesh_shadows not in MESH_SHADOW_METHODS:
            raise ValueError(f"mesh_shadows must be one of {', '.join(MESH_SHADOW_METHODS)}, got {mesh_shadows!r}")
        super().__init__(heightfield, device, caching)
        self.quadrics, self.meshes = list(quadrics), list(meshes)
        self.environment, self.uber = environment, uber
        self.caster = (QuadricCaster(self.quadrics, heightfield.heightmap, self.runtime,
                                     heights=self.renderer.pyramid.heights) if self.quadrics else None)
        self.mesh_caster = (MeshCaster(self.meshes, heightfield.heightmap, self.runtime,
                                       heights=self.renderer.pyramid.heights) if self.meshes else None)
        volumes = mesh_shadows == "volumes"
        solid = [m for m in self.meshes if m.cast_shadows and volumes and not m.surface.cuts_out]
        cut = [m for m in self.meshes if m.cast_shadows and not (volumes and not m.surface.cuts_out)]
        self.mesh_shadows = MeshShadows(solid, self.runtime) if solid else None
        self.ray_shadows = (MeshCaster(cut, None, self.runtime) if cut else None)  # rays honour cut-outs
        self._mesh_objects = None               # the meshes' own G-buffer, reused frame to frame
        self.reflections: Reflections | None = None
        self._file_map = None if environment is None or environment.cube is None else \
            environment.cube.to_device(self.runtime)
        if self._file_map is not None:
            self._reflect_with(self._file_map, None)
        self.ids: ObjectIds | None = None
        self._objects = None                    # the quadrics' own G-buffer, reused frame to frame
        self._face_scene: ObjectScene | None = None
        self.frames_rendered = 0
        self.generations = 0                    # how many times the objects' maps were generated

    def _reflect_with(self, cubes, cube_of: list[int] | None, intensity: float | None = None) -> None:
        """Reflections of ``cubes`` read at ``intensity`` (default: the environment's)."""
        env = self.environment
        intensity = env.intensity if intensity is None else intensity
        self.reflections = Reflections(cubes, [q.material for q in self.quadrics], env.rotation, intensity,
                                       env.background and self._file_map is not None, self.uber, cube_of)

    def frame(self, camera: Camera, sun: LightLike, settings: FrameSettings = FrameSettings()) -> Frame:
        """As :meth:`TerrainScene.frame` (``sun``: a sun or a :class:`oclshade.lights.PointLight`,
        not on a curved map); with ``environment.generate``, the objects' maps are
        rendered first on the first frame and, for N, every N-th frame after it (the compose
        pass then runs again; ``ran`` starts with ``"generate"`` and ``ms`` has its time)."""
        env, generated_ms = self.environment, None
        if env is not None and env.generate is not None and any(q.material.conditions for q in self.quadrics):
            n = self.frames_rendered
            if n == 0 or (env.generate != "once" and n % env.generate == 0):
                t0 = time.perf_counter()
                self._generate(sun, settings)
                generated_ms = 1e3 * (time.perf_counter() - t0)
                self._keys.pop("compose", None)
        self.frames_rendered += 1
        frame = super().frame(camera, sun, settings)
        if generated_ms is not None:
            frame.ran, frame.ms = ("generate",) + frame.ran, {"generate": generated_ms, **frame.ms}
        return frame

    def _generate(self, sun: SunLike, settings: FrameSettings) -> None:
        """A cube map from the centre of every reflective object (the terrain and the sky only)."""
        from .generate import FaceScene, generate_cube      # generate.py builds on this module
        env = self.environment
        if self._face_scene is None:
            sky = None if env.cube is None else Environment(env.cube, env.rotation, env.intensity)
            self._face_scene = FaceScene(self.renderer.field, (), sky, self.runtime)
            # the generated maps hold the sky at the environment's intensity already, so every
            # map is read at 1: the file map (the background's) scaled once instead
            self._sky_map = None if self._file_map is None or env.intensity == 1.0 else \
                CubeMap(env.cube.faces * np.float32(env.intensity)).to_device(self.runtime)
        lighting = settings.lighting if env.cube is None else replace(settings.lighting, background=(0.0, 0.0, 0.0))
        faces = replace(settings, ssaa=1, lighting=lighting)
        size = env.size if self._file_map is None else self._file_map.size
        lo, hi = map_bounds(self.renderer.field.heightmap)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        maps = [] if self._file_map is None else [self._file_map if self._sky_map is None else self._sky_map]
        cube_of = []
        for q in self.quadrics:
            if not q.material.conditions:
                cube_of.append(0)
                continue
            centre, radius = q.bound
            far = 1.05 * float(np.linalg.norm(corners - q.centre, axis=1).max()) + radius
            cube_of.append(len(maps))
            maps.append(generate_cube(self._face_scene, q.centre, size, sun, faces, env.rotation,
                                      near=min(0.5 * radius, 1e-3 * far), far=far))
        self._reflect_with(stack_cubes(maps), cube_of, intensity=1.0)
        self.generations += 1

    def _run(self, name: str, camera: Camera, sun: Sun | PointLight, settings: FrameSettings,
             lighting: Lighting) -> object:
        if name == "compose":
            return self._compose(camera, settings, lighting)
        if name == "shadows" and isinstance(sun, PointLight):
            return self._point_shadows(camera, sun, settings)
        out = super()._run(name, camera, sun, settings, lighting)
        gbuf = out if name == "gbuffer" else self._out["gbuffer"]
        if name == "gbuffer":
            ids = self._clear_ids(gbuf.shape)
            if self.caster is not None:
                self._objects = self.caster.cast(camera, self._objects)
                self.caster.merge(self._objects, gbuf, ids)
            if self.mesh_caster is not None:
                self._mesh_objects = self.mesh_caster.cast(camera, self._mesh_objects)
                self.mesh_caster.merge(self._mesh_objects, gbuf, ids)
        elif name == "normals" and (self.caster is not None or self.mesh_caster is not None):
            object_normals(self.runtime, gbuf, self.ids, out)
        elif name == "shadows":
            if self.mesh_caster is not None:
                self.mesh_caster.shadow(camera, gbuf, self.ids, sun, out, *settings.shadow_k)
            if self.caster is not None:
                self.caster.shadow(camera, gbuf, self.ids, sun, out, *settings.shadow_k)
            if self.mesh_shadows is not None:
                self.mesh_shadows.shadow(camera, gbuf, self.ids, sun, out, *settings.shadow_k)
            if self.ray_shadows is not None:
                self.ray_shadows.ray_shadow(camera, gbuf, sun, out, *settings.shadow_k)
        return out

    def _point_shadows(self, camera: Camera, light: PointLight, settings: FrameSettings) -> cl.Buffer:
        """The shadows pass for a point light (module doc): every caster on every pixel, exact;
        a shadowed pixel gets k_dark (paper 000's eq. (1) at elevation 0, as MeshShadows)."""
        if self.renderer.field.radius is not None:
            raise ValueError("sun: a point light on a curved map (Heightfield radius) is not supported: its "
                             "terrain shadows are traced over the flat map (give no radius, or use a sun)")
        gbuf = self._out["gbuffer"]
        n = gbuf.shape[0] * gbuf.shape[1]
        prev = self._out.get("shadows")
        out = prev if prev is not None and prev.size == 4 * n else self.runtime.empty(4 * n, "shadow coefficients")
        k_dark = settings.shadow_k[0]
        terrain_point_shadow(self.runtime, camera, self.renderer.field.heightmap, self.renderer.pyramid.heights,
                             gbuf, self.ids, light, out, k_dark)
        if self.caster is not None:
            self.caster.point_shadow(camera, gbuf, self.ids, light, out, k_dark)
        if self.mesh_shadows is not None:
            self.mesh_shadows.shadow(camera, gbuf, self.ids, light, out, *settings.shadow_k)
        if self.ray_shadows is not None:
            self.ray_shadows.ray_shadow(camera, gbuf, light, out, *settings.shadow_k)
        return out

    def _clear_ids(self, shape: tuple[int, int]) -> ObjectIds:
        """Object ids of the frame's size, all 0 (the buffer reused while the size holds)."""
        n = shape[0] * shape[1]
        if self.ids is None or self.ids.shape != shape:
            self.ids = ObjectIds(self.runtime.empty(4 * n, "object ids"), shape)
        cl.enqueue_fill_buffer(self.runtime.queue, self.ids.buffer, np.int32(0), 0, 4 * n)
        return self.ids

    #: compose's form of the frame (oclshade.compose.compose: 8-bit sRGB on the host)
    compose_pass = staticmethod(compose)

    def _compose(self, camera: Camera, settings: FrameSettings, lighting: Lighting) -> object:
        gbuf, refl = self._out["gbuffer"], self.reflections
        shown = refl.weights(gbuf, self.ids, camera) if refl is not None else gbuf
        image = self.compose_pass(shown, camera, lighting, shadow=self._out["shadows"], ao=self._out["ao"],
                                  device=self.runtime, normal=self._out["normals"], ssaa=settings.ssaa)
        return image if refl is None else self._add_reflections(refl, image, gbuf, camera, settings.ssaa)

    def _add_reflections(self, refl: Reflections, image: np.ndarray, gbuf, camera: Camera, ssaa: int) -> np.ndarray:
        return refl.apply(image, gbuf, self.ids, camera, ssaa)


def scene_camera(desc: SceneDescription, heightmap: Heightmap) -> Camera:
    """The description's camera; near and far enclose the map (if any), every quadric and
    every mesh."""
    spec = desc.camera
    width, height = spec.size
    if spec.position is None:
        camera = frame_heightmap(heightmap, width, height, azimuth=spec.view[0], elevation=spec.view[1], fov=spec.fov)
    else:
        camera = Camera(np.array(spec.position), np.array(spec.look_at), width, height, fov=spec.fov)
    reach = 0.0
    if desc.terrain is not None:
        lo, hi = map_bounds(heightmap)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        reach = float(np.linalg.norm(corners - camera.position, axis=1).max())
    for q in desc.quadrics:
        centre, radius = q.bound
        reach = max(reach, float(np.linalg.norm(centre - camera.position)) + radius)
    for m in desc.meshes:
        reach = max(reach, float(np.linalg.norm(m.vertices - camera.position, axis=1).max()))
    far = max(camera.far, 1.02 * reach) if spec.position is None else 1.02 * reach
    near = camera.near if spec.position is None else 1e-4 * far
    return replace(camera, near=min(near, 0.5 * far), far=far)


#: a scene without terrain renders over this map: 2 x 2 samples, all holes (nothing drawn,
#: nothing that shades)
NO_TERRAIN = np.full((2, 2), np.nan)


def load_heightmap(desc: SceneDescription) -> Heightmap:
    """The description's DEM as a Heightmap; a map of holes (:data:`NO_TERRAIN`) without one."""
    t = desc.terrain
    if t is None:
        return Heightmap.from_array(NO_TERRAIN, 1.0)
    raster = read_dem(t.dem, cellsize=t.cellsize, nodata=t.nodata)
    if t.cellsize is None and not {33550, 34264} & raster.georef.keys():
        raise SceneError(f"{desc.path}: [terrain] dem {t.dem} does not record its cell size; give cellsize = ...")
    return Heightmap.from_array(raster.heights, cellsize=(raster.dx, raster.dy), z_factor=t.z_factor)


def render_scene(desc: SceneDescription, device: str | int | Runtime | None = None,
                 uber: bool = False) -> tuple[Frame, ObjectScene, Camera]:
    """Render a scene description: (the frame, the scene that made it, its camera)."""
    heightmap = load_heightmap(desc)
    environment = None
    if desc.environment is not None:
        e = desc.environment
        cube = None if e.file is None else load_cube(e.file, e.layout, e.size, device)
        environment = Environment(cube, e.rotation, e.intensity, e.background, e.generate,
                                  e.size if cube is None and e.size is not None else 128)
    radius = None if desc.terrain is None else desc.terrain.radius
    scene = ObjectScene(Heightfield(heightmap, radius), desc.quadrics, environment, device, uber=uber,
                        meshes=desc.meshes, mesh_shadows=desc.render.mesh_shadows)
    camera = scene_camera(desc, heightmap)
    r = desc.render
    shown = environment is not None and environment.cube is not None and environment.background
    given = {} if desc.intensity is None else {"sun_intensity": desc.intensity}
    lighting = Lighting(sun=desc.light, background=(0.0, 0.0, 0.0), **given) if shown else \
        Lighting(sun=desc.light, **given)
    ao = AOSettings(radius=r.ao * max(heightmap.dx, heightmap.dy)) if r.ao > 0 else None
    settings = FrameSettings(shadows=r.shadows, ao=ao, lighting=lighting, ssaa=r.ssaa)
    return scene.frame(camera, desc.light, settings), scene, camera
