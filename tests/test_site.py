"""Where a raster lies and which way its grid faces (oclshade.solar.site), and grids that are not
north-up (oclshade.io.require_north_up): suns from datetimes on projected maps."""
import argparse
import math
import warnings
from datetime import datetime

import numpy as np
import pytest
import tifffile

pyproj = pytest.importorskip("pyproj")

from oclshade.cli import main  # noqa: E402
from oclshade.heightmap import InputWarning  # noqa: E402
from oclshade.io import Raster, RasterIOError, read_dem  # noqa: E402
from oclshade.solar import suns_at  # noqa: E402
from oclshade.solar.cli import suns_for  # noqa: E402
from oclshade.solar.site import MapSite, map_site  # noqa: E402

UTM33N = (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)        # projected, EPSG:32633
PROJECTED_NO_CODE = (1, 1, 0, 2, 1024, 0, 1, 1, 1025, 0, 1, 1)               # projected, no EPSG code
WGS84_A, WGS84_F, UTM_K0 = 6378137.0, 1.0 / 298.257223563, 0.9996


def write_tif(path, heights, keys=UTM33N, west=500000.0, north=6700000.0, cell=30.0, transform=None):
    tags = [(34735, 3, len(keys), keys, True)]
    if transform is None:
        tags += [(33550, 12, 3, (cell, cell, 0.0), True), (33922, 12, 6, (0, 0, 0, west, north, 0), True)]
    else:
        tags += [(34264, 12, 16, transform, True)]
    tifffile.imwrite(path, np.asarray(heights, np.float32), extratags=tags)
    return path


def meridian_arc(lat_deg: float) -> float:
    """Metres along the WGS84 meridian from the equator to a latitude (numerical integral of the
    meridian's radius of curvature), an independent check of the inverse projection."""
    e2 = WGS84_F * (2.0 - WGS84_F)
    phi = np.linspace(0.0, math.radians(lat_deg), 200001)
    radius = WGS84_A * (1.0 - e2) / (1.0 - e2 * np.sin(phi) ** 2) ** 1.5
    return float(np.sum((radius[1:] + radius[:-1]) / 2.0 * np.diff(phi)))


@pytest.mark.parametrize("lat, lon", [(60.0, 12.0), (47.0, 17.9), (-33.0, 13.0), (10.0, 15.0)])
def test_grid_azimuths_turn_by_the_meridian_convergence(lat, lon):
    """UTM 33N (central meridian 15 E): a true azimuth A is the grid azimuth A - gamma, gamma
    the convergence, atan(tan(lon - 15) sin(lat)) on the sphere (within 0.01 degrees on the
    ellipsoid) and PROJ's meridian_convergence factor (to 1e-5 degrees): west of the central
    meridian in the north grid north lies west of true north, so true north reads east of 0."""
    site = MapSite(lat, lon, pyproj.CRS.from_epsg(32633), "EPSG:32633")
    gamma_sphere = math.degrees(math.atan(math.tan(math.radians(lon - 15.0)) * math.sin(math.radians(lat))))
    gamma_proj = pyproj.Proj(site.crs).get_factors(lon, lat).meridian_convergence
    true = np.array([0.0, 45.0, 90.0, 180.0, 271.5, 359.9])
    grid = site.grid_azimuths(true)
    turn = (grid - true + 180.0) % 360.0 - 180.0
    assert np.all((grid >= 0.0) & (grid < 360.0))
    np.testing.assert_allclose(turn, -gamma_sphere, atol=0.01)
    np.testing.assert_allclose(turn, -gamma_proj, atol=1e-5)
    if lon == 15.0:
        np.testing.assert_allclose(turn, 0.0, atol=1e-6)


def test_without_a_projected_crs_grid_azimuths_are_true_ones():
    site = MapSite(46.0, 7.0)
    np.testing.assert_array_equal(site.grid_azimuths([0.0, 370.0, -10.0]), [0.0, 10.0, 350.0])
    suns = suns_at([datetime.fromisoformat("2024-06-21T08:00+00:00")], 46.0, 7.0)
    assert site.grid_suns(suns) == suns


