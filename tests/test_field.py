"""The sun over a whole map (oclshade.solar.field) and its tracing per block (ShadowCaster with a
SunField): every cell's own sun within the tolerance of its block's, each block exact against
the float64 reference with its own sun, and the same bits whatever kernel variant runs."""
import argparse
import math
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
import tifffile
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pyproj = pytest.importorskip("pyproj")

from oclshade import ShadowCaster  # noqa: E402
from oclshade import reference as ref  # noqa: E402
from oclshade.cli import main  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import Curvature  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.solar import map_places, map_site, sun_field, suns_at  # noqa: E402
from oclshade.solar.cli import suns_for  # noqa: E402
from oclshade.solar.field import (MapPlaces, angles_between, on_heightmap, sun_differences, sun_spread,  # noqa: E402
                                   unit_vectors)
from oclshade.sun import Sun, SunBlock, SunField  # noqa: E402
from oclshade.sunshine import SunshineCaster  # noqa: E402

from test_site import write_tif  # noqa: E402
from test_sunshine import assert_sums_match  # noqa: E402

WGS84 = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)   # geographic, EPSG:4326


def write_geographic(path, heights, west, north, step):
    tags = [(34735, 3, len(WGS84), WGS84, True), (33550, 12, 3, (step, step, 0.0), True),
            (33922, 12, 6, (0, 0, 0, west, north, 0), True)]
    tifffile.imwrite(path, np.asarray(heights, np.float32), extratags=tags)
    return path


def cell_suns(places, when, shape):
    """(rows, cols, 3) unit vectors of every cell's own sun (at its centre), grid frame."""
    ii, jj = np.meshgrid(np.arange(shape[0]) + 0.5, np.arange(shape[1]) + 0.5, indexing="ij")
    return unit_vectors(*places.suns(when, ii, jj)).reshape(*shape, 3)


def assert_covers(field):
    """The blocks tile the map once, in raster order."""
    seen = np.zeros(field.shape, np.int32)
    for block in field.blocks:
        seen[block.row0:block.row1, block.col0:block.col1] += 1
    assert np.all(seen == 1)
    starts = [(b.row0, b.col0) for b in field.blocks]
    assert starts == sorted(starts)


MAPS = [  # (kind, rows, cols, cell, west, north, when)
    ("utm", 401, 301, 60.0, 300000.0, 5400000.0, "2024-06-21T05:15+02:00"),    # low sun, 12.3 E 48.7 N
    ("utm", 200, 500, 30.0, 680000.0, 7600000.0, "2024-03-20T12:00+01:00"),    # 68 N, noon
    ("geo", 241, 361, 1 / 120, -160.0, 22.3, "2024-06-21T07:00-10:00"),       # 30" cells, 2 x 3 degrees
]


