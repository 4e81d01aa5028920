"""A projected grid's scale (oclshade.solar.MapPlaces.grid_scales): a grid metre is 1 / k metres on
the ground (UTM: k = 0.9996 on the central meridian; Web Mercator: sec(latitude), 1.41 at 45 N;
polar stereographic: 1.03 at 62 N), so its suns and horizons are traced at that scale.  Checked
against PROJ's own scale factors, and on the ground: a tower's shadow is H / tan(e) metres long
and its horizon atan(H / D), however the grid draws them."""
import math
from pathlib import Path

import numpy as np
import pytest

pyproj = pytest.importorskip("pyproj")


from oclshade import ShadowCaster, Sun  # noqa: E402
from oclshade.cli import main  # noqa: E402
from oclshade.heightmap import Heightmap, InputWarning  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.solar import map_places, sun_field  # noqa: E402
from oclshade.reference import ground_metre  # noqa: E402
from oclshade.solar.scale import direction_factor, height_factor, height_residual_of  # noqa: E402

from test_site import write_tif  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def keys(epsg: int) -> tuple:
    """GeoTIFF keys of a projected CRS by its EPSG code."""
    return (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, epsg)


def grid_xy(epsg: int, lon: float, lat: float) -> tuple[float, float]:
    crs = pyproj.CRS.from_epsg(epsg)
    return pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True).transform(lon, lat)


@pytest.mark.parametrize("epsg, lon, lat", [(32633, 15.0, 60.0), (32633, 11.2, 47.0), (3413, -45.0, 62.0),
                                            (3413, 30.0, 78.0), (2154, 3.0, 46.5), (3031, 0.0, -75.0)])
def test_a_conformal_grids_metre_is_one_over_projs_scale_factor(tmp_path, epsg, lon, lat):
    """UTM, polar stereographic (ArcticDEM's 3413, REMA's 3031) and Lambert-93: conformal, so one
    scale both ways, PROJ's k (its analytic factors, not our central differences)."""
    x, y = grid_xy(epsg, lon, lat)
    raster = read_dem(write_tif(tmp_path / "map.tif", np.zeros((20, 20)), keys(epsg), x - 300.0, y + 300.0))
    places = map_places(raster)
    here_lon, here_lat = places.lonlat(np.array([10.0]), np.array([10.0]))
    k = pyproj.Proj(places.crs).get_factors(here_lon[0], here_lat[0]).parallel_scale
    scale, p, q = places.projected_scales(here_lon, here_lat)
    assert scale[0] == pytest.approx(1.0 / k, rel=1e-8) and p[0] == 0.0 and q[0] == 0.0
    sx, sy, p, q = places.grid_scales(np.array([10.0]), np.array([10.0]))      # between its lattice's points
    assert sx[0] == sy[0] and sx[0] == (1.0 if abs(scale[0] - 1.0) <= 2.4e-4 else pytest.approx(scale[0], rel=1e-9))
    assert p[0] == 0.0 and q[0] == 0.0


