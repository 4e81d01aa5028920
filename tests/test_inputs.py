"""Input that used to give silent wrong answers (issue 16): each is now right or refused in one line."""
from __future__ import annotations

import math
import os
import re
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import tifffile
from PIL import Image

from oclshade import gdal_reader
from oclshade import Heightmap, ShadowCaster, Sun
from oclshade import io as rio
from oclshade.cli import main
from oclshade.frames import AOSettings
from oclshade.heightmap import InputWarning
from oclshade.io import RasterIOError, metres_per_degree, read_dem, write_raster
from oclshade.synthetic import canyon_crater

ROWS, COLS = 40, 56

ESRI_WGS84 = ('GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],'
              'PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]')
OGC_4326 = ('GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],'
            'AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0,AUTHORITY["EPSG","8901"]],'
            'UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4326"]]')
UTM_10N = ('PROJCS["WGS 84 / UTM zone 10N",' + OGC_4326 + ',PROJECTION["Transverse_Mercator"],'
           'PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",-123],PARAMETER["scale_factor",0.9996],'
           'PARAMETER["false_easting",500000],PARAMETER["false_northing",0],UNIT["metre",1,AUTHORITY["EPSG","9001"]],'
           'AXIS["Easting",EAST],AXIS["Northing",NORTH],AUTHORITY["EPSG","32610"]]')
FTUS_WKT2 = ('PROJCRS["NAD83 / California zone 3 (ftUS)",BASEGEOGCRS["NAD83",DATUM["North American Datum 1983",'
             'ELLIPSOID["GRS 1980",6378137,298.257222101,LENGTHUNIT["metre",1]]],PRIMEM["Greenwich",0,'
             'ANGLEUNIT["degree",0.0174532925199433]],ID["EPSG",4269]],CONVERSION["SPCS83 California zone 3 '
             '(US Survey feet)",METHOD["Lambert Conic Conformal (2SP)",ID["EPSG",9802]],PARAMETER["Easting at '
             'false origin",6561666.667,LENGTHUNIT["US survey foot",0.304800609601219],ID["EPSG",8826]]],'
             'CS[Cartesian,2],AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219]],'
             'AXIS["northing (Y)",north,ORDER[2],LENGTHUNIT["US survey foot",0.304800609601219]],ID["EPSG",2227]]')
ESRI_FOOT = ('PROJCS["NAD_1983_StatePlane_California_III_FIPS_0403_Feet",GEOGCS["GCS_North_American_1983",'
             'DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],'
             'UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],'
             'PARAMETER["False_Easting",6561666.666666666],UNIT["Foot",0.3048]]')


@pytest.fixture(scope="module")
def dem() -> np.ndarray:
    return canyon_crater(ROWS, COLS, seed=7, relief=800.0).astype(np.float64)


def one_line(err: str, kind: str = "error") -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"oclshade: {kind}: "), err
    return lines[0]


def write_asc(path: Path, heights: np.ndarray, cellsize: float, x0: float, y0: float,
              prj: str | None = None, nodata: float | None = None) -> Path:
    rows, cols = heights.shape
    head = f"ncols {cols}\nnrows {rows}\nxllcorner {x0!r}\nyllcorner {y0!r}\ncellsize {cellsize!r}\n"
    if nodata is not None:
        head += f"NODATA_value {nodata!r}\n"
    body = "\n".join(" ".join(repr(float(v)) for v in row) for row in heights)
    path.write_text(head + body + "\n")
    if prj is not None:
        path.with_suffix(".prj").write_text(prj)
    return path


def geographic_tif(path: Path, heights: np.ndarray) -> Path:
    georef = rio._georef_4326(1 / 1200, -105.5, 40.2, pixel_is_point=False)
    tifffile.imwrite(path, heights.astype(np.float32),
                     extratags=[(c, rio.GEOTIFF_TAGS[c], 0 if c == 34737 else len(v), v, True)
                                for c, v in georef.items()])
    return path


