"""Frames of a terrain scene: passes reused exactly when their inputs are unchanged."""
from dataclasses import replace

import numpy as np
import pytest

from oclshade.camera import frame_heightmap
from oclshade.compose import Lighting, compose
from oclshade.frames import AOSettings, FrameSettings, TerrainScene
from oclshade.heightmap import Heightmap
from oclshade.screen_shadows import ScreenShadowCaster
from oclshade.ssao import SSAO
from oclshade.synthetic import canyon_crater
from oclshade.terrain import Heightfield, TerrainRenderer


@pytest.fixture(scope="module")
def scene_parts():
    hm = Heightmap.from_array(canyon_crater(96, 80, seed=3), 30.0)
    camera = frame_heightmap(hm, 96, 64, azimuth=210.0, elevation=35.0)
    return hm, camera


def test_frame_equals_passes_run_by_hand(scene_parts):
    """The frame: the sun's visibility (eq. (1) with k_dark = k_bright = 0), SSAO on the geometric
    normal, compose with the smooth shading normals."""
    hm, camera = scene_parts
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=16))
    frame = TerrainScene(Heightfield(hm)).frame(camera, (135.0, 12.0), settings)
    assert frame.ran == ("gbuffer", "normals", "shadows", "ao", "compose")

    renderer = TerrainRenderer(Heightfield(hm))
    gbuf = renderer.render(camera)
    shadow = ScreenShadowCaster(hm).shade(gbuf, (135.0, 12.0), k_dark=0.0, k_bright=0.0).coefficient
    assert set(np.unique(shadow)) == {0.0, 1.0}
    ao = SSAO().compute(gbuf, camera.projection_matrix, radius=90.0, m=16)
    normal = renderer.shading_normals(camera, gbuf)
    expected = compose(gbuf, camera, Lighting(sun=(135.0, 12.0)), shadow=shadow, ao=ao, normal=normal)
    assert np.array_equal(frame.image, expected)
    assert 0.0 < (shadow[gbuf.hit] < 1.0).mean() < 1.0, "the test view must show both shadow and light"
    assert not np.array_equal(frame.image, compose(gbuf, camera, Lighting(sun=(135.0, 12.0)), shadow=shadow, ao=ao))


def test_before_settings_reproduce_the_old_look(scene_parts):
    """normals="geometric" leaves out the normals pass (the G-buffer's facet normals shade) and
    shadow_k passes paper 000 eq. (1)'s levels to the shadow pass."""
    hm, camera = scene_parts
    old_light = Lighting(sun=(135.0, 12.0), sun_intensity=1.6, sky=(0.22, 0.26, 0.32))
    settings = FrameSettings(normals="geometric", shadow_k=(0.25, 0.65), lighting=old_light)
    frame = TerrainScene(Heightfield(hm)).frame(camera, (135.0, 12.0), settings)
    assert frame.ran == ("gbuffer", "shadows", "compose") and frame.normals is None
    gbuf = TerrainRenderer(Heightfield(hm)).render(camera)
    coef = ScreenShadowCaster(hm).shade(gbuf, (135.0, 12.0)).coefficient          # the paper's defaults
    assert np.array_equal(frame.image, compose(gbuf, camera, old_light, shadow=coef))


def test_supersampled_frame_is_the_box_filter_of_its_samples(scene_parts):
    hm, camera = scene_parts
    scene = TerrainScene(Heightfield(hm))
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=8), ssaa=2)
    frame = scene.frame(camera, (135.0, 12.0), settings)
    assert frame.image.shape == (camera.height, camera.width, 4)
    assert frame.gbuffer.shape == (2 * camera.height, 2 * camera.width) and frame.ao_factor().shape == (128, 192)
    big = replace(camera, width=2 * camera.width, height=2 * camera.height)
    assert scene.frame(big, (135.0, 12.0), replace(settings, ssaa=1)).ran == ("compose",)   # the same samples
    whole = TerrainScene(Heightfield(hm)).frame(big, (135.0, 12.0), replace(settings, ssaa=1))
    assert np.array_equal(whole.ao_factor(), frame.ao_factor())
    g = whole.gbuffer
    again = compose(g, big, Lighting(sun=(135.0, 12.0)), shadow=whole.shadow,
                    ao=whole.ao, normal=whole.normals, device=scene.runtime, ssaa=2)
    assert np.array_equal(again, frame.image)


def test_settings_are_checked():
    with pytest.raises(ValueError, match="normals must be one of smooth, geometric"):
        FrameSettings(normals="flat")
    with pytest.raises(ValueError, match="ssaa must be an integer in 1..8"):
        FrameSettings(ssaa=0)
    with pytest.raises(ValueError, match="k_dark"):
        FrameSettings(shadow_k=(-0.1, 0.5))
    hm = Heightmap.from_array(np.zeros((4, 4)), 1.0)
    with pytest.raises(ValueError, match="at most 32768 per side"):
        TerrainScene(Heightfield(hm)).frame(frame_heightmap(hm, 8000, 10), (0.0, 45.0), FrameSettings(ssaa=5))


def test_sun_path_reruns_only_sun_dependent_passes(scene_parts):
    hm, camera = scene_parts
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=8))
    cached, uncached = TerrainScene(Heightfield(hm)), TerrainScene(Heightfield(hm), caching=False)
    for k, sun in enumerate([(100.0, 10.0), (140.0, 25.0), (140.0, 25.0), (200.0, 40.0)]):
        a, b = cached.frame(camera, sun, settings), uncached.frame(camera, sun, settings)
        assert np.array_equal(a.image, b.image)
        assert b.ran == ("gbuffer", "normals", "shadows", "ao", "compose")
        if k == 0:
            assert a.ran == b.ran
        elif k == 2:                                   # nothing changed at all
            assert a.ran == ()
        else:                                          # the sun moved; camera fixed
            assert a.ran == ("shadows", "compose")


def test_camera_move_reruns_camera_passes_and_features_are_off(scene_parts):
    hm, camera = scene_parts
    scene = TerrainScene(Heightfield(hm))
    first = scene.frame(camera, (135.0, 30.0), FrameSettings(shadows=False))
    assert first.ran == ("gbuffer", "normals", "compose") and first.shadow is None and first.ao is None
    moved = frame_heightmap(hm, 96, 64, azimuth=250.0, elevation=35.0)
    second = scene.frame(moved, (135.0, 30.0), FrameSettings(shadows=False))
    assert second.ran == ("gbuffer", "normals", "compose")
    assert not np.array_equal(first.image, second.image)
    third = scene.frame(moved, (135.0, 30.0), FrameSettings(ao=AOSettings(radius=0.0)))
    assert third.ran == ("shadows", "compose") and third.ao is None     # radius 0: no AO pass at all
