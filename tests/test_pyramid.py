"""Pyramids on the device against their numpy twins: bit-identical (maps up to 100 columns wide, so
the 16-texel extrema_base of CPU devices meets several full blocks and a partial one per row)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.pyramid import build_extrema_pyramid, build_mip_pyramid


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 70), cols=st.integers(1, 100), holes=st.sampled_from([0.0, 0.05, 0.5]),
       seed=st.integers(0, 2**31))
def test_extrema_pyramid_bit_identical(rows, cols, holes, seed):
    rng = np.random.default_rng(seed)
    h = rng.normal(size=(rows, cols)) * 100.0
    h[rng.random((rows, cols)) < holes] = np.nan
    hm = Heightmap.from_array(h)
    got, want = build_extrema_pyramid(hm).to_numpy(), ref.extrema_pyramid(hm)
    assert [g.shape for g in got] == [w.shape for w in want]
    assert got[-1].shape[:2] == (1, 1)
    for g, w in zip(got, want):
        assert np.array_equal(g, w)


@pytest.mark.parametrize("shape", [(1, 1), (5, 3), (64, 64), (100, 37)])
def test_mip_pyramid_bit_identical(shape):
    rng = np.random.default_rng(1)
    h = rng.normal(size=shape)
    h[rng.random(shape) < 0.1] = np.nan
    hm = Heightmap.from_array(h)
    got, want = build_mip_pyramid(hm), ref.mip_pyramid(hm)
    assert len(got) == len(want) and got[-1].shape == (1, 1)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_extrema_bound_the_bilinear_surface():
    """Every level's max/min bound dense bilinear samples of its tile."""
    rng = np.random.default_rng(2)
    h = rng.random((33, 20)) * 10.0
    hm = Heightmap.from_array(h)
    levels = ref.extrema_pyramid(hm)
    ys, xs = np.meshgrid(np.linspace(0, 32, 257), np.linspace(0, 19, 153), indexing="ij")
    r0, c0 = np.minimum(ys.astype(int), 31), np.minimum(xs.astype(int), 18)
    fy, fx = ys - r0, xs - c0
    s = (h[r0, c0] * (1 - fx) + h[r0, c0 + 1] * fx) * (1 - fy) + (h[r0 + 1, c0] * (1 - fx) + h[r0 + 1, c0 + 1] * fx) * fy
    s = s - hm.offset
    for level, tex in enumerate(levels, start=1):
        tr, tc = r0 >> level, c0 >> level
        assert (s <= tex[tr, tc, 0] + 1e-4).all() and (s >= tex[tr, tc, 1] - 1e-4).all()
