"""Frames of a terrain scene: passes reused exactly when their inputs are unchanged."""
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
    hm, camera = scene_parts
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=16))
    frame = TerrainScene(Heightfield(hm)).frame(camera, (135.0, 12.0), settings)
    assert frame.ran == ("gbuffer", "shadows", "ao", "compose")

    gbuf = TerrainRenderer(Heightfield(hm)).render(camera)
    shadow = ScreenShadowCaster(hm).shade(gbuf, (135.0, 12.0)).coefficient
    ao = SSAO().compute(gbuf, camera.projection_matrix, radius=90.0, m=16)
    expected = compose(gbuf, camera, Lighting(sun=(135.0, 12.0)), shadow=shadow, ao=ao)
    assert np.array_equal(frame.image, expected)
    assert 0.0 < (shadow[gbuf.hit] < 1.0).mean() < 1.0, "the test view must show both shadow and light"


def test_sun_path_reruns_only_sun_dependent_passes(scene_parts):
    hm, camera = scene_parts
    settings = FrameSettings(ao=AOSettings(radius=90.0, m=8))
    cached, uncached = TerrainScene(Heightfield(hm)), TerrainScene(Heightfield(hm), caching=False)
    for k, sun in enumerate([(100.0, 10.0), (140.0, 25.0), (140.0, 25.0), (200.0, 40.0)]):
        a, b = cached.frame(camera, sun, settings), uncached.frame(camera, sun, settings)
        assert np.array_equal(a.image, b.image)
        assert b.ran == ("gbuffer", "shadows", "ao", "compose")
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
    assert first.ran == ("gbuffer", "compose") and first.shadow is None and first.ao is None
    moved = frame_heightmap(hm, 96, 64, azimuth=250.0, elevation=35.0)
    second = scene.frame(moved, (135.0, 30.0), FrameSettings(shadows=False))
    assert second.ran == ("gbuffer", "compose")
    assert not np.array_equal(first.image, second.image)
    third = scene.frame(moved, (135.0, 30.0), FrameSettings(ao=AOSettings(radius=0.0)))
    assert third.ran == ("shadows", "compose") and third.ao is None     # radius 0: no AO pass at all
