"""Screen-space ambient occlusion over a G-buffer (paper 001), on the device.

>>> pass_ = SSAO()
>>> ao = pass_.compute(gbuffer, projection, radius=8.0)      # float32 (H, W), 1 = unoccluded

Stages: ``ssao_prepare`` (empty pixels, alpha cut-outs, normal map), the AO
estimator ``ssao_ao``, then an optional blur (the paper's box blur or an
edge-aware one).  Definitions, buffer layouts and the -D options are in
``kernels/ssao.cl``; the float64 twins are :func:`oclshade.reference.ssao`
(point samples) and :func:`oclshade.reference.ssao_lines` (line samples), and
the ground truths they are measured against are
:func:`oclshade.reference.volume_ao_lines` (and its point-quadrature check
:func:`oclshade.reference.volume_ao`) and :func:`oclshade.reference.raytraced_ao`.

The AO map is the *unoccluded* fraction: the compose pass multiplies it into
the ambient term (``kernels/compose.cl`` with ``-D OCLS_AO``).

What each estimator estimates.  The depth-buffer model behind all of them:
everything behind a stored surface (along the line of sight) is solid.  The
depth is known only on each pixel's line of sight (through its stored point
Q), so every depth test happens there: a sample is moved onto the line of
sight of the pixel it falls in (at most half a pixel) before it is compared
with Q; a sample moved below P's tangent plane is not counted.  Comparing the
sample itself with the depth at the pixel centre (the paper) makes any oblique
plane occlude itself (the stored depth is nearer than the plane on one side of
the centre): that read 0.90-0.97 on flat ground and slopes; now a plane reads
exactly 1 (kernels/ssao.cl step 4, tests/test_ssao_planes.py).  A sample is
occluded when at least delta + DEPTH_TOL |z| behind the stored depth z.

* Point samples (the paper's AO map; ``paper``, ``uniform``, ``centre``): the
  fraction of m points around P whose pixel holds a surface at least delta
  nearer the camera: a Monte Carlo estimate of the occupied fraction of the
  volume the point set stands for (``uniform``: the hemisphere of radius R on
  the normal, i.e. ground truth (a); ``paper``: the half-cube [-R, R]^2 x [0, R]).
* Line samples (``lines``, -D OCLS_LINES; volumetric obscurance in the manner
  of Loos and Sloan 2010, not in the paper): the same occupied fraction of the
  hemisphere as ground truth (a), integrated over m lines of sight instead of
  points.  Under the model the solid along a line of sight is one interval
  (behind the surface its pixel stores), so one depth fetch gives the exact
  occupied length of the line's chord through the hemisphere (the ball of
  radius R cut by the tangent plane); lines along the *normal* would cross
  many pixels and need many fetches.  The lines run through m points of a
  stratified disk of radius R perpendicular to P's line of sight, each moved
  to the line of sight of the pixel it falls in, and the estimate is the sum
  of occupied lengths over the sum of lengths.  The 1-D integral's variance is
  gone, so few samples reach a small error against (a) (bench/results/ssao.md).
* Ray samples (``rays``, -D OCLS_RAYS; not in the paper): ground truth (b),
  ray-traced AO (cosine-weighted rays of length R, a ray occluded when it meets
  the surface), in screen space: m cosine-weighted rays, each tested at
  ``RAY_STEPS`` points out to R; a ray is occluded when one of its points is.
  The default (below).
* bench/ssao.py and bench/ssao_bias.py measure each against both truths.

Sample tables (unit radius), generated once on the host and uploaded to
``__constant`` memory:

* ``paper``: tangent space (z along the normal), S = (2 f1 - 1, 2 f2 - 1, f3),
  f ~ U[0, 1) (seeded numpy PCG64): the paper's half-cube, not normalised; it
  stands for the box [-R, R]^2 x [0, R], not the hemisphere.
* ``uniform``: stratified, uniform in the volume of the unit hemisphere
  (radius (i + 1/2)/m cubed-rooted, cos(polar) and azimuth from a golden-ratio
  sequence): an unbiased estimator of ground truth (a).
* ``centre``: the directions of ``uniform``, radii 0.1 + 0.9 ((i + 1/2)/m)^2,
  more samples near the centre (the common "normalised, scaled" kernel): it
  weights near occluders more, i.e. a distance falloff; it estimates neither
  ground truth exactly.
* ``lines``: :func:`line_table`, the Vogel spiral uniform in the disk's area
  (x, y in the plane perpendicular to the line of sight) and each point's
  chord half-length sqrt(1 - x^2 - y^2).
* ``rays``: the same table read as unit tangent-space directions (x, y,
  sqrt(1 - x^2 - y^2)): the disk lifted to the hemisphere, cosine-weighted
  (Malley's method).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pyopencl as cl

from .gbuffer import GBuffer
from . import tuning
from .runtime import Runtime, get_runtime

POINT_DISTRIBUTIONS = ("paper", "uniform", "centre")
DISTRIBUTIONS = POINT_DISTRIBUTIONS + ("lines", "rays")
#: the depth test's tolerance, relative to the stored depth: a sample is occluded only when at least
#: delta + DEPTH_TOL |z_t| behind it (kernels/ssao.cl step 4).  2^-16 = 128 eps32: the float32 depth's
#: resolution with headroom for the renderer's hit error (up to 40 eps32 |P| measured off rendered planes)
DEPTH_TOL = 2.0 ** -16
#: ray samples: points per ray, at R k / RAY_STEPS for k = 1 .. RAY_STEPS (-D OCLS_RAY_STEPS)
RAY_STEPS = 4
BLURS = ("none", "box", "edge")
M_MIN, M_MAX = 4, 256
PAPER_SEED = 2019
_GOLDEN = (0.6180339887498949, 0.7548776662466927, 0.5698402909980532)


def hemisphere_points(n: int, distribution: str) -> np.ndarray:
    """n points of a tangent-space sample kernel (float64, (n, 3)), see the module docstring."""
    if distribution not in POINT_DISTRIBUTIONS:
        raise ValueError(f"distribution must be one of {', '.join(POINT_DISTRIBUTIONS)} (point samples; "
                         f"'lines' has line_table), got {distribution!r}")
    if distribution == "paper":
        f = np.random.default_rng(PAPER_SEED).random((n, 3))
        return np.stack([2 * f[:, 0] - 1, 2 * f[:, 1] - 1, f[:, 2]], axis=1)
    i = np.arange(n)
    s = (i + 0.5) / n
    cos_t = (i * _GOLDEN[1] + 0.5) % 1.0
    phi = 2.0 * np.pi * ((i * _GOLDEN[2] + 0.25) % 1.0)
    r = np.cbrt(s) if distribution == "uniform" else 0.1 + 0.9 * s * s
    sin_t = np.sqrt(1.0 - cos_t * cos_t)
    return np.stack([r * sin_t * np.cos(phi), r * sin_t * np.sin(phi), r * cos_t], axis=1)


def sample_kernel(m: int, distribution: str) -> np.ndarray:
    """The kernel's sample table: float32 (m, 4), xyz = :func:`hemisphere_points`, w = 0."""
    out = np.zeros((m, 4), np.float32)
    out[:, :3] = hemisphere_points(m, distribution)
    return out


