"""The C host API's mip pyramid, terrain G-buffer, shading normals, per-pixel shadows, SSAO
(tables and passes) and compose entry points, and the host/examples/render_frame.c example,
against the Python host bit for bit, on generated and real maps.

The C side is host/tests/host_passes.c (one subcommand per family; it also checks itself that
pitched fields at offsets and other tuning knobs give the same bits).  The build of host/ is
the session fixture of tests/test_host_api.py.  Real data: /work/shared/data (skipped when
absent).
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade.camera import Camera
from oclshade.cli import main as cli_main
from oclshade.compose import Lighting, compose, compose_linear
from oclshade.heightmap import Heightmap
from oclshade.pyramid import build_mip_levels
from oclshade.screen_shadows import LodOptions, ScreenShadowCaster
from oclshade.ssao import SSAO, AOFeatures, line_table, sample_kernel
from oclshade.terrain import Heightfield, TerrainRenderer
from oclshade.tuning import family
from oclshade.tuning.rules import rule_values

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)

REAL_DEM = Path("/work/shared/data/dem/whiteboxR/DEM.tif")
SAMPLES = ("paper", "uniform", "centre", "lines", "rays")
BLURS = ("none", "box", "edge")
METHODS = ("exact", "paper", "maxmip", "dda")
CASTERS = ("bisect", "march", "dda")
GBUFFER = {"position": 4, "normal": 4, "uv": 2, "uv_grad": 4, "depth": 1, "albedo": 4}


def random_map(rows: int = 45, cols: int = 58, holes: bool = True) -> Heightmap:
    rng = np.random.default_rng(23)
    h = np.cumsum(rng.normal(size=(rows, cols)), axis=0) * 6.0 + np.cumsum(rng.normal(size=(rows, cols)), axis=1) * 6.0
    h += 800.0
    if holes:
        h[rng.random(h.shape) < 0.02] = np.nan
    return Heightmap.from_array(h, (25.0, 30.0))


def real_map() -> Heightmap:
    if not REAL_DEM.is_file():
        pytest.skip(f"{REAL_DEM} not present (real data lives outside the repository)")
    from oclshade.io import read_dem

    raster = read_dem(REAL_DEM)
    return Heightmap.from_array(raster.heights[:120, :150], (raster.dx, raster.dy))


def camera_over(hm: Heightmap, width: int, height: int, projection: str = "perspective") -> Camera:
    rows, cols = hm.shape
    lo = float(np.nanmin(hm.heights))
    hi = float(np.nanmax(hm.heights))
    target = np.array([0.45 * cols * hm.dx, -0.55 * rows * hm.dy, lo])
    position = target + np.array([-0.3, -1.1, 0.55]) * max(cols * hm.dx, rows * hm.dy) + np.array([0, 0, hi - lo])
    extent = float(np.hypot(cols * hm.dx, rows * hm.dy))
    if projection == "orthographic":
        return Camera(position, target, width, height, near=0.0, far=3 * extent + 2 * (hi - lo),
                      projection="orthographic", ortho_height=0.8 * extent)
    return Camera(position, target, width, height, fov=50.0, near=1.0, far=4 * extent)


def camera_spec(cam: Camera) -> str:
    """host_passes' CAMERA argument for a Camera (floats as repr: exact round trips)."""
    size = cam.ortho_height if cam.projection == "orthographic" else cam.fov
    numbers = [*cam.position, *cam.look_at, size, cam.near, cam.far]
    kind = "ortho" if cam.projection == "orthographic" else "look"
    return f"{kind}:" + ",".join([*(repr(float(v)) for v in numbers), str(cam.width), str(cam.height)])


def load(folder: Path, name: str, dtype, shape=None) -> np.ndarray:
    a = np.fromfile(folder / name, dtype)
    return a if shape is None else a.reshape(shape)


def save_heights(tmp: Path, hm: Heightmap) -> Path:
    path = tmp / "heights.f64"
    np.ascontiguousarray(hm.heights, np.float64).tofile(path)
    return path