SUN = ["-az", "315", "-alt", "20"]   # the sun of api_mask, for CLI runs compared with it


def api_mask(heights: np.ndarray, cellsize: float | tuple[float, float]) -> np.ndarray:
    return ShadowCaster(Heightmap.from_array(heights, cellsize)).cast(Sun(315.0, 20.0)).mask


def tags(path: Path) -> dict:
    with tifffile.TiffFile(path) as tif:
        return {t.code: t.value for t in tif.pages[0].tags.values()}


# ----------------------------------------------------------------------------- 1. -s on geographic input

@pytest.mark.parametrize("command", ["shadow", "render"])
def test_scale_on_geographic_input_is_refused(tmp_path, dem, capsys, command):
    geo = geographic_tif(tmp_path / "geo.tif", dem)
    out = tmp_path / ("out.tif" if command == "shadow" else "out.png")
    assert main([command, str(geo), str(out), "-s", "111120", "-q"]) == 2
    line = one_line(capsys.readouterr().err)
    assert "-s 111120" in line and "geographic CRS" in line and "drop -s" in line
    assert not out.exists()


def test_scale_on_srtm_hgt_is_refused(tmp_path, capsys):
    hgt = tmp_path / "N10E010.hgt"
    hgt.write_bytes(np.full((1201, 1201), 100, ">i2").tobytes())
    assert main(["shadow", str(hgt), str(tmp_path / "o.tif"), "-s", "111120"]) == 2
    assert "geographic CRS" in one_line(capsys.readouterr().err)


def test_scale_one_and_explicit_cellsize_still_work_on_geographic_input(tmp_path, dem):
    geo = geographic_tif(tmp_path / "geo.tif", dem)
    assert main(["shadow", str(geo), str(tmp_path / "a.npy"), "-q", *SUN]) == 0
    r = read_dem(geo)
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), api_mask(dem.astype(np.float32), (r.dx, r.dy)))
    # --cellsize replaces the file's cell size: -s then scales the given one
    assert main(["shadow", str(geo), str(tmp_path / "b.npy"), "--cellsize", "1", "-s", "30", "-q", *SUN]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "b.npy"), api_mask(dem.astype(np.float32), 30.0))


# ----------------------------------------------------------------------------- 2. ESRI ASCII grids and .prj

def test_asc_with_esri_geographic_prj(tmp_path, dem):
    path = write_asc(tmp_path / "g.asc", dem, 1 / 1200, -105.55, 40.09, prj=ESRI_WGS84)
    r = read_dem(path)
    assert r.geographic and r.crs_wkt == ESRI_WGS84
    mx, my = metres_per_degree(40.09 + ROWS / 2400)
    assert (r.dx, r.dy) == pytest.approx((mx / 1200, my / 1200))
    assert 34735 not in r.georef            # no EPSG code in the WKT: no code is made up
    assert r.georef[33922][3:5] == pytest.approx((-105.55, 40.09 + ROWS / 1200))


def test_asc_with_epsg_geographic_prj_gets_its_geokey(tmp_path, dem):
    r = read_dem(write_asc(tmp_path / "g.asc", dem, 1 / 1200, -105.55, 40.09, prj=OGC_4326))
    keys = r.georef[34735]
    assert r.geographic and keys[4:8] == (1024, 0, 1, 2) and keys[12:16] == (2048, 0, 1, 4326)


def test_asc_with_projected_prj_keeps_its_crs_in_the_output(tmp_path, dem, capsys):
    path = write_asc(tmp_path / "utm.asc", dem, 30.0, 500000.0, 4000000.0, prj=UTM_10N)
    r = read_dem(path)
    assert not r.geographic and (r.dx, r.dy) == (30.0, 30.0) and r.crs_wkt == UTM_10N
    assert r.georef[34735] == (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32610)
    assert main(["shadow", str(path), str(tmp_path / "out.tif"), "-q"]) == 0
    assert capsys.readouterr().err == ""
    out = tags(tmp_path / "out.tif")
    assert tuple(out[34735])[-4:] == (3072, 0, 1, 32610)
    assert tuple(out[33922])[3:5] == (500000.0, 4000000.0 + 30 * ROWS)


