"""Scene files (TOML): terrain, camera, light (sun or point), render settings, environment,
quadrics and meshes.

>>> scene = load_scene("valley.toml")        # a SceneDescription; paths relative to the file
>>> scene.quadrics[0].material.kind
'mirror'

The format (every section optional, but a scene needs ``[terrain]`` or at least one
object; an unknown key or section is an error that names it, so a typo never passes
silently)::

    [terrain]                    # optional with [[mesh]] / [[quadric]] objects (then give
                                 #   [camera] position / look_at: view frames a map)
    dem = "dem.tif"              # path; cellsize: the file's, or [terrain] cellsize
    cellsize = 30.0              # or [dx, dy] (metres)
    z_factor = 1.0
    nodata = -32768              # overrides the file's
    radius = 6371000.0           # the map on a sphere (optional)

    [camera]                     # default: the map framed from view = [200, 30]
    position = [x, y, z]         # metres: x east from the first column, y north from the
    look_at = [x, y, z]          #   first row (the map lies at y <= 0), z up
    view = [azimuth, elevation]  # instead of position / look_at: the framed view
    fov = 45.0                   # vertical, degrees
    size = [1280, 720]

    [sun]
    azimuth = 315.0              # degrees clockwise from north
    elevation = 45.0

    [[light]]                    # instead of [sun]: exactly one light for now (docs/meshes.md
    kind = "point"               #   "Point lights"); "point" or "sun"
    position = [x, y, z]         # point: world metres (over or inside the map, anywhere)
    intensity = 2.0              # optional: irradiance on a plane facing the light (linear;
                                 #   default 2.0, the sun's); for a point light at `distance`
    distance = 500.0             # point, optional: the inverse-square falloff's reference
                                 #   distance in metres, intensity (distance / d)^2 at d metres;
                                 #   absent: no falloff
    # kind = "sun" takes azimuth, elevation (as [sun]) and intensity

    [render]
    ssaa = 1                     # samples per pixel along each axis
    shadows = true
    ao = 4.0                     # SSAO radius in cells (metres without terrain); 0 or absent: off

    [environment]
    file = "envmaps/sky.exr"     # any layout oclshade.envmap reads
    layout = "latlong"           # optional: detected from the file
    size = 256                   # cube face size for a lat-long file (default width / 4), or of
                                 #   generated maps without a file (default 128)
    rotation = 0.0               # degrees about world up (oclshade.envmap.cube_frame)
    intensity = 1.0
    background = true            # empty pixels show the map
    generate = "once"            # or N: maps rendered from each reflective object's centre
                                 #   (oclshade.scene.generate), on the first frame or every N

    [[quadric]]
    kind = "sphere"              # sphere: radius; ellipsoid: radii = [a, b, c];
    centre = [x, y, z]           # cylinder: radius, height (centre mid-axis);
    radius = 120.0               # paraboloid: radius, height (centre = vertex)
    axis = [0, 0, 1]             # optional
    material = "mirror"          # diffuse (default), mirror, glossy
    colour = [0.9, 0.9, 0.9]     # linear RGB; roughness, fresnel: see Material

    [[mesh]]                     # triangle meshes (issue 20; oclshade.meshes, docs/meshes.md)
    file = "bunny.obj"           # OBJ, PLY, or another format trimesh reads
    up = "z"                     # the file's up axis: "z" or "y" (turned to z-up)
    translate = [x, y, z]        # placed: scaled, turned rotate_z degrees counter-clockwise
    scale = 1.0                  #   (seen from above), then moved by translate
    rotate_z = 0.0
    cast_shadows = true
    colour = [0.8, 0.8, 0.8]     # linear RGB albedo (times the texture's where there is one)
    texture = "bark.png"         # optional; needs uvs in the file; alpha < alpha_cutoff: cut out
    alpha_cutoff = 0.5
    normal_map = "bark_n.png"    # optional tangent-space normal map; needs uvs
"""
from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:                                   # pragma: no cover - Python 3.10
    import tomli as tomllib

from ..envmap.materials import Material
from ..lights import Light, PointLight
from ..meshes.load import UPS, load_mesh, load_normal_map, load_texture
from ..meshes.mesh import MeshSurface, TriangleMesh
from ..quadrics.objects import Quadric
from ..sun import DEFAULT_AZIMUTH, DEFAULT_ELEVATION, Sun

