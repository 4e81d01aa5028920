"""The C host API's sunshine, horizon and zeroing entry points (oclshade_enqueue_sunshine,
oclshade_enqueue_horizon, oclshade_enqueue_zero) against the Python host bit for bit, on
generated maps: the accumulated sums after several suns (both routes: exact masks and
horizons), horizon angles per azimuth and the sky-view factor sums (both definitions, with and
without Earth curvature).

The C side is host/tests/host_passes.c (subcommands sunshine and horizon); the build of host/
is the session fixture of tests/test_host_api.py.  The Python host's raw sums are read from
SunshineCaster's device buffers just before it turns them into maps (a spy on _maps), so the
comparison is of the very buffers, and the maps derived from the C sums by the formulas the
header documents must equal the Python host's maps.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyopencl as cl
import pytest

from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature, HorizonCaster, azimuth_grid
from oclshade.horizon.caster import sweeps
from oclshade.sun import Sun
from oclshade.sunshine import SunshineCaster

from test_host_api import host, run_program  # noqa: F401  (the session build of host/)
from test_horizon import varied_map

# (azimuth, elevation, seconds): a night sun (skipped by both hosts), suns at grid azimuths
# and between them, 45 degrees (w = 1 exactly), weights that differ
SUNS = [(100.0, 12.0, 600), (135.0, 45.0, 900), (181.3, 30.5, 300), (250.0, -3.0, 600), (290.0, 8.0, 1200),
        (359.9, 60.0, 60), (0.0, 20.0, 3600), (47.0, 5.0, 7)]


def generated_map(seed: int, rows: int, cols: int, holes: bool) -> Heightmap:
    rng = np.random.default_rng(seed)
    h = np.cumsum(rng.normal(size=(rows, cols)), axis=0) * 5.0 + np.cumsum(rng.normal(size=(rows, cols)), axis=1) * 5.0
    h += 400.0
    h[rows // 3, cols // 2] += 80.0
    if holes:
        h[rng.random(h.shape) < 0.03] = np.nan
    return Heightmap.from_array(h, (20.0, 25.0))


MAPS = {"holes": (5, 33, 47, True), "full": (8, 40, 29, False)}


def heights_file(tmp: Path, hm: Heightmap) -> Path:
    path = tmp / "heights.f64"
    np.ascontiguousarray(hm.heights, np.float64).tofile(path)
    return path


def python_sums(hm: Heightmap, method: str, azimuths: int):
    """The Python host's maps and its raw sums (sun, cast: uint32; beam: float32 pairs)."""
    caster = SunshineCaster(hm)
    raw: dict[str, np.ndarray] = {}
    finish = caster._maps

    def spy(outs, sums, *rest):
        for name, dtype, per in (("sun", np.uint32, 1), ("cast", np.uint32, 1), ("beam", np.float32, 2)):
            raw[name] = np.empty(hm.heights.size * per, dtype)
            cl.enqueue_copy(caster.runtime.queue, raw[name], sums[name])
        return finish(outs, sums, *rest)

    caster._maps = spy
    maps = caster.accumulate([(az, el) for az, el, _ in SUNS], np.array([s for *_, s in SUNS]), outputs="all",
                             method=method, azimuths=azimuths)
    return maps, raw


@pytest.mark.parametrize("case", sorted(MAPS))
@pytest.mark.parametrize("azimuths", [0, 12])   # 0: the masks route; N: horizons at N grid azimuths
def test_c_sunshine_equals_python(host: dict, tmp_path: Path, case: str, azimuths: int) -> None:
    hm = generated_map(*MAPS[case])
    rows, cols = hm.shape
    day = [(az, el, s) for az, el, s in SUNS if el > 0]
    if azimuths:   # the horizon route adds the suns by grid interval of azimuth (a Kahan sum's order matters)
        day.sort(key=lambda sun: min(int(np.floor(sun[0] % 360.0 * azimuths / 360.0)), azimuths - 1))
    day = [f"{az!r},{el!r},{s}" for az, el, s in day]
    run_program(host, "host_passes", "sunshine", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), azimuths, *day)
    maps, raw = python_sums(hm, "horizons" if azimuths else "masks", azimuths or 64)
    got = {name: np.fromfile(tmp_path / f"{name}.{ext}", raw[name].dtype)
           for name, ext in (("sun", "u32"), ("cast", "u32"), ("beam", "f32"))}
    for name in raw:
        assert got[name].tobytes() == raw[name].tobytes(), f"{case}: {name} sums differ"
        if not azimuths:
            pitched = np.fromfile(tmp_path / f"pitched_{name}.{'f32' if name == 'beam' else 'u32'}", raw[name].dtype)
            assert pitched.tobytes() == raw[name].tobytes(), f"{case}: {name} sums with pitched heights differ"
    assert raw["sun"].any() and raw["cast"].any(), "the suns must light and shade some cells"
    # the maps by the header's formulas
    nodata = np.isnan(hm.heights)
    total = sum(s for _, el, s in SUNS if el > 0)
    beam = got["beam"].reshape(rows, cols, 2).astype(np.float64)
    derived = {"hours": got["sun"].reshape(rows, cols) / 3600.0,
               "fraction": got["cast"].reshape(rows, cols) / total,
               "irradiation": beam[..., 0] - beam[..., 1]}
    for name, values in derived.items():
        want = getattr(maps, name)
        assert np.where(nodata, np.nan, values).astype(np.float32).tobytes() == want.tobytes(), name