@pytest.mark.parametrize("wkt, factor", [(FTUS_WKT2, 0.304800609601219), (ESRI_FOOT, 0.3048)])
def test_asc_in_feet_gets_metre_cells(tmp_path, dem, wkt, factor):
    with pytest.warns(InputWarning, match=f"converted to metres.*add -z {factor:.10g}$"):
        r = read_dem(write_asc(tmp_path / "ft.asc", dem, 10.0, 6000000.0, 2000000.0, prj=wkt))
    assert not r.geographic and (r.dx, r.dy) == pytest.approx((10 * factor, 10 * factor))
    assert r.georef[33550][:2] == (10.0, 10.0)            # the transform stays in the CRS's feet
    assert (34735 in r.georef) == (wkt == FTUS_WKT2)
    assert main(["shadow", str(tmp_path / "ft.asc"), str(tmp_path / "m.npy"), "-q", *SUN]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "m.npy"), api_mask(dem, 10 * factor))


def test_asc_compound_crs_uses_its_horizontal_part(tmp_path, dem):
    wkt = f'COMPD_CS["UTM + height",{UTM_10N},VERT_CS["EGM96 height",VERT_DATUM["EGM96",2005],UNIT["metre",1]]]'
    r = read_dem(write_asc(tmp_path / "c.asc", dem, 30.0, 500000.0, 4000000.0, prj=wkt))
    assert not r.geographic and r.georef[34735][-1] == 32610


@pytest.mark.parametrize("prj, message", [
    ("Projection UTM\nZone 10\nUnits METERS\n", r"bad.prj: not WKT"),
    ('GEOCCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],UNIT["metre",1]]',
     r"bad.prj: unsupported CRS GEOCCS"),
    ('PROJCS["x",GEOGCS["y",UNIT["degree",0.0174532925199433]],PROJECTION["Mercator"]', r"bad.prj: .*not closed"),
    ('GEOGCS["grads",UNIT["grad",0.015707963267949]]', r"bad.prj: angular unit 'grad'"),
])
def test_bad_prj_is_refused_naming_it(tmp_path, dem, prj, message):
    path = write_asc(tmp_path / "bad.asc", dem, 30.0, 500000.0, 4000000.0, prj=prj)
    with pytest.raises(RasterIOError, match=message) as info:
        read_dem(path)
    assert "\n" not in str(info.value)


def test_asc_without_prj_that_could_be_degrees_is_refused(tmp_path, dem, capsys):
    """The bug: a 0.5 m local grid near the origin came out as degrees (0 % shadow, latitude 120)."""
    path = write_asc(tmp_path / "local.asc", dem, 0.5, 0.0, 0.0)
    with pytest.raises(RasterIOError, match=r"local.asc: no local.prj .* could be degrees or metres"):
        read_dem(path)
    assert main(["shadow", str(path), str(tmp_path / "out.tif")]) == 1
    line = one_line(capsys.readouterr().err)
    assert "local.prj" in line and "--cellsize" in line

    assert main(["shadow", str(path), str(tmp_path / "out.tif"), "--cellsize", "0.5", "-q", *SUN]) == 0
    assert capsys.readouterr().err == ""
    out = tags(tmp_path / "out.tif")
    assert 34735 not in out                              # no EPSG:4326 stamped in
    assert tuple(out[33550])[:2] == (0.5, 0.5) and tuple(out[33922])[3:5] == (0.0, 0.5 * ROWS)
    with tifffile.TiffFile(tmp_path / "out.tif") as tif:
        mask = tif.pages[0].asarray()
    np.testing.assert_array_equal(mask, api_mask(dem, 0.5))
    assert (mask == 1).mean() > 0.1                       # shadows, not a flattened map