@pytest.mark.parametrize("kind, rows, cols, cell, west, north, when", MAPS)
def test_every_cells_own_sun_is_within_the_tolerance_of_its_blocks(tmp_path, kind, rows, cols, cell, west, north,
                                                                   when):
    path = tmp_path / "map.tif"
    if kind == "utm":
        write_tif(path, np.zeros((rows, cols)), west=west, north=north, cell=cell)
    else:
        write_geographic(path, np.zeros((rows, cols)), west, north, cell)
    raster = read_dem(path)
    places = map_places(raster)
    t = datetime.fromisoformat(when)
    v = cell_suns(places, t, (rows, cols))
    for tolerance in (0.05, 0.01):
        field = sun_field(places, t, tolerance)
        assert_covers(field)
        assert field.deviation <= tolerance and field.tolerance == tolerance
        assert field.uniform == (sun_spread(places, [t]) <= tolerance)
        worst = max(float(angles_between(v[b.row0:b.row1, b.col0:b.col1], unit_vectors(b.sun.azimuth,
                                                                                        b.sun.elevation)).max())
                    for b in field.blocks)
        assert worst <= tolerance
    # the centre's sun is the one the site gives (NREL SPA there, turned through the CRS), at the
    # grid's scale there (a UTM grid's metre is not the ground's: test_projected_scale.py)
    site = map_site(raster)
    given = site.grid_suns(suns_at([t], site.latitude, site.longitude))[0]
    centre = places.on_grid(np.array([rows / 2]), np.array([cols / 2]), np.array([given.azimuth]),
                            np.array([given.elevation]))
    assert field.centre == Sun(float(centre[0][0]), float(centre[1][0]))
    # one block's sun at its centre, as the site code gives it for that place
    b = field.blocks[len(field.blocks) // 3]
    lon, lat = places.lonlat(np.array([(b.row0 + b.row1) / 2]), np.array([(b.col0 + b.col1) / 2]))
    here = map_site(raster, float(lat[0]), float(lon[0]))
    expected = here.grid_suns(suns_at([t], here.latitude, here.longitude))[0]
    # and that sun at the block's scale (test_geographic_scale.py, test_projected_scale.py)
    az, el = places.on_grid(np.array([(b.row0 + b.row1) / 2]), np.array([(b.col0 + b.col1) / 2]),
                            np.array([expected.azimuth]), np.array([expected.elevation]))
    if kind == "geo":
        assert abs(az[0] - expected.azimuth) > 1e-3     # its rows are off the centre latitude: another scale
    else:
        assert az[0] == expected.azimuth                # one scale both ways: the grid azimuth as it is
    expected = Sun(float(az[0]), float(el[0]))
    assert b.sun.azimuth == pytest.approx(expected.azimuth, abs=1e-9)
    assert b.sun.elevation == pytest.approx(expected.elevation, abs=1e-9)
    # the map is wide: one sun would be off by far more than the tolerance at its corners
    assert sun_spread(places, [t]) > 0.03


def test_a_small_map_is_one_block_and_the_tolerance_is_checked(tmp_path):
    raster = read_dem(write_tif(tmp_path / "small.tif", np.zeros((20, 30)), west=300000.0, north=5400000.0))
    places = map_places(raster)
    t = datetime.fromisoformat("2024-06-21T05:15+02:00")
    field = sun_field(places, t)
    assert field.uniform and field.blocks[0] == SunBlock(0, 20, 0, 30, field.centre)
    assert field.deviation == sun_spread(places, [t]) <= 0.01
    for bad in (0.0, -1.0, math.nan, math.inf, "0.1"):
        with pytest.raises(ValueError, match="tolerance must be a positive number of degrees"):
            sun_field(places, t, bad)


def test_night_and_the_refraction_jump_do_not_split_the_map(tmp_path):
    """Where the sun is below the horizon at every corner every cell is in shadow, whatever SPA's
    refraction does there (it jumps by 0.57 degrees where the upper limb sets)."""
    raster = read_dem(write_tif(tmp_path / "m.tif", np.zeros((1201, 1201)), west=350000.0, north=5400000.0))
    field = sun_field(map_places(raster), datetime.fromisoformat("2024-06-01T02:00+02:00"))
    assert field.uniform and field.centre.elevation < -5.0


def random_field(shape, rows, cols, seed, low=2.0, azimuths=None):
    """Blocks on these row and column cuts with random suns (elevations from ``low`` to 70;
    ``azimuths``: drawn from these)."""
    rng = np.random.default_rng(seed)
    blocks = [SunBlock(rows[a], rows[a + 1], cols[b], cols[b + 1],
                       Sun(float(rng.choice(azimuths) if azimuths is not None else rng.uniform(0.0, 360.0)),
                           float(rng.uniform(low, 70.0))))
              for a in range(len(rows) - 1) for b in range(len(cols) - 1)]
    return SunField(shape, tuple(blocks), blocks[0].sun)


@st.composite
def partitions(draw):
    rows, cols = draw(st.integers(2, 60)), draw(st.integers(2, 80))
    cuts_r = sorted(set(draw(st.lists(st.integers(1, rows - 1), max_size=3))))
    cuts_c = sorted(set(draw(st.lists(st.integers(1, cols - 1), max_size=4))))
    return rows, cols, [0, *cuts_r, rows], [0, *cuts_c, cols], draw(st.integers(0, 2**31))


KNOBS = [None, {"lanes": 0}, {"lanes": 8, "run": 64}, {"lanes": 0, "images": 1}]


def recut(field, seed):
    """The field with some blocks cut in two across a row or a column of their own (the second
    part with another sun, some at or below the horizon or at the zenith): the blocks no longer
    form a grid of bands, which the sun table makes of them."""
    rng = np.random.default_rng(seed)
    blocks = []
    for b in field.blocks:
        other = Sun(float(rng.uniform(0.0, 360.0)), float(rng.choice([-3.0, 0.0, 90.0, rng.uniform(2.0, 70.0)])))
        if rng.random() < 0.4 and b.row1 - b.row0 > 1:
            r = int(rng.integers(b.row0 + 1, b.row1))
            blocks += [SunBlock(b.row0, r, b.col0, b.col1, b.sun), SunBlock(r, b.row1, b.col0, b.col1, other)]
        elif rng.random() < 0.4 and b.col1 - b.col0 > 1:
            c = int(rng.integers(b.col0 + 1, b.col1))
            blocks += [SunBlock(b.row0, b.row1, b.col0, c, other), SunBlock(b.row0, b.row1, c, b.col1, b.sun)]
        else:
            blocks.append(b)
    return SunField(field.shape, tuple(blocks), field.centre)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(part=partitions(), knobs=st.sampled_from(KNOBS), certificates=st.booleans(), cut=st.booleans(),
       curved=st.booleans())
def test_a_field_traces_each_block_as_its_own_sun(part, knobs, certificates, cut, curved):
    """Bit for bit the whole-map outputs of each block's sun on that block's cells, whatever the
    kernel variant (packet runs cut to the block columns, one ray per item, images, with and
    without certificates), wherever the blocks are cut (``cut``: not on a grid of bands, some
    suns down or at the zenith), with Earth curvature or not (a 20 km radius, so that it
    matters on these maps): one launch with the field's sun table."""
    rows, cols, cut_r, cut_c, seed = part
    rng = np.random.default_rng(seed)
    h = np.cumsum(np.cumsum(rng.normal(size=(rows, cols)), 0), 1) * 3.0
    h[rng.random((rows, cols)) < 0.03] = np.nan
    hm = Heightmap.from_array(h, 10.0)
    caster = ShadowCaster(hm, cache=False, knobs=knobs, certificates=certificates,
                          curvature=Curvature(radius=2e4) if curved else None)
    field = random_field(hm.shape, cut_r, cut_c, seed)
    field = recut(field, seed) if cut else field
    outputs = ("mask", "self", "coefficient")
    got = caster.cast_many([field], outputs=outputs)[0]
    assert got.sun == field.centre
    assert caster.cast(field, outputs=outputs).mask.tobytes() == got.mask.tobytes()
    for block in field.blocks:
        whole = caster.cast(block.sun, outputs=outputs)
        window = np.s_[block.row0:block.row1, block.col0:block.col1]
        for name in ("mask", "self_shadow", "coefficient"):
            np.testing.assert_array_equal(getattr(got, name)[window], getattr(whole, name)[window])


def test_a_field_is_exact_against_the_reference_per_block():
    """The float64 reference with each block's sun, ties apart, on a real-like terrain."""
    rng = np.random.default_rng(5)
    h = np.cumsum(np.cumsum(rng.normal(size=(90, 120)), 0), 1) * 2.0
    hm = Heightmap.from_array(h, 30.0)
    field = random_field(hm.shape, [0, 17, 60, 90], [0, 32, 48, 120], 11)
    got = ShadowCaster(hm, cache=False).cast_many([field], outputs=("mask", "self"))[0]
    expected = ref.cast_field_shadows(hm, field)
    ties = expected.ties(ref.field_tie_tolerance(hm, field))
    differ = got.mask != expected.mask
    assert not (differ & ~ties).any() and differ.sum() <= 3
    assert np.array_equal(got.self_shadow, expected.self_shadow)
    for block in field.blocks:     # the twin is each block's own sun, cell by cell
        window = np.s_[block.row0:block.row1, block.col0:block.col1]
        np.testing.assert_array_equal(expected.margin[window], ref.cast_shadows(hm, block.sun, window).margin)
    assert (got.mask == 1).sum() > 100 and (got.mask == 0).sum() > 100


def test_a_field_must_tile_its_map():
    sun = Sun(90.0, 10.0)
    with pytest.raises(ValueError, match="must be non-empty and inside the 12x10 map"):
        SunField((10, 12), (SunBlock(0, 10, 0, 13, sun),), sun)
    with pytest.raises(ValueError, match="areas add up to 60 cells, not 120"):
        SunField((10, 12), (SunBlock(0, 10, 0, 6, sun),), sun)
    with pytest.raises(ValueError, match="non-empty"):
        SunField((10, 12), (SunBlock(0, 0, 0, 12, sun), SunBlock(0, 10, 0, 12, sun)), sun)


def test_a_field_must_fit_the_map():
    hm = Heightmap.from_array(np.zeros((10, 12)), 1.0)
    field = SunField.single(Sun(90.0, 10.0), (12, 10))
    with pytest.raises(ValueError, match="sun field is for a 10x12 map, not this 12x10 one"):
        ShadowCaster(hm).cast_many([field])


def test_the_cli_traces_datetimes_per_block_on_a_projected_map(tmp_path, capsys):
    """`shadow --datetime` on a 12 x 15 km UTM map: the API's field bit for bit, and not one sun
    (cells differ); a large --sun-tolerance gives one block, the sun at the map's centre."""
    rng = np.random.default_rng(0)
    heights = np.cumsum(np.cumsum(rng.normal(size=(400, 500)), 0), 1) * 0.5
    dem = write_tif(tmp_path / "utm.tif", heights, west=350000.0, north=5400000.0, cell=30.0)
    when = "2024-06-21T06:00+02:00"
    assert main(["shadow", str(dem), str(tmp_path / "f.npy"), "--datetime", when]) == 0
    err = capsys.readouterr().err
    assert "the sun per block of cells" in err and "--sun-tolerance 0.01" in err
    assert main(["shadow", str(dem), str(tmp_path / "one.npy"), "--datetime", when, "--sun-tolerance", "1",
                 "-q"]) == 0
    assert capsys.readouterr().err == ""
    raster = read_dem(dem)
    field = sun_field(map_places(raster), datetime.fromisoformat(when))
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    expected = ShadowCaster(hm, cache=False).cast_many([field])[0].mask
    per_block, one = np.load(tmp_path / "f.npy"), np.load(tmp_path / "one.npy")
    assert np.array_equal(per_block, expected)
    assert np.array_equal(one, ShadowCaster(hm, cache=False).cast(field.centre).mask)
    assert (per_block != one).sum() > 50
    (tmp_path / "suns.csv").write_text(f"datetime\n{when}\n")     # --suns datetime rows: the same
    assert main(["shadow", str(dem), str(tmp_path / "csv.npy"), "--suns", str(tmp_path / "suns.csv"), "-q"]) == 0
    assert np.array_equal(np.load(tmp_path / "csv.npy"), per_block)
    assert main(["shadow", str(dem), str(tmp_path / "x.npy"), "--datetime", when, "--sun-tolerance", "0"]) == 2
    assert "sun tolerance must be degrees above 0" in capsys.readouterr().err


def test_lat_lon_given_means_one_sun(tmp_path):
    dem = write_tif(tmp_path / "utm.tif", np.zeros((400, 500)), west=350000.0, north=5400000.0)
    args = argparse.Namespace(input=str(dem), lat=48.7, lon=13.0, sun_tolerance=0.01)
    placed = suns_for([datetime.fromisoformat("2024-06-21T06:00+02:00")], args, read_dem(dem))
    # one sun over the map, at the grid's scale (here, 150 km west of the central meridian, a grid
    # metre is within 0.00025 of the ground's: the sun as it is; test_projected_scale.py)
    assert [f.uniform for f in placed.fields] == [True] and [f.blocks[0].sun for f in placed.fields] == placed.suns


def test_sunshine_makes_its_suns_over_the_map_with_a_bar(tmp_path, capsys):
    """Past FIELDS_BAR steps the sun fields are made under a progress bar (quiet with -q); one
    line per tenth in a log."""
    from oclshade.solar.cli import FIELDS_BAR

    dem = write_tif(tmp_path / "utm.tif", np.cumsum(np.ones((40, 50)), 1), west=350000.0, north=5400000.0,
                    cell=30.0)
    start = datetime.fromisoformat("2024-06-21T00:00+02:00")
    argv = ["sunshine", str(dem), str(tmp_path / "s.npy"), "--start", start.isoformat(), "--end",
            (start + timedelta(minutes=10 * (FIELDS_BAR + 1))).isoformat()]
    assert main(argv) == 0
    bar = [line for line in capsys.readouterr().err.splitlines() if line.endswith("suns over the map")]
    assert len(bar) == 11 and bar[-1].endswith(f"{FIELDS_BAR + 1}/{FIELDS_BAR + 1} suns over the map")
    assert main([*argv, "-q"]) == 0
    assert capsys.readouterr().err == ""


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(part=partitions(), other=partitions())
def test_sunshine_sums_each_block_with_its_own_sun(part, other):
    """Steps that are sun fields (some blocks' suns below the horizon) mixed with plain suns: the
    masks route equals the float64 twin, each cell's daylight time (the fraction's denominator)
    summed over the steps whose block sun was up there."""
    rows, cols, cut_r, cut_c, seed = part
    rng = np.random.default_rng(seed)
    h = np.cumsum(np.cumsum(rng.normal(size=(rows, cols)), 0), 1) * 3.0
    h[rng.random((rows, cols)) < 0.03] = np.nan
    hm = Heightmap.from_array(h, 10.0)
    _, _, cut_r2, cut_c2, seed2 = other
    cut_r2 = sorted({min(r, rows) for r in cut_r2} | {0, rows})
    cut_c2 = sorted({min(c, cols) for c in cut_c2} | {0, cols})
    steps = [random_field(hm.shape, cut_r, cut_c, seed, low=-20.0), Sun(120.0, 25.0),
             random_field(hm.shape, cut_r2, cut_c2, seed2, low=-5.0), Sun(300.0, -3.0)]
    weights = [600, 300, 900, 600]
    got = SunshineCaster(hm).accumulate(steps, np.array(weights), "all")
    want = ref.sunshine_sums(hm, steps, weights)
    assert_sums_match(got, want, np.isnan(h), 3)
    day = np.broadcast_to(want.daylight_seconds, hm.shape)
    assert got.daylight_seconds == sum(w for s, w in zip(steps, weights) if (
        any(b.sun.elevation > 0 for b in s.blocks) if isinstance(s, SunField) else s.elevation > 0))
    assert np.all(day <= got.daylight_seconds)


def test_sunshine_horizon_route_per_block_on_grid_azimuths_is_exact():
    """Block suns on the horizon route's grid azimuths need no interpolation: the twin's sums."""
    rng = np.random.default_rng(3)
    h = np.cumsum(np.cumsum(rng.normal(size=(40, 56)), 0), 1) * 4.0
    hm = Heightmap.from_array(h, 20.0)
    grid = [360.0 * k / 16 for k in range(16)]
    steps = [random_field(hm.shape, [0, 13, 40], [0, 16, 21, 56], seed, low=-10.0, azimuths=grid)
             for seed in range(4)]
    got = SunshineCaster(hm).accumulate(steps, 600, ("hours", "fraction"), method="horizons", azimuths=16)
    want = ref.sunshine_sums(hm, steps, [600] * len(steps))
    assert_sums_match(got, want, np.isnan(h), 3)
    assert np.nanmax(got.hours) > 0 and np.nanmin(got.fraction) < np.nanmax(got.fraction)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(part=partitions(), method=st.sampled_from(["masks", "horizons"]))
def test_sunshine_of_a_field_is_each_blocks_own_sun_bit_for_bit(part, method):
    """A step that is a field (its table, one launch; the horizon route one per interval of grid
    azimuths holding its block suns, here at any azimuth) sums on each block's cells what that
    block's sun alone sums there: the same uint seconds and the same float32 beam sums."""
    rows, cols, cut_r, cut_c, seed = part
    rng = np.random.default_rng(seed)
    h = np.cumsum(np.cumsum(rng.normal(size=(rows, cols)), 0), 1) * 3.0
    hm = Heightmap.from_array(h, 10.0)
    field = recut(random_field(hm.shape, cut_r, cut_c, seed, low=-10.0), seed)
    if not any(b.sun.elevation > 0.0 for b in field.blocks):
        return
    caster = SunshineCaster(hm)
    got = caster.accumulate([field], 600, "all", method=method, azimuths=8)
    for block in field.blocks:
        window = np.s_[block.row0:block.row1, block.col0:block.col1]
        if block.sun.elevation <= 0.0:
            assert np.all(got.hours[window] == 0.0)
            continue
        alone = caster.accumulate([block.sun], 600, "all", method=method, azimuths=8)
        for name in ("hours", "irradiation"):
            np.testing.assert_array_equal(getattr(got, name)[window], getattr(alone, name)[window])


def test_sunshine_cli_sums_per_block_on_a_projected_map(tmp_path, capsys):
    """`sunshine` on a 15 x 12 km UTM map sums each block with its own sun by default: the API's
    sums over the fields of the steps, bit for bit, and not those of one sun per step (what
    `--sun-tolerance 1` gives there: one block)."""
    rng = np.random.default_rng(2)
    heights = np.cumsum(np.cumsum(rng.normal(size=(400, 500)), 0), 1) * 0.5
    dem = write_tif(tmp_path / "utm.tif", heights, west=350000.0, north=5400000.0, cell=30.0)
    argv = ["sunshine", str(dem), "", "--start", "2024-06-21T04:30+02:00", "--end", "2024-06-21T07:30+02:00",
            "--step", "30min", "--output", "hours,fraction"]
    assert main([*argv[:2], str(tmp_path / "f.npy"), *argv[3:]]) == 0
    assert "the sun per block of cells" in capsys.readouterr().err
    assert main([*argv[:2], str(tmp_path / "one.npy"), *argv[3:], "--sun-tolerance", "1", "-q"]) == 0
    assert capsys.readouterr().err == ""
    raster = read_dem(dem)
    places = map_places(raster)
    times = [datetime.fromisoformat("2024-06-21T04:45+02:00") + k * timedelta(minutes=30) for k in range(6)]
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    fields = [sun_field(places, t) for t in times]
    assert not any(f.uniform for f in fields[1:])
    want = SunshineCaster(hm).accumulate(fields, 1800, ("hours", "fraction"))
    one = SunshineCaster(hm).accumulate([f.centre for f in fields], 1800, ("hours", "fraction"))
    per_block, single = np.load(tmp_path / "f.npy"), np.load(tmp_path / "one.npy")
    np.testing.assert_array_equal(per_block[0], want.hours)
    np.testing.assert_array_equal(per_block[1], want.fraction)
    np.testing.assert_array_equal(single[0], one.hours)
    assert (per_block[0] != single[0]).sum() > 20


def test_sunshine_progress_with_fields_reports_once_a_launch():
    """With sun fields each daylight step is one launch (its sun table), so the progress callback
    comes once a daylight step, in order, ending at the total; the horizon route launches once a
    step and interval of grid azimuths holding one of its block suns."""
    hm = Heightmap.from_array(np.cumsum(np.ones((20, 40)), 1), 10.0)
    steps = [random_field(hm.shape, [0, 10, 20], [0, 16, 40], 1), Sun(90.0, 20.0),
             random_field(hm.shape, [0, 20], [0, 32, 40], 2, low=-30.0), Sun(200.0, -1.0)]
    day = 2 + any(b.sun.elevation > 0 for b in steps[2].blocks)
    calls = []
    SunshineCaster(hm).accumulate(steps, 60, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(k, day) for k in range(1, day + 1)]
    calls.clear()
    SunshineCaster(hm).accumulate(steps, 60, method="horizons", azimuths=8,
                                  progress=lambda done, total: calls.append((done, total)))
    intervals = {(k, int(b.sun.azimuth % 360.0 // 45.0)) for k, s in enumerate(steps[:3]) if isinstance(s, SunField)
                 for b in s.blocks if b.sun.elevation > 0} | {(1, 2)}
    assert calls == [(k, len(intervals)) for k in range(1, len(intervals) + 1)] and len(intervals) > day


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lat=st.floats(-84.0, 84.0), lon=st.floats(-180.0, 179.0), span=st.sampled_from([0.05, 0.5, 2.0]),
       minutes=st.integers(0, 366 * 24 * 60), tolerance=st.sampled_from([0.01, 0.03]))
def test_fields_hold_the_tolerance_anywhere(tmp_path_factory, lat, lon, span, minutes, tolerance):
    """Geographic maps anywhere (across the antimeridian too, up to 84 degrees), any time of
    2024: the blocks tile the map and the cells' own suns (a 25 x 25 sample of cell centres, the
    corners included) are within the tolerance of their block's, where either is up."""
    rows, cols = 120, 160
    step = span / cols
    north = min(lat + rows * step / 2, 89.9)
    path = write_geographic(tmp_path_factory.mktemp("g") / "g.tif", np.zeros((rows, cols)), lon, north, step)
    places = map_places(read_dem(path))
    when = datetime(2024, 1, 1, tzinfo=timezone.utc) + timedelta(minutes=minutes)
    field = sun_field(places, when, tolerance)
    assert_covers(field)
    r = np.unique(np.linspace(0, rows - 1, 25).round().astype(int))
    c = np.unique(np.linspace(0, cols - 1, 25).round().astype(int))
    rr, cc = np.meshgrid(r, c, indexing="ij")
    own = unit_vectors(*places.suns(when, rr + 0.5, cc + 0.5))
    block_of = {}
    for k, b in enumerate(field.blocks):
        block_of.update({(i, j): k for i in r if b.row0 <= i < b.row1 for j in c if b.col0 <= j < b.col1})
    theirs = np.array([unit_vectors(field.blocks[block_of[(i, j)]].sun.azimuth,
                                    field.blocks[block_of[(i, j)]].sun.elevation)
                       for i, j in zip(rr.ravel(), cc.ravel())])
    assert float(sun_differences(own, theirs).max()) <= tolerance


def test_sunlit_traces_the_disc_of_each_blocks_sun(tmp_path, capsys):
    """Soft shadows of a sun field: each block's cells bit for bit the whole-map fractions of its
    own sun's disc (API), and `sunlit --datetime` on a UTM map the API's field (one sun with
    --sun-tolerance 1)."""
    from oclshade.horizon import HorizonCaster

    rng = np.random.default_rng(4)
    hm = Heightmap.from_array(np.cumsum(np.cumsum(rng.normal(size=(50, 70)), 0), 1) * 3.0, 10.0)
    field = random_field(hm.shape, [0, 20, 50], [0, 16, 33, 70], 3, low=-5.0)
    caster = HorizonCaster(hm, cache=False)
    got = caster.sun_disc(field, columns=8)
    for block in field.blocks:
        window = np.s_[block.row0:block.row1, block.col0:block.col1]
        assert got[window].tobytes() == caster.sun_disc(block.sun, columns=8)[window].tobytes()
    assert np.nanmin(got) == 0.0 and np.nanmax(got) == 1.0 and ((got > 0) & (got < 1)).any()

    heights = np.cumsum(np.cumsum(rng.normal(size=(200, 260)), 0), 1) * 0.5
    dem = write_tif(tmp_path / "utm.tif", heights, west=350000.0, north=5400000.0, cell=30.0)
    when = "2024-06-21T05:40+02:00"
    assert main(["sunlit", str(dem), str(tmp_path / "f.npy"), "--datetime", when, "--columns", "4"]) == 0
    assert "the sun per block of cells" in capsys.readouterr().err
    assert main(["sunlit", str(dem), str(tmp_path / "one.npy"), "--datetime", when, "--columns", "4",
                 "--sun-tolerance", "1", "-q"]) == 0
    raster = read_dem(dem)
    sunfield = sun_field(map_places(raster), datetime.fromisoformat(when))
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    per_block, one = np.load(tmp_path / "f.npy"), np.load(tmp_path / "one.npy")
    caster = HorizonCaster(hm, cache=False)
    assert per_block.tobytes() == caster.sun_disc(sunfield, columns=4).tobytes()
    assert one.tobytes() == caster.sun_disc(sunfield.centre, columns=4).tobytes()
    assert not sunfield.uniform and (per_block != one).any()


def test_tiles_trace_a_field_as_the_whole_map():
    """cast_tiled of sun fields (small tiles, low suns: long halos) equals the whole map's
    per-block outputs bit for bit: each tile's window holds the terrain of every block sun."""
    from oclshade.tiles import cast_tiled

    rng = np.random.default_rng(8)
    h = np.cumsum(np.cumsum(rng.normal(size=(150, 190)), 0), 1) * 2.0
    hm = Heightmap.from_array(h, 10.0)
    fields = [random_field(hm.shape, [0, 37, 90, 150], [0, 48, 112, 190], seed, low=2.0) for seed in (1, 2)]
    outputs = ("mask", "self", "coefficient")
    whole = ShadowCaster(hm, cache=False).cast_many(fields, outputs=outputs)
    tiled = cast_tiled(hm, fields, outputs=outputs, tile_size=64)
    for w, t in zip(whole, tiled):
        assert t.sun == w.sun
        for name in ("mask", "self_shadow", "coefficient"):
            assert getattr(t, name).tobytes() == getattr(w, name).tobytes(), name


@pytest.mark.parametrize("workers", [None, 1])
def test_tiled_cli_traces_datetimes_per_block(tmp_path, capsys, workers):
    """`shadow --datetime --tile 128` on a UTM map, in this process or on Dask workers (the
    `dask` extra): the untiled per-block output, bit for bit."""
    if workers is not None:
        pytest.importorskip("distributed")
    rng = np.random.default_rng(0)
    heights = np.cumsum(np.cumsum(rng.normal(size=(400, 500)), 0), 1) * 0.5
    dem = write_tif(tmp_path / "utm.tif", heights, west=350000.0, north=5400000.0, cell=30.0)
    when = "2024-06-21T06:00+02:00"
    assert main(["shadow", str(dem), str(tmp_path / "whole.tif"), "--datetime", when, "-q"]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "tiled.tif"), "--datetime", when, "--tile", "128",
                 *(["--workers", str(workers)] if workers else [])]) == 0
    err = capsys.readouterr().err
    assert "the sun per block of cells" in err and "warning" not in err
    assert np.array_equal(tifffile.imread(tmp_path / "tiled.tif"), tifffile.imread(tmp_path / "whole.tif"))


