"""A site's horizon along the geodesics (oclshade.horizon.site): the sup of its own path in
closed form, the map's edge at the right distance, the kernels' horizons where grid lines are
geodesics, the geodesic where they are not, ECEF on real terrain, and the CLI's CSV."""
from __future__ import annotations

import csv
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

pyproj = pytest.importorskip("pyproj")

from oclshade import reference as ref  # noqa: E402
from oclshade.cli import main  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import EARTH_RADIUS, Curvature, HorizonCaster  # noqa: E402
from oclshade.horizon.site import site_horizon  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.solar import map_places  # noqa: E402
from oclshade.solar.scale import height_factor, height_residual_of  # noqa: E402

from test_site import write_tif  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GEOGRAPHIC = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
UTM32N = (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32632)


def bench(name: str):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def hills(shape, seed: int, relief: float) -> np.ndarray:
    """Smooth random terrain (a few Gaussian hills) plus sample noise, ``relief`` metres high."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64)
    h = np.zeros(shape)
    for _ in range(6):
        cy, cx, r = rng.uniform(0, shape[0]), rng.uniform(0, shape[1]), rng.uniform(3, shape[0] / 3)
        h += rng.uniform(0.2, 1.0) * np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * r * r))
    h += 0.05 * rng.standard_normal(shape)
    return relief * (h - h.min()) / (h.max() - h.min())


def geographic(tmp_path, heights, north=46.5, west=9.0, cell=1.0 / 1200, name="dem.tif"):
    return read_dem(write_tif(tmp_path / name, heights, GEOGRAPHIC, west, north, cell))


def path_samples(raster, lat, lon, azimuth, above, c, per_chord=48):
    """The largest (S(t) - z0 - c t^2) / t over ``per_chord`` points of each chord of the site's
    path (the same geodesic points, chords and distances) and where the chords cross grid lines,
    found by sampling, refined around the best: what the closed form must equal."""
    from oclshade.horizon.site import STEP_SHARE, _bilinear

    places = map_places(raster)
    h = raster.heights.astype(np.float64)
    rows, cols = h.shape
    row, col = (float(v[0]) - 0.5 for v in places.cells_of(np.array([lon]), np.array([lat])))
    z0 = float(_bilinear(h, np.array([row]), np.array([col]))[0]) + above
    step = STEP_SHARE * min(raster.dx, raster.dy) * float(np.min(places.row_scales()[..., :2]))
    far = 2.0 * math.hypot(rows * raster.dy, cols * raster.dx)
    s = step * np.arange(int(far / step) + 1)
    plon, plat, _ = places.geod.fwd(np.full(s.size, lon), np.full(s.size, lat), np.full(s.size, azimuth), s)
    y, x = (v - 0.5 for v in places.cells_of(plon, plat))
    y[0], x[0] = row, col
    scale = height_factor(places.height)

    def tangents(u):                                # u: chord index + share along it, (n,)
        k = np.minimum(np.floor(u).astype(int), s.size - 2)
        f = u - k
        yy, xx = y[k] + f * (y[k + 1] - y[k]), x[k] + f * (x[k + 1] - x[k])
        t = (s[k] + f * (s[k + 1] - s[k])) * scale
        inside = (yy >= 0) & (yy <= rows - 1) & (xx >= 0) & (xx <= cols - 1)
        out = np.cumsum(~inside) > 0                # past the first point outside: the path has ended
        with np.errstate(divide="ignore", invalid="ignore"):
            v = (_bilinear(h, yy, xx) - z0 - c * t * t) / t
        return np.where(out | (t <= 0), -np.inf, v)

    kinks = []                                      # where a chord crosses a grid line: the profile's kinks
    for p in (x, y):
        lo, hi = np.minimum(p[:-1], p[1:]), np.maximum(p[:-1], p[1:])
        for k in np.flatnonzero(np.floor(hi) > np.floor(lo)):
            kinks.append(k + (np.floor(hi[k]) - p[k]) / (p[k + 1] - p[k]))
    u = np.sort(np.concatenate([kinks, np.arange(1, (s.size - 1) * per_chord) / per_chord]))
    v = tangents(u)
    best = np.nanargmax(v)
    fine = np.linspace(u[max(best - 1, 0)], u[min(best + 1, u.size - 1)], 4001)
    top = max(float(np.nanmax(v)), float(np.nanmax(tangents(fine))))
    if above == 0.0:        # the eye on the surface: f / t is linear in t from it (f(0) = 0), its sup there the
        top = max(top, float(2.0 * tangents(np.array([1e-4]))[0] - tangents(np.array([2e-4]))[0]))   # limit
    return math.degrees(math.atan(top))


@pytest.mark.parametrize("seed", range(4))
def test_a_site_horizon_is_the_sup_of_its_path(tmp_path, seed):
    """The closed form per piece (the kernels' level 0, in float64) against sampling the same
    path densely and refining: never below a sample (it is a sup; 1e-8 degree for rounding),
    and at most 1e-6 degree above the refined samples; sites off the samples, above the surface
    or on it, with and without curvature."""
    rng = np.random.default_rng(seed)
    raster = geographic(tmp_path, hills((60, 80), seed, 800.0))
    places = map_places(raster)
    curvature = Curvature(EARTH_RADIUS, 0.13) if seed % 2 else None
    c = 0.0 if curvature is None else curvature.coefficient
    for _ in range(3):
        lon, lat = (float(v[0]) for v in places.lonlat(rng.uniform(1, 59, 1), rng.uniform(1, 79, 1)))
        above = float(rng.choice([0.0, 2.0, 30.0]))
        azimuths = rng.uniform(0.0, 360.0, 5)
        got = site_horizon(raster, lat, lon, azimuths, above=above, curvature=curvature)
        for a, angle in zip(azimuths, got):
            sampled = path_samples(raster, lat, lon, float(a), above, c)
            assert sampled - 1e-8 <= angle <= sampled + 1e-6, (a, angle, sampled, above)


def test_the_map_edge_ends_the_path_at_its_geodesic_distance(tmp_path):
    """From 100 m above a flat plain with no curvature the horizon is the map's edge,
    atan(-100 / D), D the geodesic distance to the edge (pyproj), here due north and due south."""
    raster = geographic(tmp_path, np.zeros((50, 70)))
    places = map_places(raster)
    lon, lat = (float(v[0]) for v in places.lonlat(np.array([20.25]), np.array([30.75])))
    north_edge, south_edge = (float(v) for v in places.lonlat(np.array([0.5, 49.5]), np.array([30.75, 30.75]))[1])
    geod = pyproj.Geod(ellps="WGS84")
    got = site_horizon(raster, lat, lon, [0.0, 180.0], above=100.0)
    for angle, edge in zip(got, (north_edge, south_edge)):
        d = geod.inv(lon, lat, lon, edge)[2]
        assert angle == pytest.approx(math.degrees(math.atan(-100.0 / d)), abs=1e-9)
    near = site_horizon(raster, lat, lon, [0.0], above=100.0, max_distance=300.0)[0]
    assert near == pytest.approx(math.degrees(math.atan(-100.0 / 300.0)), abs=1e-9)


def test_where_grid_lines_are_geodesics_it_is_the_kernels_horizon(tmp_path):
    """On UTM 32N's central meridian (a 6 km map: grid lines within a millimetre of the
    geodesics) a site at a sample, on the surface, at the true azimuths of the grid's (the
    meridian convergence turns them by up to 0.03 degree here), has the float64 twin's horizon
    at that cell (to 1e-5 degree: the heightmap's float32 heights, UTM's scale across the map)
    and the kernel's within its float32 band, with curvature too,
    both given the true metres of a grid metre (UTM's 1 / 0.9996 here, at the map's height)."""
    heights = hills((200, 200), 7, 600.0)
    x, y = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(9.0, 46.0)
    raster = read_dem(write_tif(tmp_path / "utm.tif", heights, UTM32N, x - 100 * 30.0, y + 100 * 30.0, 30.0))
    places = map_places(raster)
    k = pyproj.Proj("EPSG:32632").get_factors(9.0, 46.0).meridional_scale          # 0.9996 on the meridian
    ground = height_factor(places.height) / k      # true metres per grid metre (the library traces this map as drawn)
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy), row_scales=np.full((200, 2), ground))
    curvature = Curvature(EARTH_RADIUS, 0.13)
    cells = (np.array([37, 100, 163]), np.array([52, 99, 140]))
    lon, lat = places.lonlat(cells[0] + 0.5, cells[1] + 0.5)
    azimuths = np.arange(12) * 30.0
    kernel = HorizonCaster(hm, curvature=curvature, cache=False).horizons(azimuths)[:, cells[0], cells[1]]
    band = ref.angle_tolerance(hm, curvature.coefficient)
    geod = pyproj.Geod(ellps="WGS84")
    for k in range(3):
        g = np.radians(azimuths)                    # the grid azimuths the kernel traces, as true ones here
        ahead = places.lonlat(cells[0][k] + 0.5 - 0.01 * np.cos(g), cells[1][k] + 0.5 + 0.01 * np.sin(g))
        true = geod.inv(np.full(g.size, lon[k]), np.full(g.size, lat[k]), *ahead)[0]
        got = site_horizon(raster, float(lat[k]), float(lon[k]), true, curvature=curvature)
        for a, az in enumerate(azimuths):
            twin = ref.banded_horizon_angles(hm, float(az), curvature.coefficient, (cells[0][k:k + 1], cells[1][k:k + 1]))
            assert abs(got[a] - twin[0]) <= 1e-5, (k, az, got[a], twin[0])
        assert np.abs(got - kernel[:, k]).max() <= band


def test_where_they_are_not_it_follows_the_geodesic(tmp_path):
    """The peak of tests/test_projected_scale.py: 30 km due east at 46 N, one row south of the
    site's row, where the geodesic passes: the kernel at 90 degrees misses it, the site's horizon
    sees it, as bench/geodesic_rays.py's ECEF brute force does (within the heights' residual)."""
    cell = 1.0 / 1200
    lon0, lat0 = 9.0 + 10.5 * cell, 46.5 - 20.5 * cell
    lon, lat, _ = pyproj.Geod(ellps="WGS84").fwd(lon0, lat0, 90.0, 30000.0)
    heights = np.zeros((41, 520))
    heights[round((46.5 - lat) / cell - 0.5), round((lon - 9.0) / cell - 0.5)] = 500.0
    raster = geographic(tmp_path, heights, cell=cell)
    places = map_places(raster)
    got = site_horizon(raster, lat0, lon0, [90.0], curvature=Curvature(EARTH_RADIUS, 0.0))[0]
    brute = bench("geodesic_rays").geodesic_horizons(raster, places, (np.array([20]), np.array([10])),
                                                     np.array([90.0]))[0][0, 0]
    kernel = HorizonCaster(Heightmap.from_raster(raster), curvature=Curvature(EARTH_RADIUS, 0.0),
                           cache=False).horizons([90.0])[0][20, 10]
    assert abs(kernel) < 1e-3 and got > 0.5
    assert abs(got - brute) <= height_residual_of(500.0) + 5e-4, (got, brute)


def test_on_real_terrain_it_is_the_ecef_geodesic_within_the_heights_residual():
    """N22W160 (Kauai, 3 arc-sec): 8 sites x 16 azimuths with curvature against the ECEF brute
    force along the geodesic (bench/geodesic_rays.py): within relief / 4R plus the drop's sphere
    against the ellipsoid's curvature over the map's diagonal."""
    path = ROOT.parent / "shared" / "data" / "dem" / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip"
    if not path.exists():
        pytest.skip("needs ../shared/data (N22W160)")
    raster = read_dem(path)
    places = map_places(raster)
    rng = np.random.default_rng(8)
    valid = np.argwhere(np.isfinite(raster.heights) & (raster.heights > 100))
    pick = valid[rng.choice(len(valid), 8, replace=False)]
    azimuths = np.arange(16) * 22.5
    curvature = Curvature(EARTH_RADIUS, 0.0)
    brute = bench("geodesic_rays").geodesic_horizons(raster, places, (pick[:, 0], pick[:, 1]), azimuths)[0]
    lon, lat = places.lonlat(pick[:, 0] + 0.5, pick[:, 1] + 0.5)
    relief = float(np.nanmax(raster.heights) - np.nanmin(raster.heights))
    a, e2 = 6378137.0, 6.69437999014e-3          # the drop's radius R against the ellipsoid's own curvature
    w = 1.0 - e2 * math.sin(math.radians(22.5)) ** 2  # along an azimuth, between M and N: (1/R - 1/rho) D / 2
    bend = max(abs(1.0 / EARTH_RADIUS - w ** 1.5 / (a * (1.0 - e2))), abs(1.0 / EARTH_RADIUS - math.sqrt(w) / a))
    spheroid = math.degrees(bend * math.hypot(*raster.heights.shape) * raster.dy / 2.0)     # 0.003 degree
    for k in range(pick.shape[0]):
        got = site_horizon(raster, float(lat[k]), float(lon[k]), azimuths, curvature=curvature)
        seen = brute[:, k] > -90.0
        assert np.abs(got - brute[:, k])[seen].max() <= height_residual_of(relief) + spheroid + 1e-4


def test_a_site_needs_a_place_on_the_map(tmp_path):
    raster = geographic(tmp_path, np.where(np.eye(30, 40) > 0, np.nan, 10.0))
    places = map_places(raster)
    lon, lat = (float(v[0]) for v in places.lonlat(np.array([5.5]), np.array([20.5])))
    with pytest.raises(ValueError, match="outside the map"):
        site_horizon(raster, lat + 1.0, lon, 4)
    hole_lon, hole_lat = (float(v[0]) for v in places.lonlat(np.array([3.5]), np.array([3.5])))
    with pytest.raises(ValueError, match="on nodata"):
        site_horizon(raster, hole_lat, hole_lon, 4)
    with pytest.raises(ValueError, match="above must be"):
        site_horizon(raster, lat, lon, 4, above=-1.0)
    with pytest.raises(ValueError, match="latitude must be"):
        site_horizon(raster, 95.0, lon, 4)
    plain = read_dem(write_npy(tmp_path, np.zeros((8, 8))))
    with pytest.raises(ValueError, match="georeferenced"):
        site_horizon(plain, 0.0, 0.0, 4)


def write_npy(tmp_path, heights):
    np.save(tmp_path / "plain.npy", heights)
    return tmp_path / "plain.npy"


def test_cli_writes_the_site_horizon_as_csv(tmp_path, capsys):
    raster = geographic(tmp_path, hills((60, 80), 2, 500.0))
    places = map_places(raster)
    lon, lat = (float(v[0]) for v in places.lonlat(np.array([30.2]), np.array([40.7])))
    out = tmp_path / "site.csv"
    assert main(["horizon", str(tmp_path / "dem.tif"), str(out), "--site", f"{lat},{lon}", "--above", "2",
                 "--azimuths", "8", "--curvature", "-q"]) == 0
    assert capsys.readouterr().err == ""
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["azimuth", "elevation"] and len(rows) == 9
    expected = site_horizon(raster, lat, lon, 8, above=2.0, curvature=Curvature())
    np.testing.assert_array_equal([float(r[1]) for r in rows[1:]], np.round(expected, 6))
    assert [float(r[0]) for r in rows[1:]] == [45.0 * k for k in range(8)]
    assert main(["horizon", str(tmp_path / "dem.tif"), str(tmp_path / "x.tif"), "--site", f"{lat},{lon}"]) == 2
    assert "--site writes a .csv" in capsys.readouterr().err
    assert main(["horizon", str(tmp_path / "dem.tif"), str(tmp_path / "x.csv"), "--site", f"{lat + 1},{lon}"]) == 1
    assert "outside the map" in capsys.readouterr().err


def test_a_site_across_the_antimeridian(tmp_path):
    """A map from 179.9 E across 180 (west edge 179.9, 0.2 degree wide): a site at 179.95 W is on
    it, the same place as 180.05 E, and its paths cross the antimeridian without a jump."""
    cell = 1.0 / 1200
    raster = geographic(tmp_path, hills((60, 240), 4, 300.0), north=-16.0, west=179.9, cell=cell)
    east = site_horizon(raster, -16.02, 180.05, 8)
    west = site_horizon(raster, -16.02, -179.95, 8)
    np.testing.assert_allclose(east, west, rtol=0, atol=1e-8)          # (the two longitudes round apart)
    assert np.all(east > -90.0)


def test_a_whole_earth_map_ends_its_paths_at_its_seam(tmp_path):
    """A map of the whole Earth's width (1-degree cells, 80 S to 80 N): beyond its east edge lies
    its west edge, but the map's model has no terrain past an edge, as the kernels' rays: a
    peak just west of 180 W is not seen from a plain just east of 180 E looking east (the path
    ends at the seam instead of jumping across the map or halving its steps for ever)."""
    heights = np.zeros((160, 360))
    heights[79:81, 0] = 5000.0                                  # at 179.5 W
    raster = geographic(tmp_path, heights, north=80.0, west=-180.0, cell=1.0)
    east, west = site_horizon(raster, 0.0, 178.5, [90.0, 270.0])
    assert east == 0.0 and west == 0.0
    assert site_horizon(raster, 0.0, 179.5, [90.0])[0] == -90.0    # (on the edge, looking out: nothing, as the kernels)
    assert site_horizon(raster, 0.0, -178.5, [270.0])[0] > 1.0     # (from the west edge's side it is seen)


def test_site_sunshine_on_a_plain_is_the_daylight(tmp_path):
    """On a flat map (no curvature) every sun above the horizontal plane shines on the site: the
    hours of direct sun are the daylight hours, the horizon 0 by day and NaN by night."""
    from datetime import datetime, timedelta, timezone

    from oclshade.sunshine import site_sunshine, time_steps

    raster = geographic(tmp_path, np.full((40, 40), 250.0))
    places = map_places(raster)
    lon, lat = (float(v[0]) for v in places.lonlat(np.array([20.0]), np.array([20.0])))
    start = datetime(2024, 3, 20, tzinfo=timezone.utc)
    result = site_sunshine(raster, lat, lon, time_steps(start, start + timedelta(days=1), timedelta(minutes=10)))
    up = np.array([sun.elevation > 0.0 for sun in result.suns])
    assert 11.5 < result.daylight_hours < 12.7 and result.hours == result.daylight_hours
    assert np.all(result.horizon[up] == 0.0) and np.all(np.isnan(result.horizon[~up]))
    np.testing.assert_array_equal(result.sunlit, up)


def test_site_sunshine_agrees_with_the_maps_at_its_cell(tmp_path, capsys):
    """On UTM 32N's central meridian (grid lines are geodesics there) a site at a sample is lit
    as long as the map's sunshine leaves that cell out of cast shadow: its daylight less the
    `fraction` in cast shadow (a day of 10-minute steps, hills), to a step (the map takes each
    block's sun to 0.01 degree).  (The map's `hours` also drop steps where the cell's normal
    faces away; at a sample, a kink of the bilinear surface, that is not the surface along the
    sun's azimuth, which the horizon holds.)  The CLI's CSV adds up to the API's hours."""
    import tifffile

    from datetime import datetime, timedelta, timezone

    from oclshade.sunshine import site_sunshine, time_steps

    heights = hills((160, 160), 3, 700.0)
    x, y = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(9.0, 46.0)
    path = write_tif(tmp_path / "utm.tif", heights, UTM32N, x - 80 * 30.0, y + 80 * 30.0, 30.0)
    raster = read_dem(path)
    places = map_places(raster)
    args = ["--start", "2024-06-21T00:00", "--end", "2024-06-22T00:00", "--tz", "UTC", "--step", "10min", "-q"]
    assert main(["sunshine", str(path), str(tmp_path / "all.tif"), *args, "--output", "fraction"]) == 0
    fraction = tifffile.imread(tmp_path / "all.tif")
    start = datetime(2024, 6, 21, tzinfo=timezone.utc)
    steps = time_steps(start, start + timedelta(days=1), timedelta(minutes=10))
    for cell in ((40, 50), (80, 80), (120, 111)):
        lon, lat = (float(v[0]) for v in places.lonlat(np.array([cell[0] + 0.5]), np.array([cell[1] + 0.5])))
        site = site_sunshine(raster, lat, lon, steps)
        uncast = site.daylight_hours * (1.0 - float(fraction[cell]))
        assert abs(site.hours - uncast) <= 10.0 / 60.0 + 1e-4, (cell, site.hours, uncast)
    assert main(["sunshine", str(path), str(tmp_path / "site.csv"), *args, "--site", f"{lat},{lon}"]) == 0
    rows = list(csv.DictReader((tmp_path / "site.csv").open()))
    assert len(rows) == 144 and sum(int(r["seconds"]) * int(r["sunlit"]) for r in rows) / 3600.0 == site.hours
    assert main(["sunshine", str(path), str(tmp_path / "x.csv"), *args, "--site", f"{lat},{lon}",
                 "--output", "all"]) == 2
    assert "does not go with --site" in capsys.readouterr().err


def test_site_sunshine_takes_curvature_with_site_only(tmp_path, capsys):
    """--curvature lowers the site's horizon at each sun's azimuth as site_horizon does (a ridge
    40 km east, 60 m up: above the horizontal without it, below with it), and the map's sunshine,
    which has none, refuses it in one line."""
    from datetime import datetime, timedelta, timezone

    from oclshade.sunshine import site_sunshine, time_steps

    heights = np.zeros((40, 700))
    heights[:, 660:] = 60.0                                # 40 km east of the site at column 10
    raster = geographic(tmp_path, heights, north=0.02, west=0.0)
    places = map_places(raster)
    lon, lat = (float(v[0]) for v in places.lonlat(np.array([20.5]), np.array([10.5])))
    start = datetime(2024, 3, 20, 5, 30, tzinfo=timezone.utc)
    steps = time_steps(start, start + timedelta(hours=2), timedelta(minutes=10))
    flat, bent = (site_sunshine(raster, lat, lon, steps, curvature=c) for c in (None, Curvature(EARTH_RADIUS, 0.0)))
    up = np.isfinite(flat.horizon)
    assert np.all(flat.horizon[up] > 0.05) and np.all(bent.horizon[up] <= 0.0)
    azimuths = np.array([sun.azimuth for sun in bent.suns])[up]
    np.testing.assert_array_equal(bent.horizon[up], site_horizon(raster, lat, lon, azimuths,
                                                                 curvature=Curvature(EARTH_RADIUS, 0.0)))
    args = ["--start", "2024-03-20T05:30", "--end", "2024-03-20T07:30", "--tz", "UTC", "-q"]
    assert main(["sunshine", str(tmp_path / "dem.tif"), str(tmp_path / "s.csv"), *args, "--site", f"{lat},{lon}",
                 "--curvature"]) == 0
    rows = list(csv.DictReader((tmp_path / "s.csv").open()))
    np.testing.assert_array_equal([float(r["horizon"]) for r in rows if r["horizon"]], np.round(bent.horizon[up], 6))
    assert main(["sunshine", str(tmp_path / "dem.tif"), str(tmp_path / "m.tif"), *args, "--curvature"]) == 2
    assert "--curvature goes with --site" in capsys.readouterr().err