def test_asc_without_prj_in_metres_warns_and_keeps_no_crs(tmp_path, dem):
    with pytest.warns(InputWarning, match=r"no m.prj next to the file: cell size 10 x 10 taken as metres"):
        r = read_dem(write_asc(tmp_path / "m.asc", dem, 10.0, 0.0, 0.0))
    assert not r.geographic and (r.dx, r.dy) == (10.0, 10.0) and r.crs_wkt is None and 34735 not in r.georef
    # a small cell size whose extent cannot be degrees is metres too
    with pytest.warns(InputWarning, match="taken as metres"):
        r = read_dem(write_asc(tmp_path / "wide.asc", np.zeros((4, 500)), 0.5, 0.0, 0.0))
    assert (r.dx, r.dy, r.geographic) == (0.5, 0.5, False)


# ----------------------------------------------------------------------------- 3. extreme values

@pytest.mark.parametrize("value", [1e30, float(np.finfo(np.float32).max)])
def test_one_extreme_cell_is_refused_with_the_numbers(dem, value):
    h = dem.copy()
    h[5, 7] = value
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)   # float32 max is also a known sentinel
        with pytest.raises(ValueError, match=r"round by up to .* more than the tolerance 0.003") as info:
            Heightmap.from_array(h, 30.0)
    msg = str(info.value)
    assert f"1 cell(s) equal {value:.9g}" in msg and "row 5, col 7" in msg and "nodata" in msg
    Heightmap.from_array(h, 30.0, nodata=value)         # declared: fine


@pytest.mark.parametrize("value", [1e300, -1e300])
def test_heights_beyond_float32_are_refused(dem, value):
    h = dem.copy()
    h[0, 0] = value
    h[1, 1] = -value
    with pytest.raises(ValueError, match=r"exceed the float32 range .* 1 cell\(s\) equal"):
        Heightmap.from_array(h, 30.0)


def test_float32_tolerance_is_max_of_1mm_and_1e4_cells():
    ramp = np.linspace(0.0, 32000.0, 12).reshape(3, 4)       # half-range 16000 m: 0.49 mm rounding
    Heightmap.from_array(ramp, 1.0)
    with pytest.raises(ValueError, match="tolerance 0.001"):
        Heightmap.from_array(ramp * 3, 1.0)                   # half-range 48000 m: 1.95 mm
    Heightmap.from_array(ramp * 3, 30.0)                      # tolerance 3 mm
    with pytest.raises(ValueError, match="tolerance 0.003"):
        Heightmap.from_array(ramp * 6, 30.0)                  # 3.9 mm


@pytest.mark.parametrize("sentinel", [-32768.0, -9999.0, -99999.0, -3.4028235e38])
def test_undeclared_sentinels_warn(dem, sentinel):
    h = dem.copy()
    h[2, 3] = sentinel
    with pytest.warns(InputWarning, match=re.escape(f"1 cell(s) equal {sentinel:.8g}, a common nodata value")):
        try:
            Heightmap.from_array(h, 30.0)
        except ValueError:
            assert sentinel < -1e30                           # float32 max is refused as well
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        hm = Heightmap.from_array(h, 30.0, nodata=sentinel)
    assert np.isnan(hm.heights[2, 3])


def test_cli_warns_of_sentinels_and_nodata_declares_them(tmp_path, dem, capsys):
    h = dem.astype(np.float32)
    h[2, 3] = -32768
    np.save(tmp_path / "s.npy", h)
    assert main(["shadow", str(tmp_path / "s.npy"), str(tmp_path / "a.npy"), "--cellsize", "30", "-q"]) == 0
    line = one_line(capsys.readouterr().err, "warning")
    assert "-32768" in line and "--nodata -32768" in line
    assert main(["shadow", str(tmp_path / "s.npy"), str(tmp_path / "b.npy"), "--cellsize", "30", "-q",
                 "--nodata", "-32768"]) == 0
    assert capsys.readouterr().err == ""
    assert np.load(tmp_path / "b.npy")[2, 3] == 255