def disk_points(n: int) -> np.ndarray:
    """The line samples' disk set (``AOFeatures.lines``): n points stratified and uniform in the
    area of the unit disk (the Vogel spiral: radius sqrt((i + 1/2) / n), azimuth 2 pi frac(i g),
    g the golden ratio's fraction), float64 (n, 2)."""
    i = np.arange(n)
    r = np.sqrt((i + 0.5) / n)
    phi = 2.0 * np.pi * ((i * _GOLDEN[0]) % 1.0)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)


def line_table(m: int) -> np.ndarray:
    """The kernel's table for line samples: float32 (m, 3) = (x, y, sqrt(1 - x^2 - y^2)) of
    :func:`disk_points` (the third: the half-length of the unit sphere's chord through the point)."""
    d = disk_points(m)
    return np.stack([d[:, 0], d[:, 1], np.sqrt(np.maximum(1.0 - (d * d).sum(axis=1), 0.0))], axis=1).astype(np.float32)


def line_eye(projection: np.ndarray) -> np.ndarray:
    """The point every pixel's line of sight passes through, homogeneous (float64 (4,)), scaled so
    that ``E.xyz - E.w X`` points from a view-space point X towards the camera.

    The lines of sight are the lines of constant pixel: points X with rows 0, 1 and 3 of the
    projection (x, y, w of clip space) proportional, so E spans the null space of those rows.
    Perspective: E = (camera centre, 1); orthographic: E = (view direction, 0), oriented to +z
    (the depth test's convention: a larger view-space z is nearer the camera)."""
    rows = np.asarray(projection, np.float64)[[0, 1, 3]]
    _, sv, vt = np.linalg.svd(rows)
    if not sv[2] > 1e-12 * sv[0]:
        raise ValueError("projection: rows 0, 1 and 3 (clip x, y, w) must have rank 3 (a camera)")
    e = vt[-1]
    if abs(e[3]) > 1e-9 * float(np.abs(e[:3]).max()):
        return e / e[3]
    if abs(e[2]) <= 1e-9 * float(np.abs(e[:3]).max()):
        raise ValueError("projection: the lines of sight lie in the view plane z = const (no depth); "
                         "SSAO needs a view direction with a z component")
    e = e / np.linalg.norm(e[:3]) * np.sign(e[2])
    e[3] = 0.0
    return e


