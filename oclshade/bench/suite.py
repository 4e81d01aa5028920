"""The benchmark's cases: every kernel family through the public Python API, on standard inputs.

Inputs are generated, never read: the heightmap is
``oclshade.synthetic.canyon_crater(n, seed=0, relief=1500)`` with 30 m cells
(the terrain of ``data/canyon_512.tif`` at n = 512, deterministic per seed),
and the frames are :func:`oclshade.camera.frame_heightmap` views of it
(azimuth 200, elevation 35).  Suns: 37 / 20 degrees for the masks (the
headline case), 37 / 10 for the per-pixel shadows and the composed frame.

Cases (``family/variant``) and what one timed run is:

* ``pyramid``: :func:`~oclshade.pyramid.build_extrema_pyramid` of the map,
  new buffers each run, until the device is done;
* ``masks/<method>`` for every method of :data:`oclshade.shadows.METHODS`:
  ``ShadowCaster(..., cache=False, analyse=False).cast(sun, method)`` over the
  resident pyramid, the mask copied to the host (no result is reused and no
  host-side scene analysis runs: the device's traversal is what is timed);
* ``render/<method>`` for every method of :data:`oclshade.terrain.METHODS`:
  ``TerrainRenderer.render(camera, method, on_device=True, out=...)``;
* ``pixel_shadows/<method>`` (exact, maxmip): ``ScreenShadowCaster.shade_to_device``
  on the bisect G-buffer, the default level of detail (q = 0: exact);
* ``ssao/default`` (:data:`~oclshade.ssao.DEFAULT_FEATURES`, m = DEFAULT_M) and
  ``ssao/paper`` (:data:`~oclshade.ssao.PAPER_RECIPE`, m = PAPER_M), radius 4 cells;
* ``compose``: :func:`oclshade.compose.compose` of the G-buffer with the exact
  per-pixel shadow coefficients and the default AO, the frame copied to the host;
* ``horizons``: ``HorizonCaster(..., cache=False).horizons([37])`` (exact horizon
  angles, one azimuth, the band copied to the host) on the canyon of a quarter of
  the masks' side (a horizon ray walks until nothing further can be higher: a
  horizon band costs tens of masks);
* ``horizons/radius``: the same within a search radius of :data:`HORIZON_RADIUS_CELLS`
  cells, on the masks' map (the sweep: kernels/horizon.cl, "The sweep");
* ``horizons/radius_blocks``: the ``horizons/radius`` case traced in blocks of :func:`blocked_scales`
  (the sweep's runs read their block's ray from a table, one launch);
* ``horizons/blocks``: the ``horizons`` case on the same canyon traced in blocks of their own
  scale (:func:`blocked_scales`: an equal-area-like grid metre changing 1 % across the map
  and stretched 3-4 % by direction, :data:`BLOCK_COLUMN_BANDS` column bands; each cell's ray
  and cell sizes from its block's table in one launch, kernels/horizon.cl OCLS_SUN_TABLE);
* ``horizons/sun_disc``: ``HorizonCaster(...).sun_disc`` of :data:`LOW_SUN` in
  :data:`SUN_DISC_COLUMNS` strips (soft shadows: each strip's horizons clamped to its
  chord, -D OCLS_CLAMP, summed on the host) on the ``horizons`` case's canyon;
* ``sunshine/masks``: ``SunshineCaster(..., analyse=False).accumulate`` of the
  :data:`SUNSHINE_SUNS` (a day's path, 600 s each) over the masks' map, hours and
  cast fraction: a mask per sun traced and summed on the device, the sums copied
  to the host;
* ``meshes/cast``: ``MeshCaster.cast(camera, out=...)`` of :func:`bench_mesh` (a wavy
  sheet of 2 x MESH_QUADS^2 triangles generated over the middle of the frame's map, its
  BVH built once when the case is prepared) into its own G-buffer and object ids;
* ``meshes/shadow_rays``: ``MeshCaster.shadow_rays`` (any-hit rays through the BVH toward
  the low sun) from every pixel of the bisect G-buffer with the sheet merged in;
* ``meshes/shadow_volumes``: ``MeshShadows([sheet]).mask`` (paper 003's silhouette
  volumes, built once for the sun and cached, as the paper's static light allows; the
  per-frame count of crossings is what is timed) on the same G-buffer and sun: the same
  question as ``meshes/shadow_rays`` by the other method, same run.

Work model, per case (``nbytes`` and ``flops`` of :class:`Case`): the traffic
and arithmetic the case cannot avoid, so the roofline time derived from them
is a lower bound and the roofline fraction an upper bound on the share of the
device a case uses.  Bytes: every input array the kernels need read once,
every output written once, and outputs the API copies to the host counted
twice more (a read on the device side and a write to host memory); pyramid
texels, sample tables and re-reads of neighbours (caches) are not counted.
Flops: float operations of the minimum work per item, with min / max
counting as one; the data-dependent traversal steps beyond it are not
counted (those kernels are bound by latency and branching, which is what
their small roofline fractions say).  With N cells and P pixels:

========================  ===============================  ====================================
case                      bytes                            flops
========================  ===============================  ====================================
pyramid                   4 N + 8 T (T: stored texels)     16 T1 + 6 (T - T1) (T1: level-1 texels;
                                                           3x3 samples per level-1 texel, 2x2 above)
masks/*                   4 N heights + N mask + 2 N copy  20 N (the start patch test of each ray)
render/*                  16 P (one patch per ray) +       60 P (ray set-up, clip, one exact patch hit)
                          76 P G-buffer written
pixel_shadows/*           40 P (position, uv, uv_grad) +   30 P (start point and start patch test)
                          5 P (flag, coefficient)
ssao/default              92 P (prepare: 32 read, 20       m (25 P) + 20 P (per sample: rotation,
                          written; AO: 36 read, 4 written)  offset, projection, depth test)
ssao/paper                124 P (as above + two blur       m (25 P) + 20 P + 4 b P (b x b box blur,
                          passes of 16 P each)             two separable passes)
compose                   56 P read + 4 P written +        40 P (Lambert, sky, three sRGB encodes)
                          8 P copy
horizons                  4 N heights + 4 N angles +       30 N (the start patch of each ray)
                          8 N copy (N: cells of its map)
horizons/radius           4 N heights + 4 N angles +       60 K N (K patches a ray crosses within
                          8 N copy                         the radius, 60 flops each)
horizons/radius_blocks    as horizons/radius               as horizons/radius (the table's reads not
                                                           counted)
horizons/blocks           4 N heights + 4 N angles +       30 N (as horizons; the table's reads not
                          8 N copy                         counted)
horizons/sun_disc         k (4 N heights + 4 N angles +    30 k N (each strip's start patch; k: the
                          8 N copy)                        strips)
sunshine/masks            S (4 N heights + 2 N mask        S (20 N + 12 N) (each mask's start patch
                          written and read + 16 N sums     test; gradient, facing test and sums;
                          read and written) + 16 N copy    S: the number of suns)
meshes/cast               80 P G-buffer and ids written    60 P (ray set-up, the root box's slab
                          + B (B: the mesh tables: 80 per  test, one watertight triangle test)
                          triangle, 24 per vertex; BVH
                          nodes not counted)
meshes/shadow_rays        16 P positions + 4 P written     50 P (ray set-up, one slab test, one
                          + B                              triangle test)
meshes/shadow_volumes     20 P (position, depth) + P mask  30 P (the view segment's set-up and one
                          + 16 V (V: volume vertices,      face's crossing test)
                          sent each frame)
========================  ===============================  ====================================

``exact`` cases must give the same bits on every device (their results equal
the float64 reference by construction): the pyramid (min / max only) and the
``exact`` masks, the horizons (all five cases), the sunshine sums of exact masks (integer seconds).  The other cases are compared too, for information.
"""
from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pyopencl as cl