@pytest.mark.parametrize("workers", [None, 1])
def test_tiled_runs_take_the_ground_metres_at_the_maps_middle_height(tmp_path, capsys, workers):
    """A windowed run holds no heights until it reads them: its relief pass gives the places
    the map's middle height (MapPlaces.height), so a high UTM map on its meridian (2700 m up:
    its ground metres 1.0004 of the ellipsoid's and UTM's 1 / 0.9996, traced per block) comes
    out of `shadow --sun --tile` and `--workers` as the whole run, bit for bit, and its masks
    differ from the ellipsoid's metres' (the places without the height)."""
    if workers is not None:
        pytest.importorskip("distributed")
    rng = np.random.default_rng(3)
    heights = 2700.0 + np.cumsum(np.cumsum(rng.normal(size=(300, 400)), 0), 1) * 0.5
    dem = write_tif(tmp_path / "high.tif", heights, north=5200000.0, cell=30.0)
    sun = ["--sun", "120,4", "--sun", "250,9"]
    assert main(["shadow", str(dem), str(tmp_path / "whole.tif"), *sun, "-q"]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "tiled.tif"), *sun, "--tile", "96", "-q",
                 *(["--workers", str(workers)] if workers else [])]) == 0
    assert "warning" not in capsys.readouterr().err
    whole = tifffile.imread(tmp_path / "whole.tif")
    assert np.array_equal(tifffile.imread(tmp_path / "tiled.tif"), whole)
    places = map_places(read_dem(dem))
    assert places.height == pytest.approx(2700.0, abs=300.0)
    low = MapPlaces(places.transform, places.shape, places.crs)          # (the ellipsoid's metres)

    def masks(hm: Heightmap) -> np.ndarray:
        suns = [on_heightmap(hm, Sun(120.0, 4.0)), on_heightmap(hm, Sun(250.0, 9.0))]
        return np.stack([r.mask for r in ShadowCaster(hm, cache=False).cast_many(suns)])

    assert np.array_equal(masks(Heightmap.from_raster(read_dem(dem))), whole)
    assert not np.array_equal(masks(Heightmap.from_array(heights, 30.0, row_scales=low.row_scales())), whole)