def tower_map(tmp_path, epsg: int, lon: float, lat: float, rows: int = 40, cols: int = 120, cell: float = 30.0,
              height: float = 300.0):
    """Flat ground with a 3 x 3-cell tower ``height`` m tall at column 100, centred on (lon, lat)."""
    heights = np.zeros((rows, cols))
    heights[rows // 2 - 1:rows // 2 + 2, 99:102] = height
    x, y = grid_xy(epsg, lon, lat)
    path = write_tif(tmp_path / f"tower{epsg}.tif", heights, keys(epsg), x - cols / 2 * cell, y + rows / 2 * cell,
                     cell)
    return path, read_dem(path)


def shadow_cells(mask: np.ndarray) -> int:
    """Shadowed cells west of the tower along its middle row, up to the first lit one."""
    row = mask[mask.shape[0] // 2, :99][::-1]
    return int(np.argmax(row == 0)) if (row == 0).any() else row.size


@pytest.mark.parametrize("epsg, lon, lat, k", [(3857, 10.0, 45.0, math.sqrt(2.0)), (3413, -45.0, 62.0, None),
                                               (32633, 15.0, 60.0, 0.9996)])
def test_a_towers_shadow_is_as_long_on_the_ground_as_its_sun_makes_it(tmp_path, epsg, lon, lat, k):
    """H / tan(e) metres on the ground, k H / tan(e) grid metres: on Web Mercator at 45 N the grid
    draws it 1.41 times longer, and a grid taken as metres cast it 30 % short."""
    path, raster = tower_map(tmp_path, epsg, lon, lat)
    places = map_places(raster)
    if k is None:
        k = pyproj.Proj(places.crs).get_factors(lon, lat).parallel_scale
    elevation, height = 20.0, 300.0
    expected = k * height / math.tan(math.radians(elevation)) / raster.dx     # grid cells past the tower's edge
    out = tmp_path / "mask.tif"
    assert main(["shadow", str(path), str(out), "-az", "90", "-alt", str(elevation), "-q"]) == 0
    got = shadow_cells(read_dem(out).heights)
    assert abs(got - expected) <= 1.5, (got, expected)          # the tower's bilinear edge: within a cell
    api = ShadowCaster(Heightmap.from_raster(raster), cache=False).cast(Sun(90.0, elevation)).mask
    assert np.array_equal(api, np.where(np.isnan(read_dem(out).heights), 255, read_dem(out).heights))
    as_metres = ShadowCaster(Heightmap.from_array(raster.heights, (raster.dx, raster.dy)), cache=False)
    wrong = shadow_cells(as_metres.cast(Sun(90.0, elevation)).mask)
    if abs(k - 1.0) > 0.1:
        assert abs(wrong - expected) > 3.0                      # the grid's metres as the ground's
    horizons = tmp_path / "horizons.tif"                        # the tower seen from 40 cells west of it
    assert main(["horizon", str(path), str(horizons), "--azimuths", "4", "-q"]) == 0
    east = read_dem(horizons, band=2).heights[raster.heights.shape[0] // 2, 99 - 40]
    assert east == pytest.approx(math.degrees(math.atan(height * k / (40 * raster.dx))), abs=0.05)


def test_the_beam_on_flat_web_mercator_ground_is_sin_e(tmp_path):
    """The sunshine's beam needs the true sun: flat ground gets sin(e) per hour, not the grid
    sun's sin(e') (e' = atan(tan(e) / 1.41) on Web Mercator at 45 N)."""
    from oclshade.sunshine import SunshineCaster

    _, raster = tower_map(tmp_path, 3857, 10.0, 45.0)
    flat = Heightmap.from_raster(type(raster)(np.zeros(raster.heights.shape), raster.dx, raster.dy,
                                              georef=raster.georef))
    sun = Sun(135.0, 25.0)
    got = SunshineCaster(flat).accumulate([sun], [3600], "irradiation").irradiation
    assert np.nanmax(np.abs(got[1:-1, 1:-1] - math.sin(math.radians(25.0)))) <= 2e-6


@pytest.mark.parametrize("epsg, lon, lat, rows, bands", [(32633, 15.0, 60.0, 200, 1), (3857, 10.0, 45.0, 600, 4),
                                                         (3035, 25.0, 60.0, 200, 1)])
def test_masks_and_horizons_agree_on_a_projected_map(tmp_path, epsg, lon, lat, rows, bands):
    """A cell is in cast shadow at (az, e) exactly when its horizon at az is above e, ties apart:
    on a scaled grid too (UTM on its central meridian, k = 0.9996; Web Mercator at 45 N, whose
    scale changes by 0.2 % over the map: bands of rows; LAEA Europe at 60 N 25 E, stretched by
    direction: the sun's band and the horizons' rays alike), both traced in the same bands."""
    from oclshade.synthetic import canyon_crater

    x, y = grid_xy(epsg, lon, lat)
    path = write_tif(tmp_path / "map.tif", canyon_crater(rows, 160, seed=4, relief=2500.0), keys(epsg),
                     x - 80 * 30.0, y + rows / 2 * 30.0)
    field = sun_field(map_places(read_dem(path)), Sun(45.0, 12.0))
    assert field.blocks[0].sun.elevation != 12.0 and len(field.blocks) >= bands     # traced at the grid's scale
    horizons = tmp_path / "horizons.tif"
    assert main(["horizon", str(path), str(horizons), "--azimuths", "8", "-q"]) == 0
    shadowed = 0
    for k, elevation in ((0, 15.0), (1, 12.0), (2, 20.0), (5, 8.0), (7, 30.0)):
        mask_path = tmp_path / f"mask{k}.tif"
        assert main(["shadow", str(path), str(mask_path), "-az", str(45.0 * k), "-alt", str(elevation), "-q"]) == 0
        mask, horizon = read_dem(mask_path).heights, read_dem(horizons, band=k + 1).heights
        differ = (mask != 255) & ((mask == 1) != (horizon > elevation))
        assert not np.any(differ & (np.abs(horizon - elevation) > 1e-3)), int(differ.sum())
        shadowed += int(np.count_nonzero(mask == 1))
    assert shadowed > 1000


@pytest.mark.parametrize("epsg, lon, lat", [(3035, 25.0, 60.0), (5070, -120.0, 47.0), (3857, 10.0, 45.0)])
def test_a_projection_that_stretches_by_direction_is_followed(tmp_path, capsys, epsg, lon, lat):
    """Albers and Lambert azimuthal equal-area keep areas, not angles (and Web Mercator is not
    conformal on the ellipsoid): a grid metre's length depends on its direction, by a share that
    would move angles by up to 0.15 degree.  Its length along any grid
    azimuth is what the geodesic between grid points says, and the run, which follows it, has
    nothing to warn of."""
    x, y = grid_xy(epsg, lon, lat)
    path = write_tif(tmp_path / "map.tif", np.zeros((30, 30)), keys(epsg), x - 15 * 30.0, y + 15 * 30.0)
    places = map_places(read_dem(path))
    azimuths = np.arange(0.0, 180.0, 15.0)
    lengths = np.array([ground_metre(places, 15.0, 15.0, a) for a in azimuths])
    assert math.degrees((lengths.max() / lengths.min() - 1.0) / 4.0) > 0.04     # what one scale per band left
    scale, p, q = places.projected_scales(*places.lonlat(np.array([15.0]), np.array([15.0])))
    model = scale[0] * direction_factor(np.array([1.0, 1.0, p[0], q[0]]), azimuths)
    assert np.allclose(model, lengths, rtol=1e-7, atol=0.0)
    assert places.scale_residual <= 0.01          # the bands' own tolerance (it was 0.05-0.2)
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "-az", "90", "-alt", "20"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_a_map_too_coarse_for_its_scale_is_named(tmp_path, capsys):
    """Polar stereographic 1500 km wide at 70 N in 30 columns of 50 km (rows of 15): k changes along each row by
    more than one scale per band of rows follows (0.06 degree), and a map that narrow cannot be cut
    into column bands (16 columns at least); the run says so in one line, and the API warns."""
    x, y = grid_xy(3413, -45.0, 70.0)
    transform = (50000.0, 0.0, 0.0, x - 15 * 50000.0, 0.0, -15000.0, 0.0, y + 4 * 15000.0) + (0.0,) * 7 + (1.0,)
    path = write_tif(tmp_path / "wide.tif", np.zeros((8, 30)), keys(3413), transform=transform)   # 50 by 15 km cells
    places = map_places(read_dem(path))
    assert places.row_scales().shape == (8, 1, 4)
    ks = [pyproj.Proj(places.crs).get_factors(*places.lonlat(np.array([4.0]), np.array([c]))).parallel_scale[0]
          for c in (0.0, 15.0)]                          # the edge against the middle
    expected = math.degrees(abs(ks[1] / ks[0] - 1.0) / 2.0 / 2.0)  # half the range off the middle, halved
    assert expected <= places.scale_residual <= expected + 0.015 and expected > 0.05   # (+ the bands' own share)
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "-az", "90", "-alt", "20"]) == 0
    assert f"angles within {places.scale_residual:.3f} deg" in capsys.readouterr().err
    with pytest.warns(InputWarning, match=f"angles within {places.scale_residual:.3f} deg"):   # the API's too
        Heightmap.from_raster(read_dem(path))
    x, y = grid_xy(32633, 15.0, 60.0)                      # a conformal grid of a usual width: nothing to say
    path = write_tif(tmp_path / "utm.tif", np.zeros((30, 30)), keys(32633), x, y)
    assert map_places(read_dem(path)).scale_residual < 1e-4


def test_a_utm_map_far_from_its_meridian_is_traced_in_column_bands(tmp_path, capsys):
    """Across 110 km of UTM 33N around 17.9 E, 47 N, k runs from about 1.0000 to 1.0005 along the
    rows: each row is cut into column bands (oclshade.solar.scale.column_edges), each traced at
    the middle of PROJ's k over it (not at 1, as the map's middle alone is near enough to 1),
    which leaves every cell within the tolerance, and the run says nothing."""
    from oclshade.solar.scale import column_edges

    x, y = grid_xy(32633, 17.9, 47.0)
    path = write_tif(tmp_path / "wide.tif", np.zeros((8, 1200)), keys(32633), x - 600 * 92.0, y + 4 * 92.0, 92.0)
    places = map_places(read_dem(path))
    scales = places.row_scales()
    edges = column_edges(1200, scales.shape[1])
    ks = [pyproj.Proj(places.crs).get_factors(*places.lonlat(np.array([4.5]), np.array([float(c)]))).parallel_scale[0]
          for c in edges]                                       # k grows eastwards: its extremes at the bands' edges
    assert max(ks) - min(ks) > 4e-4 and abs(1.0 / np.mean(ks) - 1.0) < 2.45e-4      # PROJ's k along the rows
    assert scales.shape[1] > 1 and np.all(np.diff(ks) > 0.0)
    for b in range(scales.shape[1]):
        assert scales[4, b, 0] == pytest.approx((1.0 / ks[b] + 1.0 / ks[b + 1]) / 2.0, rel=1e-6), b
    assert places.scale_residual <= 0.01
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "-az", "90", "-alt", "20"]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("offset", [0.5, -0.3])
def test_a_walls_penumbra_on_web_mercator_is_the_skys(tmp_path, offset):
    """Soft shadows on a scaled grid: a cell sees a long wall's top at h = atan(H / D) on the
    ground (D in ground metres at the top's height H, H / R longer than the ellipsoid's), and the sun's disc (radius r) centred at h - offset r, so the
    share above the wall is the circular segment above offset r, in closed form. The grid draws
    the disc 0.75 times as tall (sin^2 + 0.5 cos^2 of its 14 degrees, over 0.71): traced with
    the sky's chords it read that share at 0.75 offset instead."""
    from oclshade.horizon import SUN_RADIUS, HorizonCaster

    from test_sun_disc import segment_share

    x, y = grid_xy(3857, 10.0, 45.0)
    heights = np.zeros((9, 120))
    heights[:, 100:103] = 400.0                       # a wall along the columns, its top edge at column 100
    raster = read_dem(write_tif(tmp_path / "wall.tif", heights, keys(3857), x - 60 * 30.0, y + 4.5 * 30.0, 30.0))
    banded = Heightmap.from_raster(raster)
    scale = ground_metre(map_places(raster), 4.5, 60.0, 90.0)      # ground metres per grid metre east (0.71)
    assert scale == pytest.approx(1.0 / math.sqrt(2.0), rel=2e-3)
    distance = 40 * 30.0 * scale * height_factor(400.0)      # the cell 40 columns west of the wall's top
    top = math.degrees(math.atan(400.0 / distance))
    sun = Sun(90.0, top - offset * SUN_RADIUS)
    got = HorizonCaster(banded, cache=False).sun_disc(sun, columns=64)[4, 60]
    assert got == pytest.approx(segment_share(offset), abs=2e-3)
    field = sun_field(map_places(raster), sun)
    flat = Heightmap.from_array(heights, (raster.dx, raster.dy))
    twin = ref_disc(flat, field.blocks[0].sun, 64, scale)[4, 60]
    assert got == pytest.approx(twin, abs=1e-3)
    sky = HorizonCaster(flat, cache=False).sun_disc(field.blocks[0].sun, columns=64)[4, 60]   # the sky's chords
    assert abs(sky - segment_share(offset)) > 0.03          # 0.04-0.07: 20-35 times the bound above


