"""Tiles with exact halos (oclshade.tiles): the same masks as the whole map, tile by tile."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade.heightmap import Heightmap
from oclshade.synthetic import canyon_crater
from oclshade.tiles import ReliefGrid, TileHeightmap, Tracing, Window, cast_tiled, halo_window, plan_tiles, \
    reach_distance, run_jobs
from oclshade.tiles.plan import ALIGN, TileJob, auto_tile_size, halo_bound, tiles_of
from tile_cases import FLIP_OFFSET, FLIP_SUN, FLIP_TILE, flipped_map

OUTPUT_FIELDS = ("mask", "self_shadow", "coefficient")


def assert_same_bits(a: np.ndarray | None, b: np.ndarray | None, what: str) -> None:
    """Equal bit for bit (NaN equal to NaN), or both absent."""
    assert (a is None) == (b is None), what
    if a is not None:
        assert a.dtype == b.dtype and a.shape == b.shape, what
        differ = a.view(np.uint8) != b.view(np.uint8)
        assert not differ.any(), f"{what}: {int(differ.sum())} bytes differ, first at {np.argwhere(differ)[0]}"


def assert_tiled_equal(hm: Heightmap, sun: Sun, tile_size: int, outputs=("mask",), **kw) -> None:
    """The tiled outputs equal the whole map's bit for bit (the windows form the whole map's cell
    coordinates: ShadowCaster(origin=...))."""
    knobs = kw.pop("knobs", None)
    whole = ShadowCaster(hm, cache=False, knobs=knobs).cast(sun, outputs=outputs)
    kw.setdefault("align", 1)              # windows exactly the halo's (the default alignment only adds)
    kw.setdefault("block", 8)              # tight halos (the default block is larger than these maps)
    tiled = cast_tiled(hm, [sun], outputs=outputs, tile_size=tile_size, knobs=knobs, **kw)[0]
    for name in OUTPUT_FIELDS:
        assert_same_bits(getattr(whole, name), getattr(tiled, name),
                         f"{name} at {sun}, tiles of {tile_size} on {hm.shape}, knobs {knobs}")


# ----------------------------------------------------------------------------- relief grid

@given(rows=st.integers(1, 90), cols=st.integers(1, 90), block=st.integers(1, 40), seed=st.integers(0, 2**31),
       holes=st.floats(0.0, 1.0))
@settings(max_examples=40, deadline=None)
def test_relief_grid_is_the_block_extrema(rows, cols, block, seed, holes):
    rng = np.random.default_rng(seed)
    h = rng.normal(0, 100, (rows, cols))
    h[rng.random((rows, cols)) < holes] = np.nan
    grid = ReliefGrid.of(h, block)
    for bi in range(-(-rows // block)):
        for bj in range(-(-cols // block)):
            part = h[bi * block:(bi + 1) * block, bj * block:(bj + 1) * block]
            finite = part[np.isfinite(part)]
            assert grid.hi[bi, bj] == (finite.max() if finite.size else -np.inf)
            assert grid.lo[bi, bj] == (finite.min() if finite.size else np.inf)
    streamed = ReliefGrid((rows, cols), block)
    r = 0
    while r < rows:                       # stripes of any height
        n = int(rng.integers(1, 2 * block + 2))
        streamed.accumulate(h[r:r + n])
        r += n
    assert streamed.complete and np.array_equal(streamed.hi, grid.hi) and np.array_equal(streamed.lo, grid.lo)
    if np.isfinite(h).any():
        assert grid.base == Heightmap.from_array(h).offset      # the whole map's base, exactly
    else:
        assert grid.base == 0.0 and math.isnan(grid.extrema[0])


def test_relief_grid_refuses_stripes_that_do_not_fit():
    grid = ReliefGrid((10, 4), 4)
    grid.accumulate(np.zeros((7, 4)))
    with pytest.raises(ValueError, match="does not continue"):
        grid.accumulate(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="does not continue"):
        ReliefGrid((10, 4), 4).accumulate(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="block must be a positive integer"):
        ReliefGrid((10, 4), 0)


@given(r0=st.integers(0, 60), c0=st.integers(0, 60), n=st.integers(1, 40), m=st.integers(1, 40),
       seed=st.integers(0, 2**31), z=st.sampled_from([1.0, 0.3048, 3.0]))
@settings(max_examples=30, deadline=None)
def test_window_heights_are_the_whole_maps_bits(r0, c0, n, m, seed, z):
    h = np.random.default_rng(seed).normal(1000.0, 300.0, (100, 100))
    h[5:9, 40:60] = np.nan
    whole = Heightmap.from_array(h, 30.0, z_factor=z)
    part = TileHeightmap(whole.heights[r0:r0 + n, c0:c0 + m], 30.0, 30.0, whole.offset)
    assert part.offset == whole.offset
    assert np.array_equal(part.relative32.view(np.uint32), whole.relative32[r0:r0 + n, c0:c0 + m].view(np.uint32))


# ----------------------------------------------------------------------------- halos

def test_halo_reaches_as_far_as_the_longest_shadow():
    """A wall 100 m high west of a plain, sun from the west at 5 degrees: its shadow is 38 cells
    long; every tile the shadow crosses must see the wall, the others need not."""
    h = np.zeros((24, 120))
    h[:, 5] = 100.0
    hm = Heightmap.from_array(h, 30.0)
    sun = Sun(270.0, 5.0)
    whole = ShadowCaster(hm, cache=False).cast(sun).mask
    length = 100.0 / math.tan(math.radians(5.0)) / 30.0
    assert whole[10, 6 + int(length) - 1] == 1 and whole[10, 6 + int(length) + 2] == 0
    relief = ReliefGrid.of(hm.heights, block=8)
    for tile in tiles_of(hm.shape, 8):
        window = halo_window(relief, tile, sun, 30.0, 30.0)
        assert window.c1 == min(tile.c1 + 1, 120) and window.r0 == max(tile.r0 - 1, 0)   # 1 cell off the sun
        if tile.c0 <= 5 + length:
            assert window.c0 <= 5, f"tile {tile} does not see the wall: window {window}"
        assert window.c0 >= tile.c0 - (length + 8 + 3)       # the bound, one block and the margin
    assert_tiled_equal(hm, sun, 8)


def test_halo_is_capped_by_the_map_for_a_sun_at_the_horizon():
    h = canyon_crater(64, seed=2).astype(np.float64)
    relief = ReliefGrid.of(h, 16)
    tile = Window(24, 40, 24, 40)
    grazing = halo_window(relief, tile, Sun(90.0, 1e-6), 30.0, 30.0)
    assert grazing == Window(23, 41, 23, 64)              # the whole map eastward, 1 cell elsewhere
    for sun in (Sun(90.0, 0.0), Sun(90.0, -5.0), Sun(12.0, 90.0)):  # no traversal: a 1-cell ring
        assert reach_distance(relief, tile, sun, 30.0, 30.0) == 0.0
        assert halo_window(relief, tile, sun, 30.0, 30.0) == Window(23, 41, 23, 41)
    # a tile of nodata only casts and receives nothing
    h[:32, :32] = np.nan
    assert reach_distance(ReliefGrid.of(h, 16), Window(0, 16, 0, 16), Sun(135.0, 5.0), 30.0, 30.0) == 0.0


@given(seed=st.integers(0, 2**31), az=st.floats(0.0, 360.0), el=st.floats(0.5, 89.0), block=st.sampled_from([4, 16]))
@settings(max_examples=30, deadline=None)
def test_halo_within_relief_over_tan_elevation(seed, az, el, block):
    """The march never asks for more than the whole map's bound (relief / tan elevation)."""
    h = np.random.default_rng(seed).uniform(0.0, 300.0, (50, 70))
    relief = ReliefGrid.of(h, block)
    sun = Sun(az, el)
    bound_r, bound_c = halo_bound(relief, sun, 30.0, 30.0)
    for tile in tiles_of(h.shape, 16):
        w = halo_window(relief, tile, sun, 30.0, 30.0)
        assert tile.r0 - w.r0 <= bound_r and w.r1 - tile.r1 <= bound_r
        assert tile.c0 - w.c0 <= bound_c and w.c1 - tile.c1 <= bound_c