def test_a_projected_map_gives_its_centre_as_the_place(tmp_path):
    """The centre of a UTM 33N map on the central meridian: longitude 15 exactly, and the latitude
    whose meridian arc times k0 is the centre's northing."""
    rows, cols, cell, north = 40, 60, 30.0, 6700000.0
    raster = read_dem(write_tif(tmp_path / "utm.tif", np.zeros((rows, cols)), west=500000.0 - cols * cell / 2,
                                north=north, cell=cell))
    site = map_site(raster)
    assert site.crs_name == "EPSG:32633"
    assert site.longitude == pytest.approx(15.0, abs=1e-9)
    assert UTM_K0 * meridian_arc(site.latitude) == pytest.approx(north - rows * cell / 2, abs=1e-3)
    given = map_site(raster, 47.5, 14.0)
    assert (given.latitude, given.longitude, given.crs_name) == (47.5, 14.0, "EPSG:32633")


def test_a_geographic_map_or_one_without_crs():
    geographic = Raster(np.zeros((10, 20)), 1.0, 1.0, None, True,
                        {33550: (0.1, 0.1, 0.0), 33922: (0, 0, 0, 6.0, 47.0, 0)})
    site = map_site(geographic)
    assert (site.latitude, site.longitude, site.crs) == (pytest.approx(46.5), pytest.approx(7.0), None)
    bare = Raster(np.zeros((10, 20)), 30.0, 30.0)
    assert map_site(bare) is None
    assert map_site(bare, 46.0, 7.0) == MapSite(46.0, 7.0)


def test_a_projected_crs_without_a_code_is_refused_unless_the_place_is_given(tmp_path):
    raster = read_dem(write_tif(tmp_path / "nocode.tif", np.zeros((8, 8)), keys=PROJECTED_NO_CODE))
    with pytest.raises(ValueError, match="no EPSG code or WKT"):
        map_site(raster)
    with pytest.warns(InputWarning, match="used as grid azimuths"):
        site = map_site(raster, 46.0, 7.0)
    assert site == MapSite(46.0, 7.0)


def _args(path, lat=None, lon=None):
    return argparse.Namespace(input=str(path), lat=lat, lon=lon, sun_tolerance=0.01)


def test_suns_for_a_utm_map_are_turned_to_its_grid(tmp_path):
    raster = read_dem(write_tif(tmp_path / "utm.tif", np.zeros((8, 8)), west=320000.0, north=5300000.0))
    times = [datetime.fromisoformat(t) for t in ("2024-06-21T06:00+00:00", "2024-12-21T13:00+00:00")]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        placed = suns_for(times, _args(tmp_path / "utm.tif", 47.8, 12.6), raster)
    true = suns_at(times, 47.8, 12.6)
    assert placed.true == true
    gamma = pyproj.Proj(pyproj.CRS.from_epsg(32633)).get_factors(12.6, 47.8).meridian_convergence
    assert gamma == pytest.approx(-1.78, abs=0.01)
    for grid, sun in zip(placed.suns, true):
        assert grid.elevation == sun.elevation
        assert grid.azimuth == pytest.approx((sun.azimuth - gamma) % 360.0, abs=1e-5)
    assert "on the grid of EPSG:32633" in placed.describe(times[0])