def ref_disc(hm, sun, columns, scale):
    from oclshade.horizon import SUN_RADIUS
    from oclshade.reference.sun_disc import sun_disc_fraction

    return sun_disc_fraction(hm, sun, SUN_RADIUS, columns=columns, scale=scale)


def test_soft_shadows_on_a_scaled_grid_equal_their_float64_twin(tmp_path):
    """Every cell of a canyon on Web Mercator against the twin on the sky (true horizons and the
    true disc, 64 strips, at the ground's metres along the sun, measured by the geodesic):
    within the float32 bound of the strips (each strip's angle within the band, over the
    disc's total chord on the grid, 0.70-0.72 of the sky's) plus the disc's first-order stretch
    (0.02 of the disc is ample: it is 1e-3 of the radius squared)."""
    from oclshade.horizon import SUN_RADIUS, HorizonCaster
    from oclshade.horizon.disc import disc_columns
    from oclshade.reference import angle_tolerance
    from oclshade.synthetic import canyon_crater

    x, y = grid_xy(3857, 10.0, 45.0)
    raster = read_dem(write_tif(tmp_path / "canyon.tif", canyon_crater(40, 48, seed=5, relief=600.0), keys(3857),
                                x - 24 * 30.0, y + 20 * 30.0, 30.0))
    banded = Heightmap.from_raster(raster)
    flat = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    places = map_places(raster)
    for sun in (Sun(300.0, 4.0), Sun(135.0, 10.0)):
        field = sun_field(places, sun)
        assert field.uniform and field.scales[0, 0] < 0.72
        got = HorizonCaster(banded, cache=False).sun_disc(sun, columns=64)
        scale = ground_metre(places, 20.0, 24.0, sun.azimuth)
        want = ref_disc(flat, field.blocks[0].sun, 64, scale)
        on_grid = math.atan(scale * math.tan(math.radians(sun.elevation)))     # the grid sun's elevation
        stretch = (scale ** 2 * math.cos(on_grid) ** 2 + math.sin(on_grid) ** 2) / scale   # the disc's height there
        chords = 2.0 * disc_columns(sun, SUN_RADIUS, 64)[1].sum() * stretch
        assert 64 * angle_tolerance(flat) / chords + 0.02 < 0.1           # a bound that can fail
        assert np.nanmax(np.abs(got - want)) <= 64 * angle_tolerance(flat) / chords + 0.02
        assert 0.0 < ((want > 0) & (want < 1)).mean() < 0.6