# ----------------------------------------------------------------------------- tiled == whole map

SUNS = [Sun(az, el) for el in (5.0, 20.0, 45.0) for az in (0.0, 90.0, 135.0, 37.3, 212.7)] + [Sun(270.0, 20.0),
                                                                                             Sun(315.0, 5.0)]


@pytest.fixture(scope="module")
def canyon() -> Heightmap:
    h = canyon_crater(83, 121, seed=4, relief=1500.0).astype(np.float64)
    h[30:37, 50:70] = np.nan                 # a hole
    h[0, :] = np.nan                         # and a nodata edge
    return Heightmap.from_array(h, 30.0)


@pytest.mark.parametrize("sun", SUNS, ids=str)
def test_tiled_equals_whole_map(canyon, sun):
    # 40: slivers of 3 and 1 cells at the map's edges (83 = 2 x 40 + 3, 121 = 3 x 40 + 1)
    assert_tiled_equal(canyon, sun, 40, outputs=("mask", "self", "coefficient"))


@pytest.mark.parametrize("tile_size", [3, 7, 82, 120, 500])
def test_tiled_equals_whole_map_for_any_tile_size(canyon, tile_size):
    assert_tiled_equal(canyon, Sun(135.0, 20.0), tile_size, overlap=tile_size % 2 == 0)
    assert_tiled_equal(canyon, Sun(135.0, 20.0), tile_size, align=ALIGN, knobs={"lanes": 0})   # one ray per item