# ------------------------------------------------------------------------ mip pyramid and tables
@pytest.mark.parametrize("shape", [(37, 53), (1, 1), (1, 9), (64, 3), (17, 17)])
def test_mip_pyramid(host: dict, tmp_path: Path, shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(shape[0] * 100 + shape[1])
    values = (rng.normal(size=shape) * 50).astype(np.float32)
    values[rng.random(shape) < 0.15] = np.nan
    values.tofile(tmp_path / "in.f32")
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_passes", "mip", out, tmp_path / "in.f32", *shape)
    levels = build_mip_levels(values)
    raw = (out / "mip.bin").read_bytes()
    rows = [tuple(map(int, line.split())) for line in (out / "mip_layout.txt").read_text().splitlines()]
    assert len(rows) == len(levels) - 1
    for level, (r, c, offset) in zip(levels[1:], rows):
        assert level.shape == (r, c)
        assert raw[offset:offset + 4 * r * c] == level.tobytes()


def test_ssao_tables(host: dict, tmp_path: Path) -> None:
    """The C generator's tables (numpy's PCG64 for the paper's, golden-ratio and Vogel sets for
    the others) are the Python host's, bit for bit, for every m tried."""
    run_program(host, "host_passes", "tables", tmp_path)
    for code, name in enumerate(SAMPLES):
        for m in (4, 5, 8, 13, 32, 100, 256):
            mpad = -(-m // 8) * 8
            want = np.full((3, mpad), np.nan, np.float32)
            want[:, :m] = (line_table(m) if name in ("lines", "rays") else sample_kernel(m, name)[:, :3]).T
            assert (tmp_path / f"table_{code}_{m}.f32").read_bytes() == want.tobytes(), (name, m)


# ------------------------------------------------------------------------ SSAO
SSAO_SPECS = [  # samples, m, range_check, plane_test, blur, blur_size, radius, delta, seed, alpha, normal_map
    ("rays", 8, 1, 0, "box", 3, 90.0, 0.0, 0, 0, 0),      # the library default
    ("paper", 32, 0, 0, "box", 5, 60.0, 0.5, 3, 0, 0),    # the paper's recipe
    ("uniform", 13, 1, 1, "edge", 5, 80.0, 0.0, 1, 0, 0),
    ("centre", 16, 0, 0, "none", 3, 70.0, 0.0, 0, 1, 0),
    ("lines", 20, 1, 0, "box", 7, 50.0, 1.0, 9, 0, 1),
    ("lines", 9, 0, 1, "edge", 3, 100.0, 0.0, 0, 1, 1),
    ("rays", 5, 0, 1, "none", 3, 40.0, 0.0, 2, 0, 0),
]


def ssao_case(host: dict, tmp_path: Path, hm: Heightmap, width: int, height: int) -> None:
    cam = camera_over(hm, width, height)
    gbuf = TerrainRenderer(Heightfield(hm)).render(cam)
    inputs = tmp_path / "in"
    inputs.mkdir()
    gbuf.position.tofile(inputs / "position.f32")
    gbuf.normal.tofile(inputs / "normal.f32")
    cam.projection_matrix.astype(np.float64).tofile(inputs / "projection.f64")
    rng = np.random.default_rng(7)
    alpha = rng.random((height, width)).astype(np.float32)
    normal_map = rng.normal(size=(height, width, 4)).astype(np.float32)
    normal_map[..., 3] = 0.0
    normal_map[..., :3] /= np.linalg.norm(normal_map[..., :3], axis=-1, keepdims=True)
    tangent = rng.normal(size=(height, width, 4)).astype(np.float32)
    tangent[..., 3] = np.sign(tangent[..., 3])
    alpha.tofile(inputs / "alpha.f32")
    normal_map.tofile(inputs / "normal_map.f32")
    tangent.tofile(inputs / "tangent.f32")
    specs = [",".join(str(SAMPLES.index(v) if i == 0 else BLURS.index(v) if i == 4 else v) for i, v in enumerate(s))
             for s in SSAO_SPECS]
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_passes", "ssao", out, inputs, width, height, *specs)
    ssao = SSAO()
    for k, (samples, m, rc, pt, blur, size, radius, delta, seed, al, nm) in enumerate(SSAO_SPECS):
        features = AOFeatures(normal_map=bool(nm), alpha_map=bool(al), range_check=bool(rc), plane_test=bool(pt),
                              distribution=samples, blur=blur, blur_size=size)
        maps = {"alpha": alpha} if al else {}
        if nm:
            maps.update(normal_map=normal_map, tangent=tangent)
        want = ssao.compute(None, cam.projection_matrix, radius=radius, m=m, delta=delta, features=features,
                            seed=seed, position=gbuf.position, normal=gbuf.normal, **maps)
        assert load(out, f"ao_{k}.f32", np.float32).tobytes() == want.tobytes(), SSAO_SPECS[k]


def test_ssao_random(host: dict, tmp_path: Path) -> None:
    ssao_case(host, tmp_path, random_map(), 53, 37)


def test_ssao_real(host: dict, tmp_path: Path) -> None:
    ssao_case(host, tmp_path, real_map(), 64, 40)


# ------------------------------------------------------------------------ terrain G-buffer
def terrain_case(host: dict, tmp_path: Path, hm: Heightmap, cam: Camera, caster: str = "bisect",
                 radius: float | None = None, colour: np.ndarray | None = None, matrices: bool = False) -> None:
    field = Heightfield(hm, radius, colour)
    renderer = TerrainRenderer(field)
    extra = tmp_path / "extra"
    extra.mkdir()
    spec = camera_spec(cam)
    if matrices:
        cam.view.astype(np.float64).tofile(extra / "view.f64")
        cam.projection_matrix.astype(np.float64).tofile(extra / "projection.f64")
        spec = f"matrices:{cam.width},{cam.height}"
    if colour is not None:
        tex, table, count = renderer.texture
        q = renderer.runtime.queue
        texels = np.empty(tex.size // 4, np.float32)
        levels = np.empty(4 * count, np.int32)
        cl.enqueue_copy(q, texels, tex)
        cl.enqueue_copy(q, levels, table)
        texels.tofile(extra / "texture.f32")
        levels.tofile(extra / "texture_levels.i32")
        (extra / "texture_count.txt").write_text(f"{count} {texels.size // 4}\n")
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_passes", "terrain", out, save_heights(tmp_path, hm), *hm.shape, repr(hm.dx), repr(hm.dy),
                repr(radius or 0.0), CASTERS.index(caster) + 1, spec, extra)
    assert load(out, "relative.f32", np.float32).tobytes() == hm.relative32.tobytes()
    assert load(out, "offset.f64", np.float64)[0] == hm.offset
    # the camera's maths: rotation, slopes and depths exactly; the translation up to numpy's
    # matrix-vector product (OpenBLAS dgemv sums in its own order)
    c = load(out, "camera.f64", np.float64)
    view, proj = c[:16].reshape(4, 4), c[16:32].reshape(4, 4)
    assert np.array_equal(view[:3, :3], cam.view[:3, :3]) and np.array_equal(view[3], cam.view[3])
    np.testing.assert_allclose(view[:3, 3], cam.view[:3, 3], rtol=1e-15, atol=1e-12)
    assert np.array_equal(proj, cam.projection_matrix)
    if matrices:   # sx = 1 / (1 / sx), near and far solved from the projection: up to its rounding,
        # which far inherits amplified by far / near (m22 + 1 = -2 near / (far - near) cancels)
        np.testing.assert_allclose(c[32:], [*cam.scale, cam.near, cam.far], rtol=1e-14 * cam.far / cam.near)
    else:
        assert list(c[32:]) == [*cam.scale, cam.near, cam.far]
    # the dilated levels' layout follows the leaf knob: Python's with the C handle's knobs (the
    # rule); the G-buffer below comes from Python's own tuning (knobs never change its bits)
    rule = rule_values(family("terrain"), renderer.runtime.device)
    dil, table = TerrainRenderer(field, renderer.runtime, **rule).dilated
    q = renderer.runtime.queue
    want_dil = np.empty(dil.size // 4, np.float32)
    want_table = np.empty(table.size // 4, np.int32)
    cl.enqueue_copy(q, want_dil, dil)
    cl.enqueue_copy(q, want_table, table)
    q.finish()
    assert (out / "dilated.f32").read_bytes() == want_dil.tobytes()
    assert (out / "dilated_table.i32").read_bytes() == want_table.tobytes()
    gbuf = renderer.render(cam, caster)
    for name in GBUFFER:
        want = getattr(gbuf, name)
        assert (out / f"gbuffer_{name}.f32").read_bytes() == want.tobytes(), name
    assert np.any(gbuf.position[..., 3] > 0.5) and np.any(gbuf.position[..., 3] < 0.5), "a view with sky and terrain"
    normals = renderer.shading_normals(cam, gbuf, caster)
    assert (out / "normals.f32").read_bytes() == normals.tobytes()


def test_terrain_random(host: dict, tmp_path: Path) -> None:
    hm = random_map()
    terrain_case(host, tmp_path, hm, camera_over(hm, 61, 43))


@pytest.mark.parametrize("caster", ["march", "dda"])
def test_terrain_other_casters(host: dict, tmp_path: Path, caster: str) -> None:
    hm = random_map(33, 29)
    terrain_case(host, tmp_path, hm, camera_over(hm, 41, 31), caster)


def test_terrain_orthographic_sphere_colour(host: dict, tmp_path: Path) -> None:
    hm = random_map(40, 36)
    colour = (np.random.default_rng(2).random((17, 23, 3)) * 255).astype(np.uint8)
    terrain_case(host, tmp_path, hm, camera_over(hm, 47, 35, "orthographic"), radius=6371e3 / 50, colour=colour)


def test_terrain_camera_from_matrices(host: dict, tmp_path: Path) -> None:
    """An engine's view and projection matrices give the G-buffer of the camera they came from."""
    hm = random_map(30, 40, holes=False)
    terrain_case(host, tmp_path, hm, camera_over(hm, 50, 30), matrices=True)


def test_terrain_real(host: dict, tmp_path: Path) -> None:
    hm = real_map()
    terrain_case(host, tmp_path, hm, camera_over(hm, 80, 50))


# ------------------------------------------------------------------------ per-pixel shadows
def pixels_case(host: dict, tmp_path: Path, hm: Heightmap, cam: Camera, sun: tuple[float, float], method: str,
                lod: LodOptions, k: tuple[float, float]) -> None:
    gbuf = TerrainRenderer(Heightfield(hm)).render(cam)
    inputs = tmp_path / "in"
    inputs.mkdir()
    for name in ("position", "uv", "uv_grad"):
        getattr(gbuf, name).tofile(inputs / f"{name}.f32")
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_passes", "pixels", out, save_heights(tmp_path, hm), *hm.shape, repr(hm.dx), repr(hm.dy),
                inputs, cam.width, cam.height, f"{sun[0]!r},{sun[1]!r}", METHODS.index(method) + 1,
                -1 if lod.force_q is None else lod.force_q, lod.bias, lod.n_a_max, repr(k[0]), repr(k[1]))
    caster = ScreenShadowCaster(hm)
    grids, offsets = caster.coarse
    q = caster.runtime.queue
    want_grids = np.empty(grids.size // 4, np.float32)
    want_offsets = np.empty(offsets.size // 4, np.int32)
    cl.enqueue_copy(q, want_grids, grids)
    cl.enqueue_copy(q, want_offsets, offsets)
    q.finish()
    assert (out / "coarse.f32").read_bytes() == want_grids.tobytes()
    assert (out / "coarse_offsets.i32").read_bytes() == want_offsets.tobytes()
    res = caster.shade(gbuf, sun, method, lod, ("flag", "coefficient", "lod"), *k)
    assert (out / "flag.u8").read_bytes() == res.flag.tobytes()
    assert (out / "coef.f32").read_bytes() == res.coefficient.tobytes()
    assert (out / "lod.u8").read_bytes() == res.lod.tobytes()
    assert np.any(res.flag == 1) and np.any(res.flag == 0), "a view with shadowed and lit pixels"


@pytest.mark.parametrize("method, lod, sun", [
    ("exact", LodOptions.automatic(), (200.0, 12.0)),
    ("exact", LodOptions(force_q=0), (135.0, 8.0)),
    ("maxmip", LodOptions.automatic(bias=1, n_a_max=4), (300.0, 15.0)),
    ("paper", LodOptions(force_q=2), (45.0, 10.0)),
    ("dda", LodOptions.automatic(bias=-1), (90.0, 6.0)),
])
def test_pixel_shadows_random(host: dict, tmp_path: Path, method: str, lod: LodOptions, sun) -> None:
    hm = random_map()
    pixels_case(host, tmp_path, hm, camera_over(hm, 57, 39), sun, method, lod, (0.25, 0.65))


def test_pixel_shadows_real(host: dict, tmp_path: Path) -> None:
    hm = real_map()
    pixels_case(host, tmp_path, hm, camera_over(hm, 72, 48), (210.0, 10.0), "exact", LodOptions(), (0.0, 0.0))


# ------------------------------------------------------------------------ compose
@pytest.mark.parametrize("ssaa, shadow, ao, linear", [(1, True, True, 0), (2, True, False, 0), (3, False, True, 0),
                                                      (1, False, False, 0), (1, True, True, 1), (2, False, True, 1)])
def test_compose(host: dict, tmp_path: Path, ssaa: int, shadow: bool, ao: bool, linear: int) -> None:
    hm = random_map()
    cam = camera_over(hm, 24 * ssaa, 17 * ssaa)
    renderer = TerrainRenderer(Heightfield(hm))
    gbuf = renderer.render(cam)
    normals = renderer.shading_normals(cam, gbuf)
    rng = np.random.default_rng(ssaa)
    shadow_map = rng.random(gbuf.shape).astype(np.float32) if shadow else None
    ao_map = rng.random(gbuf.shape).astype(np.float32) if ao else None
    inputs = tmp_path / "in"
    inputs.mkdir()
    gbuf.position.tofile(inputs / "position.f32")
    normals.tofile(inputs / "normal.f32")
    gbuf.albedo.tofile(inputs / "albedo.f32")
    cam.rotation.astype(np.float64).tofile(inputs / "rotation.f64")
    for name, arr in (("shadow", shadow_map), ("ao", ao_map)):
        if arr is not None:
            arr.tofile(inputs / f"{name}.f32")
    lighting = Lighting(sun=(130.0, 25.0), sun_intensity=1.7, sky=(0.2, 0.3, 0.4), background=(0.5, 0.6, 0.7))
    out = tmp_path / "out"
    out.mkdir()
    run_program(host, "host_passes", "compose", out, inputs, 24, 17, ssaa, "130.0,25.0", "1.7", "0.2,0.3,0.4",
                "0.5,0.6,0.7", int(shadow), int(ao), linear)
    if not linear:
        want = compose(gbuf, cam, lighting, shadow=shadow_map, ao=ao_map, normal=normals, ssaa=ssaa)
        assert (out / "image.u8").read_bytes() == want.tobytes()
        return
    rt = renderer.runtime                          # compose_linear: the float4 frame on the device
    buf = compose_linear(gbuf, cam, lighting, shadow=shadow_map, ao=ao_map, normal=normals, device=rt, ssaa=ssaa)
    want = np.empty((17, 24, 4), np.float32)
    cl.enqueue_copy(rt.queue, want, buf)
    rt.queue.finish()
    assert (out / "image.f32").read_bytes() == want.tobytes()


def _light_at(hm: Heightmap, where: str) -> np.ndarray:
    """A point light's world position relative to the map's bounding box."""
    rows, cols = hm.shape
    lo, hi = float(np.nanmin(hm.heights)), float(np.nanmax(hm.heights))
    x, y = 0.55 * (cols - 1) * hm.dx, -0.45 * (rows - 1) * hm.dy
    return {"above": np.array([x, y, hi + 400.0]),
            "inside": np.array([0.3 * (cols - 1) * hm.dx, -0.6 * (rows - 1) * hm.dy, 0.5 * (lo + hi)]),
            "below": np.array([x, y, lo - 150.0]),
            "off": np.array([-300.0, 250.0, lo + 20.0])}[where]


@pytest.mark.parametrize("where, distance, ssaa, shadow, ao, linear", [
    ("above", None, 1, True, True, 0), ("above", 500.0, 2, True, False, 0), ("inside", 300.0, 1, False, True, 0),
    ("inside", None, 1, True, True, 1), ("below", None, 1, True, False, 0), ("off", 1000.0, 2, False, False, 1)])
def test_compose_point_light(host: dict, tmp_path: Path, where: str, distance: float | None, ssaa: int,
                             shadow: bool, ao: bool, linear: int) -> None:
    """compose with a point light (-D OCLS_POINT_LIGHT: point_light, light_position,
    light_distance, translation) equals the Python host's compose / compose_linear bit for bit:
    lights over, inside and under the map's bounding box and off the map, with and without
    the falloff."""
    from oclshade.lights import PointLight

    hm = random_map()
    cam = camera_over(hm, 24 * ssaa, 17 * ssaa)
    renderer = TerrainRenderer(Heightfield(hm))
    gbuf = renderer.render(cam)
    normals = renderer.shading_normals(cam, gbuf)
    rng = np.random.default_rng(10 + ssaa)
    shadow_map = rng.random(gbuf.shape).astype(np.float32) if shadow else None
    ao_map = rng.random(gbuf.shape).astype(np.float32) if ao else None
    inputs = tmp_path / "in"
    inputs.mkdir()
    gbuf.position.tofile(inputs / "position.f32")
    normals.tofile(inputs / "normal.f32")
    gbuf.albedo.tofile(inputs / "albedo.f32")
    cam.rotation.astype(np.float64).tofile(inputs / "rotation.f64")
    np.ascontiguousarray(cam.view[:3, 3], np.float64).tofile(inputs / "translation.f64")
    for name, arr in (("shadow", shadow_map), ("ao", ao_map)):
        if arr is not None:
            arr.tofile(inputs / f"{name}.f32")
    light = PointLight(_light_at(hm, where), distance)
    lighting = Lighting(sun=light, sun_intensity=1.7, sky=(0.2, 0.3, 0.4), background=(0.5, 0.6, 0.7))
    out = tmp_path / "out"
    out.mkdir()
    spec = ",".join(repr(float(v)) for v in (*light.position, distance or 0.0))
    run_program(host, "host_passes", "compose", out, inputs, 24, 17, ssaa, "130.0,25.0", "1.7", "0.2,0.3,0.4",
                "0.5,0.6,0.7", int(shadow), int(ao), linear, spec)
    if not linear:
        want = compose(gbuf, cam, lighting, shadow=shadow_map, ao=ao_map, normal=normals, ssaa=ssaa)
        sun = compose(gbuf, cam, Lighting(sun=(130.0, 25.0), sun_intensity=1.7, sky=(0.2, 0.3, 0.4),
                                          background=(0.5, 0.6, 0.7)), shadow=shadow_map, ao=ao_map, normal=normals,
                      ssaa=ssaa)
        assert want.tobytes() != sun.tobytes(), "the point light must shade otherwise than the sun"
    else:
        rt = renderer.runtime
        buf = compose_linear(gbuf, cam, lighting, shadow=shadow_map, ao=ao_map, normal=normals, device=rt, ssaa=ssaa)
        want = np.empty((17, 24, 4), np.float32)
        cl.enqueue_copy(rt.queue, want, buf)
        rt.queue.finish()
    assert (out / ("image.f32" if linear else "image.u8")).read_bytes() == want.tobytes()


# ------------------------------------------------------------------------ the example
def png_pixels(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(io.BytesIO(path.read_bytes())) as im:
        im.load()
        return np.asarray(im.convert("RGB"))


@pytest.mark.parametrize("options", [
    ("--sun", "150,18", "--ao", "3"),
    ("--sun", "250,9", "--ssaa", "2", "--shadow-method", "maxmip"),
    ("--sun", "120,30", "--no-shadows", "--method", "dda"),
])
def test_render_frame_example_equals_cli(host: dict, tmp_path: Path, options: tuple[str, ...]) -> None:
    """host/examples/render_frame.c renders a whole frame on its own queue (G-buffer, shading
    normals, per-pixel shadows, SSAO, compose) into a PNG with the pixels of `oclshade render`
    for the same camera, sun and settings."""
    if not (host["build"] / "render_frame").exists():
        pytest.skip("render_frame was not built: CMake found no zlib (zlib1g-dev)")
    hm = random_map(52, 47)
    np.save(tmp_path / "dem.npy", hm.heights)
    save_heights(tmp_path, hm)
    rows, cols = hm.shape
    camera = "{},{},{},{},{},{}".format(-200.0, -1900.0, 1500.0, 700.0, -700.0, 780.0)
    size = "64x40"
    status = cli_main(["render", str(tmp_path / "dem.npy"), str(tmp_path / "cli.png"), "--cellsize", repr(hm.dx),
                       repr(hm.dy), "--size", size, f"--camera={camera}", "--quiet", *options])
    assert status == 0
    run_program(host, "render_frame", tmp_path / "heights.f64", rows, cols, repr(hm.dx), repr(hm.dy),
                tmp_path / "c.png", "--size", size, "--camera", camera, *options)
    ours, theirs = png_pixels(tmp_path / "c.png"), png_pixels(tmp_path / "cli.png")
    assert ours.shape == theirs.shape == (40, 64, 3)
    assert np.array_equal(ours, theirs)
    assert len(np.unique(ours.reshape(-1, 3), axis=0)) > 50, "a frame with content"