@pytest.mark.parametrize("elevation", [40.0, 20.0])
def test_a_walls_end_cuts_the_skys_disc_on_web_mercator(tmp_path, elevation):
    """The strips of a scaled grid's disc are spread in azimuth by the sky's elevation (the
    disc is round on the sky, not on the grid, whose elevation is lower: 33 and 14.5 degrees
    here).  A cell sees the end of a tall wall as a vertical edge in the sky; with the edge at
    four places across the disc, the share it leaves open equals the true disc's over the true
    horizons (each strip's, at the ground's metres along the sun, measured by the geodesic,
    reference.ground_metre, not the tracing's model), within the float32 band of the one strip
    the edge cuts plus 2e-3.
    Spread by the grid's elevation instead, the strips miss by up to 0.037 of the disc."""
    from oclshade import reference as ref
    from oclshade.horizon import SUN_RADIUS, HorizonCaster

    heights = np.zeros((12, 80))
    heights[0:5, 60:63] = 3000.0                      # a wall ending at row 4, seen at 74 degrees
    x, y = grid_xy(3857, 10.0, 45.0)
    raster = read_dem(write_tif(tmp_path / "wall.tif", heights, keys(3857), x - 40 * 30.0, y + 6 * 30.0, 30.0))
    places = map_places(raster)
    i0, j0, columns = 10, 20, 64
    cell = (np.array([i0]), np.array([j0]))

    def horizon(azimuth: float) -> float:             # the true horizon angle that way
        g = ground_metre(places, i0 + 0.5, j0 + 0.5, azimuth)
        return float(ref.horizon_angles(Heightmap(raster.heights, raster.dx * g, raster.dy * g), azimuth,
                                        cells=cell)[0])

    lo, hi = 81.5, 83.5                               # the wall's end: above the sun, then open sky
    assert horizon(lo) > 60.0 and horizon(hi) <= 0.0
    for _ in range(40):
        lo, hi = ((lo + hi) / 2.0, hi) if horizon((lo + hi) / 2.0) > elevation else (lo, (lo + hi) / 2.0)
    width = 2.0 * SUN_RADIUS / columns
    x = -SUN_RADIUS + (np.arange(columns) + 0.5) * width        # the strips across the true disc
    c = np.sqrt(SUN_RADIUS ** 2 - x ** 2)
    caster = HorizonCaster(Heightmap.from_raster(raster), cache=False)
    band = ref.angle_tolerance(Heightmap.from_array(raster.heights, (raster.dx, raster.dy)))
    for offset in (-0.55, -0.2, 0.15, 0.5):           # the edge at offset r across the disc
        azimuth = lo - offset * SUN_RADIUS / math.cos(math.radians(elevation))
        h = np.array([horizon(azimuth + xk / math.cos(math.radians(elevation))) for xk in x])
        true = float(np.clip(elevation + c - h, 0.0, 2.0 * c).sum() / (2.0 * c).sum())
        cut = int(np.count_nonzero((h >= elevation - c - 0.05) & (h <= elevation + c + 0.05)))
        assert cut <= 1                               # a sharp edge: one strip at most cut
        got = float(caster.sun_disc(Sun(azimuth, elevation), columns=columns)[i0, j0])
        assert abs(got - true) <= cut * band / (2.0 * c).sum() + 2e-3, (offset, got, true)
        assert 0.15 < true < 0.85


@pytest.mark.parametrize("knobs, radius", [({"batch": 1}, None), ({"batch": 8}, None), ({"sweep_far": 2}, 1500.0)])
def test_horizons_on_an_equal_area_grid_are_the_grounds(tmp_path, knobs, radius):
    """LAEA Europe at 25 E 60 N (a grid metre 0.5 % longer one way than the other): each
    azimuth's horizons equal the float64 twin's on the grid at that direction's true metres
    (reference.ground_metre: the geodesic, not the tracing's model), within the float32 band plus the bands'
    0.01-degree tolerance; one scale for every direction (what the runs did before) is off by
    several times that.  The device's per-band rays equal the twin of the same bands
    (reference.banded_horizon_angles) within the float32 band, walk, batch or sweep."""
    from oclshade import reference as ref
    from oclshade.horizon import HorizonCaster
    from oclshade.synthetic import canyon_crater

    x, y = grid_xy(3035, 25.0, 60.0)
    path = write_tif(tmp_path / "laea.tif", canyon_crater(96, 128, seed=5, relief=1500.0), keys(3035),
                     x - 64 * 30.0, y + 48 * 30.0)
    raster = read_dem(path)
    places = map_places(raster)
    banded = Heightmap.from_raster(raster)
    assert np.hypot(banded.row_scales[..., 2], banded.row_scales[..., 3]).min() > 5e-3     # stretched by direction
    caster = HorizonCaster(banded, max_distance=radius, knobs=knobs, cache=False)
    azimuths = [0.0, 30.0, 45.0, 90.0, 135.0, 200.0, 300.0]
    got = caster.horizons(azimuths)
    band = ref.angle_tolerance(banded)
    limit = radius or math.inf
    rng = np.random.default_rng(3)
    cells = rng.integers(0, 96, 300), rng.integers(0, 128, 300)
    worst = 0.0
    for k, azimuth in enumerate(azimuths):
        twin = ref.banded_horizon_angles(banded, azimuth, cells=cells, max_distance=limit)
        assert np.array_equal(got[k][cells] == -90.0, twin == -90.0)
        assert np.nanmax(np.abs(got[k][cells] - twin)) <= band
        true = ground_metre(places, 48.0, 64.0, azimuth)            # the ground's metres that way
        ground = Heightmap(banded.heights, raster.dx * true, raster.dy * true)
        exact = ref.horizon_angles(ground, azimuth, cells=cells, max_distance=limit)
        seen = exact > -90.0
        assert np.nanmax(np.abs(got[k][cells][seen] - exact[seen])) <= band + 0.01
        one = Heightmap(banded.heights, raster.dx * banded.row_scales[48, -1, 0], raster.dy * banded.row_scales[48, -1, 0])
        old = ref.horizon_angles(one, azimuth, cells=cells, max_distance=limit)
        worst = max(worst, float(np.nanmax(np.abs(old[seen] - exact[seen]))))
    assert worst > 0.04, worst            # one scale for every direction: four times the bound above


