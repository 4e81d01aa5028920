"""The final frame (kernels/compose.cl) against its float64 twin, with and without shadow / AO
inputs, shading normals and supersampling; the lighting model checked by hand on flat ground."""
from __future__ import annotations

import math

import numpy as np
import pytest

from oclshade import reference as ref
from oclshade.camera import frame_heightmap
import pyopencl as cl

from oclshade.compose import Lighting, compose, compose_linear
from oclshade.frames import FrameSettings, TerrainScene
from oclshade.terrain import Heightfield, TerrainRenderer


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(11)
    y, x = np.mgrid[0:50, 0:60]
    h = 30.0 * np.sin(x / 7.0) * np.cos(y / 9.0) + rng.random((50, 60))
    field = Heightfield.from_array(h, 5.0)
    cam = frame_heightmap(field.heightmap, 80, 60, azimuth=160.0, elevation=35.0, crop=0.0)
    renderer = TerrainRenderer(field)
    return field, cam, renderer, renderer.render(cam)


def expected(g, cam, light, shadow=None, ao=None, normal=None, ssaa=1):
    return ref.compose(g.position, g.normal if normal is None else normal, g.albedo, light.sun_view(cam),
                       light.sun_intensity, np.array(light.sky), light.up_view(cam), np.array(light.background),
                       shadow, ao, ssaa)


def srgb_decode(v: np.ndarray) -> np.ndarray:
    c = np.asarray(v, float) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


@pytest.mark.parametrize("with_shadow,with_ao", [(False, False), (True, False), (False, True), (True, True)])
def test_compose_matches_reference(scene, with_shadow, with_ao):
    _, cam, renderer, g = scene
    rng = np.random.default_rng(1)
    shadow = rng.random(g.shape).astype(np.float32) if with_shadow else None
    ao = rng.random(g.shape).astype(np.float32) if with_ao else None
    light = Lighting(sun=(120.0, 30.0))
    got = compose(g, cam, light, shadow=shadow, ao=ao, device=renderer.runtime)
    want = expected(g, cam, light, shadow, ao)
    assert got.dtype == np.uint8 and got.shape == g.shape + (4,)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    assert np.all(got[~g.hit][:, :3] == want[~g.hit][:, :3])      # background


