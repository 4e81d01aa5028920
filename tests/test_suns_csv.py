"""--suns FILE.csv (oclshade.cli.read_suns_csv): what Excel and hand-written files hold."""
from __future__ import annotations

from datetime import datetime, timedelta, timezone
from zoneinfo import ZoneInfo

import numpy as np
import pytest

from oclshade.cli import UsageError, main, read_suns_csv
from oclshade.solar import suns_at
from oclshade.sun import Sun

SUNS = [Sun(37.0, 5.0), Sun(135.0, 20.0)]


def read_from(tmp_path, data: bytes, zone: ZoneInfo | None = None) -> tuple[list[Sun], list[datetime]]:
    path = tmp_path / "suns.csv"
    path.write_bytes(data)
    return read_suns_csv(str(path), zone)


def suns_from(tmp_path, data: bytes) -> list[Sun]:
    suns, times = read_from(tmp_path, data)
    assert times == []
    return suns


@pytest.mark.parametrize("data", [
    b"\xef\xbb\xbfazimuth,elevation\r\n37,5\r\n135,20\r\n",      # Excel: UTF-8 BOM, CRLF
    b"\xef\xbb\xbf37,5\n135,20\n",                              # BOM without a header
    b"az,el\n37,5\n135,20",                                     # no final line end
    b"Azimuth,Elev\r\n37,5\r\n\r\n135,20\r\n",
    b"time,ALTITUDE,notes,AZ\n10:00,5,x,37\n11:00,20,,135\n",   # any columns, any order
    b"# sun positions\n37, 5\n\n135, 20\n",
    b"37,5\r135,20\r",                                          # old Mac line ends
])
def test_accepted_files(tmp_path, data):
    assert suns_from(tmp_path, data) == SUNS


@pytest.mark.parametrize("data, message", [
    (b"azimuth,elevation\n37,5\n135\n", "line 3: expected AZ,ALT, got '135'"),
    (b"\xef\xbb\xbf37,5\r\n135\r\n", "line 2: expected AZ,ALT, got '135'"),
    (b"time,az,alt\n10:00,37,5\n11:00,135\n", "line 3: expected AZ,ALT in columns 2 and 3, got '11:00,135'"),
    (b"azimuth,zenith\n37,85\n", "line 1: the header must name one azimuth column (azimuth or az) and one "
                                 "elevation column (elevation, elev, el, altitude or alt), got azimuth,zenith"),
    (b"az,alt,elevation\n37,5,5\n", "line 1: the header must name one azimuth column"),
    (b"37,5\n135,120\n", "line 2: elevation must be in [-90, 90] degrees, got 120"),
    (b"37,5\n135,x\n", "line 2: elevation must be a number, got 'x'"),
    (b"# nothing\n\n", "no sun positions in the file"),
    (b"\xff\xfea\x00z\x00", "cannot read"),                      # UTF-16 ('Unicode text' in Excel)
])
def test_refused_files_name_the_line(tmp_path, data, message):
    with pytest.raises(UsageError) as info:
        suns_from(tmp_path, data)
    assert str(info.value).startswith(f"--suns {tmp_path / 'suns.csv'}") and message in str(info.value)


# --- datetime rows -----------------------------------------------------------------------

ZURICH = ZoneInfo("Europe/Zurich")


@pytest.mark.parametrize("data, zone, expected", [
    (b"datetime\n2024-06-21T12:00+02:00\n2024-06-21T10:00Z\n", None,
     [datetime(2024, 6, 21, 10, tzinfo=timezone.utc)] * 2),
    (b"\xef\xbb\xbfplace,DateTime,notes\r\nBern,2024-12-21T09:00,x\r\n\r\nBern,2024-07-01T09:00,\r\n", ZURICH,
     [datetime(2024, 12, 21, 8, tzinfo=timezone.utc), datetime(2024, 7, 1, 7, tzinfo=timezone.utc)]),
])
def test_datetime_rows(tmp_path, data, zone, expected):
    suns, times = read_from(tmp_path, data, zone)
    assert suns == [] and times == expected