from ..camera import Camera, frame_heightmap, map_bounds
from ..compose import Lighting, compose
from ..gbuffer import CHANNELS
from ..heightmap import Heightmap
from ..horizon import HorizonCaster
from ..meshes import MeshCaster, MeshShadows, TriangleMesh
from ..pyramid import build_extrema_pyramid, extrema_shapes
from ..runtime import Runtime
from ..screen_shadows import ScreenShadowCaster
from ..shadows import METHODS as SHADOW_METHODS, ShadowCaster
from ..ssao import DEFAULT_FEATURES, DEFAULT_M, PAPER_M, PAPER_RECIPE, SSAO, AOFeatures, AOInputs
from ..sun import BlockGrid, Sun, SunField
from ..sunshine import SunshineCaster
from ..synthetic import canyon_crater
from ..terrain import METHODS as TERRAIN_METHODS, DeviceGBuffer, Heightfield, TerrainRenderer

FAMILIES = ("pyramid", "masks", "render", "pixel_shadows", "ssao", "compose", "horizons", "sunshine", "meshes")
PIXEL_SHADOW_METHODS = ("exact", "maxmip")
CELL_M = 30.0
RELIEF_M = 1500.0
MASK_SUN = Sun(37.0, 20.0)
FIELD_BLOCK = 16          # cells per side of the sun field case's blocks (sun_field's on a 1-degree SRTM tile)
#: the horizons/radius case's search radius in cells (RVT's default)
HORIZON_RADIUS_CELLS = 10
LOW_SUN = Sun(37.0, 10.0)
SUN_DISC_COLUMNS = 16      # the soft shadows' strips (oclshade.horizon.DEFAULT_COLUMNS)
VIEW = (200.0, 35.0)      # frame_heightmap azimuth, elevation
AO_RADIUS_CELLS = 4.0
#: the sunshine case's suns: a day's path, east to west
SUNSHINE_SUNS = tuple(Sun(az, el) for az, el in ((70.0, 5.0), (90.0, 20.0), (120.0, 40.0), (160.0, 55.0),
                                                (200.0, 55.0), (240.0, 40.0), (270.0, 20.0), (290.0, 5.0)))
