"""Result caches: pyramids shared across casters, results reused only while every input is
unchanged, callers cannot corrupt the cache, switches and bounds work."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from oclshade import ShadowCaster, cache, cast_shadows
from oclshade.heightmap import Heightmap


@pytest.fixture(autouse=True)
def fresh_caches():
    was = cache.enabled()
    cache.set_enabled(True)
    cache.clear()
    yield
    cache.set_enabled(was)
    cache.clear()


def terrain(seed: int = 0, shape=(40, 50)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=shape), axis=1) * 8.0


SUN = (250.0, 12.0)


def test_pyramid_built_once_per_heights_and_shared():
    h = terrain()
    a = ShadowCaster(Heightmap.from_array(h, 10.0))
    b = ShadowCaster(Heightmap.from_array(h.copy(), 25.0))     # same heights, other cells, other object
    assert a.pyramid is b.pyramid
    s = cache.PYRAMIDS.stats()
    assert (s["misses"], s["hits"], s["entries"]) == (1, 1, 1) and s["bytes"] > h.size * 4
    c = ShadowCaster(Heightmap.from_array(h + 1.0, 10.0))        # relative heights equal: shared too
    assert c.pyramid is a.pyramid
    d = ShadowCaster(Heightmap.from_array(h * 2.0, 10.0))
    assert d.pyramid is not a.pyramid
    assert ShadowCaster(Heightmap.from_array(h, 10.0), cache=False).pyramid is not a.pyramid


def test_repeated_call_reuses_the_result_and_copies_it():
    h = terrain(1)
    first = cast_shadows(h, 10.0, SUN, outputs="all")
    assert cache.RESULTS.stats()["misses"] == 1 and cache.RESULTS.stats()["hits"] == 0
    expected = {n: getattr(first, n).copy() for n in ("mask", "self_shadow", "coefficient")}
    first.mask[:] = 7                                      # the caller's arrays are its own
    second = cast_shadows(h, 10.0, SUN, outputs="all")
    assert cache.RESULTS.stats()["hits"] == 1
    for name, arr in expected.items():
        got = getattr(second, name)
        assert got.flags.writeable and np.array_equal(got, arr, equal_nan=True)
    second.coefficient[:] = -1.0
    third = cast_shadows(h, 10.0, SUN, outputs="all")
    assert np.array_equal(third.coefficient, expected["coefficient"], equal_nan=True)
    stored = next(iter(cache.RESULTS._items.values()))[0]
    assert not stored.mask.flags.writeable


@pytest.mark.parametrize("change", ["heights", "cell", "azimuth", "elevation", "method", "outputs",
                                    "k_dark", "k_bright"])
def test_any_changed_input_misses_and_gives_the_uncached_answer(change):
    h = terrain(2)
    base = dict(heights=h, cellsize=10.0, sun=SUN, method="exact", outputs=("mask", "coefficient"),
                k_dark=0.2, k_bright=0.7)
    cast_shadows(**base)
    changed = dict(base)
    if change == "heights":
        h2 = h.copy()
        h2[20, 25] += 500.0                                # a new peak: new shadows
        changed["heights"] = h2
    else:
        changed.update({"cell": {"cellsize": 3.0}, "azimuth": {"sun": (70.0, 12.0)},
                        "elevation": {"sun": (250.0, 30.0)}, "method": {"method": "dda"},
                        "outputs": {"outputs": ("mask", "self", "coefficient")},
                        "k_dark": {"k_dark": 0.3}, "k_bright": {"k_bright": 0.8}}[change])
    hits = cache.RESULTS.hits
    got = cast_shadows(**changed)
    assert cache.RESULTS.hits == hits, f"{change}: served from the cache"
    want = cast_shadows(**changed, cache=False)
    assert np.array_equal(got.mask, want.mask) and np.array_equal(got.coefficient, want.coefficient)
    if change == "heights":
        assert not np.array_equal(got.mask, cast_shadows(**base).mask)


def test_coefficients_do_not_split_mask_only_results():
    h = terrain(3)
    cast_shadows(h, 10.0, SUN, k_dark=0.1)
    cast_shadows(h, 10.0, SUN, k_dark=0.4)
    assert cache.RESULTS.stats()["hits"] == 1


def test_disabled_caching_stores_nothing():
    h = terrain(4)
    cache.set_enabled(False)
    a = cast_shadows(h, 10.0, SUN)
    b = cast_shadows(h, 10.0, SUN)
    assert np.array_equal(a.mask, b.mask)
    assert all(s["entries"] == 0 and s["hits"] == 0 for s in cache.stats().values())
    cache.set_enabled(True)
    caster = ShadowCaster(Heightmap.from_array(h, 10.0), cache=False)
    caster.cast(SUN)
    caster.cast(SUN)
    assert all(s["entries"] == 0 for s in cache.stats().values())


def test_cache_off_from_the_environment():
    env = dict(os.environ, OCLSHADE_CACHE="0")
    code = "from oclshade import cache; print(cache.enabled())"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_lru_bound_and_counters():
    c = cache.LRUCache("test", max_bytes=100)
    for k in range(5):
        c.put(k, str(k), 30)
    assert c.nbytes <= 100 and len(c) == 3 and c.evictions == 2
    assert c.get(0) is None and c.get(4) == "4"
    c.get(2)                                       # 2 becomes the most recent
    c.put(5, "5", 30)
    assert c.get(3) is None and c.get(2) == "2"
    c.put("big", "x", 1000)                        # larger than the bound: not stored
    assert c.get("big") is None and c.nbytes <= 100
    assert c.stats()["hits"] == 3 and c.stats()["misses"] == 3


def test_digest_follows_content_not_identity():
    h = terrain(5)
    a, b = Heightmap.from_array(h, 1.0), Heightmap.from_array(h.copy(), 1.0)
    assert cache.heights_digest(a) == cache.heights_digest(b) == cache.heights_digest(a)
    h[0, 0] += 1e-3
    assert cache.heights_digest(Heightmap.from_array(h, 1.0)) != cache.heights_digest(a)
    assert cache.heights_digest(Heightmap.from_array(h[:, :-1], 1.0)) != cache.heights_digest(a)


def test_images_built_for_a_cached_pyramid_count_in_its_size():
    from oclshade import pyramid_images

    hm = Heightmap.from_array(terrain(2), 10.0)
    caster = ShadowCaster(hm, knobs={"lanes": 0, "images": 1})
    pyr = caster.pyramid
    before = cache.PYRAMIDS.stats()["bytes"]
    assert before == pyr.heights.size + pyr.buffer.size + pyr.offsets.size
    why = pyramid_images.images_unavailable(pyr.runtime, pyr.map_shape, pyr.shapes)
    if why is not None:
        pytest.skip(f"this device holds no images: {why}")
    caster.cast(SUN)
    imgs = pyr.images()
    assert imgs is not None and caster._features("exact", ("mask",)).imaged
    # the images' rows at least as wide as the map's / the atlas's texels
    rows, cols = hm.shape
    atlas = pyramid_images.atlas_rows(pyr.shapes)[-1]
    assert imgs.nbytes >= 4 * rows * cols + 4 * imgs.channels * atlas * pyr.shapes[0][1]
    assert cache.PYRAMIDS.stats()["bytes"] == before + imgs.nbytes == pyr.nbytes
    assert cache.PYRAMIDS.get(pyr._cache_key) is pyr