@dataclass(frozen=True)
class AOFeatures:
    """Features of the AO pass.  ``normal_map``, ``alpha_map``, ``range_check``, ``plane_test``
    and ``blur`` are compile-time (-D options, absent from the program when off); ``distribution``
    picks the sample table, ``"lines"`` also the line-sample estimator (-D OCLS_LINES) and ``"rays"``
    the ray-sample one (-D OCLS_RAYS; m = rays), see the module docstring; ``blur_size`` (N of the
    N x N window, odd >= 3) is a kernel argument."""

    normal_map: bool = False
    alpha_map: bool = False
    range_check: bool = False
    plane_test: bool = False
    distribution: str = "paper"
    blur: str = "none"
    blur_size: int = 5
    #: ``plane_test``: a sample is occluded iff it lies at least delta below the tangent plane of
    #: the surface at its pixel (plane from the stored position and geometric normal), instead of
    #: the depth test on the pixel's line of sight; see kernels/ssao.cl step 4 (not in the paper).
    #: With line samples: each line (through the disk point, parallel to P's line of sight) is cut
    #: at that plane

    def __post_init__(self) -> None:
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}; got {self.distribution!r}")
        if self.blur not in BLURS:
            raise ValueError(f"blur must be one of {', '.join(BLURS)}; got {self.blur!r}")
        if not (isinstance(self.blur_size, int) and self.blur_size >= 3 and self.blur_size % 2 == 1):
            raise ValueError(f"blur_size must be an odd integer >= 3 (the paper's N >= 3), got {self.blur_size!r}")

    def defines(self) -> dict[str, object]:
        return {
            "OCLS_NORMAL_MAP": self.normal_map,
            "OCLS_ALPHA": self.alpha_map,
            "OCLS_RANGE_CHECK": self.range_check,
            "OCLS_PLANE_TEST": self.plane_test,
            "OCLS_LINES": self.distribution == "lines",
            "OCLS_RAYS": self.distribution == "rays",
            "OCLS_RAY_STEPS": RAY_STEPS if self.distribution == "rays" else False,
            "OCLS_BLUR_BOX": self.blur == "box",
            "OCLS_BLUR_EDGE": self.blur == "edge",
        }


#: the paper's recipe: its half-cube kernel, m = 32, no range check, a 5 x 5 box blur
PAPER_RECIPE = AOFeatures(distribution="paper", blur="box", blur_size=5)
PAPER_M = 32
#: the library default (``oclshade render --ao``, frames.AOSettings): 8 ray samples (32 depth tests,
#: as many as the recipe's), range check, 3 x 3 box blur.  Chosen against ray-traced AO (ground
#: truth b) by bench/ssao_bias.py (bench/results/ssao_bias.md): on all 24 views (the bundled canyon,
#: a generated terrain and two SRTM DEMs; views 200,12 / 135,30 / top; R 4 and 8 cells) its RMSE is
#: below the paper recipe's, 0.87 of it at worst and 0.55 on average.  The former default, 20 line
#: samples, estimates the volume fraction (a) instead and lost to the recipe against (b) on 20 of 24.
DEFAULT_FEATURES = AOFeatures(distribution="rays", range_check=True, blur="box", blur_size=3)
DEFAULT_M = 8


