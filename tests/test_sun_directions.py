"""Sun directions on arrays (oclshade.sun: sincos_degrees, sun_rays, sun_vectors) and a field's
grid of bands (SunField.bands), which the kernels' sun tables read."""
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from oclshade.sun import Sun, SunBlock, SunField, sincos_degrees, sun_directions, sun_rays, sun_vectors

ANGLES = st.floats(-1e4, 1e4, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(angle=ANGLES)
def test_sincos_is_the_c_librarys_away_from_multiples_of_45(angle):
    """numpy's sin and cos of the radians, bit for bit those of Python's math module (the C
    library's, which the C host's rays use), wherever no exact value applies."""
    a = math.fmod(angle, 360.0)
    a = a + 360.0 if a < 0.0 else a
    if a == 360.0 or a % 45.0 == 0.0:
        return
    sin, cos = sincos_degrees(angle)
    assert (float(sin), float(cos)) == (math.sin(math.radians(a)), math.cos(math.radians(a)))


def test_sincos_is_exact_at_multiples_of_45():
    half = math.sqrt(0.5)
    angles = np.array([0.0, -0.0, 90.0, 180.0, 270.0, 360.0, -90.0, 720.0, 45.0, 135.0, 225.0, 315.0, -45.0,
                       -1e-300, 1e-300])
    sin, cos = sincos_degrees(angles)
    want = [(0, 1), (0, 1), (1, 0), (0, -1), (-1, 0), (0, 1), (-1, 0), (0, 1), (half, half), (half, -half),
            (-half, -half), (-half, half), (-half, half), (0, 1)]
    assert list(zip(sin[:14].tolist(), cos[:14].tolist())) == [(float(s), float(c)) for s, c in want]
    assert cos[14] == 1.0 and 0.0 < sin[14] < 1e-300     # a tiny positive angle is not north


@settings(max_examples=60, deadline=None)
@given(azimuths=st.lists(ANGLES, min_size=1, max_size=20),
       elevations=st.lists(st.floats(-90.0, 90.0), min_size=20, max_size=20),
       cell=st.tuples(st.floats(1e-4, 1e3), st.floats(1e-4, 1e3)))
def test_arrays_of_suns_are_each_suns_own(azimuths, elevations, cell):
    """A batch (the sun tables' path) gives each sun what it gets alone (Sun.ray, Sun.vector)."""
    el = np.array(elevations[:len(azimuths)] + [45.0, 90.0, -90.0, 0.0])
    az = np.array(azimuths + [10.0, 20.0, 30.0, 40.0])
    rays, vectors = sun_rays(az, el, *cell), sun_vectors(az, el)
    assert rays.dtype == np.float32 and vectors.dtype == np.float64
    both = sun_directions(az, el, *cell)           # what the sun tables take
    assert both[0].tobytes() == rays.tobytes() and both[1].tobytes() == vectors.tobytes()
    for k in range(len(az)):
        sun = Sun(float(az[k]), float(el[k]))
        assert tuple(rays[k].tolist()) == sun.ray(*cell) and tuple(vectors[k].tolist()) == sun.vector()
    assert rays[-4, 2] == 1.0 and math.isinf(rays[-3, 2])


def test_bands_name_each_cells_block():
    """For a grid of blocks and for blocks cut across it, band[i] + band[rows + j] indexes the
    band cell of (i, j), and its owner is the block holding the cell."""
    sun = Sun(90.0, 10.0)
    grid = [SunBlock(r0, r1, c0, c1, sun) for r0, r1 in ((0, 5), (5, 12)) for c0, c1 in ((0, 16), (16, 20))]
    cut = [SunBlock(0, 5, 0, 20, sun), SunBlock(5, 12, 0, 3, sun), SunBlock(5, 9, 3, 20, sun),
           SunBlock(9, 12, 3, 20, sun)]
    for blocks in (grid, cut):
        field = SunField((12, 20), tuple(blocks), sun)
        band, owner = field.bands
        assert band.dtype == np.int32 and band.shape == (32,)
        for i in range(12):
            for j in range(20):
                b = blocks[owner[band[i] + band[12 + j]]]
                assert b.row0 <= i < b.row1 and b.col0 <= j < b.col1
    assert len(SunField((12, 20), tuple(grid), sun).bands[1]) == 4
    assert len(SunField((12, 20), tuple(cut), sun).bands[1]) == 3 * 2    # row cuts 5, 9; column cut 3


def test_overlapping_blocks_are_refused():
    """Blocks whose areas add up to the map's but that overlap leave cells in no block."""
    sun = Sun(90.0, 10.0)
    field = SunField((4, 4), (SunBlock(0, 2, 0, 4, sun), SunBlock(0, 2, 0, 4, sun)), sun)
    try:
        field.bands
    except ValueError as exc:
        assert "some cells are in no block" in str(exc)
    else:
        raise AssertionError("overlapping blocks were accepted")