def test_large_fields_trace_instead_of_proving_each_block_shadow_free():
    """The scene analysis proves a sun shadow-free in about 0.16 ms: a field's block suns are
    tried only up to ANALYSED_BLOCKS (beyond, one traced launch costs less); the outputs are the
    same either way."""
    from oclshade.shadows import ANALYSED_BLOCKS

    hm = Heightmap.from_array(np.zeros((40, 40)), 10.0)     # flat, no holes: no sun casts anything
    caster = ShadowCaster(hm, cache=False)
    small = random_field(hm.shape, [0, 20, 40], [0, 16, 40], 1, low=10.0)
    cuts = list(range(0, 41, 2))
    large = random_field(hm.shape, cuts, [0, 16, 40], 1, low=10.0)
    assert len(small.blocks) <= ANALYSED_BLOCKS < len(large.blocks)
    assert caster._casts_nothing(small) and not caster._casts_nothing(large)
    for field in (small, large):
        assert np.all(caster.cast(field, outputs=("mask",)).mask == 0)


@settings(max_examples=60, deadline=None)
@given(azimuth=st.floats(0.0, 360.0), elevation=st.floats(-90.0, 90.0), stretched=st.booleans(),
       seed=st.integers(0, 2**32 - 1))
def test_a_banded_fields_vectors_are_its_suns_unit_vectors(azimuth, elevation, stretched, seed):
    """scaled_sun_vectors (banded_field's deviation, by algebra) are unit_vectors of scaled_suns'
    angles (geographic (east, north) and projected (s, s, p, q) scales), and angles_between (the
    chord's form) is the atan2 form's angle, to float64 rounding."""
    from oclshade.solar.field import scaled_sun_vectors, scaled_suns

    rng = np.random.default_rng(seed)
    east, north = rng.uniform(0.5, 1.5, 64), rng.uniform(0.5, 1.5, 64)
    scales = (np.stack([east, east, *rng.uniform(-0.45, 0.45, (2, 64))], axis=-1) if stretched
              else np.stack([east, north], axis=-1))
    sun = Sun(azimuth, elevation)
    want = unit_vectors(*scaled_suns(scales, np.full(64, azimuth), np.full(64, elevation)))
    got = scaled_sun_vectors(scales, sun)
    assert np.abs(got - want).max() <= 1e-14
    other = unit_vectors(rng.uniform(0.0, 360.0, 64), rng.uniform(-90.0, 90.0, 64))
    atan2 = np.degrees(np.arctan2(np.linalg.norm(np.cross(got, other), axis=-1), np.sum(got * other, axis=-1)))
    assert np.abs(angles_between(got, other) - atan2).max() <= 1e-9


def test_the_blocks_of_a_read_only_map_are_cut_once():
    """scale_blocks remembers the blocks of a read-only row-scale array (a heightmap's: every sun
    given by its angles cuts the same) and gives them read-only; a writable array, another
    tolerance or another array is cut anew, to the same blocks."""
    from oclshade.solar.scale import scale_blocks

    scales = np.stack(np.broadcast_arrays(1.0 + 1e-4 * np.arange(200)[:, None], 1.0), axis=-1)[:, 0, :]
    frozen = scales.copy()
    frozen.setflags(write=False)
    first = scale_blocks((200, 50), frozen)
    assert scale_blocks((200, 50), frozen) is first and not first.scales.flags.writeable
    again = scale_blocks((200, 50), scales)                   # writable: not remembered
    assert again is not first and np.array_equal(again.scales, first.scales)
    assert np.array_equal(again.row_edges, first.row_edges) and len(first.row_edges) > 2
    assert scale_blocks((200, 50), frozen, 0.02) is not first
    copy = frozen.copy()
    copy.setflags(write=False)
    assert scale_blocks((200, 50), copy) is not first