@pytest.mark.parametrize("definition,curved,radius_cells,case", [(1, False, 0, "holes"), (2, True, 0, "holes"),
                                                                (2, True, 11.5, "holes"), (1, False, 120.0, "holes"),
                                                                (2, False, 6.5, "varied"), (1, True, 20.0, "varied")])
def test_c_horizons_and_svf_equal_python(host: dict, tmp_path: Path, definition: int, curved: bool,
                                         radius_cells: float, case: str) -> None:
    """With a radius host_passes also checks that sweep_cells 0 and 256 (every azimuth walked,
    every one swept) and sweep_far 2 (every one swept past the reach) give its default's bits;
    the varied map's flats and cliffs hold the float32 ties on which a walk without its margins
    (kernels/horizon.cl, prune_slack) differs."""
    hm = varied_map() if case == "varied" else generated_map(*MAPS[case])
    rows, cols = hm.shape
    n = 8
    curvature = Curvature(radius=20000.0, refraction=0.13) if curved else None   # a small planet: visible drops
    coefficient = curvature.coefficient if curved else 0.0
    max_distance = radius_cells * hm.dx or None
    run_program(host, "host_passes", "horizon", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), repr(coefficient), definition, n, repr(max_distance or 0.0))
    caster = HorizonCaster(hm, curvature=curvature, max_distance=max_distance, cache=False)
    if radius_cells == 120.0:    # at sweep_cells 128 the sweep near the axes, the walk on the diagonals (and the
        # C side checks itself that 0 and 256, every azimuth walked or swept, give the same bits)
        swept = [sweeps(*Sun(float(az), 0.0).ray(hm.dx, hm.dy)[:2], caster.radius, 128) for az in azimuth_grid(n)]
        assert any(swept) and not all(swept)
    angles = caster.horizons(n)
    for k in range(n):
        assert np.fromfile(tmp_path / f"angle_{k}.f32", np.float32).tobytes() == angles[k].tobytes(), k
    sums = np.fromfile(tmp_path / "svf.f32", np.float32).reshape(rows, cols, 2).astype(np.float64)
    svf = (1.0 - (sums[..., 0] - sums[..., 1]) / n).astype(np.float32)   # the header's formula
    svf[np.isnan(hm.heights)] = np.nan
    want = caster.sky_view_factor(n, "cosine" if definition == 1 else "solid-angle")
    assert svf.tobytes() == want.tobytes()
    assert np.nanmin(want) < 1.0   # some horizon above 0: the sums are not all zero


def row_scales_of(rows: int, north: float, south: float) -> np.ndarray:
    """A geographic grid's row scales from north to south (oclshade.solar.MapPlaces.row_scales, by
    its formula: io.metres_per_degree over the centre's)."""
    from oclshade.io import metres_per_degree

    lat = north + (south - north) * (np.arange(rows) + 0.5) / rows
    east, north_m = np.array([metres_per_degree(v) for v in lat]).T
    centre = metres_per_degree((north + south) / 2.0)
    return np.stack([east / centre[0], north_m / centre[1]], axis=-1)


@pytest.mark.parametrize("definition,radius_cells,span", [(1, 0, 0.1), (2, 0, 0.5), (2, 11.5, 0.5),
                                                         (1, 120.0, 0.5)])
