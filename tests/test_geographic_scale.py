"""A geographic grid's scale (oclshade.solar.MapPlaces.on_grid): its cells are metres at the
centre latitude's scale, so a sun is traced per block of rows with the direction that runs
over the same ground as the true one; checked against pyproj's geodesics and, on a map 1.7
degrees tall at 60 N, against the float64 reference traced row by row."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pyproj = pytest.importorskip("pyproj")

from oclshade import reference as ref  # noqa: E402
from oclshade.cli import main  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.io import Raster, read_dem  # noqa: E402
from oclshade.solar import map_places, sun_field  # noqa: E402
from oclshade.sun import BlockGrid, Sun, SunField  # noqa: E402
from oclshade.synthetic import canyon_crater  # noqa: E402

from test_field import write_geographic  # noqa: E402

GEOD = pyproj.Geod(ellps="WGS84")


def ground_sun(raster, places, row, col, azimuth, elevation, metres=50.0):
    """The true (azimuth, elevation) of the line a grid sun traces from cell (row, col): a step of
    ``metres`` grid metres along it, to longitude and latitude, then pyproj's geodesic there."""
    lon0, lat0 = places.lonlat(np.array([row + 0.5]), np.array([col + 0.5]))
    a, e = places.on_grid(np.array([row + 0.5]), np.array([col + 0.5]), np.array([azimuth]), np.array([elevation]))
    a, e = math.radians(a[0]), math.radians(e[0])
    dcol, drow = math.sin(a) * metres / raster.dx, -math.cos(a) * metres / raster.dy
    lon1, lat1 = places.lonlat(np.array([row + 0.5 + drow]), np.array([col + 0.5 + dcol]))
    forward, _, distance = GEOD.inv(lon0[0], lat0[0], lon1[0], lat1[0])
    return forward % 360.0, math.degrees(math.atan2(metres * math.tan(e), distance))


