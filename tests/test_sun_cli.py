"""``oclshade sun``: through ``oclshade.cli.main``."""
import json
import re
from datetime import datetime
from zoneinfo import ZoneInfo

import numpy as np
import pytest

from oclshade.cli import main
from oclshade.io import Raster, _georef_4326, write_raster
from oclshade.solar import sun_position, suns_at

SPA_EXAMPLE = ["--lat", "39.742476", "--lon", "-105.1786", "--altitude", "1830.14", "--pressure", "820",
               "--temperature", "11"]


def run(capsys, *argv):
    status = main(["sun", *argv])
    out, err = capsys.readouterr()
    return status, out, err


def test_text_output_spa_example(capsys):
    # Reda & Andreas (2008), table A5.1: zenith 50.11162, azimuth 194.34024 (with Delta T 67 s; ours
    # estimates 64.5 s for 2003, which moves the sun by 0.00003 degrees)
    status, out, err = run(capsys, *SPA_EXAMPLE, "--datetime", "2003-10-17T12:30:30-07:00",
                           "--datetime", "2003-10-17T19:30:30Z")
    assert status == 0 and err == ""
    header, *lines = out.splitlines()
    assert header.split() == ["datetime", "azimuth", "elevation"]
    rows = [line.split() for line in lines]
    assert [row[0] for row in rows] == ["2003-10-17T12:30:30-07:00", "2003-10-17T19:30:30+00:00"]
    for _, azimuth, elevation in rows:
        assert re.fullmatch(r"\d+\.\d{4}", azimuth) and re.fullmatch(r"\d+\.\d{4}", elevation)
        assert float(azimuth) == pytest.approx(194.34024, abs=1e-4)
        assert 90.0 - float(elevation) == pytest.approx(50.11162, abs=1e-4)


def test_json_and_no_refraction(capsys):
    times = ["--datetime", "2003-10-17T12:30:30-07:00"]
    status, out, _ = run(capsys, *SPA_EXAMPLE, *times, "--json")
    bent = json.loads(out)
    assert status == 0 and bent["latitude"] == 39.742476 and bent["refraction"] is True
    [position] = bent["positions"]
    assert position["datetime"] == "2003-10-17T12:30:30-07:00"
    assert position["azimuth"] == pytest.approx(194.34024, abs=1e-4)
    assert 90.0 - position["elevation"] == pytest.approx(50.11162, abs=1e-4)
    status, out, _ = run(capsys, *SPA_EXAMPLE, *times, "--json", "--no-refraction")
    straight = json.loads(out)["positions"][0]
    assert status == 0 and json.loads(out)["refraction"] is False
    assert 0.01 < position["elevation"] - straight["elevation"] < 0.03  # refraction at 40 degrees, 820 hPa


def test_tz_resolves_daylight_saving_time(capsys):
    status, out, _ = run(capsys, "--lat", "46.95", "--lon", "7.45", "--tz", "Europe/Zurich", "--json",
                         "--datetime", "2024-07-01T12:00", "--datetime", "2024-12-01T12:00")
    summer, winter = json.loads(out)["positions"]
    assert status == 0
    assert summer["datetime"] == "2024-07-01T12:00:00+02:00" and winter["datetime"] == "2024-12-01T12:00:00+01:00"
    status, out, _ = run(capsys, "--lat", "46.95", "--lon", "7.45", "--json",
                         "--datetime", "2024-07-01T10:00Z", "--datetime", "2024-12-01T11:00+00:00")
    assert json.loads(out)["positions"][0]["azimuth"] == summer["azimuth"]
    assert json.loads(out)["positions"][1]["elevation"] == winter["elevation"]


@pytest.mark.parametrize("argv, message", [
    (["--datetime", "2024-06-21T12:00"], "--datetime 2024-06-21T12:00 has no UTC offset: add one"),
    (["--datetime", "2024-06-21"], "--datetime '2024-06-21' has no time of day"),
    (["--datetime", "noon"], "--datetime 'noon' is not an ISO 8601 date and time"),
    (["--datetime", "2024-06-21T12:00Z", "--tz", "Europe/Zurich"], "has a UTC offset and --tz Europe/Zurich was given"),
    (["--datetime", "2024-06-21T12:00", "--tz", "Mars/Olympus"], "--tz 'Mars/Olympus' is not an IANA time zone"),
    (["--datetime", "2024-03-31T02:30", "--tz", "Europe/Zurich"], "does not exist in Europe/Zurich"),
    (["--datetime", "2024-10-27T02:30", "--tz", "Europe/Zurich"], "occurs twice in Europe/Zurich"),
    (["--datetime", "2024-06-21T12:00Z", "--pressure", "0"], "argument --pressure: pressure must be hPa above 0"),
])
def test_bad_arguments_one_line(capsys, argv, message):
    status, out, err = run(capsys, "--lat", "46.95", "--lon", "7.45", *argv)
    assert status == 2 and out == ""
    assert err.startswith("oclshade: error: ") and message in err and err.count("\n") == 1


