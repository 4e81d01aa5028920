"""--suns FILE.csv (oclshade.cli.read_suns_csv): what Excel and hand-written files hold."""
from __future__ import annotations

import pytest

from oclshade.cli import UsageError, read_suns_csv
from oclshade.sun import Sun

SUNS = [Sun(37.0, 5.0), Sun(135.0, 20.0)]


def suns_from(tmp_path, data: bytes) -> list[Sun]:
    path = tmp_path / "suns.csv"
    path.write_bytes(data)
    return read_suns_csv(str(path))


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