#: the meshes cases' sheet: MESH_QUADS x MESH_QUADS quads (3200 triangles)
MESH_QUADS = 40


@dataclass(frozen=True)
class Sizes:
    """Input sizes and repetitions of one benchmark run."""

    name: str
    map_side: int                 # heightmap side for the pyramid and the masks
    frame_map_side: int           # heightmap side the frames look at
    frame: tuple[int, int]        # frame width, height (pixels)
    reps: int                     # timed repetitions per case (after the warm-up)
    max_case_s: float             # a case stops repeating once its timed runs add up to this
    copy_bytes: int               # size of each roofline copy buffer
    probe_s: float                # time per roofline probe variant


SIZES = {
    # the headline sizes of README "Benchmarks": 4096^2 masks, 1920x1080 frames of a 2048^2 map
    "full": Sizes("full", 4096, 2048, (1920, 1080), 5, 30.0, 256 << 20, 0.3),
    # about a minute for both PoCL devices of a 2-core machine, first-time compiles included (35-70 s measured)
    "quick": Sizes("quick", 1024, 1024, (960, 540), 3, 3.0, 64 << 20, 0.25),
    # a smoke test (the test suite): seconds per device once the kernels are cached
    "tiny": Sizes("tiny", 48, 48, (64, 36), 2, 1.0, 1 << 20, 0.01),
}


@dataclass
class Case:
    """One prepared case: ``run`` does the timed work and waits for the device; ``outputs``
    returns the arrays of the last run (their bytes make the digest)."""

    what: str
    unit: str                 # what ``items`` counts: cells, rays or pixels
    items: int
    nbytes: float
    flops: float
    input_digest: str
    run: Callable[[], None]
    outputs: Callable[[], list[np.ndarray]]


@dataclass(frozen=True)
class CaseSpec:
    """A case before its inputs exist: ``prepare`` builds it on one device's :class:`Workload`."""

    id: str
    family: str
    exact: bool
    prepare: Callable[["Workload"], Case]


