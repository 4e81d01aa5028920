"""The final frame (kernels/compose.cl) against its float64 twin, with and without shadow / AO inputs."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade import reference as ref
from oclshade.camera import frame_heightmap
from oclshade.compose import Lighting, compose
from oclshade.terrain import Heightfield, TerrainRenderer


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(11)
    y, x = np.mgrid[0:50, 0:60]
    h = 30.0 * np.sin(x / 7.0) * np.cos(y / 9.0) + rng.random((50, 60))
    field = Heightfield.from_array(h, 5.0)
    cam = frame_heightmap(field.heightmap, 80, 60, azimuth=160.0, elevation=35.0)
    renderer = TerrainRenderer(field)
    return field, cam, renderer, renderer.render(cam)


def expected(g, cam, light, shadow=None, ao=None):
    return ref.compose(g.position, g.normal, g.albedo, light.sun_view(cam), light.sun_intensity,
                       np.array(light.sky), np.array(light.background), shadow, ao)


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


def test_compose_checks_shapes(scene):
    _, cam, renderer, g = scene
    with pytest.raises(ValueError, match="shadow"):
        compose(g, cam, shadow=np.ones((3, 3)), device=renderer.runtime)
    with pytest.raises(ValueError, match="sky"):
        Lighting(sky=(1.0, -1.0, 0.0))


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