@dataclass
class AOInputs:
    """Device-resident inputs (``cl.Buffer`` s in the kernel's layout, see kernels/ssao.cl).

    position, normal: float4 per pixel; alpha: float per pixel (with the
    ``alpha_map`` feature); normal_map: float4 tangent-space normal per pixel
    and tangent: float4 view-space tangent + handedness (``normal_map``)."""

    shape: tuple[int, int]
    position: cl.Buffer
    normal: cl.Buffer
    alpha: cl.Buffer | None = None
    normal_map: cl.Buffer | None = None
    tangent: cl.Buffer | None = None


def _field(name: str, value: object, shape: tuple[int, int] | None, channels: int) -> np.ndarray:
    a = np.ascontiguousarray(value, dtype=np.float32)
    want = (shape if shape else a.shape[:2]) + ((channels,) if channels > 1 else ())
    if channels == 3 and a.shape[-1:] == (3,):   # xyz given without w: pad
        a = np.concatenate([a, np.zeros(a.shape[:-1] + (1,), np.float32)], axis=-1)
        channels = 4
        want = want[:2] + (4,)
    if a.shape != want or a.size == 0:
        raise ValueError(f"{name} must be a float array of shape {want}, got {np.shape(value)}")
    return a


def check_params(m: int, radius: float, delta: float) -> None:
    if not (isinstance(m, (int, np.integer)) and (m == 0 or M_MIN <= m <= M_MAX)):
        raise ValueError(f"m must be 0 (AO off) or an integer in {M_MIN}..{M_MAX}, got {m!r}")
    if not (math.isfinite(radius) and radius >= 0):
        raise ValueError(f"radius must be finite and >= 0 (0 = AO off), got {radius!r}")
    if not math.isfinite(delta):
        raise ValueError(f"delta must be finite, got {delta!r}")


def _projection(projection: object) -> np.ndarray:
    p = np.asarray(projection, np.float64)
    if p.shape != (4, 4) or not np.all(np.isfinite(p)):
        raise ValueError(f"projection must be a finite 4x4 matrix (view -> clip, column vectors), got shape {p.shape}")
    return p