def test_c_horizons_of_a_geographic_grid_equal_python(host: dict, tmp_path: Path, definition: int,
                                                      radius_cells: float, span: float) -> None:
    """row_scales: each band of rows walked (or swept) with its own ray and cell sizes, the
    Python host's HorizonCaster(row_scales=...) bit for bit (host_passes checks itself that the
    azimuths in one call, at batch 1, 8 and 64, and the sweep knobs give the same bits).  Bands
    of 16 rows (0.1 degree of latitude) and of 5 (0.5 degree)."""
    hm = varied_map()
    rows, cols = hm.shape
    scales = row_scales_of(rows, 61.0, 61.0 - span)
    n = 8
    max_distance = radius_cells * hm.dx or None
    caster = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales)
    assert caster.scale_blocks.scales.shape[:2] > (3, 0)       # several bands, of several sizes
    scales_file = tmp_path / "row_scales.f64"
    np.ascontiguousarray(scales, np.float64).tofile(scales_file)
    run_program(host, "host_passes", "horizon", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), "0.0", definition, n, repr(max_distance or 0.0), scales_file)
    angles = caster.horizons(n)
    flat = HorizonCaster(hm, max_distance=max_distance, cache=False).horizons(n)
    assert not np.array_equal(angles, flat, equal_nan=True)      # the bands' scales change the angles
    for k in range(n):
        assert np.fromfile(tmp_path / f"angle_{k}.f32", np.float32).tobytes() == angles[k].tobytes(), k
    sums = np.fromfile(tmp_path / "svf.f32", np.float32).reshape(rows, cols, 2).astype(np.float64)
    svf = (1.0 - (sums[..., 0] - sums[..., 1]) / n).astype(np.float32)
    svf[np.isnan(hm.heights)] = np.nan
    assert svf.tobytes() == caster.sky_view_factor(n, "cosine" if definition == 1 else "solid-angle").tobytes()


@pytest.mark.parametrize("radius_cells, bands", [(0, 0), (120.0, 0), (0, 3), (120.0, 3)])
def test_c_horizons_of_an_equal_area_grid_equal_python(host: dict, tmp_path: Path, radius_cells: float,
                                                       bands: int) -> None:
    """row_scale_columns 4: a projected grid's stretch by direction (rows made like
    oclshade.solar.MapPlaces.row_scales of an equal-area map: east = north = s, and p, q of a
    0.2-0.6 % stretch, all changing down the rows, and with row_scale_bands 3 across the columns
    too: blocks of rows by column bands), each block's rays stretched per azimuth, the Python
    host's HorizonCaster bit for bit (walked, swept, and all azimuths in one call at batch 1, 8
    and 64: host_passes checks those itself)."""
    hm = varied_map()
    rows, cols = hm.shape
    lat = 60.0 - 2.0 * (np.arange(rows) + 0.5) / rows       # made like a map's: s, p and q change down the rows
    slow = 0.04 if bands else 1.0                           # (with column bands: bands of several rows each)
    s = 0.9 + 0.05 * slow * (lat - 59.0)
    scales = np.stack([s, s, -0.004 + 0.002 * slow * (lat - 59.0), 0.0025 + 0.001 * slow * (lat - 59.0)], axis=-1)
    if bands:                                               # and across them
        across = np.arange(bands)[None, :, None] * np.array([0.01, 0.01, 0.001, -0.0005])
        scales = scales[:, None, :] + across
    n = 8
    max_distance = radius_cells * hm.dx or None
    caster = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales)
    blocks = caster.scale_blocks
    assert blocks.scales.shape[0] > 3 and blocks.scales.shape[1:] == (max(bands, 1), 4)
    assert bands == 0 or 1 < np.diff(blocks.row_edges).min() < rows       # bands of rows, of several
    scales_file = tmp_path / "row_scales.f64"
    np.ascontiguousarray(scales, np.float64).tofile(scales_file)
    run_program(host, "host_passes", "horizon", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), "0.0", 1, n, repr(max_distance or 0.0), scales_file, 4, bands)
    angles = caster.horizons(n)
    walked = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales, knobs={"batch": 1})
    assert walked.horizons(n).tobytes() == angles.tobytes()          # an azimuth per launch: the same bits
    unstretched = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales[..., :2]).horizons(n)
    assert not np.array_equal(angles, unstretched, equal_nan=True)     # the stretch changes the angles
    if bands:                                                          # and the column bands theirs
        one_band = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales[:, 0]).horizons(n)
        assert not np.array_equal(angles[:, :, 64:], one_band[:, :, 64:], equal_nan=True)
    for k in range(n):
        assert np.fromfile(tmp_path / f"angle_{k}.f32", np.float32).tobytes() == angles[k].tobytes(), k
    sums = np.fromfile(tmp_path / "svf.f32", np.float32).reshape(rows, cols, 2).astype(np.float64)
    svf = (1.0 - (sums[..., 0] - sums[..., 1]) / n).astype(np.float32)
    svf[np.isnan(hm.heights)] = np.nan
    assert svf.tobytes() == caster.sky_view_factor(n, "cosine").tobytes()


