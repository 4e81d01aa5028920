"""Environment maps: face table, seam-continuous filtering and lat-long <-> cube conversion on
the device against the float64 twins (oclshade.reference.envmap), and the file layouts."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from oclshade.envmap import CubeMap, cube_frame, latlong_to_cube
from oclshade.envmap.files import EnvmapFileError, load_cube, read_image, save_cube
from oclshade.reference import envmap as ref

EPS = float(np.finfo(np.float32).eps)
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "envmaps"


def smooth_cube(n: int) -> np.ndarray:
    """A smooth map: colour = a smooth function of the direction of each texel centre."""
    d = ref.texel_directions(n)
    return (0.5 + 0.5 * np.stack([d[..., 0], d[..., 1] * d[..., 2], np.sin(2 * d[..., 2])], -1)).astype(np.float32)


def random_directions(rng: np.random.Generator, count: int) -> np.ndarray:
    d = rng.normal(size=(count, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# --- face table ------------------------------------------------------------------------------

def test_face_table_axes_and_corners():
    f, s, t = ref.face_st(np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float))
    assert list(f) == [0, 1, 2, 3, 4, 5] and np.all(s == 0.5) and np.all(t == 0.5)
    # +X face: s grows towards -z, t towards -y (OpenGL); +Y face: t grows towards +z
    f, s, t = ref.face_st(np.array([[1.0, 0.5, -0.5], [0.5, 1.0, 0.5]]))
    assert list(f) == [0, 2] and s[0] == 0.75 and t[0] == 0.25 and s[1] == 0.75 and t[1] == 0.75
    # ties: x before y before z
    f, _, _ = ref.face_st(np.array([[1.0, 1.0, 1.0], [0.0, -1.0, 1.0]]))
    assert list(f) == [0, 3]


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=20, deadline=None)
def test_face_direction_inverts_face_st(seed):
    d = random_directions(np.random.default_rng(seed), 200)
    f, s, t = ref.face_st(d)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    back = ref.face_direction(f, s, t)
    back /= np.linalg.norm(back, axis=1, keepdims=True)
    assert np.max(np.abs(back - d)) < 1e-14


def test_cube_frame_puts_the_sky_on_plus_y():
    m = cube_frame()
    assert np.allclose(m @ [0, 0, 1], [0, 1, 0]) and np.allclose(m @ [1, 0, 0], [1, 0, 0])
    assert np.allclose(m @ [0, -1, 0], [0, 0, 1])                 # south -> +Z (lat-long centre)
    assert np.allclose(cube_frame(90.0) @ [1, 0, 0], [0, 0, 1])   # turned: east -> +Z
    assert np.isclose(np.linalg.det(m), 1.0)
    with pytest.raises(ValueError, match="rotation"):
        cube_frame(float("nan"))


# --- filtering (reference) ---------------------------------------------------------------------

def test_reference_filter_is_exact_at_texel_centres_and_continuous_on_seams():
    faces = np.random.default_rng(2).random((6, 8, 8, 3))
    assert np.max(np.abs(ref.sample_cube(faces, ref.texel_directions(8)) - faces)) < 1e-12
    assert ref.seam_jump(faces) < 1e-12


def clamped_seam_jump(faces: np.ndarray) -> float:
    """The seam jump of bilinear filtering clamped to each face (no border): what the border fixes."""
    n = faces.shape[1]
    worst = 0.0
    for f in range(6):
        for axis in (0, 1):
            for edge in (0, n - 1):
                here = faces[f, edge] if axis == 0 else faces[f, :, edge]
                d = ref.face_direction(np.full(n, f), *(((np.arange(n) + 0.5) / n, np.full(n, edge // (n - 1)))
                                                       if axis == 0 else (np.full(n, edge // (n - 1)),
                                                                          (np.arange(n) + 0.5) / n)))
                g, s, t = ref._across_seam(d, f)
                there = faces[g, np.clip((t * n).astype(int), 0, n - 1), np.clip((s * n).astype(int), 0, n - 1)]
                worst = max(worst, float(np.max(np.abs(0.5 * (here - there)))))
    return worst


def test_seam_error_measured_against_a_clamped_filter():
    faces = np.random.default_rng(3).random((6, 16, 16, 3))
    assert ref.seam_jump(faces) < 1e-12 < 0.1 < clamped_seam_jump(faces)


# --- device against the twins -------------------------------------------------------------------

@given(st.integers(0, 2**32 - 1), st.integers(1, 9), st.integers(2, 24), st.integers(1, 12))
@settings(max_examples=12, deadline=None)
def test_latlong_to_cube_matches_the_twin(seed, n, w, h):
    """Bound: the texel position u = (pi - atan2) / 2pi W carries the float32 rounding of atan2
    and hypot (<= 6 and 4 ulp, OpenCL 1.2 sec. 7.4) and of the scaling, |du| <= 16 eps W (and
    16 eps H in v); the value moves by at most |du| + |dv| times the largest texel step, plus
    the blend's own rounding (8 eps of the largest texel)."""
    ll = np.random.default_rng(seed).random((h, w, 3)).astype(np.float32)
    got = latlong_to_cube(ll, n).bordered()[:, 1:-1, 1:-1, :3]
    want = ref.latlong_to_cube(ll, n)
    assert np.max(np.abs(got - want)) <= (16.0 * (w + h) + 8.0) * EPS * ll.max()