SECTIONS = ("terrain", "camera", "sun", "light", "render", "environment", "quadric", "mesh")
MATERIAL_KEYS = ("material", "colour", "roughness", "fresnel")
_KEYS = {
    "terrain": ("dem", "cellsize", "z_factor", "nodata", "radius"),
    "camera": ("position", "look_at", "view", "fov", "size"),
    "sun": ("azimuth", "elevation"),
    "light": ("kind", "position", "azimuth", "elevation", "intensity", "distance"),
    "render": ("ssaa", "shadows", "ao", "mesh_shadows"),
    "environment": ("file", "layout", "size", "rotation", "intensity", "background", "generate"),
    "quadric": ("kind", "centre", "radius", "radii", "height", "axis") + MATERIAL_KEYS,
    "mesh": ("file", "up", "translate", "scale", "rotate_z", "cast_shadows", "colour", "texture", "alpha_cutoff",
             "normal_map"),
}
#: the keys each [[light]] kind takes (kind besides)
_LIGHT_KEYS = {"point": ("position", "intensity", "distance"), "sun": ("azimuth", "elevation", "intensity")}
#: which size keys each quadric kind takes
_SHAPE_KEYS = {"sphere": ("radius",), "ellipsoid": ("radii",), "cylinder": ("radius", "height"),
               "paraboloid": ("radius", "height")}


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file, the section and the key."""


@dataclass(frozen=True)
class TerrainSpec:
    dem: Path
    cellsize: float | tuple[float, float] | None = None
    z_factor: float = 1.0
    nodata: float | None = None
    radius: float | None = None


@dataclass(frozen=True)
class CameraSpec:
    """Either position and look_at, or the framed ``view`` (azimuth, elevation)."""

    size: tuple[int, int] = (1280, 720)
    fov: float = 45.0
    position: tuple[float, float, float] | None = None
    look_at: tuple[float, float, float] | None = None
    view: tuple[float, float] = (200.0, 30.0)


@dataclass(frozen=True)
class RenderSpec:
    ssaa: int = 1
    shadows: bool = True
    ao: float = 0.0                       # SSAO radius in cells, 0 off
    mesh_shadows: str = "rays"            # "rays" (BVH any-hit) or "volumes" (paper 003)


@dataclass(frozen=True)
class EnvironmentSpec:
    file: Path | None
    layout: str | None = None
    size: int | None = None
    rotation: float = 0.0
    intensity: float = 1.0
    background: bool = True
    generate: str | int | None = None


@dataclass(frozen=True)
class SceneDescription:
    path: Path
    terrain: TerrainSpec | None                 # None: no terrain (objects only)
    camera: CameraSpec = CameraSpec()
    light: Light = Sun(DEFAULT_AZIMUTH, DEFAULT_ELEVATION)    # [sun] or the one [[light]]
    render: RenderSpec = RenderSpec()
    environment: EnvironmentSpec | None = None
    quadrics: tuple[Quadric, ...] = field(default_factory=tuple)
    meshes: tuple[TriangleMesh, ...] = field(default_factory=tuple)
    intensity: float | None = None              # [[light]] intensity; None: Lighting's default

    @property
    def sun(self) -> Light:
        """The light (the name of the sun-only format): a Sun or a PointLight."""
        return self.light


class _Reader:
    """Typed access to one table with messages naming file, section and key."""

    def __init__(self, path: Path, where: str, table: object):
        self.path, self.where = path, where
        if not isinstance(table, dict):
            raise self.error(f"must be a table, got {type(table).__name__}")
        self.table = table

    def error(self, message: str, key: str | None = None) -> SceneError:
        at = f"{self.where} {key}" if key else self.where
        return SceneError(f"{self.path}: {at}: {message}")

    def check_keys(self, allowed: tuple[str, ...]) -> None:
        for key in self.table:
            if key not in allowed:
                raise self.error(f"unknown key {key!r}; expected one of {', '.join(allowed)}")

    def number(self, key: str, default: float | None = None, positive: bool = False) -> float | None:
        if key not in self.table:
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
            raise self.error(f"must be a {'positive ' if positive else ''}finite number, got {v!r}", key)
        return float(v)

    def integer(self, key: str, default: int | None, low: int = 1) -> int | None:
        if key not in self.table:
            return default
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise self.error(f"must be an integer >= {low}, got {v!r}", key)
        return v

    def boolean(self, key: str, default: bool) -> bool:
        v = self.table.get(key, default)
        if not isinstance(v, bool):
            raise self.error(f"must be true or false, got {v!r}", key)
        return v

    def numbers(self, key: str, count: int, default: tuple | None = None) -> tuple[float, ...] | None:
        if key not in self.table:
            return default
        v = self.table[key]
        if (not isinstance(v, list) or len(v) != count
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
            raise self.error(f"must be a list of {count} finite numbers, got {v!r}", key)
        return tuple(float(x) for x in v)

    def text(self, key: str, default: str | None = None) -> str | None:
        v = self.table.get(key, default)
        if v is not None and not isinstance(v, str):
            raise self.error(f"must be a string, got {v!r}", key)
        return v

    def file(self, key: str) -> Path:
        v = self.text(key)
        if v is None:
            raise self.error("is required", key)
        p = Path(os.path.expanduser(v))
        return p if p.is_absolute() else (self.path.parent / p)


def load_scene(path: str | os.PathLike) -> SceneDescription:
    """Read and check a scene file (module doc); paths in it are relative to its folder."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            doc = tomllib.load(fh)
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from None
    for key in doc:
        if key not in SECTIONS:
            raise SceneError(f"{path}: unknown section [{key}]; expected {', '.join(SECTIONS)}")
    if "terrain" not in doc and not (doc.get("mesh") or doc.get("quadric")):
        raise SceneError(f"{path}: a [terrain] section with dem = \"...\", or at least one [[mesh]] or "
                         "[[quadric]], is required")
    sections = {name: _Reader(path, f"[{name}]", doc.get(name, {})) for name in SECTIONS
                if name not in ("quadric", "mesh", "light")}
    for name, reader in sections.items():
        reader.check_keys(_KEYS[name])
    tables = {}
    for name, plural in (("quadric", "quadrics"), ("mesh", "meshes"), ("light", "lights")):
        tables[name] = doc.get(name, [])
        if not isinstance(tables[name], list):
            raise SceneError(f"{path}: {plural} are an array of tables: write [[{name}]]")
    if len(tables["light"]) > 1:
        raise SceneError(f"{path}: [[light]]: exactly one light for now, got {len(tables['light'])} "
                         "[[light]] tables")
    if tables["light"] and "sun" in doc:
        raise SceneError(f"{path}: [sun] and [[light]] together: give the light once, as [sun] or as one "
                         "[[light]] (kind = \"sun\" takes azimuth / elevation)")
    light, intensity = (_light(_Reader(path, "[[light]] 1", tables["light"][0])) if tables["light"]
                        else (_sun(sections["sun"]), None))
    camera = _camera(sections["camera"])
    if "terrain" not in doc and camera.position is None:
        raise sections["camera"].error("a scene without [terrain] needs position and look_at (view frames a map)")
    return SceneDescription(
        path=path, terrain=_terrain(sections["terrain"]) if "terrain" in doc else None, camera=camera,
        light=light, intensity=intensity, render=_render(sections["render"]),
        environment=_environment(sections["environment"]) if "environment" in doc else None,
        quadrics=tuple(_quadric(_Reader(path, f"[[quadric]] {k + 1}", t)) for k, t in enumerate(tables["quadric"])),
        meshes=tuple(_mesh(_Reader(path, f"[[mesh]] {k + 1}", t)) for k, t in enumerate(tables["mesh"])))