@pytest.mark.parametrize("tile_size", [1, 2])
def test_tiles_of_one_or_two_cells(tile_size):
    hm = Heightmap.from_array(canyon_crater(13, 17, seed=3, relief=800.0).astype(np.float64), 30.0)
    for sun in (Sun(135.0, 5.0), Sun(270.0, 20.0), Sun(45.0, 45.0)):
        assert_tiled_equal(hm, sun, tile_size, outputs=("mask", "self"))


@st.composite
def maps(draw) -> np.ndarray:
    rows, cols = draw(st.integers(2, 60)), draw(st.integers(2, 60))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    kind = draw(st.sampled_from(["noise", "integer", "walk", "canyon"]))
    if kind == "noise":
        h = rng.uniform(0.0, 500.0, (rows, cols))
    elif kind == "integer":
        h = rng.integers(0, 20, (rows, cols)).astype(np.float64) * 10.0
    elif kind == "walk":
        h = np.cumsum(rng.normal(0.0, 30.0, (rows, cols)), axis=1)
    else:
        h = canyon_crater(rows, cols, seed=int(rng.integers(1000))).astype(np.float64)
    h[rng.random((rows, cols)) < draw(st.sampled_from([0.0, 0.05]))] = np.nan
    return h


@given(h=maps(), az=st.one_of(st.sampled_from([0.0, 45.0, 90.0, 135.0, 180.0, 270.0]), st.floats(0.0, 360.0)),
       el=st.one_of(st.sampled_from([5.0, 20.0, 45.0]), st.floats(0.5, 80.0)), tile=st.integers(3, 40))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_tiled_equals_whole_map_on_random_maps(h, az, el, tile):
    assert_tiled_equal(Heightmap.from_array(h, 30.0), Sun(az, el), tile, outputs=("mask", "self"))


# ------------------------------------------------------- bit for bit on adversarial maps
# Integer and quarter-metre heights on 1 m cells make many rays graze the surface (decisions
# within float32 rounding); embedding a map at a large row / column offset of a nodata map makes
# the whole map's cell coordinates round at 2^-12 instead of < 2^-17.  Before the kernels took
# the window's origin, tiles formed their own (small) coordinates and such cells could flip.

