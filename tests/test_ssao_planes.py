"""SSAO has no self-occlusion bias: nothing occludes a plane, so every estimator (the paper
recipe's point samples, line samples, ray samples and the default) reads 1 on a plane at any view
angle (grazing to face-on, perspective and orthographic), radius (a fraction of a pixel to tens of
pixels) and sample count, with delta = 0.  Stated bound: every pixel >= 1 - 1e-6 (for point and ray
samples, whose AO is a ratio of counts: exactly 1), so every mean is 1 within far less than 0.5 %.

Before the fix the depth test compared each sample with the depth at its pixel's centre, nearer
than an oblique plane at the sample on one side of the centre: flat ground and slopes read
0.90-0.97 (single pixels 0.76) in ``oclshade render --ao``.  The float64 twins model the same
sampling: the kernel-vs-twin tests are in test_ssao.py and test_ssao_lines.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from oclshade import reference as ref
from oclshade.camera import frame_heightmap
from oclshade.frames import AOSettings, FrameSettings, TerrainScene
from oclshade.heightmap import Heightmap
from oclshade.ssao import DEFAULT_FEATURES, PAPER_RECIPE, SSAO, AOFeatures, sample_kernel
from oclshade.terrain import Heightfield, TerrainRenderer

ESTIMATORS = {
    "points": AOFeatures(),                                  # the paper's kernel and test, no blur
    "paper-recipe": PAPER_RECIPE,
    "lines": AOFeatures(distribution="lines"),
    "rays": AOFeatures(distribution="rays"),
    "default": DEFAULT_FEATURES,
}
MS = (4, 8, 20, 32)
BOUND = 1e-6


@pytest.fixture(scope="module")
def ssao() -> SSAO:
    return SSAO()


def plane_view(angle: float, tilt: float, persp: bool, w: int = 64, h: int = 48, depth: float = 50.0):
    """A plane through (0, 0, -depth) whose normal is ``angle`` degrees off the view axis (0: facing
    the camera, 80: seen 10 degrees above grazing), turned ``tilt`` degrees about the view axis;
    positions where the pixel-centre rays meet it (float64, rounded once to float32), empty beyond
    20 x depth (the horizon).  Returns (projection, position, normal, pixel footprint at the centre)."""
    a, t = math.radians(angle), math.radians(tilt)
    n = np.array([math.sin(a) * math.sin(t), math.sin(a) * math.cos(t), math.cos(a)])
    ndc_x = (2 * (np.arange(w) + 0.5) / w - 1)[None, :]
    ndc_y = (1 - 2 * (np.arange(h) + 0.5) / h)[:, None]
    if persp:
        f = 1.0 / math.tan(math.radians(30))
        near, far = 0.1, 1000.0 * depth
        P = np.array([[f * h / w, 0, 0, 0], [0, f, 0, 0],
                      [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]])
        d = np.stack(np.broadcast_arrays(ndc_x / P[0, 0], ndc_y / P[1, 1], -np.ones((1, 1))), axis=-1)
        o = np.zeros(3)
        pixel = 2 * depth / (f * h)
    else:
        pixel = 0.5
        P = np.diag([2.0 / (w * pixel), 2.0 / (h * pixel), -1.0 / (100 * depth), 1.0])
        o = np.stack(np.broadcast_arrays(ndc_x * w * pixel / 2, ndc_y * h * pixel / 2, np.zeros((1, 1))), axis=-1)
        d = np.array([0.0, 0.0, -1.0])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (n @ np.array([0, 0, -depth]) - o @ n) / (d @ n)
    p3 = o + d * np.asarray(s)[..., None]
    hit = np.isfinite(s) & (s > 0) & (-p3[..., 2] < 20 * depth)
    pos = np.zeros((h, w, 4), np.float32)
    pos[hit, :3] = p3[hit]
    pos[hit, 3] = 1.0
    nrm = np.zeros((h, w, 4), np.float32)
    nrm[..., :3] = n
    return P, pos, nrm, pixel


def assert_open(ao: np.ndarray, hit: np.ndarray, what: str) -> None:
    a = ao[hit].astype(np.float64)
    assert a.size > 100, f"{what}: too few terrain pixels ({a.size})"
    assert a.mean() >= 1 - 0.005, f"{what}: mean {a.mean():.5f}"
    assert a.min() >= 1 - BOUND, f"{what}: lowest pixel {a.min():.6f}, {np.sum(a < 1 - BOUND)} pixels below"


@pytest.mark.parametrize("persp", [True, False], ids=["perspective", "orthographic"])
@pytest.mark.parametrize("angle", [0, 45, 70, 80])
def test_plane_reads_one(ssao: SSAO, persp: bool, angle: float) -> None:
    for tilt in (0.0, 35.0):
        P, pos, nrm, pixel = plane_view(angle, tilt, persp)
        hit = pos[..., 3] > 0.5
        for r_px in (0.5, 2.0, 8.0, 32.0):          # the radius in pixels of the view's centre
            for name, f in ESTIMATORS.items():
                for m in MS:
                    ao = ssao.compute(None, P, position=pos, normal=nrm, radius=r_px * pixel, m=m, features=f)
                    assert_open(ao, hit, f"{name} m {m}, R {r_px} px, angle {angle}, tilt {tilt}")


def slope_heights(n: int, slope: float, aspect: float) -> np.ndarray:
    """n x n heights (1 m cells) of a constant slope of ``slope`` degrees rising towards the compass
    direction ``aspect`` (degrees clockwise from north)."""
    i, j = np.mgrid[0:n, 0:n].astype(np.float64)
    a = math.radians(aspect)
    return math.tan(math.radians(slope)) * (math.sin(a) * j - math.cos(a) * i)


#: (slope, aspect, azimuth, elevation, projection): constant slopes seen from above their plane
SLOPES = [(0, 0, 200, 10, "perspective"), (30, 20, 200, 12, "perspective"), (30, 315, 135, 30, "perspective"),
          (45, 110, 200, 60, "perspective"), (10, 250, 200, 90, "perspective"), (30, 0, 135, 30, "orthographic"),
          (60, 20, 200, 90, "orthographic")]


@pytest.mark.parametrize("slope,aspect,azimuth,elevation,projection", SLOPES)
def test_rendered_constant_slope_reads_one(ssao: SSAO, slope, aspect, azimuth, elevation, projection) -> None:
    hm = Heightmap.from_array(slope_heights(96, slope, aspect), 1.0)
    cam = frame_heightmap(hm, 160, 90, azimuth, elevation, projection=projection)
    gb = TerrainRenderer(Heightfield(hm)).render(cam)
    for r_cells in (0.5, 2.0, 8.0):
        for name, f in ESTIMATORS.items():
            for m in MS:
                ao = ssao.compute(gb, cam.projection_matrix, radius=r_cells, m=m, features=f)
                assert_open(ao, gb.hit, f"{name} m {m}, R {r_cells} cells")


@pytest.mark.parametrize("slope", [0, 30])
def test_render_ao_on_flat_ground_and_a_slope(slope: float) -> None:
    # the case: `oclshade render DEM out.png --ao 4` / `--ao 8` at 640x360, views 200,12 and
    # 135,30 (frames.TerrainScene is what the CLI runs); a 30-degree slope rising away from the camera
    hm = Heightmap.from_array(slope_heights(192, slope, 20.0), 1.0)
    scene = TerrainScene(Heightfield(hm))
    for view in ((200.0, 12.0), (135.0, 30.0)):
        cam = frame_heightmap(hm, 640, 360, *view)
        for cells in (4, 8):
            frame = scene.frame(cam, (135.0, 40.0), FrameSettings(shadows=False, ao=AOSettings(radius=float(cells))))
            assert_open(frame.ao_factor(), frame.gbuffer.to_host().hit, f"view {view}, --ao {cells}")


def test_the_pixel_centre_depth_test_was_the_bias() -> None:
    # what the fix removes, in float64: the paper's test (sample vs the depth at its pixel's centre)
    # on a 60-degree slope seen from above with pixels of half the radius finds false occluders;
    # the test on the pixel's line of sight (the twin of the kernel) finds none
    w, h, px, R = 40, 32, 2.0, 4.0
    x = (np.arange(w) + 0.5 - w / 2) * px
    y = (h / 2 - np.arange(h) - 0.5) * px
    X, Y = np.meshgrid(x, y)
    s = math.tan(math.radians(60))
    pos = np.stack([X, Y, -50 + s * X, np.ones_like(X)], axis=-1).astype(np.float32)
    n = np.array([-s, 0.0, 1.0]) / math.hypot(s, 1.0)
    nrm = np.concatenate([np.broadcast_to(n, (h, w, 3)), np.zeros((h, w, 1))], axis=-1).astype(np.float32)
    P = np.diag([2.0 / (w * px), 2.0 / (h * px), -1e-3, 1.0])
    kernel = sample_kernel(32, "paper")[:, :3].astype(np.float64)
    tw = ref.ssao(pos, nrm, P, kernel, R, 0.0)
    np.testing.assert_array_equal(tw.ao, 1.0)
    # the old rule: A against zbuf at floor(pixel of A), no snapping
    rr, cc = np.nonzero(np.ones((h, w), bool))
    T, B = ref.ao._rotated_frame(ref.rotation_vectors(w, h, 0)[rr, cc], np.broadcast_to(n, (rr.size, 3)))
    Pp = pos[rr, cc, :3].astype(np.float64)
    occluded = np.zeros(rr.size)
    for sx, sy, sz in kernel:
        A = Pp + R * (T * sx + B * sy + n * sz)
        on, j, _ = ref.ao._pixel_of(A, P, w, h, np.zeros(rr.size))
        occluded += on & (pos[..., 2].ravel()[j] >= A[:, 2])
    assert occluded.sum() / (32 * rr.size) > 0.03