@given(st.integers(0, 2**32 - 1), st.integers(1, 10), st.integers(1, 16))
@settings(max_examples=12, deadline=None)
def test_cube_to_latlong_matches_the_twin(seed, n, h):
    """Bound: sin, cos (<= 4 ulp) and the division sc / ma give |ds| <= 16 eps, so the texel
    position moves by <= 16 eps N; ties of the major-axis rule cost nothing (the filter is
    continuous across seams); plus 8 eps of rounding in the blend."""
    faces = np.random.default_rng(seed).random((6, n, n, 3)).astype(np.float32)
    got = CubeMap(faces).to_latlong(h, 2 * h + 1)
    want = ref.cube_to_latlong(faces, h, 2 * h + 1)
    assert np.max(np.abs(got - want)) <= (32.0 * (n + 1) + 8.0) * EPS * faces.max()


def test_device_border_matches_the_reference_seam_rule():
    n = 5
    faces = np.random.default_rng(4).random((6, n, n, 3)).astype(np.float32)
    bordered = CubeMap(faces).to_device().bordered()[..., :3]
    i = np.arange(-1, n + 1)
    ii, jj = np.meshgrid(i, i, indexing="ij")
    for f in range(6):
        want = ref._tap(faces, np.full(ii.shape, f), ii, jj)
        assert np.max(np.abs(bordered[f] - want)) <= 2 * EPS, f


def test_device_samples_are_continuous_across_seams():
    """Lat-long texel centres straddle the seams; the device's values there stay within the
    map's own slope of the twin's (continuous), unlike a clamped filter's half-texel jumps."""
    faces = np.random.default_rng(5).random((6, 4, 4, 3)).astype(np.float32)
    got = CubeMap(faces).to_latlong(64, 128)
    want = ref.cube_to_latlong(faces, 64, 128)
    assert np.max(np.abs(got - want)) <= (32.0 * 5 + 8.0) * EPS


# --- files ----------------------------------------------------------------------------------------

