"""pytest-benchmark suite for the shadow kernels (not collected by the default test run).

    python -m pytest bench/test_bench_kernels.py --benchmark-enable
    python -m pytest bench/test_bench_kernels.py --benchmark-enable --benchmark-json=/tmp/kernels.json

``setup.cfg`` sets ``testpaths = tests`` and ``--benchmark-disable``: without
``--benchmark-enable`` each benchmark runs once, as a smoke test.

Times: the extrema pyramid build of a 1024^2 synthetic canyon-and-crater map
(30 m cells), and its cast-shadow mask at elevation 20 degrees (azimuth 37)
for each method over the resident pyramid (host copy of the mask included).
"""
from __future__ import annotations

import numpy as np
import pytest

from oclshade.heightmap import Heightmap
from oclshade.shadows import METHODS, ShadowCaster
from oclshade.synthetic import canyon_crater

SIZE = 1024
SUN = (37.0, 20.0)


@pytest.fixture(scope="module")
def heightmap() -> Heightmap:
    return Heightmap.from_array(canyon_crater(SIZE, seed=0), cellsize=30.0)


@pytest.fixture(scope="module")
def caster(heightmap: Heightmap) -> ShadowCaster:
    c = ShadowCaster(heightmap)
    for m in METHODS:
        c.warm_up(m)            # pyramid and every kernel variant built before timing
    return c


def test_pyramid_build(benchmark, heightmap: Heightmap, caster: ShadowCaster) -> None:
    def build() -> ShadowCaster:
        c = ShadowCaster(heightmap, caster.runtime)
        c.pyramid
        c.runtime.queue.finish()
        return c

    benchmark.group = f"pyramid {SIZE}^2"
    c = benchmark(build)
    assert c.pyramid.levels == caster.pyramid.levels


@pytest.mark.parametrize("method", ["exact", "maxmip", "dda", "paper"])
def test_mask(benchmark, caster: ShadowCaster, method: str) -> None:
    benchmark.group = f"mask {SIZE}^2 az {SUN[0]:g} alt {SUN[1]:g}"
    result = benchmark(caster.cast, SUN, method)
    mask = result.mask
    assert mask.shape == (SIZE, SIZE) and mask.dtype == np.uint8
    benchmark.extra_info["shadow_fraction"] = float((mask == 1).mean())
    if method != "paper":       # exact, maxmip and dda decide every cell alike
        ref = caster.cast(SUN, "exact").mask
        assert int((mask != ref).sum()) == 0