class SSAO:
    """The AO pass on one device: sample tables and work buffers are kept between calls.
    ``lanes`` (pixels per work-item of the AO and box-blur kernels, -D OCLS_SSAO_LANES),
    ``group`` (work-group size) and ``own_builtins`` (inline built-ins, kernels/common.h) are
    the ``ssao`` family's tuning knobs (:data:`TUNING`; None:
    the device's tuning entry): they change the speed, never the result."""

    def __init__(self, device: str | int | Runtime | None = None, *, lanes: int | None = None,
                 group: int | None = None, own_builtins: int | None = None):
        rt = get_runtime(device)
        given = {k: v for k, v in (("lanes", lanes), ("group", group), ("own_builtins", own_builtins))
                 if v is not None}
        knobs = {**tuning.settings(rt, "ssao").values, **TUNING.check(given, partial=True)}
        self.lanes, self.group, self.own_builtins = knobs["lanes"], knobs["group"], bool(knobs["own_builtins"])
        self.runtime = rt
        self._tables: dict[tuple[int, str], cl.Buffer] = {}
        self._work: dict[str, cl.Buffer] = {}
        self._work_shape: tuple[int, int] | None = None

    # --- inputs --------------------------------------------------------------------
    def upload(self, gbuffer: GBuffer | None = None, *, position: object = None, normal: object = None,
               alpha: object = None, normal_map: object = None, tangent: object = None) -> AOInputs:
        """Copy host arrays to the device: a :class:`GBuffer` or position/normal arrays
        ((H, W, 4) float32, or (H, W, 3) xyz for the normal), plus the optional maps."""
        rt = self.runtime
        if gbuffer is not None:
            position, normal = gbuffer.position, gbuffer.normal
        if position is None or normal is None:
            raise ValueError("upload needs a gbuffer or both position and normal arrays")
        pos = _field("position", position, None, 4)
        shape = pos.shape[:2]
        nrm = _field("normal", normal, shape, 3 if np.shape(normal)[-1:] == (3,) else 4)
        inputs = AOInputs(shape, rt.to_device(pos, "G-buffer positions"), rt.to_device(nrm, "G-buffer normals"))
        if alpha is not None:
            inputs.alpha = rt.to_device(_field("alpha", alpha, shape, 1), "alpha map")
        if (normal_map is None) != (tangent is None):
            raise ValueError("normal_map and tangent go together (the tangent builds the TBN frame)")
        if normal_map is not None:
            inputs.normal_map = rt.to_device(_field("normal_map", normal_map, shape, 3 if np.shape(normal_map)[-1:] == (3,) else 4), "normal map")
            inputs.tangent = rt.to_device(_field("tangent", tangent, shape, 4), "tangents")
        return inputs

    # --- the pass ------------------------------------------------------------------
    def run(self, inputs: AOInputs, projection: object, *, radius: float, m: int = DEFAULT_M, delta: float = 0.0,
            features: AOFeatures = DEFAULT_FEATURES, seed: int = 0, alpha_eps: float = 0.5,
            plane_tol: float | None = None) -> cl.Buffer | None:
        """Enqueue the pass on device inputs; returns the AO buffer (float32 per pixel,
        row-major), or None when AO is off (radius 0 or m 0: factor 1, nothing launched).
        ``plane_tol`` (edge-aware blur) defaults to radius / 4."""
        check_params(m, float(radius), float(delta))
        proj = _projection(projection)
        if features.alpha_map and inputs.alpha is None:
            raise ValueError("features.alpha_map is on but no alpha map was given")
        if features.normal_map and inputs.normal_map is None:
            raise ValueError("features.normal_map is on but no normal map and tangents were given")
        if m == 0 or radius == 0:
            return None
        rt = self.runtime
        height, width = inputs.shape
        work = self._buffers(inputs.shape)
        defines = {**features.defines(), "OCLS_SSAO_LANES": self.lanes, "OCLS_OWN_BUILTINS": self.own_builtins,
                   "OCLS_DEPTH_TOL": f"{DEPTH_TOL.hex()}f"}
        dims = (np.int32(width), np.int32(height))

        prep = rt.kernel("ssao.cl", "ssao_prepare", defines)
        args: list = [inputs.position, inputs.normal]
        if features.alpha_map:
            args += [inputs.alpha, np.float32(alpha_eps)]
        if features.normal_map:
            args += [inputs.normal_map, inputs.tangent]
        plane = [work["plane"]] if features.plane_test else []
        prep.set_args(*args, *dims, work["zbuf"], work["normal"], *plane)
        self._launch(prep, width, height)

        ao = rt.kernel("ssao.cl", "ssao_ao", defines)
        rows = np.concatenate([0.5 * width * (proj[0] + proj[3]), 0.5 * height * (proj[3] - proj[1]), proj[3],
                               line_eye(proj)])
        prj = rt.to_device(rows.astype(np.float32), "projection rows")   # referenced until enqueued
        ao.set_args(inputs.position, work["normal"], work["zbuf"], *dims, prj, self._table(m, features.distribution),
                    np.int32(m), np.int32(-(-m // 8) * 8), np.float32(radius), np.float32(delta), np.uint32(seed), work["ao"], *plane)
        items = -(-width // self.lanes)   # `lanes` pixels per work-item
        self._launch(ao, items, height)
        if features.blur == "none":
            return work["ao"]
        half = np.int32(features.blur_size // 2)
        if features.blur == "box":
            bh = rt.kernel("ssao.cl", "ssao_box_h", defines)
            bh.set_args(work["ao"], work["zbuf"], *dims, half, work["tmp"])
            self._launch(bh, items, height)
            bv = rt.kernel("ssao.cl", "ssao_box_v", defines)
            bv.set_args(work["tmp"], work["zbuf"], *dims, half, work["out"])
            self._launch(bv, items, height)
        else:
            tol = float(radius) / 4.0 if plane_tol is None else float(plane_tol)
            if not (math.isfinite(tol) and tol > 0):
                raise ValueError(f"plane_tol must be positive and finite, got {plane_tol!r}")
            be = rt.kernel("ssao.cl", "ssao_edge", defines)
            be.set_args(work["ao"], inputs.position, work["normal"], work["zbuf"], *dims, half,
                        np.float32(tol), work["out"])
            self._launch(be, width, height)
        return work["out"]

    def compute(self, gbuffer: GBuffer | None, projection: object, *, radius: float, m: int = DEFAULT_M,
                delta: float = 0.0, features: AOFeatures = DEFAULT_FEATURES, seed: int = 0,
                alpha_eps: float = 0.5, plane_tol: float | None = None, **arrays: object) -> np.ndarray:
        """Host in, host out: the AO factor per pixel, float32 (H, W), 1 = unoccluded.
        ``arrays``: position=, normal=, alpha=, normal_map=, tangent= (see :meth:`upload`)."""
        inputs = self.upload(gbuffer, **arrays)
        buf = self.run(inputs, projection, radius=radius, m=m, delta=delta, features=features, seed=seed,
                       alpha_eps=alpha_eps, plane_tol=plane_tol)
        out = np.ones(inputs.shape, np.float32)
        if buf is not None:
            cl.enqueue_copy(self.runtime.queue, out, buf)
            self.runtime.queue.finish()
        return out

    # --- internals -----------------------------------------------------------------
    def _launch(self, kernel: cl.Kernel, width: int, height: int) -> None:
        gsize, lsize = self.runtime.grid_2d(kernel, width, height, self.group)
        cl.enqueue_nd_range_kernel(self.runtime.queue, kernel, gsize, lsize)

    def _table(self, m: int, distribution: str) -> cl.Buffer:
        key = (m, distribution)
        if key not in self._tables:
            mpad = -(-m // 8) * 8    # structure of arrays x[mpad], y[mpad], z[mpad]; NaN padding
            table = np.full((3, mpad), np.nan, np.float32)
            table[:, :m] = (line_table(m) if distribution in ("lines", "rays") else sample_kernel(m, distribution)[:, :3]).T
            self._tables[key] = self.runtime.to_device(table, "sample kernel")
        return self._tables[key]

    def _buffers(self, shape: tuple[int, int]) -> dict[str, cl.Buffer]:
        if self._work_shape != shape:
            n = shape[0] * shape[1]
            rt = self.runtime
            self._work = {"zbuf": rt.empty(4 * n, "AO depth"), "normal": rt.empty(16 * n, "AO normals"),
                          "ao": rt.empty(4 * n, "AO map"), "plane": rt.empty(16 * n, "occluder planes"), "tmp": rt.empty(8 * n, "blur sums"),
                          "out": rt.empty(4 * n, "blurred AO map")}
            self._work_shape = shape
        return self._work


def write_ao_exr(path: str | Path, ao: np.ndarray) -> None:
    """Write an AO map (float32 (H, W)) to OpenEXR, one channel named "AO" (atomic write)."""
    from .io import write_raster
    a = np.asarray(ao)
    if a.ndim != 2:
        raise ValueError(f"ao must be a 2-D (height, width) map, got shape {a.shape}")
    if Path(path).suffix.lower() != ".exr":
        raise ValueError(f"path must end in .exr, got {str(path)!r}")
    write_raster(path, a.astype(np.float32), band_names=["AO"])


def _case(rt: Runtime, size: int, width: int, height: int):
    from .camera import frame_heightmap
    from .terrain import Heightfield, TerrainRenderer
    field = Heightfield(tuning.standard_heightmap(size))
    camera = frame_heightmap(field.heightmap, width, height, 200.0, 25.0)
    return TerrainRenderer(field, rt).render(camera), camera.projection_matrix


def _smoke(rt: Runtime, knobs: tuning.Values) -> None:
    gbuffer, projection = _case(rt, 48, 40, 30)
    SSAO(rt, **knobs).compute(gbuffer, projection, radius=90.0)


def _workload(rt: Runtime, knobs: tuning.Values, quick: bool) -> Callable[[], None]:
    gbuffer, projection = _case(rt, 512 if quick else 1024, *((640, 360) if quick else (1920, 1080)))
    ssao = SSAO(rt, **knobs)
    inputs = ssao.upload(gbuffer)
    return lambda: ssao.run(inputs, projection, radius=90.0)


#: the SSAO pass's knobs (kernels/ssao.cl)
TUNING = tuning.register(tuning.Family(
    "ssao",
    (tuning.Param("lanes", (4, 8, 16), 8, "pixels per work-item on vector lanes (-D OCLS_SSAO_LANES)", vector=True,
                  rule="wider"),
     tuning.Param("group", (16, 64, 256), 64, "work-group size (work-items)"),
     tuning.OWN_BUILTINS),
    ("ssao.cl",), _smoke, _workload, "screen-space ambient occlusion (paper 001)"))