def test_cli_refuses_an_extreme_value_in_one_line_and_nodata_fixes_it(tmp_path, dem, capsys):
    h = dem.astype(np.float32)
    h[5, 7] = 1e30
    np.save(tmp_path / "x.npy", h)
    assert main(["shadow", str(tmp_path / "x.npy"), str(tmp_path / "a.npy"), "--cellsize", "30"]) == 1
    line = one_line(capsys.readouterr().err)
    assert "1.00000002e+30" in line and "row 5, col 7" in line and "--nodata" in line
    assert not (tmp_path / "a.npy").exists()
    assert main(["render", str(tmp_path / "x.npy"), str(tmp_path / "a.png"), "--cellsize", "30"]) == 1
    assert "row 5, col 7" in one_line(capsys.readouterr().err)
    np.save(tmp_path / "huge.npy", np.where(h == h[5, 7], 1e300, h.astype(np.float64)))
    assert main(["shadow", str(tmp_path / "huge.npy"), str(tmp_path / "a.npy"), "--cellsize", "30"]) == 1
    assert "exceed the float32 range" in one_line(capsys.readouterr().err)
    assert main(["shadow", str(tmp_path / "x.npy"), str(tmp_path / "a.npy"), "--cellsize", "30", "-q",
                 "--nodata", "1.00000002e+30", *SUN]) == 0
    expected = api_mask(np.where(h == h[5, 7], np.nan, h), 30.0)
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), expected)


def test_nodata_overrides_the_files(tmp_path, dem):
    raw = np.round(dem).astype(np.int16)
    raw[0, 0], raw[1, 1] = -9999, 0
    tifffile.imwrite(tmp_path / "d.tif", raw, extratags=[(42113, 2, 0, "-9999", True)])
    assert np.isnan(read_dem(tmp_path / "d.tif").heights[0, 0])
    r = read_dem(tmp_path / "d.tif", nodata=0)
    assert r.nodata == 0 and np.isnan(r.heights[1, 1]) and r.heights[0, 0] == -9999
    with pytest.raises(TypeError, match="nodata must be a number"):
        read_dem(tmp_path / "d.tif", nodata="x")


# ----------------------------------------------------------------------------- 4. Python API

def test_from_array_copies_the_callers_array(dem):
    h = dem.copy()
    hm = Heightmap.from_array(h, 30.0)
    before = ShadowCaster(hm).cast(Sun(315.0, 20.0)).mask
    h[:] = 0.0
    assert not np.shares_memory(hm.heights, h) and np.array_equal(hm.heights, dem)
    np.testing.assert_array_equal(ShadowCaster(hm).cast(Sun(315.0, 20.0)).mask, before)


def test_masked_array_cells_are_nodata(dem):
    masked = np.ma.masked_array(dem, mask=np.zeros(dem.shape, bool))
    masked[4, 5] = np.ma.masked
    hm = Heightmap.from_array(masked, 30.0)
    assert np.isnan(hm.heights[4, 5]) and np.isnan(hm.heights).sum() == 1
    ints = np.ma.masked_equal(np.round(dem).astype(np.int32), int(round(dem[0, 0])))
    assert np.isnan(Heightmap.from_array(ints, 30.0).heights[0, 0])


@pytest.mark.parametrize("nodata", ["x", [1], True])
def test_non_numeric_nodata_is_a_type_error(dem, nodata):
    with pytest.raises(TypeError, match="nodata must be a number"):
        Heightmap.from_array(dem, 30.0, nodata=nodata)


def test_z_factor_overflow_is_refused(dem):
    with pytest.raises(ValueError, match=r"z_factor=1e\+308 makes heights overflow"):
        Heightmap.from_array(dem, 30.0, z_factor=1e308)


@pytest.mark.parametrize("kwargs, message", [({"radius": -1.0}, "radius must be finite and >= 0"),
                                              ({"radius": math.inf}, "radius must be finite"),
                                              ({"radius": 10.0, "m": 2}, "m must be 0"),
                                              ({"radius": 10.0, "delta": math.nan}, "delta must be finite")])