@pytest.mark.parametrize("ssaa", [2, 5])
def test_supersampled_compose_matches_reference(scene, ssaa):
    """ssaa x ssaa samples per pixel: the kernel's box filter against the twin's mean (of the
    samples clamped to [0, 1]), with shading normals bound in place of the G-buffer's."""
    _, cam, renderer, g = scene
    rng = np.random.default_rng(2)
    n = g.normal.copy()
    n[..., :3] += 0.3 * rng.standard_normal(n[..., :3].shape).astype(np.float32)
    n[..., :3] /= np.linalg.norm(n[..., :3], axis=-1, keepdims=True)
    shadow = (rng.random(g.shape) < 0.5).astype(np.float32)
    light = Lighting(sun=(200.0, 20.0), sun_intensity=4.0)                 # some samples clip
    got = compose(g, cam, light, shadow=shadow, normal=n, device=renderer.runtime, ssaa=ssaa)
    want = expected(g, cam, light, shadow, normal=n, ssaa=ssaa)
    assert got.shape == (g.shape[0] // ssaa, g.shape[1] // ssaa, 4)
    assert np.abs(got.astype(int) - want.astype(int)).max() <= 1
    assert not np.array_equal(got, compose(g, cam, light, shadow=shadow, device=renderer.runtime, ssaa=ssaa))


@pytest.mark.parametrize("ssaa", [1, 2])
def test_linear_compose_keeps_the_range(scene, ssaa):
    """-D OCLS_LINEAR: float4 linear light on the device, unclamped (a sun of intensity 6
    drives lit samples far above 1), against the twin's unclamped mean; the 8-bit frame of the
    same inputs is the clamped, encoded one."""
    _, cam, renderer, g = scene
    rng = np.random.default_rng(3)
    shadow = (rng.random(g.shape) < 0.6).astype(np.float32)
    ao = rng.random(g.shape).astype(np.float32)
    light = Lighting(sun=(140.0, 40.0), sun_intensity=6.0, background=(2.5, 0.0, 0.25))
    rt = renderer.runtime
    buf = compose_linear(g, cam, light, shadow=shadow, ao=ao, device=rt, ssaa=ssaa)
    got = np.empty((g.shape[0] // ssaa, g.shape[1] // ssaa, 4), np.float32)
    cl.enqueue_copy(rt.queue, got, buf)
    rt.queue.finish()
    want = ref.compose(g.position, g.normal, g.albedo, light.sun_view(cam), light.sun_intensity,
                       np.array(light.sky), light.up_view(cam), np.array(light.background), shadow, ao, ssaa,
                       linear=True)
    assert want.max() > 2.0                                          # the range a clamp would lose
    assert np.all(got[..., 3] == 1.0)
    assert np.allclose(got[..., :3], want, rtol=1e-5, atol=1e-6)
    if ssaa == 1:
        assert np.all(got[~g.hit][:, :3] == np.float32([2.5, 0.0, 0.25]))   # background kept exactly
    encoded = compose(g, cam, light, shadow=shadow, ao=ao, device=rt, ssaa=ssaa)
    clamped = ref.compose(g.position, g.normal, g.albedo, light.sun_view(cam), light.sun_intensity,
                          np.array(light.sky), light.up_view(cam), np.array(light.background), shadow, ao, ssaa)
    assert np.abs(encoded.astype(int) - clamped.astype(int)).max() <= 1


def test_flat_ground_by_hand():
    """Unoccluded flat ground of one albedo: albedo * (I sin(elevation) + sky); in shadow
    albedo * sky (the direct term gone, the sky's light left); AO scales the sky term only.
    Values from the formula, decoded from the 8-bit sRGB output (1/255 steps: 2 % here)."""
    field = Heightfield.from_array(np.zeros((30, 30)), 10.0)
    cam = frame_heightmap(field.heightmap, 40, 30, azimuth=180.0, elevation=60.0)
    r = TerrainRenderer(field)
    g = r.render(cam)
    assert g.hit.mean() > 0.5
    albedo = g.albedo[g.hit][0, :3].astype(float)
    light = Lighting(sun=(90.0, 30.0))
    sky = np.array(light.sky)
    cases = {"lit": (None, None, albedo * (light.sun_intensity * 0.5 + sky)),
             "shadow": (np.zeros(g.shape), None, albedo * sky),
             "shadow, ao 0.5": (np.zeros(g.shape), np.full(g.shape, 0.5), albedo * sky * 0.5),
             "lit, ao 0": (None, np.zeros(g.shape), albedo * light.sun_intensity * 0.5)}
    for name, (shadow, ao, want) in cases.items():
        got = srgb_decode(compose(g, cam, light, shadow=shadow, ao=ao, device=r.runtime)[..., :3])[g.hit]
        assert np.allclose(got, want, rtol=0.02, atol=1e-3), name


def test_sky_light_falls_with_tilt():
    """The sky term of a plane tilted by beta is (1 + cos beta) / 2 of the horizontal one's
    (sun below the horizon of both: sky light only)."""
    beta = math.radians(60.0)
    x = np.arange(40) * 1.0
    tilted = Heightfield.from_array(np.tile(x * math.tan(beta), (40, 1)), 1.0)      # rises to the east
    flat = Heightfield.from_array(np.zeros((40, 40)), 1.0)
    out = []
    for field in (flat, tilted):
        cam = frame_heightmap(field.heightmap, 32, 24, azimuth=270.0, elevation=50.0)
        r = TerrainRenderer(field)
        g = r.render(cam)
        colour = g.albedo[g.hit][:, :3].astype(float)
        light = Lighting(sun=(270.0, 1.0), sun_intensity=0.0, sky=(1.0, 1.0, 1.0))
        got = srgb_decode(compose(g, cam, light, device=r.runtime)[..., :3])[g.hit]
        out.append(np.median(got / colour, axis=0))
    assert np.allclose(out[0], 1.0, rtol=0.02)
    assert np.allclose(out[1], (1.0 + math.cos(beta)) / 2.0, rtol=0.02)


def test_shadow_and_ao_darken(scene):
    _, cam, renderer, g = scene
    light = Lighting()
    full = compose(g, cam, light, device=renderer.runtime).astype(int)
    dark = compose(g, cam, light, shadow=np.zeros(g.shape), ao=np.zeros(g.shape), device=renderer.runtime)
    hit = g.hit
    assert np.all(dark[hit][:, :3] <= full[hit][:, :3]) and dark[hit][:, :3].max() <= 1   # no light at all
    same = compose(g, cam, light, shadow=np.ones(g.shape), ao=np.ones(g.shape), device=renderer.runtime)
    assert np.array_equal(same, full.astype(np.uint8))


def test_device_gbuffer_composes_like_host(scene):
    _, cam, renderer, g = scene
    dev = renderer.render(cam, on_device=True)
    assert np.array_equal(compose(dev, cam), compose(g, cam, device=renderer.runtime))


def test_sun_facing_slopes_are_brighter(scene):
    """A north-facing plane lit from the north is brighter than lit from the south."""
    field = Heightfield.from_array(np.linspace(10.0, 0.0, 20)[:, None] * np.ones((20, 20)), 1.0)  # falls to the south
    cam = frame_heightmap(field.heightmap, 40, 30, azimuth=180.0, elevation=60.0)
    r = TerrainRenderer(field)
    g = r.render(cam)
    north = compose(g, cam, Lighting(sun=(0.0, 30.0)), device=r.runtime)[g.hit][:, :3].astype(int).sum()
    south = compose(g, cam, Lighting(sun=(180.0, 30.0)), device=r.runtime)[g.hit][:, :3].astype(int).sum()
    assert south > north    # the slope faces south (it falls towards the south)


def test_compose_checks_arguments(scene):
    _, cam, renderer, g = scene
    with pytest.raises(ValueError, match="shadow"):
        compose(g, cam, shadow=np.ones((3, 3)), device=renderer.runtime)
    with pytest.raises(ValueError, match="sky"):
        Lighting(sky=(1.0, -1.0, 0.0))
    with pytest.raises(ValueError, match="ssaa 3 must divide"):
        compose(g, cam, ssaa=3, device=renderer.runtime)                       # 60 x 80
    for bad in (0, 9, 2.0, True):
        with pytest.raises(ValueError, match="ssaa must be an integer in 1..8"):
            compose(g, cam, ssaa=bad, device=renderer.runtime)
    with pytest.raises(ValueError, match="normal must be"):
        compose(g, cam, normal=np.ones((60, 80, 2)), device=renderer.runtime)


def test_ssaa_frame_smooths_edges_and_keeps_flat_regions():
    """--ssaa 3 on a flat map seen to its far edge: the frame keeps the requested size, a pixel
    whose 9 samples all hit the (one-coloured) ground keeps the 1-sample frame's colour bit for
    bit, and a pixel on the map's edge (some samples sky) lies strictly between ground and sky."""
    field = Heightfield.from_array(np.zeros((40, 60)), 10.0)
    cam = frame_heightmap(field.heightmap, 64, 36, azimuth=200.0, elevation=20.0, crop=0.0)
    scene = TerrainScene(field)
    one = scene.frame(cam, (150.0, 40.0), FrameSettings(shadows=False))
    three = scene.frame(cam, (150.0, 40.0), FrameSettings(shadows=False, ssaa=3))
    assert one.image.shape == three.image.shape == (36, 64, 4)
    assert three.gbuffer.shape == (108, 192)
    hits = three.gbuffer.to_host().hit.reshape(36, 3, 64, 3).sum(axis=(1, 3))
    ground = np.unique(one.image[one.gbuffer.to_host().hit][:, :3], axis=0)
    sky = one.image[~one.gbuffer.to_host().hit][0, :3]
    assert len(ground) == 1 and (hits == 9).sum() > 100 and ((hits > 0) & (hits < 9)).sum() > 20
    assert np.all(three.image[hits == 9][:, :3] == ground[0])
    assert np.all(three.image[hits == 0][:, :3] == sky)
    edge = three.image[(hits > 0) & (hits < 9)][:, :3].astype(int)
    lo, hi = np.minimum(ground[0], sky).astype(int), np.maximum(ground[0], sky).astype(int)
    assert np.all((edge >= lo) & (edge <= hi)) and np.all((edge != ground[0]).any(1) & (edge != sky).any(1))


def test_colour_texture_is_sampled(scene):
    """A constant colour texture gives that albedo everywhere; a two-tone one splits the map."""
    field, cam, _, _ = scene
    rows, cols = field.heightmap.shape
    red = np.zeros((rows * 2, cols * 2, 3), np.float32)
    red[..., 0] = 0.8
    g = TerrainRenderer(Heightfield(field.heightmap, colour=red)).render(cam)
    assert np.abs(g.albedo[g.hit] - np.array([0.8, 0.0, 0.0, 1.0], np.float32)).max() <= 1e-6
    halves = np.zeros((7, 9, 3), np.uint8)
    halves[:, 5:] = 255                       # east part white (sRGB 255 -> linear 1)
    g2 = TerrainRenderer(Heightfield(field.heightmap, colour=halves)).render(cam)
    u = g2.uv[..., 0][g2.hit]
    a = g2.albedo[..., 0][g2.hit]
    assert np.all(a[u < 0.3 * cols] < 0.05) and np.all(a[u > 0.8 * cols] > 0.95)
