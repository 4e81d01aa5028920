"""SSAO lane count (SSAO(lanes=...), -D OCLS_SSAO_LANES): a speed setting that never changes a
result bit, whatever the features and however the row width splits into lanes."""
from __future__ import annotations

import numpy as np
import pytest
from test_ssao import random_extras, random_gbuffer

from oclshade.ssao import SSAO, TUNING, AOFeatures

LANE_CHOICES = TUNING.param("lanes").values
SAFE_LANES = TUNING.param("lanes").safe

FEATURES = [
    AOFeatures(distribution="paper", blur="box", blur_size=5),
    AOFeatures(distribution="lines"),
    AOFeatures(distribution="lines", plane_test=True, range_check=True, blur="box", blur_size=3),
    AOFeatures(distribution="uniform", plane_test=True, range_check=True, blur="edge"),
    AOFeatures(distribution="centre", alpha_map=True, normal_map=True, range_check=True, blur="box"),
    AOFeatures(distribution="rays", range_check=True, blur="box", blur_size=3),
    AOFeatures(distribution="rays", plane_test=True),
]
#: (width, height, perspective): a width that is no multiple of any lane count, and one of all
SHAPES = [(37, 23, True), (48, 16, False)]


@pytest.fixture(scope="module")
def passes() -> dict[int, SSAO]:
    # lanes with a work-group size and a built-ins choice each, so every legal value of every knob runs
    groups = TUNING.param("group").values
    return {lanes: SSAO(lanes=lanes, group=groups[k % len(groups)], own_builtins=k % 2)
            for k, lanes in enumerate(LANE_CHOICES)}


@pytest.mark.parametrize("features", FEATURES, ids=lambda f: f"{f.distribution}-{f.blur}")
def test_lane_counts_give_the_same_bits(passes: dict[int, SSAO], features: AOFeatures) -> None:
    for seed, (w, h, persp) in enumerate(SHAPES):
        rng = np.random.default_rng(seed)
        pos, nrm, P = random_gbuffer(rng, w, h, persp)
        extra = random_extras(rng, w, h, features.alpha_map, features.normal_map)
        got = {lanes: s.compute(None, P, position=pos, normal=nrm, radius=1.5, m=24, delta=0.02,
                                features=features, seed=seed, alpha_eps=0.3, **extra)
               for lanes, s in passes.items()}
        want = got[SAFE_LANES]
        assert 0.0 < np.mean(want < 1.0) < 1.0, "a scene with occluded and open pixels"
        for lanes, ao in got.items():
            assert np.array_equal(ao.view(np.uint32), want.view(np.uint32)), \
                f"lanes {lanes} vs {SAFE_LANES}, {w}x{h}: {np.sum(ao != want)} pixels differ"


def test_lanes_validation() -> None:
    assert SSAO().lanes in LANE_CHOICES
    for bad in (3, 32, 8.0, "8"):
        with pytest.raises(ValueError, match="lanes"):
            SSAO(lanes=bad)