def assert_embedded_tiled_equal(h: np.ndarray, sun: Sun, tile: int, offset: tuple[int, int], lanes: int) -> None:
    """``h`` embedded at ``offset`` in a nodata map: over h's cells the tiles' outputs equal the
    single-shot outputs of the whole (embedded) map bit for bit.  The tiles are h's, planned on h
    and moved by the offset (the nodata around h casts and receives nothing; planning every tile
    of the large map would take longer than tracing)."""
    big = np.full((h.shape[0] + offset[0], h.shape[1] + offset[1]), np.nan)
    big[offset[0]:, offset[1]:] = h
    hm = Heightmap.from_array(big, 1.0)
    outputs = ("mask", "self", "coefficient")
    whole = ShadowCaster(hm, cache=False, knobs={"lanes": lanes}).cast(sun, outputs=outputs)

    def moved(w: Window) -> Window:
        return Window(w.r0 + offset[0], w.r1 + offset[0], w.c0 + offset[1], w.c1 + offset[1])

    plan = plan_tiles(ReliefGrid.of(h, 8), [sun], 1.0, 1.0, tile, None, 1)
    jobs = [TileJob(moved(job.tile), moved(job.window), job.suns) for job in plan.jobs]
    tiled = {name: np.zeros_like(getattr(whole, name)) for name in OUTPUT_FIELDS}

    def write(job, results) -> None:
        for name in OUTPUT_FIELDS:
            tiled[name][job.tile.r0:job.tile.r1, job.tile.c0:job.tile.c1] = getattr(results[0], name)

    tracing = Tracing((sun,), outputs=outputs, base=hm.offset, knobs={"lanes": lanes})
    run_jobs(jobs, lambda w: big[w.r0:w.r1, w.c0:w.c1], write, tracing, overlap=False)
    inside = (slice(offset[0], None), slice(offset[1], None))
    for name in OUTPUT_FIELDS:
        assert_same_bits(getattr(whole, name)[inside], tiled[name][inside],
                         f"{name} at {sun}, tiles of {tile}, offset {offset}, lanes {lanes}")


@st.composite
def grazing_maps(draw) -> np.ndarray:
    rows, cols = draw(st.integers(8, 100)), draw(st.integers(8, 100))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    kind = draw(st.sampled_from(["integer", "quarters", "noise"]))
    if kind == "integer":
        return rng.integers(0, 6, (rows, cols)).astype(np.float64)
    if kind == "quarters":
        return np.round(rng.normal(0.0, 2.0, (rows, cols)) * 4.0) / 4.0
    return rng.normal(0.0, 3.0, (rows, cols))


@given(h=grazing_maps(), az=st.floats(0.0, 360.0), el=st.sampled_from([5.0, 20.0, 45.0]), tile=st.integers(3, 40),
       offset=st.sampled_from([(0, 70001), (70001, 0), (0, 3000), (3000, 0), (0, 0)]), lanes=st.sampled_from([0, 8]))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_tiled_is_bit_identical_on_grazing_maps_at_large_offsets(h, az, el, tile, offset, lanes):
    assert_embedded_tiled_equal(h, Sun(az, el), tile, offset, lanes)


@pytest.mark.parametrize("lanes", [0, 8])
def test_tiled_is_bit_identical_where_window_coordinates_flipped_a_cell(lanes):
    h = flipped_map()
    assert h.shape == (36, 73) and np.array_equal(np.round(h * 4.0) / 4.0, h)
    assert_embedded_tiled_equal(h, FLIP_SUN, FLIP_TILE, FLIP_OFFSET, lanes)