def test_ao_settings_are_checked_as_ssao_checks_them(kwargs, message):
    with pytest.raises(ValueError, match=message):
        AOSettings(**kwargs)
    AOSettings(radius=0.0)                                    # AO off, as in SSAO.run


# ----------------------------------------------------------------------------- 5. bands

@pytest.fixture()
def three_bands(tmp_path: Path, dem: np.ndarray) -> Path:
    path = tmp_path / "rgb.tif"
    bands = np.stack([dem, dem[::-1], dem[:, ::-1]]).astype(np.float32)
    tifffile.imwrite(path, bands, photometric="minisblack", planarconfig="separate")
    return path


def test_band_selection_in_the_api(three_bands, dem):
    with pytest.warns(InputWarning, match=r"rgb.tif: the file has 3 bands; reading band 1"):
        r = read_dem(three_bands)
    np.testing.assert_allclose(r.heights, dem.astype(np.float32))
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        np.testing.assert_allclose(read_dem(three_bands, band=2).heights, dem[::-1].astype(np.float32))
        read_dem(three_bands, band=1)
    with pytest.raises(RasterIOError, match=r"rgb.tif: band 4 requested but the file has 3 band\(s\)"):
        read_dem(three_bands, band=4)
    with pytest.raises(ValueError, match="band must be a 1-based band number"):
        read_dem(three_bands, band=0)


def test_contiguous_rgb_tif_bands(tmp_path, dem):
    rgb = np.stack([dem, 2 * dem, 3 * dem], axis=-1).astype(np.float32)
    tifffile.imwrite(tmp_path / "c.tif", rgb, photometric="rgb")
    np.testing.assert_allclose(read_dem(tmp_path / "c.tif", band=3).heights, rgb[..., 2])


def test_band_selection_in_the_cli(tmp_path, three_bands, dem, capsys):
    assert main(["shadow", str(three_bands), str(tmp_path / "a.npy"), "--cellsize", "30", "-q"]) == 0
    assert "the file has 3 bands; reading band 1" in one_line(capsys.readouterr().err, "warning")
    assert main(["shadow", str(three_bands), str(tmp_path / "b.npy"), "--cellsize", "30", "-q", "-b", "2", *SUN]) == 0
    assert capsys.readouterr().err == ""
    np.testing.assert_array_equal(np.load(tmp_path / "b.npy"), api_mask(dem[::-1].astype(np.float32), 30.0))
    for command, out in (("shadow", "c.npy"), ("render", "c.png")):
        assert main([command, str(three_bands), str(tmp_path / out), "--cellsize", "30", "-b", "4"]) == 1
        assert "band 4 requested but the file has 3 band(s)" in one_line(capsys.readouterr().err)
    assert main(["shadow", str(three_bands), str(tmp_path / "d.npy"), "-b", "0"]) == 2
    assert "1-based" in one_line(capsys.readouterr().err)


def test_exr_bands_are_its_channels_in_file_order(tmp_path, dem):
    write_raster(tmp_path / "two.exr", [dem, 2 * dem], band_names=["A", "Z"])
    with pytest.warns(InputWarning, match=r"2 bands; reading band 2 \(Z\)"):
        np.testing.assert_allclose(read_dem(tmp_path / "two.exr").heights, 2 * dem.astype(np.float32))
    np.testing.assert_allclose(read_dem(tmp_path / "two.exr", band=1).heights, dem.astype(np.float32))


@pytest.mark.parametrize("name", ["one.npy", "one.png", "N10E010.hgt"])
def test_single_band_files_refuse_band_2(tmp_path, name):
    path = tmp_path / name
    if name.endswith(".npy"):
        np.save(path, np.zeros((3, 4)))
    elif name.endswith(".png"):
        Image.fromarray(np.zeros((3, 4), np.uint8)).save(path)
    else:
        path.write_bytes(np.zeros((1201, 1201), ">i2").tobytes())
    with pytest.raises(RasterIOError, match=rf"{name}: band 2 requested but the file has 1 band\(s\)"):
        read_dem(path, band=2)


