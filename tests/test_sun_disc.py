"""Soft shadows: the share of the sun's disc each cell sees (oclshade.horizon.disc), against
its float64 twin, a closed form on a plane, and the fine-strip reference; ``oclshade sunlit``."""
from __future__ import annotations

import math

import numpy as np
import pytest

from oclshade import Heightmap
from oclshade.cli import main
from oclshade.horizon import SUN_RADIUS, HorizonCaster, disc_columns
from oclshade.reference import angle_tolerance
from oclshade.reference.sun_disc import sun_disc_fraction
from oclshade.synthetic import canyon_crater


def segment_share(p: float) -> float:
    """Share of a unit disc above a horizontal line at height p (closed form)."""
    p = min(max(p, -1.0), 1.0)
    return (math.acos(p) - p * math.sqrt(1.0 - p * p)) / math.pi


@pytest.fixture(scope="module")
def canyon() -> Heightmap:
    return Heightmap.from_array(canyon_crater(24, 28, seed=5, relief=500.0), 10.0)


@pytest.mark.parametrize("elevation", [-0.2, 0.0, 0.1, 0.25, 1.0])
def test_plane_reads_the_circular_segment(elevation):
    """Over a plane every horizon looking across the map is 0 degrees: the visible share is the
    disc above a horizontal line, in closed form; the midpoint rule over 64 strips errs by less
    than 1e-3 there (the chord's square-root ends)."""
    hm = Heightmap.from_array(np.zeros((12, 12)), 10.0)
    f = HorizonCaster(hm).sun_disc((90.0, elevation), columns=64)
    inner = f[1:-1, :-1]     # the last column looks east out of the map (nothing: 1); the first and
    #                          last rows look out of it across half the disc
    want = segment_share((0.0 - elevation) / SUN_RADIUS)
    assert np.abs(inner - want).max() < 1e-3
    assert (f[:, -1] == 1.0).all()


def test_device_equals_its_float64_twin(canyon):
    """The same strips over the float64 horizons: each strip's visible chord moves by at most the
    horizon angle's float32 bound, so the share by at most K * bound / (2 sum c_k)."""
    caster = HorizonCaster(canyon)
    for sun in [(300.0, 3.0), (135.0, 12.0), (0.0, 0.5)]:
        got = caster.sun_disc(sun, columns=8)
        want = sun_disc_fraction(canyon, sun, SUN_RADIUS, columns=8)
        _, c = disc_columns(sun, SUN_RADIUS, 8)
        bound = 8 * angle_tolerance(canyon) / (2.0 * c.sum()) + 1e-6
        assert np.abs(got - want).max() <= bound
        assert 0.0 < ((want > 0) & (want < 1)).mean() < 0.5, "a view with penumbra, light and shade"


def test_default_strips_within_the_stated_error(canyon):
    """docs/methods.md "Soft shadows": 16 strips err by at most 0.03 of the disc against 256."""
    caster = HorizonCaster(canyon)
    for sun in [(300.0, 3.0), (135.0, 1.0)]:
        err = np.abs(caster.sun_disc(sun) - sun_disc_fraction(canyon, sun, SUN_RADIUS, columns=256))
        assert err.max() <= 0.03


def test_nodata_and_arguments(canyon):
    h = canyon.heights.copy()
    h[3, 4] = np.nan
    f = HorizonCaster(Heightmap.from_array(h, 10.0)).sun_disc((200.0, 5.0), columns=4)
    assert np.isnan(f[3, 4]) and np.isfinite(np.delete(f.ravel(), 3 * f.shape[1] + 4)).all()
    caster = HorizonCaster(canyon)
    for kwargs, match in [({"radius": 0.0}, "radius"), ({"radius": 6.0}, "radius"), ({"columns": 0}, "columns"),
                          ({"columns": 2.5}, "columns")]:
        with pytest.raises(ValueError, match=match):
            caster.sun_disc((0.0, 5.0), **kwargs)
    with pytest.raises(ValueError, match="elevation"):
        caster.sun_disc((0.0, 89.9))