def test_several_suns_share_windows_and_equal_the_whole_map(canyon):
    suns = [Sun(az, el) for az, el in ((30.0, 20.0), (40.0, 25.0), (200.0, 10.0), (90.0, -3.0), (10.0, 90.0))]
    whole = ShadowCaster(canyon, cache=False).cast_many(suns)
    for budget in (None, 3000):
        tiled = cast_tiled(canyon, suns, tile_size=32, max_window_cells=budget, align=8)
        for a, b in zip(whole, tiled):
            assert a.sun == b.sun and np.array_equal(a.mask, b.mask)
    relief = ReliefGrid.of(canyon.heights)
    grouped = plan_tiles(relief, suns, 30.0, 30.0, 32)
    assert all(sorted(job.suns) == list(range(len(suns))) for job in grouped.jobs)   # one window per tile
    split = plan_tiles(relief, suns, 30.0, 30.0, 32, max_window_cells=3000, align=8)
    assert len(split.jobs) > len(grouped.jobs)
    for job in split.jobs:                 # a window over the budget holds a single sun
        assert job.window.cells <= 3000 or len(job.suns) == 1
        assert job.window.r0 % 8 == 0 and job.window.c0 % 8 == 0


def test_auto_tile_size_fits_the_budget():
    h = canyon_crater(200, seed=1, relief=1500.0).astype(np.float64)
    relief = ReliefGrid.of(h, 16)
    low, high = Sun(135.0, 5.0), Sun(135.0, 60.0)
    for budget in (5000, 20000, 40000):
        size = auto_tile_size(relief, [high], 30.0, 30.0, budget)
        plan = plan_tiles(relief, [high], 30.0, 30.0, size)
        assert plan.largest_window <= budget or size == 64
    assert auto_tile_size(relief, [low], 30.0, 30.0, 40000) <= auto_tile_size(relief, [high], 30.0, 30.0, 40000)


# ----------------------------------------------------------------------------- the pipeline

def test_pipeline_hands_every_tile_once_and_raises_errors(canyon):
    relief = ReliefGrid.of(canyon.heights)
    suns = (Sun(135.0, 20.0),)
    plan = plan_tiles(relief, suns, 30.0, 30.0, 32)
    tracing = Tracing(suns, dx=30.0, dy=30.0, base=canyon.offset)

    def read(w: Window) -> np.ndarray:
        return canyon.heights[w.r0:w.r1, w.c0:w.c1]

    for overlap in (True, False):
        seen = []
        run_jobs(plan.jobs, read, lambda job, res: seen.append((job.tile, res[0].mask.shape)), tracing,
                 overlap=overlap)
        assert seen == [(job.tile, job.tile.shape) for job in plan.jobs]

    reads = []

    def bad_read(w: Window) -> np.ndarray:
        reads.append(w)
        if len(reads) % 3 == 0:
            raise OSError("disk gone")
        return read(w)

    def bad_write(job, res) -> None:
        raise RuntimeError("disk full")

    for overlap in (True, False):
        with pytest.raises(OSError, match="disk gone"):
            run_jobs(plan.jobs, bad_read, lambda job, res: None, tracing, overlap=overlap)
        with pytest.raises(RuntimeError, match="disk full"):
            run_jobs(plan.jobs, read, bad_write, tracing, overlap=overlap)


def test_tracing_checks_its_arguments():
    with pytest.raises(ValueError, match="method must be one of"):
        Tracing((Sun(),), method="fast")
    with pytest.raises(ValueError, match="outputs must be"):
        Tracing((Sun(),), outputs=("shade",))
    with pytest.raises(ValueError, match="tile size must be a positive integer"):
        tiles_of((10, 10), 0)


def test_caster_checks_the_window_origin():
    hm = Heightmap.from_array(np.zeros((4, 5)), 1.0)
    assert ShadowCaster(hm, cache=False, origin=(np.int64(3), 7)).origin == (3, 7)
    for bad in ((-1, 0), (0, -2), (1.5, 0), (0,), "ab", None, (0, (1 << 30) - 4)):
        with pytest.raises(ValueError, match="origin must be a \\(row, column\\) pair of ints"):
            ShadowCaster(hm, cache=False, origin=bad)
    ShadowCaster(hm, cache=False, origin=((1 << 30) - 4, (1 << 30) - 5))   # the largest origin that fits