def test_a_whole_equal_area_tile_is_traced_in_column_bands(tmp_path, capsys):
    """An EU-DEM tile (EPSG:3035 E50N40, 1000 km square, far east of the projection's centre): a
    grid metre's true length in one direction changes along a row by 0.9 %, so one scale per row
    would leave angles up to 0.13 degree off; cut into column bands (oclshade.solar.scale.column_edges) and bands
    of rows, every cell is traced within the tolerance, and the run says nothing."""
    from oclshade.solar.scale import stretch_of

    transform = (500.0, 0.0, 0.0, 5.0e6, 0.0, -5000.0, 0.0, 5.0e6) + (0.0,) * 7 + (1.0,)     # 0.5 by 5 km cells
    path = write_tif(tmp_path / "e50n40.tif", np.zeros((200, 2000)), keys(3035), transform=transform)
    places = map_places(read_dem(path))
    scales = places.row_scales()
    assert scales.shape[0] == 200 and scales.shape[1] > 40        # dozens of column bands
    azimuths = np.radians(np.arange(0.0, 180.0, 5.0))[None, :]
    for r in (0.5, 99.5, 199.5):                                # the ground along a row
        s, p, q = places.projected_scales(*places.lonlat(np.full(41, r), np.linspace(0.0, 2000.0, 41)))
        lengths = s[:, None] * stretch_of(np.stack([s, s, p, q], axis=-1)[:, None, :], np.sin(azimuths),
                                          np.cos(azimuths))
        assert np.max(lengths.max(axis=0) / lengths.min(axis=0)) > 1.008
    assert places.scale_residual <= 0.01 / math.sqrt(2.0)       # (d / 2 of the blocks' d <= sqrt(2) tolerance)
    one_band = (scales.min(axis=1, keepdims=True) + scales.max(axis=1, keepdims=True)) / 2.0   # a scale per row
    assert places.residual_of(one_band) > 0.1
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "-az", "90", "-alt", "20"]) == 0
    assert "warning" not in capsys.readouterr().err