@pytest.mark.parametrize("data, zone, message", [
    (b"datetime,az,alt\n2024-06-21T12:00Z,37,5\n", None,
     "line 1: the header must name one datetime column and no azimuth or elevation column (the sun one way), "
     "got datetime,az,alt"),
    (b"datetime,datetime\n2024-06-21T12:00Z,2024-06-21T13:00Z\n", None, "line 1: the header must name one datetime"),
    (b"id,datetime\n1,2024-06-21T12:00Z\n2\n", None, "line 3: expected a datetime in column 2, got '2'"),
    (b"datetime\n2024-06-21T12:00Z\nnoon\n", None,
     "line 3: datetime 'noon' is not an ISO 8601 date and time (e.g. 2024-06-21T12:00+02:00)"),
    (b"datetime\n2024-06-21T12:00\n", None, "line 2: datetime 2024-06-21T12:00 has no UTC offset"),
    (b"datetime\n2024-06-21T12:00Z\n", ZURICH, "line 2: datetime 2024-06-21T12:00Z has a UTC offset and --tz"),
    (b"datetime\n2024-03-31T02:30\n", ZURICH, "line 2: datetime 2024-03-31T02:30 does not exist in Europe/Zurich"),
    (b"datetime\n# none\n", None, "no sun positions in the file"),
])
def test_refused_datetime_rows_name_the_line(tmp_path, data, zone, message):
    with pytest.raises(UsageError) as info:
        read_from(tmp_path, data, zone)
    assert str(info.value).startswith(f"--suns {tmp_path / 'suns.csv'}") and message in str(info.value)


def test_shadow_with_datetime_rows_equals_the_same_suns_by_az_el(tmp_path):
    """--suns with datetime rows at --lat/--lon gives the bands of --suns with the SPA positions."""
    dem = tmp_path / "dem.npy"
    rng = np.random.default_rng(3)
    np.save(dem, rng.uniform(0, 300, (24, 30)))
    start = datetime(2024, 6, 21, 7, tzinfo=ZURICH)
    times = [start + timedelta(hours=k) for k in range(3)]
    (tmp_path / "t.csv").write_text("datetime\n" + "\n".join(t.strftime("%Y-%m-%dT%H:%M") for t in times) + "\n")
    suns = suns_at(times, 46.95, 7.45)
    (tmp_path / "s.csv").write_text("az,el\n" + "\n".join(f"{s.azimuth!r},{s.elevation!r}" for s in suns) + "\n")
    common = ["--cellsize", "30", "-q"]
    assert main(["shadow", str(dem), str(tmp_path / "a.npy"), "--suns", str(tmp_path / "t.csv"),
                 "--tz", "Europe/Zurich", "--lat", "46.95", "--lon", "7.45", *common]) == 0
    assert main(["shadow", str(dem), str(tmp_path / "b.npy"), "--suns", str(tmp_path / "s.csv"), *common]) == 0
    a, b = np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy")
    assert a.shape == (3, 24, 30) and np.array_equal(a, b) and a.any()


@pytest.mark.parametrize("extra, message", [
    (["--sun", "10,20"], "give the sun one way"),
    ([], "has no CRS to take the place from; give --lat and --lon"),
    (["--lat", "46"], "give both --lat and --lon"),
])
def test_shadow_datetime_rows_usage_errors(tmp_path, capsys, extra, message):
    dem = tmp_path / "dem.npy"
    np.save(dem, np.zeros((8, 8)))
    (tmp_path / "t.csv").write_text("datetime\n2024-06-21T12:00Z\n")
    status = main(["shadow", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "-q",
                   "--suns", str(tmp_path / "t.csv"), *extra])
    assert status == 2 and message in capsys.readouterr().err


def test_tz_without_any_datetime_is_refused(tmp_path, capsys):
    dem = tmp_path / "dem.npy"
    np.save(dem, np.zeros((8, 8)))
    (tmp_path / "s.csv").write_text("az,el\n37,5\n")
    status = main(["shadow", str(dem), str(tmp_path / "o.npy"), "--cellsize", "30", "-q",
                   "--suns", str(tmp_path / "s.csv"), "--tz", "UTC"])
    assert status == 2 and "--tz, --lat and --lon go with --datetime (or datetime rows in --suns)" in \
        capsys.readouterr().err