# ----------------------------------------------------------------------------- 6. input paths

def _corrupt(tmp_path: Path, name: str) -> Path:
    """A damaged file of each format: garbage, truncated or with a broken compressed stream."""
    path = tmp_path / name
    h = np.random.default_rng(1).integers(0, 3000, (1201, 1201)).astype(np.int16)
    kind, ext = name.split(".")
    if ext == "zip":
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("N10E010.hgt", h.astype(">i2").tobytes())
    elif ext == "hgt":
        path.write_bytes(h.astype(">i2").tobytes())
    elif ext == "tif":
        tifffile.imwrite(path, h, compression="zlib")
    elif ext == "exr":
        write_raster(path, h[:64, :64].astype(np.float32))
    elif ext == "png":
        Image.fromarray(h[:64, :64].astype(np.uint16)).save(path)
    elif ext == "asc":
        write_asc(path, h[:4, :4].astype(float), 30.0, 500000.0, 4000000.0)
    data = bytearray(path.read_bytes())
    if kind == "junk":
        data = bytearray(b"this is not a raster at all")
    elif kind == "trunc":
        data = data[:len(data) // 2]
    else:  # flipped bytes in the middle (compressed data)
        mid = len(data) // 2
        data[mid:mid + 64] = bytes(b ^ 0x55 for b in data[mid:mid + 64])
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("name", ["junk.zip", "trunc.zip", "flip.zip", "trunc.hgt", "junk.tif", "trunc.tif",
                                  "flip.tif", "junk.exr", "trunc.exr", "junk.png", "trunc.png", "junk.asc",
                                  "trunc.asc"])
def test_corrupt_files_are_named(tmp_path, name, capsys):
    path = _corrupt(tmp_path, name)
    if name.endswith(".hgt") or name.endswith(".zip"):
        path = path.rename(path.with_name(f"N10E010{path.suffix}"))
    with pytest.raises(RasterIOError) as info:
        read_dem(path, cellsize=30.0)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)
    assert main(["shadow", str(path), str(tmp_path / "o.npy"), "--cellsize", "30"]) == 1
    assert f"error: {path}: " in capsys.readouterr().err


def test_directory_fifo_and_broken_link_are_not_no_such_file(tmp_path, capsys):
    (tmp_path / "tiles").mkdir()
    fifo = tmp_path / "pipe.tif"
    os.mkfifo(fifo)
    (tmp_path / "link.tif").symlink_to(tmp_path / "gone.tif")
    for path, message in ((tmp_path / "tiles", "is a directory"), (fifo, "is not a regular file"),
                          (tmp_path / "link.tif", "is a broken symbolic link"),
                          (tmp_path / "gone.tif", "no such file")):
        with pytest.raises(RasterIOError, match=f"{path.name}: {message}"):
            read_dem(path)
        assert main(["shadow", str(path), str(tmp_path / "o.npy")]) == 1
        assert message in one_line(capsys.readouterr().err)


@pytest.mark.parametrize("url", ["https://example.com/dem.tif", "http://example.com/N10E010.hgt",
                                 "s3://bucket/dem.tif", "/vsicurl/https://example.com/dem.tif"])
def test_urls_are_not_mangled_into_paths(tmp_path, url, capsys, monkeypatch):
    monkeypatch.setattr(gdal_reader, "available", lambda: False)  # what a user without rasterio sees
    with pytest.raises(RasterIOError, match="optional GDAL reader") as info:
        read_dem(url)
    assert str(info.value).startswith(f"{url}: ")
    assert main(["shadow", url, str(tmp_path / "o.tif")]) == 1
    assert f"error: {url}: URLs and GDAL virtual paths need" in one_line(capsys.readouterr().err)