@pytest.mark.parametrize("flag, value, name", [("--lat", "-90.5", "latitude"), ("--lon", "181", "longitude")])
def test_place_out_of_range(capsys, flag, value, name):
    argv = {"--lat": "0", "--lon": "0", flag: value}
    status, _, err = run(capsys, *[x for kv in argv.items() for x in kv], "--datetime", "2024-06-21T12:00Z")
    assert status == 2 and f"argument {flag}: {name} must be degrees in" in err


# --- oclshade shadow --datetime -------------------------------------------------------------

def _geographic_dem(path, lat=46.0, lon=7.0, n=64):
    """A small EPSG:4326 GeoTIFF whose centre is at (lat, lon): a cone, 3 arc-second cells."""
    step = 1.0 / 1200
    y, x = np.mgrid[:n, :n] - (n - 1) / 2
    heights = np.maximum(0.0, 800.0 - 40.0 * np.hypot(x, y))
    georef = _georef_4326(step, lon - n * step / 2, lat + n * step / 2, pixel_is_point=False)
    write_raster(path, heights.astype(np.float32), like=Raster(heights, 1.0, 1.0, None, True, georef))
    return path


def test_shadow_datetime_equals_the_sun_position_at_the_map_centre(tmp_path, capsys):
    dem = _geographic_dem(tmp_path / "geo.tif")
    when = "2024-03-20T07:30:00+01:00"
    assert main(["shadow", str(dem), str(tmp_path / "t.npy"), "--datetime", when]) == 0
    stderr = capsys.readouterr().err
    assert "latitude 46.00000, longitude 7.00000" in stderr
    pos = sun_position([datetime.fromisoformat(when)], 46.0, 7.0)
    az, el = float(pos.azimuth[0]), float(pos.elevation[0])
    assert f"azimuth {az:.4f}, elevation {el:.4f}" in stderr
    assert main(["shadow", str(dem), str(tmp_path / "s.npy"), f"--sun={az!r},{el!r}", "-q"]) == 0
    timed, direct = np.load(tmp_path / "t.npy"), np.load(tmp_path / "s.npy")
    assert np.array_equal(timed, direct) and (timed == 1).any()


def test_shadow_datetime_at_a_given_place_and_zone(tmp_path):
    dem = _geographic_dem(tmp_path / "geo.tif")
    args = ["shadow", str(dem), str(tmp_path / "t.npy"), "--tz", "Europe/Zurich", "--lat", "47", "--lon", "8",
            "--datetime", "2024-12-21T09:00", "--datetime", "2024-12-21T15:00", "-q"]
    assert main(args) == 0
    suns = suns_at([datetime(2024, 12, 21, h, tzinfo=ZoneInfo("Europe/Zurich")) for h in (9, 15)], 47.0, 8.0)
    sun_args = [f"--sun={s.azimuth!r},{s.elevation!r}" for s in suns]
    assert main(["shadow", str(dem), str(tmp_path / "s.npy"), *sun_args, "-q"]) == 0
    assert np.array_equal(np.load(tmp_path / "t.npy"), np.load(tmp_path / "s.npy"))


@pytest.mark.parametrize("extra, message", [
    (["--datetime", "2024-06-21T12:00Z", "-az", "30"], "give the sun one way"),
    (["--datetime", "2024-06-21T12:00Z", "--sun", "30,20"], "give the sun one way"),
    (["--lat", "3", "--lon", "4"], "go with --datetime"),
    (["--datetime", "2024-06-21T12:00Z", "--lat", "3"], "give both --lat and --lon"),
    (["--datetime", "2024-06-21T12:00"], "has no UTC offset"),
])
def test_shadow_datetime_usage_errors(tmp_path, capsys, extra, message):
    dem = _geographic_dem(tmp_path / "geo.tif")
    assert main(["shadow", str(dem), str(tmp_path / "o.npy"), *extra]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o.npy").exists()


def test_shadow_datetime_on_a_projected_map_needs_the_place(tmp_path, capsys):
    dem = tmp_path / "dem.npy"
    np.save(dem, np.zeros((8, 8)))
    args = ["shadow", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "--datetime", "2024-06-21T12:00Z"]
    assert main(args) == 2
    assert "give --lat and --lon" in capsys.readouterr().err
    assert main([*args, "--lat", "46", "--lon", "7", "-q"]) == 0