def exr_cube_direction(face: int, n: int) -> np.ndarray:
    """OpenEXR's direction of every pixel of one face of an ENVMAP_CUBE image (ImfEnvmap.cpp:
    CubeMap::direction of the position-in-face that pixelPosition puts at that pixel)."""
    row, col = np.mgrid[0:n, 0:n].astype(float)
    top = n - 1
    # pixelPosition inverted per face: (pif.x, pif.y) of pixel (col, row of the face)
    pif = {0: (top - row, col), 1: (top - row, top - col), 2: (col, top - row), 3: (col, row),
           4: (top - col, top - row), 5: (col, top - row)}[face]
    px, py = (2.0 * pif[0] / top - 1.0, 2.0 * pif[1] / top - 1.0)
    one = np.ones_like(px)
    d = {0: (one, px, py), 1: (-one, px, py), 2: (px, one, py), 3: (px, -one, py), 4: (px, py, one),
         5: (px, py, -one)}[face]
    d = np.stack(d, -1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_openexr_cube_layout_puts_every_texel_in_its_direction(tmp_path):
    """An OpenEXR cube whose texels hold their own (OpenEXR) directions, read back: every
    texel of our faces holds our direction, to within OpenEXR's pixel convention (its edge
    texel centres sit on the cube's edges, ours half a texel in: <= 1/N of angle)."""
    import OpenEXR
    n = 16
    image = np.concatenate([exr_cube_direction(f, n) for f in range(6)]).astype(np.float32)
    path = tmp_path / "dirs.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, "envmap": OpenEXR.ENVMAP_CUBE}
    with OpenEXR.File(header, {"RGB": image}) as exr:
        exr.write(str(path))
    cube = load_cube(path)
    cos = np.sum(cube.faces * ref.texel_directions(n), -1)
    assert cos.min() > math.cos(1.0 / n)


def test_openexr_latlong_layout(tmp_path):
    """OpenEXR's lat-long directions (LatLongMap::direction at its pixel positions) land on
    ours within its pixel convention (first and last column at lon = +-pi: <= one texel)."""
    h, w = 16, 32
    r, c = np.mgrid[0:h, 0:w].astype(float)
    lat = -math.pi * (r / (h - 1) - 0.5)
    lon = -2 * math.pi * (c / (w - 1) - 0.5)
    d = np.stack([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)], -1)
    cos = np.sum(d * ref.latlong_directions(h, w), -1)
    assert cos.min() > math.cos(2 * math.pi / w + math.pi / h)


@pytest.mark.parametrize("layout", ["cube", "hcross", "vcross", "faces", "latlong"])
@pytest.mark.parametrize("ext", [".exr", ".hdr"])
def test_layouts_round_trip(tmp_path, layout, ext):
    n = 8
    faces = smooth_cube(n)
    name = "env_{face}" + ext if layout == "faces" else "env" + ext
    save_cube(tmp_path / name, CubeMap(faces), layout)
    back = load_cube(tmp_path / name, layout if layout != "latlong" else None, size=n if layout == "latlong" else None)
    tol = {".exr": 0.0, ".hdr": 1.0 / 128}[ext]
    if layout == "latlong":   # resampled twice: bilinear smoothing of a smooth map
        tol += 0.05
    assert np.max(np.abs(back.faces - faces)) <= tol * max(1.0, faces.max()) + 1e-7