def _terrain(r: _Reader) -> TerrainSpec:
    cellsize: float | tuple[float, float] | None = None
    if "cellsize" in r.table:
        v = r.table["cellsize"]
        cellsize = r.number("cellsize", positive=True) if not isinstance(v, list) else r.numbers("cellsize", 2)
        if isinstance(cellsize, tuple) and min(cellsize) <= 0:
            raise r.error(f"must be positive, got {v!r}", "cellsize")
    z = r.number("z_factor", 1.0)
    if z == 0.0:
        raise r.error("must not be 0", "z_factor")
    return TerrainSpec(r.file("dem"), cellsize, z, r.number("nodata"), r.number("radius", positive=True))


def _camera(r: _Reader) -> CameraSpec:
    size = r.numbers("size", 2, (1280, 720))
    if any(s != int(s) or s < 1 for s in size):
        raise r.error(f"must be two pixel counts >= 1, got {list(size)}", "size")
    fov = r.number("fov", 45.0)
    if not 0.0 < fov < 180.0:
        raise r.error(f"must be in (0, 180) degrees, got {fov}", "fov")
    position, look_at = r.numbers("position", 3), r.numbers("look_at", 3)
    if (position is None) != (look_at is None):
        raise r.error("position and look_at go together (or leave both out for the framed view)")
    if position is not None and "view" in r.table:
        raise r.error("view frames the map automatically: give it or position / look_at, not both", "view")
    return CameraSpec((int(size[0]), int(size[1])), fov, position, look_at, r.numbers("view", 2, (200.0, 30.0)))


def _sun(r: _Reader) -> Sun:
    try:
        return Sun(r.number("azimuth", DEFAULT_AZIMUTH), r.number("elevation", DEFAULT_ELEVATION))
    except ValueError as exc:
        raise r.error(str(exc)) from None


