"""``oclshade sunshine``: through ``oclshade.cli.main``."""
from __future__ import annotations

import re
from datetime import datetime, timedelta
from zoneinfo import ZoneInfo

import numpy as np
import pytest

from oclshade.cli import main
from oclshade.heightmap import Heightmap
from oclshade.solar import suns_at
from oclshade.synthetic import canyon_crater
from oclshade.sunshine import SunshineCaster, time_steps
from test_sun_cli import _geographic_dem

ZURICH = ZoneInfo("Europe/Zurich")
DAY = ["--start", "2024-06-21T04:00", "--end", "2024-06-21T22:00", "--tz", "Europe/Zurich", "--step", "1h"]


@pytest.fixture
def dem(tmp_path):
    path = tmp_path / "dem.npy"
    heights = canyon_crater(24, 32, seed=4, relief=600)
    heights[3, 5] = np.nan
    np.save(path, heights)
    return path


def test_outputs_are_the_library_sums_over_the_period(tmp_path, dem, capsys):
    out = tmp_path / "o.npy"
    assert main(["sunshine", str(dem), str(out), "--cellsize", "30", "--lat", "46.95", "--lon", "7.45", *DAY,
                 "--output", "irradiation,hours,fraction", "-q"]) == 0
    assert capsys.readouterr().err == ""
    got = np.load(out)
    steps = time_steps(datetime(2024, 6, 21, 4, tzinfo=ZURICH), datetime(2024, 6, 21, 22, tzinfo=ZURICH),
                       timedelta(hours=1))
    hm = Heightmap.from_array(np.load(dem), 30.0)
    want = SunshineCaster(hm).accumulate(suns_at(steps.times, 46.95, 7.45), steps.seconds, "all")
    assert got.shape == (3, 24, 32) and got.dtype == np.float32
    for band, name in zip(got, ("hours", "fraction", "irradiation")):     # the order of SUNSHINE_OUTPUTS
        assert np.array_equal(band, getattr(want, name), equal_nan=True), name
    assert np.isnan(got[:, 3, 5]).all() and 0 < np.nanmax(got[0]) <= 16.5   # 16 h 20 min of daylight in Bern


def test_horizons_method_and_summary(tmp_path, dem, capsys):
    out = tmp_path / "o.npy"
    assert main(["sunshine", str(dem), str(out), "--cellsize", "30", "--lat", "46.95", "--lon", "7.45", *DAY,
                 "--method", "horizons", "--azimuths", "32"]) == 0
    err = capsys.readouterr().err
    assert "18 steps of 1:00:00" in err and "method horizons" in err and "h of direct sun on average" in err
    hm = Heightmap.from_array(np.load(dem), 30.0)
    steps = time_steps(datetime(2024, 6, 21, 4, tzinfo=ZURICH), datetime(2024, 6, 21, 22, tzinfo=ZURICH),
                       timedelta(hours=1))
    want = SunshineCaster(hm).accumulate(suns_at(steps.times, 46.95, 7.45), steps.seconds, method="horizons",
                                         azimuths=32)
    assert np.array_equal(np.load(out), want.hours, equal_nan=True)


def test_place_from_a_geographic_input_and_geotiff_output(tmp_path, capsys):
    import tifffile

    dem = _geographic_dem(tmp_path / "geo.tif")
    out = tmp_path / "o.tif"
    assert main(["sunshine", str(dem), str(out), *DAY, "--output", "all", "--co", "COMPRESS=ZSTD"]) == 0
    assert "latitude 46.00000, longitude 7.00000" in capsys.readouterr().err
    with tifffile.TiffFile(out) as tif:
        data = tif.asarray()
        assert data.shape == (3, 64, 64) and 33550 in tif.pages[0].tags   # georeferencing kept
    assert np.all((data[1] >= 0) & (data[1] <= 1)) and data[0].max() > 0


def test_progress_bar_in_logs_and_quiet(tmp_path, dem, capsys):
    args = ["sunshine", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "--lat", "46.95", "--lon", "7.45",
            *DAY]
    assert main(args) == 0
    err = capsys.readouterr().err
    daylight = int(re.search(r"(\d+) in daylight", err).group(1))
    bars = [line for line in err.splitlines() if line.startswith("[")]
    assert 10 <= daylight < 18 and bars[-1].endswith(f"{daylight}/{daylight} suns")
    assert len(bars) <= 11 and "\r" not in err   # not a tty: one line per tenth
    assert main([*args, "-q"]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("extra, message", [
    (["--output", "hours,mask"], "expected a comma-separated subset of hours,fraction,irradiation or all"),
    (["--step", "10"], "step must be a positive whole number with a unit"),
    (["--azimuths", "32"], "--azimuths goes with --method horizons"),
    (["--method", "horizons", "--azimuths", "2"], "expected a whole number of azimuths in 4..3600"),
    (["--start", "2024-06-22T00:00"], "--start, --end, --step: end must be after start"),
    (["--tz", "Mars/Olympus"], "--tz 'Mars/Olympus' is not an IANA time zone name"),
])
def test_usage_errors(tmp_path, dem, capsys, extra, message):
    args = ["sunshine", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "--lat", "46.95", "--lon", "7.45",
            *DAY, *extra]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "o.npy").exists()


@pytest.mark.parametrize("argv, message", [
    (["o.png"], "o.png': expected .tif, .tiff, .exr or .npy (float32 bands)"),
    (["o.npy", "--start", "2024-06-21T04:00"], "--start 2024-06-21T04:00 has no UTC offset"),
    (["o.npy", "--end", "noon"], "--end 'noon' is not an ISO 8601 date and time"),
])
def test_usage_errors_without_tz(tmp_path, dem, capsys, argv, message):
    output, *extra = argv
    args = ["sunshine", str(dem), str(tmp_path / output), "--cellsize", "30", "--lat", "46.95", "--lon", "7.45",
            "--start", "2024-06-21T04:00Z", "--end", "2024-06-21T05:00Z", *extra]
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_lat_needs_lon(tmp_path, dem, capsys):
    assert main(["sunshine", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "--lat", "46", *DAY]) == 2
    assert "give both --lat and --lon, or neither" in capsys.readouterr().err


def test_a_projected_map_needs_the_place(tmp_path, dem, capsys):
    args = ["sunshine", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", *DAY]
    assert main(args) == 2
    assert "--start and --end: INPUT" in capsys.readouterr().err and not (tmp_path / "o.npy").exists()