def test_horizons_across_column_bands_are_the_grounds(tmp_path):
    """820 km of LAEA Europe far east of its centre, in 800 m cells: each cell's horizons equal the
    float64 twin's on the grid at that cell's own true metres along the azimuth
    (reference.ground_metre), within the float32 band plus the 0.01-degree tolerance; the row's
    middle scale for all of it (one scale per row) is off by twice that at the ends.  The
    device's blocks equal their twin (reference.banded_horizon_angles) within the float32 band."""
    from oclshade import reference as ref
    from oclshade.horizon import HorizonCaster
    from oclshade.synthetic import canyon_crater

    path = write_tif(tmp_path / "laea.tif", canyon_crater(96, 1024, seed=9, relief=3000.0), keys(3035),
                     5.15e6, 4.1e6, 800.0)
    raster = read_dem(path)
    places = map_places(raster)
    banded = Heightmap.from_raster(raster)
    assert banded.row_scales.shape[1] > 4
    caster = HorizonCaster(banded, cache=False)
    assert caster.scale_blocks.scales.shape[1] == banded.row_scales.shape[1]
    azimuths = [10.0, 80.0, 135.0, 260.0]
    got = caster.horizons(azimuths)
    band = ref.angle_tolerance(banded)
    rng = np.random.default_rng(4)
    cells = rng.integers(0, 96, 200), np.concatenate([rng.integers(0, 60, 100), rng.integers(964, 1024, 100)])
    middle = banded.row_scales[:, banded.row_scales.shape[1] // 2]      # each row at its middle band's scale
    one_scale = HorizonCaster(Heightmap.from_array(raster.heights, (raster.dx, raster.dy), row_scales=middle),
                              cache=False).horizons(azimuths)
    worst = 0.0
    for k, azimuth in enumerate(azimuths):
        twin = ref.banded_horizon_angles(banded, azimuth, cells=cells)
        assert np.array_equal(got[k][cells] == -90.0, twin == -90.0)
        assert np.nanmax(np.abs(got[k][cells] - twin)) <= band
        for i, j in zip(*(c[:40] for c in cells)) if k % 2 else zip(*(c[-40:] for c in cells)):
            true = ground_metre(places, i + 0.5, j + 0.5, azimuth)      # this cell's metres that way
            ground = Heightmap(raster.heights, raster.dx * true, raster.dy * true)
            exact = float(ref.horizon_angles(ground, azimuth, cells=(np.array([i]), np.array([j])))[0])
            if exact > -90.0:
                assert abs(float(got[k][i, j]) - exact) <= band + 0.01, (azimuth, i, j)
                worst = max(worst, abs(float(one_scale[k][i, j]) - exact))
    assert worst > 0.02, worst            # the row's middle scale at its ends: twice the bound above


@pytest.mark.parametrize("lanes", [1, 4, 8, 16])
def test_the_sweep_of_blocks_is_their_walk(lanes):
    """A search radius's sweep over blocks of their own scale (one launch, each run of lanes reading
    its block's ray from the table: kernels/horizon.cl "The sweep") gives the walk's angles and
    sky-view sums bit for bit, as it does on a map traced as drawn.  63 columns in 3 column
    bands put the last band's inner edge at 48: 15 columns, narrower than 16 lanes, so the last
    run is shifted left into the band before it and must take the ray of the columns it writes.
    And the blocks' scales matter: the map as drawn gives other angles."""
    from oclshade.horizon import HorizonCaster
    from oclshade.solar.scale import column_edges
    from oclshade.synthetic import canyon_crater

    rows, cols = 40, 63
    assert column_edges(cols, 3).tolist() == [0, 16, 48, 63]
    s = 0.9 + 0.002 * np.arange(rows)[:, None] + np.array([0.0, 0.02, 0.05])[None, :]     # (rows, 3)
    scales = np.stack([s, s, np.full_like(s, -0.004), 0.003 + 0.001 * np.arange(3)[None, :] + 0 * s], axis=-1)
    hm = Heightmap.from_array(canyon_crater(rows, cols, seed=11, relief=400.0), 30.0, row_scales=scales)
    radius = 12 * 30.0
    swept = HorizonCaster(hm, max_distance=radius, cache=False, knobs={"sweep_far": 2, "lanes": lanes})
    walked = HorizonCaster(hm, max_distance=radius, cache=False, knobs={"sweep_cells": 0, "sweep_far": 0})
    assert swept.scale_blocks.scales.shape[1] == 3 and swept.takes_sweep(30.0) and not walked.takes_sweep(30.0)
    azimuths = [0.0, 30.0, 90.0, 160.0, 215.0, 300.0]
    got = swept.horizons(azimuths)
    assert got.tobytes() == walked.horizons(azimuths).tobytes()
    assert swept.sky_view_factor(16).tobytes() == walked.sky_view_factor(16).tobytes()
    drawn = HorizonCaster(Heightmap.from_array(hm.heights, 30.0), max_distance=radius, cache=False,
                          knobs={"sweep_far": 2, "lanes": lanes}).horizons(azimuths)
    assert not np.array_equal(got[..., 48:], drawn[..., 48:], equal_nan=True)


def test_far_terrain_is_off_by_at_most_the_far_residual(tmp_path, capsys):
    """A ray keeps its cell's block scale along its whole length (docs/methods.md, "Far terrain"),
    and on Web Mercator at 60 N a grid metre is 2.7 % shorter on the ground 100 km further north:
    a 3000 m tower 20 to 115 km north is seen, against the truth atan(H / D) at the geodesic
    distance D (pyproj), up to MapPlaces.far_residual off (within the float32 band and the
    blocks' own residual), and by more than 0.8 of it (about as much from 20 km as from 115 km: a
    first-order error of rate dh cos^2 / 2): the bound is tight, and the run says it, with the
    ground metres' height at the middle of the heights (the truth's distance at the tower's top,
    H / R longer than the ellipsoid's; height_residual_of).  With curvature the error grows to
    rate (dh + c D^2) / 2, and the bound with it (the drop across the map, up to the relief):
    from 115 km the tower is seen 0.9 of that bound off, and the run with --curvature says so."""
    from oclshade import reference as ref
    from oclshade.horizon import Curvature, HorizonCaster

    rows, cols, cell, height = 1200, 32, 200.0, 3000.0      # 200 grid m: 100 m on the ground
    heights = np.zeros((rows, cols))
    heights[4:7, 15:18] = height                            # its south face's top at row 6
    x, y = grid_xy(3857, 10.0, 60.0)
    path = write_tif(tmp_path / "wm60.tif", heights, keys(3857), x - cols / 2 * cell, y + 60 * cell, cell)
    raster = read_dem(path)
    places = map_places(raster)
    far = places.far_residual(height, raster.dx, raster.dy)
    rate = places.far_scale_rate(raster.dx, raster.dy)
    assert rate == pytest.approx(math.tan(math.radians(60.0)) / 6.371e6, rel=0.05)
    assert 0.02 < far < 0.03
    bound = far + height_residual_of(height)
    with pytest.warns(InputWarning, match=f"angles to terrain within {bound:.3f} deg"):     # the API's warning
        hm = Heightmap.from_raster(raster)
    got = HorizonCaster(hm, cache=False).horizons([0.0])[0]
    observers = np.arange(200, 1160, 40)
    lon, lat = places.lonlat(np.append(observers, 6) + 0.5, np.full(observers.size + 1, 16.5))
    _, _, metres = pyproj.Geod(ellps="WGS84").inv(lon[:-1], lat[:-1], np.full(observers.size, lon[-1]),
                                                   np.full(observers.size, lat[-1]))
    truth = np.degrees(np.arctan(height / (metres * height_factor(height))))
    error = np.abs(got[observers, 16] - truth)
    assert np.all(error <= bound + places.scale_residual + ref.angle_tolerance(hm)), (error.max(), bound)
    assert error.max() > 0.8 * far, (error.max(), far)       # a tight bound (the blocks hold 0.01 / sqrt(2))
    assert main(["horizon", str(path), str(tmp_path / "h.tif"), "--azimuths", "4", "-q"]) == 0
    assert f"angles to terrain within {bound:.3f} deg" in capsys.readouterr().err
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "--sun", "0,10", "--tile", "256", "-q"]) == 0
    assert f"angles to terrain within {bound:.3f} deg" in capsys.readouterr().err     # a windowed run too
    c = Curvature().coefficient
    curved = HorizonCaster(hm, curvature=Curvature(), cache=False).horizons([0.0])[0]
    ground = metres * height_factor(height)
    truth = np.degrees(np.arctan((height - c * ground * metres) / ground))        # drop (R + H) theta^2 / 2
    drop = c * (rows * raster.dy * hm.row_scales[..., 0].max()) ** 2                # across the map (its length)
    far_curved = places.far_residual(height, raster.dx, raster.dy, drop)
    assert far_curved > 1.3 * far
    error = np.abs(curved[observers, 16] - truth)
    assert np.all(error <= far_curved + height_residual_of(height) + places.scale_residual
                  + ref.angle_tolerance(hm, c)), (error.max(), far_curved)
    assert error.max() > 0.85 * far_curved, (error.max(), far_curved)
    assert main(["horizon", str(path), str(tmp_path / "h.tif"), "--azimuths", "4", "-q", "--curvature"]) == 0
    assert "curvature's drop of up to" in capsys.readouterr().err