def _light(r: _Reader) -> tuple[Light, float | None]:
    r.check_keys(_KEYS["light"])
    kind = r.text("kind")
    if kind not in _LIGHT_KEYS:
        raise r.error(f"must be one of {', '.join(repr(k) for k in _LIGHT_KEYS)}, got {kind!r}", "kind")
    for key in r.table:
        if key != "kind" and key not in _LIGHT_KEYS[kind]:
            raise r.error(f"a {kind} light takes {', '.join(_LIGHT_KEYS[kind])}, not {key}", key)
    intensity = r.number("intensity")
    if intensity is not None and intensity < 0:
        raise r.error(f"must be >= 0, got {intensity}", "intensity")
    if kind == "sun":
        return _sun(r), intensity
    position = r.numbers("position", 3)
    if position is None:
        raise r.error("a point light needs position = [x, y, z] (world metres)", "position")
    return PointLight(position, r.number("distance", positive=True)), intensity


def _render(r: _Reader) -> RenderSpec:
    ao = r.number("ao", 0.0)
    if ao < 0:
        raise r.error(f"must be >= 0 cells (0: off), got {ao}", "ao")
    mesh_shadows = r.table.get("mesh_shadows", "rays")
    if mesh_shadows not in ("rays", "volumes"):
        raise r.error(f"must be \"rays\" or \"volumes\", got {mesh_shadows!r}", "mesh_shadows")
    return RenderSpec(r.integer("ssaa", 1), r.boolean("shadows", True), ao, mesh_shadows)


def _environment(r: _Reader) -> EnvironmentSpec:
    generate = r.table.get("generate")
    if generate is not None and generate != "once" and (isinstance(generate, bool) or not isinstance(generate, int)
                                                        or generate < 1):
        raise r.error(f"must be \"once\" or a number of frames >= 1, got {generate!r}", "generate")
    if generate is None and "file" not in r.table:
        raise r.error("needs file = \"...\", generate = \"once\" | N, or both")
    intensity = r.number("intensity", 1.0)
    if intensity < 0:
        raise r.error(f"must be >= 0, got {intensity}", "intensity")
    return EnvironmentSpec(r.file("file") if "file" in r.table else None, r.text("layout"), r.integer("size", None),
                           r.number("rotation", 0.0), intensity, r.boolean("background", True), generate)


def _quadric(r: _Reader) -> Quadric:
    r.check_keys(_KEYS["quadric"])
    kind = r.text("kind")
    if kind not in _SHAPE_KEYS:
        raise r.error(f"must be one of {', '.join(_SHAPE_KEYS)}, got {kind!r}", "kind")
    for key in ("radius", "radii", "height"):
        if key in r.table and key not in _SHAPE_KEYS[kind]:
            raise r.error(f"a {kind} takes {' and '.join(_SHAPE_KEYS[kind])}, not {key}", key)
    for key in _SHAPE_KEYS[kind]:
        if key not in r.table:
            raise r.error(f"a {kind} needs {key}", key)
    centre = r.numbers("centre", 3)
    if centre is None:
        raise r.error("is required", "centre")
    axis = r.numbers("axis", 3, (0.0, 0.0, 1.0))
    try:
        material = Material(r.text("material", "diffuse"), r.numbers("colour", 3), r.number("roughness", 0.0),
                            r.number("fresnel", 0.04))
        if kind == "sphere":
            return Quadric.sphere(centre, r.number("radius", positive=True), material)
        if kind == "ellipsoid":
            return Quadric.ellipsoid(centre, r.numbers("radii", 3), axis, material)
        maker = Quadric.cylinder if kind == "cylinder" else Quadric.paraboloid
        return maker(centre, r.number("radius", positive=True), r.number("height", positive=True), axis, material)
    except ValueError as exc:
        raise r.error(str(exc)) from None


def _mesh(r: _Reader) -> TriangleMesh:
    r.check_keys(_KEYS["mesh"])
    file = r.file("file")
    up = r.text("up", "z")
    if up not in UPS:
        raise r.error(f"must be one of {', '.join(repr(u) for u in UPS)}, got {up!r}", "up")
    images = {}
    for key, loader in (("texture", load_texture), ("normal_map", load_normal_map)):
        if key in r.table:
            where = r.file(key)
            try:
                images[key] = loader(where)
            except (OSError, ValueError) as exc:
                raise r.error(str(exc), key) from None
    try:
        surface = MeshSurface(r.numbers("colour", 3, (0.8, 0.8, 0.8)), images.get("texture"), images.get("normal_map"),
                              r.number("alpha_cutoff", 0.5))
        mesh = load_mesh(file, up, cast_shadows=r.boolean("cast_shadows", True), surface=surface)
    except FileNotFoundError as exc:
        raise r.error(str(exc), "file") from None
    except ValueError as exc:
        raise r.error(str(exc)) from None
    try:
        return mesh.placed(r.numbers("translate", 3, (0.0, 0.0, 0.0)), r.number("scale", 1.0, positive=True),
                           r.number("rotate_z", 0.0))
    except ValueError as exc:
        raise r.error(str(exc)) from None
