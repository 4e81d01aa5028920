"""Tuning knobs never change a result: every legal value of every family's knobs gives the
same bits (the shadow and SSAO lanes have their own files: test_packets.py, test_ssao_lanes.py)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from oclshade import reference as ref
from oclshade.camera import frame_heightmap
from oclshade.heightmap import Heightmap
from oclshade.pyramid import TUNING as PYRAMID, build_extrema_pyramid
from oclshade.screen_shadows import TUNING as SCREEN, ScreenShadowCaster
from oclshade.synthetic import canyon_crater
from oclshade.terrain import TUNING as TERRAIN, Heightfield, TerrainRenderer
from oclshade import tuning


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint8)


def every_value(family: tuning.Family) -> list[dict[str, int]]:
    """Each knob through each of its values (the others safe), and every knob at once at a
    non-safe value: every legal value of every knob runs, without the whole product."""
    safe = family.safe()
    out = [safe] + [{**safe, p.name: v} for p in family.params for v in p.values if v != p.safe]
    out.append({p.name: max(v for v in p.values if v != p.safe) for p in family.params})
    return out


def test_every_family_is_registered_with_legal_safe_values():
    fams = tuning.families()
    assert set(fams) == {"pyramid", "shadow", "terrain", "screen_shadows", "ssao", "horizon"}
    for fam in fams.values():
        assert fam.check(fam.safe()) == fam.safe()
        assert fam.fallbacks(fam.safe()) == [fam.safe()]


@pytest.mark.parametrize("shape", [(37, 61), (64, 64), (3, 200), (130, 7)])
def test_pyramid_knobs_give_the_reference_texels(shape):
    rng = np.random.default_rng(shape[0] * shape[1])
    h = rng.normal(size=shape).cumsum(axis=1) * 10.0
    h[rng.random(shape) < 0.03] = np.nan
    hm = Heightmap.from_array(h)
    want = ref.extrema_pyramid(hm)
    for knobs in every_value(PYRAMID):
        got = build_extrema_pyramid(hm, knobs=knobs).to_numpy()
        assert all(np.array_equal(bits(g), bits(w)) for g, w in zip(got, want)), knobs


@pytest.fixture(scope="module")
def scene():
    field = Heightfield.from_array(canyon_crater(150)[:, :133], 30.0)
    cameras = [frame_heightmap(field.heightmap, 97, 61, az, el) for az, el in ((200.0, 25.0), (30.0, 8.0), (120.0, 70.0))]
    return field, cameras


def test_terrain_knobs_give_the_same_gbuffer(scene):
    field, cameras = scene
    base = TerrainRenderer(field, **TERRAIN.safe())
    want = [base.render(cam) for cam in cameras]
    assert all(0.05 < np.isfinite(w.depth).mean() for w in want), [np.isfinite(w.depth).mean() for w in want]
    for knobs in every_value(TERRAIN):
        if knobs == TERRAIN.safe():
            continue
        r = TerrainRenderer(field, **knobs)
        for cam, w in zip(cameras, want):
            g = r.render(cam)
            for name in ("position", "normal", "uv", "uv_grad", "depth", "albedo"):
                assert np.array_equal(bits(getattr(g, name)), bits(getattr(w, name))), (knobs, name)


def test_screen_shadow_knobs_give_the_same_flags(scene):
    field, cameras = scene
    gbuf = TerrainRenderer(field).render(cameras[0])
    results = [ScreenShadowCaster(field.heightmap, **knobs).shade(gbuf, (300.0, 12.0), outputs="all")
               for knobs in every_value(SCREEN)]
    assert 0.02 < np.mean(results[0].flag == 1) < 0.9
    for r in results[1:]:
        for name in ("flag", "coefficient", "lod"):
            assert np.array_equal(bits(getattr(r, name)), bits(getattr(results[0], name)))