@pytest.mark.parametrize("latitude", [22.0, 46.0, 62.0])
def test_a_geographic_grids_far_scale_rate_is_its_widths(tmp_path, latitude):
    """On a geographic grid only a cell's east width changes, with latitude (cos f): a grid metre at
    grid azimuth a changes along a by sin^2 a cos a tan f / R per metre, at most 2 / (3 sqrt 3)
    tan f / R (a = 54.7 degrees); a 1-degree tile at 62 N with 2000 m of relief goes past the
    tolerance (with what the ground metres' height leaves, height_residual_of), and a flat one
    does not warn."""
    from oclshade.solar.field import checked_places

    wgs84 = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
    heights = np.zeros((241, 241))
    heights[120, 120] = 2000.0
    raster = read_dem(write_tif(tmp_path / "tile.tif", heights, wgs84, 10.0, latitude + 0.5, 1.0 / 240))
    places = map_places(raster)
    expected = 2.0 / (3.0 * math.sqrt(3.0)) * math.tan(math.radians(latitude)) / 6.371e6
    assert places.far_scale_rate(raster.dx, raster.dy) == pytest.approx(expected, rel=0.03)
    notes = checked_places(raster)[1]
    bound = places.far_residual(2000.0, raster.dx, raster.dy) + height_residual_of(2000.0)
    assert bool(notes) == (bound > 0.01) == (latitude == 62.0)
    flat = read_dem(write_tif(tmp_path / "flat.tif", np.zeros((241, 241)), wgs84, 10.0, latitude + 0.5, 1.0 / 240))
    assert checked_places(flat)[1] == []


def test_the_stretch_share_bounds_every_direction():
    """oclshade.solar.scale.stretch_share: over a box of (p, q) and every direction, the stretch
    sqrt(1 + p cos 2a + q sin 2a) differs from that at the box's middle by at most the share it
    gives, and by more than half of it somewhere (strong stretches too, where the root is steep)."""
    from oclshade.solar.scale import stretch_of, stretch_share

    rng = np.random.default_rng(11)
    a = np.radians(np.arange(0.0, 180.0, 0.5))
    sin, cos = np.sin(a), np.cos(a)
    for _ in range(200):
        middle = rng.uniform(-0.5, 0.5, 2)
        half = rng.uniform(0.0, 0.05, 2)
        lo, hi = np.array([1.0, 1.0, *(middle - half)]), np.array([1.0, 1.0, *(middle + half)])
        p, q = np.meshgrid(np.linspace(lo[2], hi[2], 9), np.linspace(lo[3], hi[3], 9))
        box = np.stack([np.ones(p.size), np.ones(p.size), p.ravel(), q.ravel()], axis=-1)
        share = np.abs(stretch_of(box[:, None, :], sin, cos) / stretch_of((lo + hi) / 2.0, sin, cos) - 1.0).max()
        bound = float(stretch_share(lo, hi))
        assert bound / 2.0 < share <= bound * (1.0 + 1e-12), (lo, hi)