def angle_gap(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(north=st.floats(-60.0, 75.0), row=st.integers(0, 1199), azimuth=st.floats(0.0, 360.0, exclude_max=True),
       elevation=st.floats(1.0, 80.0))
def test_the_grid_sun_runs_over_the_true_ground(tmp_path_factory, north, row, azimuth, elevation):
    path = write_geographic(tmp_path_factory.mktemp("geo") / "map.tif", np.zeros((1200, 4)), 10.0, north, 1 / 1200)
    raster = read_dem(path)
    places = map_places(raster)
    true_az, true_el = ground_sun(raster, places, row, 2, azimuth, elevation)
    # to the line's turn from the geodesic over the 50 m step (the meridians converge)
    assert angle_gap(true_az, azimuth) <= 2e-3 and abs(true_el - elevation) <= 2e-3


def test_the_centre_scale_alone_is_off_at_the_edges(tmp_path):
    """What the grid sun mends: the sun as given, traced at the centre's scale, runs 0.2 degree off
    at the edge of a 1-degree tile at 45 N (docs/methods.md, "Geographic grids")."""
    raster = read_dem(write_geographic(tmp_path / "map.tif", np.zeros((1200, 4)), 10.0, 46.0, 1 / 1200))
    places = map_places(raster)
    assert places.on_grid(np.array([0.5]), np.array([2.5]), np.array([90.0]), np.array([45.0]))[1][0] != 45.0

    class CentreScale:                       # the grid without the mend: suns traced as given
        def __getattr__(self, name):
            return getattr(places, name)

        def on_grid(self, rows, cols, azimuth, elevation):
            return azimuth, elevation

    true_az, true_el = ground_sun(raster, CentreScale(), 0, 2, 90.0, 45.0)
    assert abs(true_el - 45.0) > 0.2


def row_field(places, sun, shape):
    """Every row with its own grid sun: the reference the blocks approximate."""
    rows, cols = shape
    az, el = places.on_grid(np.arange(rows) + 0.5, np.full(rows, cols / 2), np.full(rows, sun.azimuth),
                            np.full(rows, sun.elevation))
    return SunField(shape, BlockGrid(np.arange(rows + 1), np.array([0, cols]), az[:, None], el[:, None]), sun)


@pytest.mark.parametrize("sun", [Sun(90.0, 20.0), Sun(240.0, 35.0)])
def test_a_sun_on_a_geographic_map_is_exact_row_by_row_to_the_tolerance(tmp_path, sun):
    rows, cols, step, tolerance = 200, 120, 1 / 120, 0.01       # 30" cells, 60.8 to 59.2 N
    path = write_geographic(tmp_path / "map.tif", canyon_crater(rows, cols, seed=3, relief=4000.0),
                            10.0, 60.0 + rows * step / 2, step)
    raster = read_dem(path)
    places = map_places(raster)
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    exact = ref.cast_field_shadows(hm, row_field(places, sun, hm.shape))
    # a margin moves by at most (sec^2 e + 2 slope) radians per radian of the sun: cells nearer a
    # tie than the tolerance's share may go either way
    gy, gx = np.gradient(hm.heights.astype(np.float64), raster.dy, raster.dx)
    bound = (1.0 / math.cos(math.radians(sun.elevation)) ** 2 + 2.0 * float(np.hypot(gx, gy).max())) \
        * math.radians(tolerance) + ref.field_tie_tolerance(hm, row_field(places, sun, hm.shape))
    clear = ~exact.ties(bound)
    out = tmp_path / "mask.tif"
    assert main(["shadow", str(path), str(out), "-az", str(sun.azimuth), "-alt", str(sun.elevation), "-q",
                 "--sun-tolerance", str(tolerance)]) == 0
    mask = read_dem(out).heights
    assert np.count_nonzero(clear) > 0.9 * mask.size
    assert np.array_equal(mask[clear], exact.mask[clear])
    # the map's scale changes by 5 % over it: one sun at the centre's scale misses clear cells
    assert main(["shadow", str(path), str(out), "-az", str(sun.azimuth), "-alt", str(sun.elevation), "-q",
                 "--sun-tolerance", "90"]) == 0
    assert np.count_nonzero(read_dem(out).heights[clear] != exact.mask[clear]) > 10


def test_lat_lon_on_a_geographic_map_keeps_its_scale(tmp_path):
    """--lat/--lon fix the sun's place, not the grid's scale: each block still gets its rows'."""
    rows, step = 200, 1 / 120
    path = write_geographic(tmp_path / "map.tif", np.zeros((rows, 40)), 10.0, 60.0 + rows * step / 2, step)
    raster = read_dem(path)
    places = map_places(raster)
    from oclshade.solar.cli import suns_for
    import argparse

    args = argparse.Namespace(lat=60.0, lon=10.0, sun_tolerance=0.01, input=str(path), quiet=True)
    from datetime import datetime, timezone
    placed = suns_for([datetime(2024, 6, 21, 9, tzinfo=timezone.utc)], args, raster)
    field = placed.fields[0]
    assert not field.uniform
    assert field == sun_field(places, placed.suns[0], 0.01)


def geo_map(tmp_path, rows=160, cols=96, step=1 / 120, north=60.67):
    """A canyon map of 30" cells from ``north`` down (60.67 to 59.33 N: its scale changes by 4 %)."""
    path = write_geographic(tmp_path / "map.tif", canyon_crater(rows, cols, seed=3, relief=4000.0), 10.0,
                            north, step)
    raster = read_dem(path)
    return path, raster, map_places(raster), Heightmap.from_array(raster.heights, (raster.dx, raster.dy))


@pytest.mark.parametrize("knobs, radius", [({"batch": 1}, None), ({"batch": 8}, None),
                                           ({"sweep_far": 2}, 20000.0), ({"sweep_far": 0}, 20000.0)])
def test_geographic_horizons_are_each_bands_own_cells_exactly(tmp_path, knobs, radius):
    from oclshade.horizon import HorizonCaster
    from oclshade.solar.scale import SCALE_TOLERANCE

    _, raster, places, hm = geo_map(tmp_path)
    scales = places.row_scales()
    caster = HorizonCaster(hm, row_scales=scales, max_distance=radius, knobs=knobs, cache=False)
    edges, band_scales = caster.scale_blocks.row_edges, caster.scale_blocks.scales[:, 0]
    assert edges[0] == 0 and edges[-1] == hm.shape[0] and len(band_scales) > 10
    for k, (r0, r1) in enumerate(zip(edges, edges[1:])):      # every row's cells within the tolerance's share
        assert np.abs(scales[r0:r1] / band_scales[k] - 1.0).max() <= math.sqrt(2.0) * math.radians(SCALE_TOLERANCE)
    azimuths = [0.0, 37.5, 90.0, 200.0, 315.0]
    got = caster.horizons(azimuths)
    flat = HorizonCaster(hm, max_distance=radius, knobs=knobs, cache=False).horizons(azimuths)
    banded = Heightmap.from_raster(raster)                   # the float64 twin: each band with its cells
    expected = np.stack([ref.banded_horizon_angles(banded, az, max_distance=caster.radius or math.inf)
                         for az in azimuths])
    band = ref.angle_tolerance(hm)
    assert np.array_equal(got == -90.0, expected == -90.0)
    assert np.nanmax(np.abs(got - expected)) <= band
    assert np.nanmax(np.abs(flat - expected)) > 0.3   # the centre's cell sizes alone: off by far more
    svf = caster.sky_view_factor(azimuths)           # the device's sums of these horizons' terms
    assert np.nanmax(np.abs(svf - ref.sky_view_factor(expected))) <= math.radians(band) + 1e-6


def test_horizon_and_svf_cli_trace_a_geographic_map_per_band(tmp_path):
    from oclshade.horizon import HorizonCaster

    path, raster, places, hm = geo_map(tmp_path)
    caster = HorizonCaster(hm, row_scales=places.row_scales(), cache=False)
    out = tmp_path / "horizons.tif"
    assert main(["horizon", str(path), str(out), "--azimuths", "8", "-q"]) == 0
    assert np.array_equal(read_dem(out, band=3).heights, caster.horizons([90.0])[0], equal_nan=True)
    assert main(["svf", str(path), str(out), "--azimuths", "8", "-q"]) == 0
    assert np.array_equal(read_dem(out).heights, caster.sky_view_factor(8), equal_nan=True)


def test_row_scales_are_checked():
    from oclshade.horizon import HorizonCaster

    hm = Heightmap.from_array(np.zeros((4, 5)), 30.0)
    with pytest.raises(ValueError, match=r"row_scales .*\(4, 2 or 4\).*\(5, 2\)"):
        HorizonCaster(hm, row_scales=np.ones((5, 2)))
    with pytest.raises(ValueError, match="row_scales"):
        HorizonCaster(hm, row_scales=np.zeros((4, 2)))


@pytest.mark.parametrize("method", ["masks", "horizons"])
def test_sunshine_beam_on_a_geographic_map_is_the_true_suns(tmp_path, method):
    """The blocks trace the grid's suns (the true shadows) and sum the beam with the true sun on
    the true slope: on flat ground sin e, on a plane tilted east its incidence, whatever the row;
    and the float64 twin's sums, hours bit for bit and the beam within its bound."""
    from oclshade.sunshine import SunshineCaster
    from test_sunshine import assert_sums_match

    rows, cols, step = 160, 48, 1 / 120
    slope = 0.3                                  # rise per true metre east
    raster = read_dem(write_geographic(tmp_path / "flat.tif", np.zeros((rows, cols)), 10.0, 60.67, step))
    places = map_places(raster)
    sun = Sun(135.0, 25.0)
    field = sun_field(places, sun, 0.01)
    assert len(field.blocks) > 8 and np.ptp(field.scales[:, 0]) > 0.03
    flat = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    tilted_heights = slope * (np.arange(cols)[None, :] * raster.dx * places.row_scales()[:, :1])
    tilted = Heightmap.from_array(tilted_heights, (raster.dx, raster.dy))
    # its gradient on the ground: east, slope; north, the meridians' convergence (z grows with the
    # parallels' length at a column)
    east = np.full((rows, cols), slope)
    north = -slope * np.arange(cols)[None, :] * raster.dx * np.gradient(places.row_scales()[:, 0])[:, None] \
        / (raster.dy * places.row_scales()[:, 1:])
    e, a = math.radians(sun.elevation), math.radians(sun.azimuth)
    incidence = (math.sin(e) - east * math.cos(e) * math.sin(a) - north * math.cos(e) * math.cos(a)) \
        / np.sqrt(1.0 + east ** 2 + north ** 2)
    for hm, expected in ((flat, math.sin(e)), (tilted, incidence[1:-1, 1:-1])):
        got = SunshineCaster(hm).accumulate([field], [3600], ("hours", "fraction", "irradiation"), method=method,
                                            azimuths=64)
        inner = got.irradiation[1:-1, 1:-1]           # one-sided gradients at the edges
        assert np.nanmax(np.abs(inner - expected)) <= (2e-6 if hm is flat else 2e-4)
        assert_sums_match(got, ref.sunshine_sums(hm, [field], [3600]), np.isnan(hm.heights), 0)


def test_masks_and_horizons_agree_on_a_geographic_map(tmp_path):
    """A cell is in cast shadow at (az, e) exactly when its horizon at az is above e, ties apart,
    on a geographic map too: a sun given by its angles is traced in the horizons' bands of rows
    (oclshade.solar.scale.scale_blocks), so both follow the same lines."""
    path, raster, places, hm = geo_map(tmp_path, rows=600, cols=300, step=1 / 1200, north=60.25)   # 3" cells
    horizons = tmp_path / "horizons.tif"
    assert main(["horizon", str(path), str(horizons), "--azimuths", "8", "-q"]) == 0
    # ties: the two kernels' float32 decisions, within 7e-5 degree on the SRTM tiles (docs/methods.md,
    # "Geographic grids"); ref.angle_tolerance's 0.01 degree bound would hide a geometry 0.01 off
    band = 1e-3
    shadowed = 0
    for k, elevation in ((1, 12.0), (2, 20.0), (5, 8.0), (7, 30.0), (3, 5.0)):
        mask_path = tmp_path / f"mask{k}.tif"
        assert main(["shadow", str(path), str(mask_path), "-az", str(45.0 * k), "-alt", str(elevation), "-q"]) == 0
        mask, horizon = read_dem(mask_path).heights, read_dem(horizons, band=k + 1).heights
        valid = mask != 255
        differ = valid & ((mask == 1) != (horizon > elevation))
        assert not np.any(differ & (np.abs(horizon - elevation) > band)), int(differ.sum())
        shadowed += int(np.count_nonzero(mask == 1))
    assert shadowed > 1000


def test_from_raster_carries_a_geographic_grids_row_scales(tmp_path):
    path, raster, places, hm = geo_map(tmp_path)
    banded = Heightmap.from_raster(raster)
    assert np.array_equal(banded.heights, hm.heights, equal_nan=True) and (banded.dx, banded.dy) == (hm.dx, hm.dy)
    assert np.array_equal(banded.row_scales, places.row_scales()) and hm.row_scales is None
    assert not banded.row_scales.flags.writeable
    assert np.array_equal(Heightmap.from_raster(raster, z_factor=2.0).heights, 2.0 * hm.heights, equal_nan=True)
    projected = Raster(raster.heights, 30.0, 30.0, georef=raster.georef)     # geographic=False: metres
    assert Heightmap.from_raster(projected).row_scales is None
    with pytest.raises(ValueError, match=r"row_scales .*\(160, 2 or 4\).*\(160, 1\)"):
        Heightmap.from_array(raster.heights, 30.0, row_scales=np.ones((160, 1)))
    with pytest.raises(ValueError, match=r"row_scales"):
        Heightmap.from_array(raster.heights, 30.0, row_scales=np.zeros((160, 2)))


@pytest.mark.parametrize("sun", [Sun(90.0, 20.0), Sun(215.0, 12.0)])
def test_a_sun_by_its_angles_on_a_geographic_heightmap_is_traced_per_band(tmp_path, sun):
    """The API as the CLI: ShadowCaster(Heightmap.from_raster(...)).cast(Sun) traces the bands'
    grid suns (sun_field(map_places(...), Sun)), bit for bit the CLI's mask, exact against the
    float64 twin of those suns; the same sun at the centre's scale differs."""
    from oclshade import ShadowCaster
    from oclshade.solar.field import on_heightmap

    path, raster, places, hm = geo_map(tmp_path)
    banded = Heightmap.from_raster(raster)
    got = ShadowCaster(banded, cache=False).cast(sun, outputs=("mask", "self"))
    assert got.sun == sun
    field = sun_field(places, sun)
    assert not field.uniform and on_heightmap(banded, sun) == field
    expected = ShadowCaster(hm, cache=False).cast(field, outputs=("mask", "self"))
    assert np.array_equal(got.mask, expected.mask) and np.array_equal(got.self_shadow, expected.self_shadow)
    out = tmp_path / "mask.tif"
    assert main(["shadow", str(path), str(out), "-az", str(sun.azimuth), "-alt", str(sun.elevation), "-q"]) == 0
    assert np.array_equal(read_dem(out).heights, np.where(got.mask == 255, np.nan, got.mask), equal_nan=True)
    twin = ref.cast_field_shadows(hm, field)
    clear = ~twin.ties(ref.field_tie_tolerance(hm, field))
    assert np.array_equal(got.mask[clear], twin.mask[clear]) and np.array_equal(got.self_shadow, twin.self_shadow)
    centre = ShadowCaster(hm, cache=False).cast(sun).mask
    assert np.count_nonzero(centre[clear] != got.mask[clear]) > 10


def test_horizons_soft_shadows_and_sunshine_on_a_geographic_heightmap_follow_its_rows(tmp_path):
    """HorizonCaster and SunshineCaster of Heightmap.from_raster: the horizons per band (as
    row_scales=), the soft shadows and the sunshine sums of a sun given by its angles as of its
    bands' field, bit for bit; each differs from the centre's scale."""
    from oclshade.horizon import HorizonCaster
    from oclshade.sunshine import SunshineCaster

    _, raster, places, hm = geo_map(tmp_path)
    banded = Heightmap.from_raster(raster)
    scaled = HorizonCaster(banded, cache=False)
    assert np.array_equal(scaled.horizons([30.0, 250.0]),
                          HorizonCaster(hm, row_scales=places.row_scales(), cache=False).horizons([30.0, 250.0]))
    sun = Sun(100.0, 8.0)
    field = sun_field(places, sun)
    disc = scaled.sun_disc(sun, columns=8)
    plain = HorizonCaster(hm, cache=False)
    assert np.array_equal(disc, plain.sun_disc(field, columns=8), equal_nan=True)
    assert not np.array_equal(disc, plain.sun_disc(sun, columns=8), equal_nan=True)
    suns, seconds = [sun, Sun(200.0, 15.0)], [600, 1200]
    fields = [sun_field(places, s) for s in suns]
    for method in ("masks", "horizons"):
        got = SunshineCaster(banded).accumulate(suns, seconds, "all", method=method, azimuths=32)
        want = SunshineCaster(hm).accumulate(fields, seconds, "all", method=method, azimuths=32)
        centre = SunshineCaster(hm).accumulate(suns, seconds, "all", method=method, azimuths=32)
        for name in ("hours", "fraction", "irradiation"):
            assert np.array_equal(getattr(got, name), getattr(want, name), equal_nan=True), (method, name)
        assert not np.array_equal(got.irradiation, centre.irradiation, equal_nan=True)