def test_cli_sunlit_equals_the_api(tmp_path, canyon, capsys):
    np.save(tmp_path / "dem.npy", canyon.heights)
    out = tmp_path / "soft.npy"
    assert main(["sunlit", str(tmp_path / "dem.npy"), str(out), "--cellsize", "10", "--sun", "300,3",
                 "--sun", "135,1", "--columns", "4", "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    bands = np.load(out)
    caster = HorizonCaster(canyon)
    assert bands.dtype == np.float32 and bands.shape == (2,) + canyon.shape
    assert np.array_equal(bands[0], caster.sun_disc((300.0, 3.0), columns=4))
    assert np.array_equal(bands[1], caster.sun_disc((135.0, 1.0), columns=4))
    assert main(["sunlit", str(tmp_path / "dem.npy"), str(out), "--cellsize", "10"]) == 2
    assert "--sun" in capsys.readouterr().err


def test_clamped_strips_equal_the_unclamped_horizons(canyon):
    """The strips' horizons are traced clamped to the strip's elevations (-D OCLS_CLAMP: rays
    stop as soon as the answer is known); the share equals the one from the full horizons bit
    for bit, curvature included."""
    from oclshade.horizon import Curvature, visible_fraction

    for caster in (HorizonCaster(canyon), HorizonCaster(canyon, curvature=Curvature(radius=2e4))):
        for sun in [(300.0, 3.0), (135.0, 1.0), (10.0, 0.1), (80.0, 30.0)]:
            azimuths, half_chords = disc_columns(sun, SUN_RADIUS, 8)
            full = visible_fraction((b for _, b in caster.iter_horizons(azimuths)), sun[1], half_chords)
            assert np.array_equal(caster.sun_disc(sun, columns=8), full.astype(np.float32))


def test_cli_sunlit_from_a_datetime_on_a_utm_map(tmp_path, canyon, capsys):
    """`sunlit --datetime`: the sun at the map's centre through its CRS (UTM 33N, 2 degrees of
    meridian convergence there), turned to the grid: the band equals `--sun` at that grid sun;
    --sun and --datetime together are refused."""
    from datetime import datetime

    from oclshade.io import Raster, read_dem, write_raster
    from oclshade.solar.cli import suns_for

    georef = {33550: (10.0, 10.0, 0.0), 33922: (0.0, 0.0, 0.0, 300000.0, 5400000.0, 0.0),
              34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}
    dem = tmp_path / "utm.tif"
    write_raster(dem, canyon.heights.astype(np.float32), like=Raster(canyon.heights, 10.0, 10.0, None, False, georef))
    when = "2024-06-21T20:30+02:00"
    assert main(["sunlit", str(dem), str(tmp_path / "t.npy"), "--datetime", when, "--columns", "4",
                 "--sun-tolerance", "1"]) == 0   # one sun for the map (per block: tests/test_field.py)
    assert "on the grid of EPSG:32633" in capsys.readouterr().err
    import argparse
    placed = suns_for([datetime.fromisoformat(when)], argparse.Namespace(input=str(dem), lat=None, lon=None),
                      read_dem(dem))   # no --sun-tolerance: the centre's one sun, as --sun-tolerance 1 gives
    sun = placed.suns[0]
    assert abs(sun.azimuth - placed.true[0].azimuth) > 1.5 and 0.0 < sun.elevation < 10.0
    assert main(["sunlit", str(dem), str(tmp_path / "s.npy"), f"--sun={sun.azimuth!r},{sun.elevation!r}",
                 "--columns", "4", "-q"]) == 0
    timed, direct = np.load(tmp_path / "t.npy"), np.load(tmp_path / "s.npy")
    assert np.array_equal(timed, direct) and (timed < 1.0).any()
    assert main(["sunlit", str(dem), str(tmp_path / "b.npy"), "--datetime", when, "--sun", "10,10"]) == 2
    assert "give the sun one way" in capsys.readouterr().err