def digest(arrays: list[np.ndarray]) -> str:
    """sha256 (hex) of the arrays' dtypes, shapes and bytes, in order."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


@functools.lru_cache(maxsize=4)
def terrain(side: int) -> Heightmap:
    """The standard generated heightmap of one size (shared by every device)."""
    return Heightmap.from_array(canyon_crater(side, side, seed=0, relief=RELIEF_M), CELL_M)


@functools.lru_cache(maxsize=4)
def terrain_digest(side: int) -> str:
    hm = terrain(side)
    return digest([hm.heights, np.array([hm.dx, hm.dy])])


#: the ``horizons/blocks`` case's column bands
BLOCK_COLUMN_BANDS = 8


def blocked_scales(side: int) -> np.ndarray:
    """float64 (side, :data:`BLOCK_COLUMN_BANDS` (at most side // 16), 4): row scales like a
    whole equal-area tile's far from its centre (oclshade.solar.scale): s from 0.996 to 1.006
    over the map, p about 0.03 and q about 0.035, all changing across the rows and columns."""
    bands = min(BLOCK_COLUMN_BANDS, max(1, side // 16))
    y = (np.arange(side)[:, None] + 0.5) / side
    x = (np.arange(bands)[None, :] + 0.5) / bands
    s = 1.0 + 0.006 * x - 0.004 * y
    return np.stack(np.broadcast_arrays(s, s, 0.03 + 0.01 * x - 0.005 * y, 0.035 - 0.008 * y + 0.002 * x), axis=-1)


def bench_mesh(hm: Heightmap) -> TriangleMesh:
    """The meshes cases' caster: a sheet of MESH_QUADS^2 quads (two triangles each) over the
    middle half of the map, at 70 % of its relief, waved by 3 % of its width (it covers much of
    the frame and casts a long shadow on the terrain under the low sun)."""
    lo, hi = map_bounds(hm)
    u, v = np.meshgrid(np.linspace(0.25, 0.75, MESH_QUADS + 1), np.linspace(0.25, 0.75, MESH_QUADS + 1))
    x, y = lo[0] + u * (hi[0] - lo[0]), lo[1] + v * (hi[1] - lo[1])
    z = lo[2] + 0.7 * (hi[2] - lo[2]) + 0.03 * (hi[0] - lo[0]) * np.sin(6 * np.pi * u) * np.cos(4 * np.pi * v)
    i = np.arange((MESH_QUADS + 1) ** 2).reshape(MESH_QUADS + 1, MESH_QUADS + 1)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel(), i[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return TriangleMesh(np.stack([x.ravel(), y.ravel(), z.ravel()], 1), faces, name="bench sheet")


def _map_label(side: int) -> str:
    return f"{side}^2 canyon_crater"


def _read(rt: Runtime, buf: cl.Buffer, shape: tuple[int, ...], dtype: type) -> np.ndarray:
    out = np.empty(shape, dtype)
    cl.enqueue_copy(rt.queue, out, buf)
    rt.queue.finish()
    return out


class Workload:
    """The inputs the cases share on one device, each built on first use."""

    def __init__(self, rt: Runtime, sizes: Sizes):
        self.rt = rt
        self.sizes = sizes

    @functools.cached_property
    def heightmap(self) -> Heightmap:
        return terrain(self.sizes.map_side)

    @functools.cached_property
    def caster(self) -> ShadowCaster:
        caster = ShadowCaster(self.heightmap, self.rt, cache=False, analyse=False)
        caster.pyramid
        self.rt.queue.finish()
        return caster

    @functools.cached_property
    def frame_map(self) -> Heightmap:
        return terrain(self.sizes.frame_map_side)

    @functools.cached_property
    def renderer(self) -> TerrainRenderer:
        return TerrainRenderer(Heightfield(self.frame_map), self.rt)

    @functools.cached_property
    def camera(self) -> Camera:
        width, height = self.sizes.frame
        return frame_heightmap(self.frame_map, width, height, azimuth=VIEW[0], elevation=VIEW[1])

    @functools.cached_property
    def gbuffer(self) -> DeviceGBuffer:
        """The bisect G-buffer the screen-space passes read."""
        gbuf = self.renderer.render(self.camera, "bisect", on_device=True)
        self.rt.queue.finish()
        return gbuf

    @functools.cached_property
    def screen_caster(self) -> ScreenShadowCaster:
        return ScreenShadowCaster(self.frame_map, pyramid=self.renderer.pyramid)

    @functools.cached_property
    def shadow_coefficient(self) -> cl.Buffer:
        """Exact per-pixel shadow coefficients of the frame (compose's input)."""
        buf = self.screen_caster.shade_to_device(self.gbuffer, LOW_SUN, "exact", outputs="coefficient")
        self.rt.queue.finish()
        return buf["coefficient"]

    @functools.cached_property
    def ao_inputs(self) -> AOInputs:
        gb = self.gbuffer
        return AOInputs(gb.shape, gb.buffers["position"], gb.buffers["normal"])

    @functools.cached_property
    def ao_factor(self) -> cl.Buffer:
        """The default AO of the frame (compose's input; its own SSAO object, so its buffer stays)."""
        buf = SSAO(self.rt).run(self.ao_inputs, self.camera.projection_matrix, radius=self.ao_radius,
                                m=DEFAULT_M, features=DEFAULT_FEATURES)
        self.rt.queue.finish()
        return buf

    @functools.cached_property
    def mesh(self) -> TriangleMesh:
        return bench_mesh(self.frame_map)

    @functools.cached_property
    def mesh_caster(self) -> MeshCaster:
        return MeshCaster([self.mesh], self.frame_map, self.rt)

    @functools.cached_property
    def mesh_gbuffer(self) -> DeviceGBuffer:
        """A bisect G-buffer of its own with the sheet merged in (the shadow cases' receivers)."""
        gbuf = self.renderer.render(self.camera, "bisect", on_device=True)
        self.mesh_caster.merge(self.mesh_caster.cast(self.camera), gbuf)
        self.rt.queue.finish()
        return gbuf

    @property
    def mesh_table_bytes(self) -> float:
        """B of the work model: the tables a mesh kernel reads (80 bytes per triangle, 24 per
        vertex; the BVH's nodes are not counted)."""
        return 80.0 * len(self.mesh.faces) + 24.0 * len(self.mesh.vertices)

    def mesh_label(self) -> str:
        return f"{len(self.mesh.faces)}-triangle sheet over the {self.frame_label()}, sun {LOW_SUN.azimuth:g}/" \
               f"{LOW_SUN.elevation:g}"

    def mesh_digest(self) -> str:
        return digest([np.frombuffer(self.frame_digest().encode(), np.uint8), self.mesh.vertices, self.mesh.faces])

    @property
    def ao_radius(self) -> float:
        return AO_RADIUS_CELLS * self.frame_map.dx

    @property
    def cells(self) -> int:
        rows, cols = self.heightmap.shape
        return rows * cols

    @property
    def pixels(self) -> int:
        return self.camera.width * self.camera.height

    def frame_label(self) -> str:
        width, height = self.sizes.frame
        return f"{width}x{height} frame of the {_map_label(self.sizes.frame_map_side)}"

    def frame_digest(self) -> str:
        cam = self.camera
        return digest([np.frombuffer(terrain_digest(self.sizes.frame_map_side).encode(), np.uint8),
                       cam.view, cam.projection_matrix])


# --- the cases ------------------------------------------------------------------------------

def _pyramid(w: Workload) -> Case:
    rt, hm = w.rt, w.heightmap
    shapes = extrema_shapes(*hm.patch_shape)
    texels = sum(r * c for r, c in shapes)
    level1 = shapes[0][0] * shapes[0][1]
    state: dict = {}

    def run() -> None:
        state["pyramid"] = build_extrema_pyramid(hm, rt)
        rt.queue.finish()

    return Case(f"extrema pyramid, {_map_label(w.sizes.map_side)}", "cells", w.cells,
                4.0 * w.cells + 8.0 * texels, 16.0 * level1 + 6.0 * (texels - level1),
                terrain_digest(w.sizes.map_side), run, lambda: state["pyramid"].to_numpy())


def _mask(method: str) -> Callable[[Workload], Case]:
    def prepare(w: Workload) -> Case:
        caster = w.caster
        state: dict = {}

        def run() -> None:
            state["result"] = caster.cast(MASK_SUN, method)

        n = w.cells
        sun = f"{MASK_SUN.azimuth:g}/{MASK_SUN.elevation:g}"
        return Case(f"{method} mask, {_map_label(w.sizes.map_side)}, sun {sun}", "cells", n, 7.0 * n, 20.0 * n,
                    terrain_digest(w.sizes.map_side), run, lambda: [state["result"].mask])
    return prepare


def bench_field(shape: tuple[int, int], block: int = FIELD_BLOCK) -> SunField:
    """A sun over the bench map (paper 000's cast shadows per block of cells, as
    :func:`oclshade.solar.sun_field` makes them): ``block`` x ``block`` cells, each block's sun
    :data:`MASK_SUN` turned by up to 0.5 degree in azimuth across the map and 0.3 in elevation
    down it (a 1-degree tile's spread is 0.6-0.7 degree)."""
    rows, cols = shape
    row_edges = np.append(np.arange(0, rows, block), rows)
    col_edges = np.append(np.arange(0, cols, block), cols)
    mid_r = (row_edges[:-1] + row_edges[1:]) / (2.0 * rows) - 0.5
    mid_c = (col_edges[:-1] + col_edges[1:]) / (2.0 * cols) - 0.5
    azimuth = MASK_SUN.azimuth + 0.5 * np.broadcast_to(mid_c, (len(mid_r), len(mid_c)))
    elevation = MASK_SUN.elevation + 0.3 * np.broadcast_to(mid_r[:, None], (len(mid_r), len(mid_c)))
    return SunField(shape, BlockGrid(row_edges, col_edges, np.array(azimuth), np.array(elevation)), MASK_SUN)


def _mask_field(w: Workload) -> Case:
    caster, field = w.caster, bench_field(w.heightmap.shape)
    state: dict = {}

    def run() -> None:
        state["result"] = caster.cast(field)

    n = w.cells
    return Case(f"exact mask of a sun field ({len(field.blocks)} blocks of {FIELD_BLOCK}^2 cells, one launch), "
                f"{_map_label(w.sizes.map_side)}", "cells", n, 7.0 * n, 20.0 * n, terrain_digest(w.sizes.map_side),
                run, lambda: [state["result"].mask])


def _render(method: str) -> Callable[[Workload], Case]:
    def prepare(w: Workload) -> Case:
        renderer, camera, rt = w.renderer, w.camera, w.rt
        state: dict = {"out": None}

        def run() -> None:
            state["out"] = renderer.render(camera, method, on_device=True, out=state["out"])
            rt.queue.finish()

        def outputs() -> list[np.ndarray]:
            gbuf = state["out"].to_host()
            return [getattr(gbuf, name) for name in CHANNELS]

        p = w.pixels
        return Case(f"{method} G-buffer, {w.frame_label()}", "rays", p, 92.0 * p, 60.0 * p, w.frame_digest(), run,
                    outputs)
    return prepare


def _pixel_shadows(method: str) -> Callable[[Workload], Case]:
    def prepare(w: Workload) -> Case:
        caster, gbuf, rt = w.screen_caster, w.gbuffer, w.rt
        state: dict = {"bufs": None}

        def run() -> None:
            state["bufs"] = caster.shade_to_device(gbuf, LOW_SUN, method, out=state["bufs"])
            rt.queue.finish()

        def outputs() -> list[np.ndarray]:
            return [_read(rt, state["bufs"]["flag"], gbuf.shape, np.uint8),
                    _read(rt, state["bufs"]["coefficient"], gbuf.shape, np.float32)]

        p = w.pixels
        return Case(f"{method} per-pixel shadows, automatic LOD, {w.frame_label()}, "
                    f"sun {LOW_SUN.azimuth:g}/{LOW_SUN.elevation:g}",
                    "pixels", p, 45.0 * p, 30.0 * p, w.frame_digest(), run, outputs)
    return prepare


def _ssao(variant: str, features: AOFeatures, m: int) -> Callable[[Workload], Case]:
    def prepare(w: Workload) -> Case:
        rt, inputs, projection, radius = w.rt, w.ao_inputs, w.camera.projection_matrix, w.ao_radius
        ssao = SSAO(rt)
        state: dict = {}

        def run() -> None:
            state["ao"] = ssao.run(inputs, projection, radius=radius, m=m, features=features)
            rt.queue.finish()

        p = w.pixels
        blur = features.blur != "none"
        nbytes = (124.0 if blur else 92.0) * p
        flops = (25.0 * m + 20.0 + (4.0 * features.blur_size if blur else 0.0)) * p
        return Case(f"SSAO {variant}: m = {m}, {features.distribution} samples, blur {features.blur}, "
                    f"radius {AO_RADIUS_CELLS:g} cells, {w.frame_label()}",
                    "pixels", p, nbytes, flops, w.frame_digest(), run,
                    lambda: [_read(rt, state["ao"], inputs.shape, np.float32)])
    return prepare


def _compose(w: Workload) -> Case:
    gbuf, camera, shadow, ao = w.gbuffer, w.camera, w.shadow_coefficient, w.ao_factor
    lighting = Lighting(sun=LOW_SUN)
    state: dict = {}

    def run() -> None:
        state["frame"] = compose(gbuf, camera, lighting, shadow=shadow, ao=ao)

    p = w.pixels
    return Case(f"compose with shadows and AO, {w.frame_label()}", "pixels", p, 68.0 * p, 40.0 * p,
                w.frame_digest(), run, lambda: [state["frame"]])


def _canyon_horizons(w: Workload, blocked: bool = False) -> tuple[int, HorizonCaster]:
    """(side, caster) of the horizon cases' canyon: a quarter of the masks' side, its pyramid built
    (``blocked``: traced in blocks of :func:`blocked_scales`)."""
    side = max(w.sizes.map_side // 4, 8)
    caster = HorizonCaster(terrain(side), w.rt, cache=False, row_scales=blocked_scales(side) if blocked else None)
    caster.pyramid
    return side, caster


def _horizons(w: Workload) -> Case:
    side, caster = _canyon_horizons(w)
    state: dict = {}

    def run() -> None:
        state["angles"] = caster.horizons([MASK_SUN.azimuth])

    n = side * side
    return Case(f"horizon angles, {_map_label(side)}, azimuth {MASK_SUN.azimuth:g}", "cells", n, 16.0 * n,
                30.0 * n, terrain_digest(side), run, lambda: [state["angles"]])


def _horizons_blocks(w: Workload) -> Case:
    side, caster = _canyon_horizons(w, blocked=True)
    state: dict = {}

    def run() -> None:
        state["angles"] = caster.horizons([MASK_SUN.azimuth])

    n, blocks = side * side, caster.scale_blocks.scales.shape
    return Case(f"horizon angles in {blocks[0]} x {blocks[1]} blocks of their own scale, {_map_label(side)}, azimuth "
                f"{MASK_SUN.azimuth:g}", "cells", n, 16.0 * n, 30.0 * n, terrain_digest(side), run,
                lambda: [state["angles"]])


def _horizons_radius(w: Workload, blocked: bool = False) -> Case:
    """The ``horizons/radius`` case (``blocked``: ``horizons/radius_blocks``, its map traced in
    blocks of :func:`blocked_scales`)."""
    hm, side = w.heightmap, w.sizes.map_side
    caster = HorizonCaster(hm, w.rt, cache=False, max_distance=HORIZON_RADIUS_CELLS * hm.dx,
                           row_scales=blocked_scales(side) if blocked else None)
    ux, uy, _ = Sun(MASK_SUN.azimuth, 0.0).ray(hm.dx, hm.dy)
    patches = caster.radius * (abs(ux) + abs(uy))
    state: dict = {}

    def run() -> None:
        state["angles"] = caster.horizons([MASK_SUN.azimuth])

    n, blocks = w.cells, caster.scale_blocks.scales.shape
    where = f" in {blocks[0]} x {blocks[1]} blocks of their own scale" if blocked else ""
    return Case(f"horizon angles within {HORIZON_RADIUS_CELLS} cells{where}, {_map_label(side)}, azimuth "
                f"{MASK_SUN.azimuth:g}", "cells", n, 16.0 * n, 60.0 * patches * n, terrain_digest(side),
                run, lambda: [state["angles"]])


def _sun_disc(w: Workload) -> Case:
    side, caster = _canyon_horizons(w)
    state: dict = {}

    def run() -> None:
        state["share"] = caster.sun_disc(LOW_SUN, columns=SUN_DISC_COLUMNS)

    n, k = side * side, SUN_DISC_COLUMNS
    return Case(f"soft shadows (the sun's disc in {k} clamped horizon strips), {_map_label(side)}, sun "
                f"{LOW_SUN.azimuth:g}/{LOW_SUN.elevation:g}", "cells", n, k * 16.0 * n, k * 30.0 * n,
                terrain_digest(side), run, lambda: [state["share"]])


def _sunshine(w: Workload) -> Case:
    caster = SunshineCaster(w.heightmap, w.rt, analyse=False)
    caster.shadows.pyramid
    state: dict = {}

    def run() -> None:
        state["maps"] = caster.accumulate(SUNSHINE_SUNS, 600, ("hours", "fraction"))

    n, s = w.cells, len(SUNSHINE_SUNS)
    return Case(f"sunshine hours and cast fraction by exact masks, {_map_label(w.sizes.map_side)}, {s} suns",
                "cells", n, s * 22.0 * n + 16.0 * n, s * 32.0 * n, terrain_digest(w.sizes.map_side), run,
                lambda: [state["maps"].hours, state["maps"].fraction])


def _mesh_cast(w: Workload) -> Case:
    caster, camera, rt = w.mesh_caster, w.camera, w.rt
    state: dict = {"out": None}

    def run() -> None:
        state["out"] = caster.cast(camera, out=state["out"])
        rt.queue.finish()

    def outputs() -> list[np.ndarray]:
        gbuf, ids = state["out"]
        host = gbuf.to_host()
        return [getattr(host, name) for name in CHANNELS] + [ids.to_host(rt)]

    p = w.pixels
    return Case(f"mesh G-buffer by BVH rays, {w.mesh_label()}", "rays", p, 80.0 * p + w.mesh_table_bytes, 60.0 * p,
                w.mesh_digest(), run, outputs)


def _mesh_shadow_rays(w: Workload) -> Case:
    caster, camera, rt, gbuf = w.mesh_caster, w.camera, w.rt, w.mesh_gbuffer
    state: dict = {"out": None}

    def run() -> None:
        state["out"] = caster.shadow_rays(camera, gbuf, LOW_SUN, out=state["out"])
        rt.queue.finish()

    p = w.pixels
    return Case(f"mesh shadows by any-hit BVH rays, {w.mesh_label()}", "pixels", p,
                20.0 * p + w.mesh_table_bytes, 50.0 * p, w.mesh_digest(), run,
                lambda: [_read(rt, state["out"], gbuf.shape, np.int32)])


def _mesh_shadow_volumes(w: Workload) -> Case:
    camera, rt, gbuf = w.camera, w.rt, w.mesh_gbuffer
    shadows = MeshShadows([w.mesh], rt)
    vertices = len(shadows.volumes(LOW_SUN, map_bounds(w.frame_map)).vertices)
    state: dict = {}

    def run() -> None:
        state["mask"] = shadows.mask(camera, gbuf, LOW_SUN)
        rt.queue.finish()

    p = w.pixels
    return Case(f"mesh shadows by silhouette shadow volumes (paper 003), {w.mesh_label()}", "pixels", p,
                21.0 * p + 16.0 * vertices, 30.0 * p, w.mesh_digest(), run,
                lambda: [_read(rt, state["mask"], gbuf.shape, np.uint8)])


SPECS: tuple[CaseSpec, ...] = (
    CaseSpec("pyramid", "pyramid", True, _pyramid),
    *(CaseSpec(f"masks/{m}", "masks", m == "exact", _mask(m)) for m in SHADOW_METHODS),
    CaseSpec("masks/sun_field", "masks", True, _mask_field),
    *(CaseSpec(f"render/{m}", "render", False, _render(m)) for m in TERRAIN_METHODS),
    *(CaseSpec(f"pixel_shadows/{m}", "pixel_shadows", False, _pixel_shadows(m)) for m in PIXEL_SHADOW_METHODS),
    CaseSpec("ssao/default", "ssao", False, _ssao("default", DEFAULT_FEATURES, DEFAULT_M)),
    CaseSpec("ssao/paper", "ssao", False, _ssao("paper", PAPER_RECIPE, PAPER_M)),
    CaseSpec("compose", "compose", False, _compose),
    CaseSpec("horizons", "horizons", True, _horizons),
    CaseSpec("horizons/blocks", "horizons", True, _horizons_blocks),
    CaseSpec("horizons/radius", "horizons", True, _horizons_radius),
    CaseSpec("horizons/radius_blocks", "horizons", True, functools.partial(_horizons_radius, blocked=True)),
    CaseSpec("horizons/sun_disc", "horizons", True, _sun_disc),
    CaseSpec("sunshine/masks", "sunshine", True, _sunshine),
    CaseSpec("meshes/cast", "meshes", False, _mesh_cast),
    CaseSpec("meshes/shadow_rays", "meshes", False, _mesh_shadow_rays),
    CaseSpec("meshes/shadow_volumes", "meshes", False, _mesh_shadow_volumes),
)