def test_shadow_datetime_on_a_utm_map_traces_the_grid_azimuth(tmp_path, capsys):
    """`oclshade shadow UTM.tif --datetime`: the place from the map's CRS (no --lat/--lon needed),
    the mask that of the sun at its grid azimuth; an unidentified projected CRS fails in one line."""
    y, x = np.mgrid[:64, :64] - 31.5
    heights = np.maximum(0.0, 600.0 - 25.0 * np.hypot(x, y))
    dem = write_tif(tmp_path / "utm.tif", heights, west=300000.0, north=5400000.0)
    when = "2024-03-20T07:30:00+01:00"   # one sun for the map (per block: tests/test_field.py)
    assert main(["shadow", str(dem), str(tmp_path / "t.npy"), "--datetime", when, "--sun-tolerance", "1"]) == 0
    err = capsys.readouterr().err
    assert "on the grid of EPSG:32633" in err
    placed = suns_for([datetime.fromisoformat(when)], _args(dem), read_dem(dem))
    sun = placed.suns[0]
    assert abs(sun.azimuth - placed.true[0].azimuth) > 1.0     # 12.3 E, 48.7 N: turned by 2.03 degrees
    assert main(["shadow", str(dem), str(tmp_path / "s.npy"), f"--sun={sun.azimuth!r},{sun.elevation!r}", "-q"]) == 0
    timed, direct = np.load(tmp_path / "t.npy"), np.load(tmp_path / "s.npy")
    assert np.array_equal(timed, direct) and (timed == 1).any()
    nocode = write_tif(tmp_path / "nocode.tif", heights, keys=PROJECTED_NO_CODE)
    assert main(["shadow", str(nocode), str(tmp_path / "n.npy"), "--datetime", when]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no EPSG code or WKT" in err
    assert not (tmp_path / "n.npy").exists()


@pytest.mark.parametrize("transform, what", [
    ((30.0, 0, 0, 500000.0, 0, 30.0, 0, 6700000.0, 0, 0, 0, 0, 0, 0, 0, 1), "south-up"),
    ((-30.0, 0, 0, 500000.0, 0, -30.0, 0, 6700000.0, 0, 0, 0, 0, 0, 0, 0, 1), "east to west"),
    ((30 * math.cos(0.5), 30 * math.sin(0.5), 0, 500000.0, 30 * math.sin(0.5), -30 * math.cos(0.5), 0, 6700000.0,
      0, 0, 0, 0, 0, 0, 0, 1), "rotated or sheared"),
])
def test_grids_that_are_not_north_up_are_refused(tmp_path, transform, what):
    path = write_tif(tmp_path / "turned.tif", np.zeros((6, 7)), transform=transform)
    with pytest.raises(RasterIOError, match=what) as info:
        read_dem(path)
    assert str(info.value).startswith(str(path)) and "gdalwarp" in str(info.value)


def test_a_negative_pixel_scale_is_a_south_up_grid_and_refused(tmp_path):
    keys = UTM33N
    tags = [(34735, 3, len(keys), keys, True), (33550, 12, 3, (30.0, -30.0, 0.0), True),
            (33922, 12, 6, (0, 0, 0, 500000.0, 6700000.0, 0), True)]
    tifffile.imwrite(tmp_path / "neg.tif", np.zeros((4, 4), np.float32), extratags=tags)
    with pytest.raises(RasterIOError, match="south-up"):
        read_dem(tmp_path / "neg.tif")


def test_a_north_up_transform_is_read():
    """The usual ModelTransformation of a north-up grid passes (as the pixel-scale form does)."""
    from oclshade.io import require_north_up
    require_north_up("x.tif", {34264: (30.0, 0, 0, 500000.0, 0, -30.0, 0, 6700000.0, 0, 0, 0, 0, 0, 0, 0, 1)})
    require_north_up("x.tif", {33550: (30.0, 30.0, 0.0), 33922: (0, 0, 0, 500000.0, 6700000.0, 0)})
    require_north_up("x.npy", {})


def test_horizon_true_north_traces_the_grid_azimuths_of_true_ones(tmp_path, capsys):
    """`horizon --true-north` on a UTM map 2 degrees off its central meridian: band i is the
    horizon at the grid azimuth of the true azimuth 360 i / N (the API's bands there, bit for
    bit), not at the grid azimuth 360 i / N; on a map without a CRS it is refused."""
    from oclshade import Heightmap
    from oclshade.horizon import HorizonCaster
    from oclshade.synthetic import canyon_crater

    heights = canyon_crater(40, 48, seed=7, relief=500.0)
    dem = write_tif(tmp_path / "utm.tif", heights, west=300000.0, north=5400000.0)
    assert main(["horizon", str(dem), str(tmp_path / "t.npy"), "--azimuths", "8", "--true-north"]) == 0
    assert "from true north (at grid azimuth 2.0" in capsys.readouterr().err
    site = map_site(read_dem(dem))
    grid = site.grid_azimuths(np.arange(8) * 45.0)
    assert np.all(np.abs((grid - np.arange(8) * 45.0 + 180.0) % 360.0 - 180.0) > 1.9)
    caster = HorizonCaster(Heightmap.from_array(heights, 30.0))
    np.testing.assert_array_equal(np.load(tmp_path / "t.npy"), caster.horizons(grid))
    assert main(["horizon", str(dem), str(tmp_path / "g.npy"), "--azimuths", "8", "-q"]) == 0
    assert not np.array_equal(np.load(tmp_path / "g.npy"), np.load(tmp_path / "t.npy"))
    np.save(tmp_path / "bare.npy", heights)
    assert main(["horizon", str(tmp_path / "bare.npy"), str(tmp_path / "b.npy"), "--cellsize", "30",
                 "--true-north"]) == 2
    assert "has no CRS to find true north from" in capsys.readouterr().err