def test_crosses_are_continuous_across_their_folds(tmp_path):
    """Neighbouring cells of a written cross show neighbouring directions: in the horizontal
    cross the centre cell is F's -Z (the left-handed "+Z"), +X on its right, +Y above."""
    n = 16
    dirs = ref.texel_directions(n).astype(np.float32) * 0.5 + 0.5
    save_cube(tmp_path / "h.exr", CubeMap(dirs), "hcross")
    img, _ = read_image(tmp_path / "h.exr")
    centre = img[n:2 * n, n:2 * n]
    assert np.allclose(centre[n // 2, n // 2] * 2 - 1, [0, 0, -1], atol=2.0 / n)
    assert np.allclose(img[n + n // 2, 2 * n + n // 2] * 2 - 1, [1, 0, 0], atol=2.0 / n)   # right: +X
    assert np.allclose(img[n // 2, n + n // 2] * 2 - 1, [0, 1, 0], atol=2.0 / n)           # top: +Y
    # every fold of the middle row and of the +-Y cells: adjacent pixels differ by ~ a texel
    for a, b in ((img[n:2 * n, n - 1], img[n:2 * n, n]), (img[n:2 * n, 2 * n - 1], img[n:2 * n, 2 * n]),
                 (img[n:2 * n, 3 * n - 1], img[n:2 * n, 3 * n]), (img[n - 1, n:2 * n], img[n, n:2 * n]),
                 (img[2 * n - 1, n:2 * n], img[2 * n, n:2 * n]), (img[n:2 * n, 0], img[n:2 * n, 4 * n - 1])):
        assert np.max(np.abs(a - b)) < 2.0 / n
    save_cube(tmp_path / "v.exr", CubeMap(dirs), "vcross")
    v, _ = read_image(tmp_path / "v.exr")
    assert np.max(np.abs(v[3 * n - 1, n:2 * n] - v[3 * n, n:2 * n])) < 2.0 / n   # -Y / -Z fold


def test_layout_errors(tmp_path):
    save_cube(tmp_path / "odd.exr", CubeMap(smooth_cube(4)), "cube")
    with pytest.raises(EnvmapFileError, match="hcross image must be 4N x 3N"):
        load_cube(tmp_path / "odd.exr", "hcross")
    with pytest.raises(EnvmapFileError, match="no such file"):
        load_cube(tmp_path / "missing.exr")
    with pytest.raises(EnvmapFileError, match="unknown image extension"):
        load_cube(tmp_path / "x.jpg")
    with pytest.raises(ValueError, match="layout must be one of"):
        load_cube(tmp_path / "odd.exr", "sphere")
    from PIL import Image
    Image.fromarray(np.zeros((5, 7, 3), np.uint8)).save(tmp_path / "x.png")
    with pytest.raises(EnvmapFileError, match="cannot tell the layout of a 7x5 image"):
        load_cube(tmp_path / "x.png")
    with pytest.raises(ValueError, match="NaN or infinite"):
        CubeMap(np.full((6, 2, 2, 3), np.nan))


def test_png_is_decoded_from_srgb(tmp_path):
    from PIL import Image
    Image.fromarray(np.array([[[0, 255, 188]] * 2], np.uint8)).save(tmp_path / "p.png")
    img, _ = read_image(tmp_path / "p.png")
    assert img.shape == (1, 2, 3)
    assert np.allclose(img[0, 0], [0.0, 1.0, ((188 / 255 + 0.055) / 1.055) ** 2.4], atol=1e-6)


# --- real data ---------------------------------------------------------------------------------------

def shared(name: str) -> Path:
    path = DATA / name
    if not path.is_file():
        pytest.skip(f"{path} not present (real data lives in ../shared/data)")
    return path


def test_kerner_pair_agrees():
    """docs/reflections.md: the lat-long file resampled to 256^2 faces against the cube file:
    median relative error 0.8 % (OpenEXR's own pixel convention would give 0.4 %)."""
    cube = load_cube(shared("KernerEnvCube.exr"))
    conv = load_cube(shared("KernerEnvLatLong.exr"), size=cube.size)
    a, b = conv.faces.astype(np.float64), cube.faces.astype(np.float64)
    rel = np.abs(a - b) / (b + 1e-3 * b.mean())
    assert np.median(rel) < 0.012 and np.percentile(rel, 95) < 0.2


def test_orientation_pair_faces():
    """The Orientation cube's faces (each labelled with its axis) hold what the Orientation
    lat-long shows in their directions: both files are read into the same frame F."""
    cube = load_cube(shared("OrientationCube.exr"))
    conv = load_cube(shared("OrientationLatLong.exr"), size=cube.size)
    diff = np.abs(conv.faces - cube.faces)
    ink = cube.faces.min(-1) < 0.8             # labels, text and guide lines on a white ground
    per_face = [float(diff[f][ink[f]].mean()) for f in range(6)]
    assert max(per_face) < 0.15, per_face      # 0.06-0.10 measured; a face flipped gives 0.30