@pytest.mark.parametrize("crs, cells, rows", [("geographic", 1.0 / 240, 241), (32632, 30.0, 300)])
def test_terrain_high_above_the_ellipsoid_is_seen_at_its_height(tmp_path, crs, cells, rows):
    """A georeferenced grid's metres are the ellipsoid's, and terrain h above it is (R + h) / R
    further apart; the ground metres are taken at the middle of the map's heights.  A 6000 m
    ridge seen due north from a 4000 m plateau (a geographic grid at 46 N, UTM 32N on its central
    meridian), with curvature and no refraction, against the elevation angle between the two
    points in ECEF (pyproj, WGS 84 heights): within height_residual_of(2000 m) = 0.0045 degree,
    and by more than 0.8 of it (terrain 1000 m above the middle, at 45 degrees: a tight bound),
    where the ellipsoid's metres read up to 0.027 degree off.  bench/ground_height.py's brute force
    in ECEF finds the same truth (its ridge edge is a patch edge it samples)."""
    import importlib.util

    from oclshade import reference as ref
    from oclshade.horizon import EARTH_RADIUS, Curvature, HorizonCaster
    from oclshade.solar.field import MapPlaces

    cols = 41
    heights = np.full((rows, cols), 4000.0)
    heights[20:23] = 6000.0                                     # its south face's top at row 22
    if crs == "geographic":
        gkeys = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
        path = write_tif(tmp_path / "ridge.tif", heights, gkeys, 9.0, 46.5, cells)
    else:
        x, y = grid_xy(crs, 9.0, 46.0)
        path = write_tif(tmp_path / "ridge.tif", heights, keys(crs), x - cols / 2 * cells, y, cells)
    raster = read_dem(path)
    places = map_places(raster)
    assert places.height == 5000.0
    curvature = Curvature(EARTH_RADIUS, 0.0)
    hm = Heightmap.from_raster(raster)
    observers = np.arange(26, rows, 10)
    at = (observers, np.full(observers.size, cols // 2))
    got = HorizonCaster(hm, curvature=curvature, cache=False).horizons([0.0])[0][at]
    twin = ref.banded_horizon_angles(hm, 0.0, curvature.coefficient, at)
    assert np.abs(got - twin).max() <= ref.angle_tolerance(hm, curvature.coefficient)
    on_ellipsoid = MapPlaces(places.transform, places.shape, places.crs)     # (height 0: the ellipsoid's metres)
    flat = Heightmap.from_array(raster.heights, (raster.dx, raster.dy), row_scales=on_ellipsoid.row_scales())
    before = ref.banded_horizon_angles(flat, 0.0, curvature.coefficient, at)
    lon, lat = places.lonlat(np.append(observers, 22) + 0.5, np.full(observers.size + 1, cols // 2 + 0.5))
    to_ecef = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    points = np.stack(to_ecef.transform(lon, lat, np.append(np.full(observers.size, 4000.0), 6000.0)), axis=-1)
    phi, lam = np.radians(lat[:-1]), np.radians(lon[:-1])
    up = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
    sight = points[-1] - points[:-1]
    truth = np.degrees(np.arcsin(np.sum(up * sight, axis=-1) / np.linalg.norm(sight, axis=-1)))
    bound = height_residual_of(2000.0)
    sphere = 5e-4       # curvature's drop on a sphere of R, not the ellipsoid: 0.3 m at 100 km, 2e-4 degree
    error = np.abs(twin - truth)
    assert error.max() <= bound + sphere, (error.max(), bound)
    assert error.max() > 0.8 * bound, (error.max(), bound)
    assert np.abs(before - truth).max() > 0.02, np.abs(before - truth).max()          # the ellipsoid's metres
    spec = importlib.util.spec_from_file_location("bench_ground_height", ROOT / "bench" / "ground_height.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    brute = bench.ecef_horizons(raster, places, at, np.array([0.0]))[0]
    assert np.abs(brute - truth).max() < 1e-6, np.abs(brute - truth).max()


def test_the_relief_and_the_middle_height_are_in_metres_after_the_z_factor(tmp_path, capsys):
    """Heights in kilometres with -z 1000 (or Heightmap.from_raster's z_factor): the map's middle
    height and relief, which set the ground metres and the bound the run warns of, are the
    metres the heightmap traces, not the raster's numbers."""
    from oclshade.solar.field import checked_places

    heights = np.zeros((64, 64))
    heights[30:34, 30:34] = 6.0                               # 6 km
    x, y = grid_xy(32632, 9.0, 46.0)
    path = write_tif(tmp_path / "km.tif", heights, keys(32632), x, y, 30.0)
    raster = read_dem(path)
    assert checked_places(raster)[1] == []
    places, notes = checked_places(raster, 1000.0)
    assert places.height == 3000.0 and len(notes) == 1
    assert f"with 6000 m of relief, angles to terrain within {height_residual_of(6000.0):.3f} deg" in notes[0]
    with pytest.warns(InputWarning, match="with 6000 m of relief"):
        hm = Heightmap.from_raster(raster, z_factor=1000.0)
    assert hm.row_scales[0, 0, 0] == pytest.approx(height_factor(3000.0) / 0.9996, rel=1e-6)
    assert main(["shadow", str(path), str(tmp_path / "m.tif"), "-az", "90", "-alt", "20", "-z", "1000"]) == 0
    assert "with 6000 m of relief" in capsys.readouterr().err


def test_rays_follow_the_grid_lines_not_the_geodesics(tmp_path):
    """The convention bench/geodesic_rays.py measures: a horizon at azimuth a looks along the
    grid's straight line leaving the cell at a (as r.horizon and SAGA do), not along the geodesic
    (the vertical plane, as HORAYZON's ECEF rays).  On a flat geographic grid at 46 N (3 arc-sec)
    one sample 30 km due east of the observer but 0.9 row south of its row, where the geodesic
    heading east passes (pyproj): the kernel at 90 degrees follows the row and does not see it, the
    bench's geodesic brute force does (about 0.6 degree up), and the kernel sees it along the grid
    line that points at it.  The bench's grid-line brute force equals the kernel's float64 twin."""
    import importlib.util

    from oclshade import reference as ref
    from oclshade.horizon import EARTH_RADIUS, Curvature, HorizonCaster

    cell = 1.0 / 1200
    rows, cols, eye = 41, 520, (20, 10)
    lon0, lat0 = 9.0 + (eye[1] + 0.5) * cell, 46.5 - (eye[0] + 0.5) * cell
    lon, lat, _ = pyproj.Geod(ellps="WGS84").fwd(lon0, lat0, 90.0, 30000.0)
    spike = (round((46.5 - lat) / cell - 0.5), round((lon - 9.0) / cell - 0.5))
    assert spike[0] == eye[0] + 1, spike            # the geodesic has turned 0.5-1.5 rows south
    heights = np.zeros((rows, cols))
    heights[spike] = 500.0
    gkeys = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
    raster = read_dem(write_tif(tmp_path / "spike.tif", heights, gkeys, 9.0, 46.5, cell))
    places = map_places(raster)
    hm = Heightmap.from_raster(raster)
    curvature = Curvature(EARTH_RADIUS, 0.0)
    at = (np.array([eye[0]]), np.array([eye[1]]))
    dx, dy = raster.dx * hm.row_scales[eye[0], 0], raster.dy * hm.row_scales[eye[0], 1]
    along = math.degrees(math.atan2((spike[1] - eye[1]) * dx, -(spike[0] - eye[0]) * dy))   # the grid line to it
    assert 90.0 < along < 90.2
    caster = HorizonCaster(hm, curvature=curvature, cache=False)
    east, aimed = (caster.horizons([a])[0][at][0] for a in (90.0, along))
    assert abs(east) < 1e-3 and aimed > 0.8, (east, aimed)     # (a plain's horizon with curvature: 0)
    spec = importlib.util.spec_from_file_location("bench_geodesic_rays", ROOT / "bench" / "geodesic_rays.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    geodesic = bench.geodesic_horizons(raster, places, at, np.array([90.0]))[0][0, 0]
    line = bench.ecef_horizons(raster, places, at, np.array([90.0]))[0, 0]
    assert 0.5 < geodesic < aimed, (geodesic, aimed)
    twin = ref.banded_horizon_angles(hm, 90.0, curvature.coefficient, at)[0]
    assert abs(line - twin) < 2e-3 and abs(east - twin) <= ref.angle_tolerance(hm, curvature.coefficient)


def test_an_undeclared_sentinel_moves_neither_the_middle_height_nor_the_relief(tmp_path, capsys):
    """A geographic DEM whose voids hold -32768 without declaring it: the run warns of the
    sentinel (declare it), but the map's ground metres and the relief its bounds take are the
    other cells' (the middle height had read about -15000 m: every scale 0.24 % short, and a
    second warning of 35000 m of relief), whole and tiled alike."""
    import tifffile

    from oclshade.solar.field import checked_places

    heights = np.random.default_rng(5).uniform(1000.0, 2500.0, (96, 96))
    heights[40:43, 50:53] = -32768.0
    gkeys = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
    path = write_tif(tmp_path / "voids.tif", heights, gkeys, 9.0, 46.5, 1.0 / 1200)
    raster = read_dem(path)
    ordinary = heights[heights > -32768.0].astype(np.float32)
    middle = (float(ordinary.min()) + float(ordinary.max())) / 2.0
    assert map_places(raster).height == middle
    places, notes = checked_places(raster, 1.0, 1e-7)
    assert places.height == middle and notes == []
    for name, extra in (("whole.tif", []), ("tiled.tif", ["--tile", "32"])):
        assert main(["shadow", str(path), str(tmp_path / name), "-az", "90", "-alt", "20", "-q", *extra]) == 0
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "9 cell(s) equal -32768" in err[0], err
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "whole.tif"), tifffile.imread(tmp_path / "tiled.tif"))
    with pytest.warns(InputWarning, match="equal -32768"):
        hm = Heightmap.from_raster(raster)
    assert hm.row_scales[0, 0] == places.row_scales()[0, 0] > 0.999                # (-15000 m: 0.9976)