@pytest.mark.parametrize("cols, edges", [(63, [0, 16, 48, 63]), (400, [0, 128, 256, 400])])
def test_c_sweep_of_blocks_with_a_narrow_last_column_band_equals_python(host: dict, tmp_path: Path, cols: int,
                                                                         edges: list) -> None:
    """63 columns in 3 column bands (edges 0, 16, 48, 63): the last band is 15 columns, narrower
    than 16 lanes, so the sweep's last run is shifted into the band before it and must take the
    ray of the columns it writes (kernels/horizon.cl).  400 columns: bands wide enough for edges
    at multiples of 64 (oclshade.solar.scale.column_alignment; at 16 they would be 0, 128, 272),
    which the C host cuts alike.  Within a search radius of 12 cells, the C host's angles and
    sky-view sums equal the Python host's bit for bit (host_passes checks itself the walk and
    the sweep at lanes 1, 4, 8 and 16 against each other)."""
    from oclshade.synthetic import canyon_crater

    rows = 40
    s = 0.9 + 0.002 * np.arange(rows)[:, None] + np.array([0.0, 0.02, 0.05])[None, :]
    scales = np.stack(np.broadcast_arrays(s, s, -0.004, 0.003 + 0.001 * np.arange(3)[None, :]), axis=-1)
    hm = Heightmap.from_array(canyon_crater(rows, cols, seed=11, relief=400.0), 30.0)
    n, max_distance = 8, 12 * 30.0
    caster = HorizonCaster(hm, max_distance=max_distance, cache=False, row_scales=scales)
    assert caster.scale_blocks.col_edges.tolist() == edges
    scales_file = tmp_path / "row_scales.f64"
    np.ascontiguousarray(scales, np.float64).tofile(scales_file)
    run_program(host, "host_passes", "horizon", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), "0.0", 1, n, repr(max_distance), scales_file, 4, 3)
    angles = caster.horizons(n)
    for k in range(n):
        assert np.fromfile(tmp_path / f"angle_{k}.f32", np.float32).tobytes() == angles[k].tobytes(), k
    sums = np.fromfile(tmp_path / "svf.f32", np.float32).reshape(rows, cols, 2).astype(np.float64)
    svf = (1.0 - (sums[..., 0] - sums[..., 1]) / n).astype(np.float32)
    assert svf.tobytes() == caster.sky_view_factor(n, "cosine").tobytes()


@pytest.mark.parametrize("azimuth, elevation, radius, columns, curved, radius_cells",
                         [(135.0, 12.0, 0.0, 0, False, 0.0), (300.5, 4.0, 0.2666, 64, False, 0.0),
                          (10.0, 25.0, 1.5, 7, True, 0.0), (225.0, 6.0, 0.0, 16, False, 150.0)])
def test_c_soft_shadows_equal_python(host: dict, tmp_path: Path, azimuth: float, elevation: float, radius: float,
                                     columns: int, curved: bool, radius_cells: float) -> None:
    """oclshade_sun_disc: the visible share of the sun's disc, the Python host's
    HorizonCaster.sun_disc bit for bit (defaults 0 = the mean sun's radius and 16 strips; a
    search radius; Earth curvature); host_passes checks itself that the strips' parts
    (oclshade_sun_disc_strips, clamped oclshade_enqueue_horizon) sum to the same bits."""
    from oclshade.horizon import DEFAULT_COLUMNS, SUN_RADIUS

    hm = varied_map()
    rows, cols = hm.shape
    max_distance = radius_cells * hm.dx or None
    caster = HorizonCaster(hm, curvature=Curvature() if curved else None, max_distance=max_distance, cache=False)
    run_program(host, "host_passes", "sun_disc", tmp_path, heights_file(tmp_path, hm), rows, cols, repr(hm.dx),
                repr(hm.dy), repr(azimuth), repr(elevation), repr(radius), columns, repr(caster.coefficient),
                repr(max_distance or 0.0))
    want = caster.sun_disc(Sun(azimuth, elevation), radius or SUN_RADIUS, columns or DEFAULT_COLUMNS)
    got = np.fromfile(tmp_path / "fraction.f32", np.float32).reshape(rows, cols)
    assert got.tobytes() == want.tobytes()
    assert 0.0 < np.nanmean(want) < 1.0 and np.any((want > 0.0) & (want < 1.0))   # lit, shaded and penumbra
