"""Output side: streaming writers (constant memory), GeoTIFF layout and creation options, COG,
georeferenced previews and sidecars, faults before work, signals, symlinks and permissions."""
from __future__ import annotations

import json
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile
from PIL import Image

from oclshade import cli, geotiff
from oclshade import io as rio
from oclshade.cli import main
from oclshade.io import Raster, RasterIOError, RasterWriter, decimated, geotransform, read_dem, write_raster
from oclshade.preview import Preview, write_preview
from oclshade.synthetic import canyon_crater

REPO = Path(__file__).resolve().parents[1]
UTM = {33550: (30.0, 30.0, 0.0), 33922: (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0),
       34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}
GDALINFO = shutil.which("gdalinfo")
needs_gdal = pytest.mark.skipif(GDALINFO is None, reason="gdalinfo (apt gdal-bin) not installed")
WKT_NO_EPSG = ('PROJCS["local_tm",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,'
               '298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
               'PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],'
               'PARAMETER["Central_Meridian",7.25],PARAMETER["Scale_Factor",1.0],'
               'PARAMETER["Latitude_Of_Origin",0.0],UNIT["Meter",1.0]]')


def gdalinfo(path: Path, *more: str) -> dict:
    run = subprocess.run([GDALINFO, "-json", *more, str(path)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.rglob("*") if ".tmp-" in p.name)


def one_error_line(err: str) -> str:
    lines = [line for line in err.strip().splitlines() if not line.startswith("[")]   # progress bars
    assert len(lines) == 1 and lines[0].startswith("oclshade: error: "), err
    return lines[0]


@pytest.fixture(scope="module")
def dem() -> np.ndarray:
    return canyon_crater(40, 56, seed=7, relief=800.0)


@pytest.fixture()
def npy(tmp_path: Path, dem: np.ndarray) -> Path:
    np.save(tmp_path / "dem.npy", dem)
    return tmp_path / "dem.npy"


@pytest.fixture()
def utm_tif(tmp_path: Path, dem: np.ndarray) -> Path:
    path = tmp_path / "utm.tif"
    write_raster(path, dem.astype(np.float32), like=Raster(dem, 30.0, 30.0, georef=UTM))
    return path


def tags(path: Path, page: int = 0) -> dict:
    with tifffile.TiffFile(path) as tif:
        return {t.code: t.value for t in tif.pages[page].tags.values()}


# ----------------------------------------------------------------------------- GeoTIFF layout and options

@pytest.mark.parametrize("dtype, predictor", [(np.float32, 3), (np.uint8, 2), (np.int16, 2), (np.float64, 3)])
def test_geotiff_default_is_tiled_deflate_with_a_predictor(tmp_path, dtype, predictor):
    rng = np.random.default_rng(1)
    bands = (rng.normal(size=(3, 300, 520)) * 50).astype(dtype)
    write_raster(tmp_path / "o.tif", bands, band_names=["a", "b", "c"])
    t = tags(tmp_path / "o.tif")
    assert (t[322], t[323], t[259], t[317], t[284]) == (256, 256, 8, predictor, 2)   # tiles, DEFLATE, planar
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "o.tif"), bands)


@pytest.mark.parametrize("options, check", [
    ({"COMPRESS": "LZW"}, {259: 5, 317: 3}),
    ({"compress": "zstd", "ZSTD_LEVEL": "15"}, {259: 50000}),
    ({"COMPRESS": "NONE"}, {259: 1}),
    ({"PREDICTOR": "1", "ZLEVEL": "9"}, {259: 8}),
    ({"BLOCKXSIZE": "128", "BLOCKYSIZE": "64"}, {322: 128, 323: 64}),
    ({"TILED": "NO"}, {278: 4}),                      # GDAL's default strip: at most 8 KiB
    ({"TILED": "NO", "BLOCKYSIZE": "7"}, {278: 7}),
    ({"BIGTIFF": "YES"}, {}),
])
def test_creation_options_round_trip(tmp_path, options, check):
    data = np.random.default_rng(2).normal(size=(2, 70, 512)).astype(np.float32)
    write_raster(tmp_path / "o.tif", data, options=options)
    t = tags(tmp_path / "o.tif")
    assert {k: t.get(k) for k in check} == check
    assert (317 in t) == (options.get("PREDICTOR", "3") != "1" and options.get("COMPRESS") != "NONE")
    with tifffile.TiffFile(tmp_path / "o.tif") as tif:
        assert tif.is_bigtiff == (options.get("BIGTIFF") == "YES")
        np.testing.assert_array_equal(tif.asarray(), data)


@pytest.mark.parametrize("options, cog, message", [
    ({"QUALITY": "75"}, False, "unknown creation option QUALITY; known: COMPRESS, PREDICTOR"),
    ({"COMPRESS": "JPEG"}, False, "COMPRESS=JPEG: expected NONE|LZW|DEFLATE|ZSTD"),
    ({"PREDICTOR": "2"}, False, "PREDICTOR=2 does not suit float32 bands: use 3"),
    ({"COMPRESS": "NONE", "PREDICTOR": "3"}, False, "PREDICTOR=3 needs compression"),
    ({"COMPRESS": "LZW", "ZLEVEL": "9"}, False, "ZLEVEL applies to COMPRESS=DEFLATE"),
    ({"ZLEVEL": "0"}, False, "ZLEVEL=0: expected an integer 1..12"),
    ({"BLOCKXSIZE": "100"}, False, "BLOCKXSIZE=100, BLOCKYSIZE=256: tiles are multiples of 16"),
    ({"TILED": "NO", "BLOCKXSIZE": "256"}, False, "BLOCKXSIZE/BLOCKSIZE need TILED=YES"),
    ({"TILED": "NO"}, True, "TILED=NO: a Cloud-Optimized GeoTIFF is tiled"),
    ({"BIGTIFF": "MAYBE"}, False, "BIGTIFF=MAYBE: expected YES|NO|IF_NEEDED|IF_SAFER"),
])
def test_bad_creation_options_are_named(tmp_path, options, cog, message):
    with pytest.raises(RasterIOError, match="o.tif: " + re.escape(message)):
        write_raster(tmp_path / "o.tif", np.zeros((4, 4), np.float32), options=options, cog=cog)
    with pytest.raises(RasterIOError, match="GeoTIFF output"):
        write_raster(tmp_path / "o.npy", np.zeros((4, 4), np.float32), options={"COMPRESS": "LZW"})
    assert list(tmp_path.iterdir()) == []


def test_bigtiff_when_needed_and_refused_with_no(tmp_path, monkeypatch):
    monkeypatch.setattr(geotiff, "_CLASSIC_LIMIT", 4096)   # as if the file passed 4 GiB
    data = np.arange(64 * 64, dtype=np.float32).reshape(64, 64)
    plain = {"COMPRESS": "NONE", "TILED": "NO"}
    write_raster(tmp_path / "big.tif", data, options=plain)
    with tifffile.TiffFile(tmp_path / "big.tif") as tif:
        assert tif.is_bigtiff
        np.testing.assert_array_equal(tif.asarray(), data)
    write_raster(tmp_path / "small.tif", data[:4, :4], options=plain)
    with tifffile.TiffFile(tmp_path / "small.tif") as tif:
        assert not tif.is_bigtiff
    with pytest.raises(RasterIOError, match="no.tif: .*BIGTIFF=NO: the file needs"):
        write_raster(tmp_path / "no.tif", data, options={**plain, "BIGTIFF": "NO"})
    assert leftovers(tmp_path) == []


def test_overviews_are_nearest_neighbour_levels(tmp_path):
    data = np.random.default_rng(3).integers(0, 2, (2, 1100, 700)).astype(np.uint8)
    write_raster(tmp_path / "o.tif", data, options={"OVERVIEWS": "AUTO"})
    with tifffile.TiffFile(tmp_path / "o.tif") as tif:
        shapes = [p.shape for p in tif.pages]
        assert shapes == [(2, 1100, 700), (2, 550, 350), (2, 275, 175), (2, 138, 88)]   # until a tile holds one
        for k, page in enumerate(tif.pages[1:], 1):
            assert page.tags[254].value == 1
            np.testing.assert_array_equal(page.asarray(), data[:, ::2 ** k, ::2 ** k])


@needs_gdal
def test_cog_is_what_gdal_calls_a_cog(tmp_path):
    data = np.random.default_rng(4).normal(size=(3, 1300, 1100)).astype(np.float32)
    like = Raster(np.zeros(data.shape[1:]), 30.0, 30.0, georef=UTM)
    write_raster(tmp_path / "c.tif", data, like=like, nodata=np.nan, band_names=["a", "b", "c"], cog=True)
    info = gdalinfo(tmp_path / "c.tif")
    assert info["metadata"]["IMAGE_STRUCTURE"]["LAYOUT"] == "COG"
    band = info["bands"][0]
    assert band["block"] == [512, 512] and [o["size"] for o in band["overviews"]] == [[550, 650], [275, 325]]
    assert info["geoTransform"] == [500000.0, 30.0, 0.0, 4000000.0, 0.0, -30.0]
    assert info["coordinateSystem"]["wkt"].endswith('ID["EPSG",32633]]')
    code = ("import sys, osgeo_utils.samples.validate_cloud_optimized_geotiff as v; "
            "sys.exit(v.main(['v', '--full-check=yes', sys.argv[1]]))")
    validator = subprocess.run(["python3", "-c", code, str(tmp_path / "c.tif")], capture_output=True, text=True)
    if "ModuleNotFoundError" not in validator.stderr:    # GDAL's validator, where python3-gdal is installed
        assert validator.returncode == 0 and "is a valid cloud optimized GeoTIFF" in validator.stdout, validator


@needs_gdal
def test_gdal_reads_descriptions_nodata_and_values(tmp_path):
    data = np.full((2, 33, 47), 7, np.uint8)
    data[1, 3, 4] = 255
    like = Raster(np.zeros((33, 47)), 30.0, 30.0, georef=UTM)
    write_raster(tmp_path / "m.tif", data, like=like, nodata=255, band_names=["mask_az315_alt20", "a<b"])
    info = gdalinfo(tmp_path / "m.tif", "-stats")
    assert [b["description"] for b in info["bands"]] == ["mask_az315_alt20", "a<b"]
    assert [b["noDataValue"] for b in info["bands"]] == [255, 255]
    assert info["bands"][1]["maximum"] == 7 and info["size"] == [47, 33]


# ----------------------------------------------------------------------------- CRS sidecars and previews

@needs_gdal
def test_wkt_without_epsg_goes_into_an_aux_xml(tmp_path):
    like = Raster(np.zeros((5, 6)), 10.0, 10.0, georef={33550: (10.0, 10.0, 0.0),
                                                       33922: (0, 0, 0, 1000.0, 2000.0, 0)}, crs_wkt=WKT_NO_EPSG)
    write_raster(tmp_path / "o.tif", np.ones((5, 6), np.float32), like=like)
    aux = tmp_path / "o.tif.aux.xml"
    assert "local_tm" in aux.read_text()
    assert 'PROJCRS["local_tm"' in gdalinfo(tmp_path / "o.tif")["coordinateSystem"]["wkt"]
    write_raster(tmp_path / "o.tif", np.ones((5, 6), np.float32))   # no CRS now: the stale sidecar goes
    assert not aux.exists()


def test_decimated_keeps_each_kept_cell_in_place():
    h = np.arange(7 * 9, dtype=float).reshape(7, 9)
    point = {**UTM, 34735: (1, 1, 0, 2, 1025, 0, 1, 2, 3072, 0, 1, 32633)}    # PixelIsPoint
    matrix = {34264: (30.0, 2.0, 0, 500000.0, 1.0, -30.0, 0, 4000000.0, 0, 0, 0, 0, 0, 0, 0, 1)}
    for georef in (UTM, point, matrix):
        small = decimated(Raster(h, 30.0, 30.0, georef=georef), 3)
        assert small.heights.shape == (3, 3) and small.dx == 90.0
        x0, a, b, y0, d, e = geotransform(georef)
        X0, A, B, Y0, D, E = geotransform(small.georef)
        for i, j in ((0, 0), (2, 1), (1, 2)):   # centre of small cell (i, j) == centre of cell (3i, 3j)
            assert X0 + A * (j + .5) + B * (i + .5) == pytest.approx(x0 + a * (3 * j + .5) + b * (3 * i + .5))
            assert Y0 + D * (j + .5) + E * (i + .5) == pytest.approx(y0 + d * (3 * j + .5) + e * (3 * i + .5))
    assert geotransform(point)[0] == 500000.0 - 15.0      # GDAL: a PixelIsPoint tie point is a cell centre


def test_preview_gets_a_world_file_and_its_crs(tmp_path, dem):
    like = Raster(dem, 30.0, 30.0, georef=UTM)
    write_preview(tmp_path / "p.png", dem, 30.0, 30.0, 315, 20, max_size=20, like=like)   # step 3
    assert Image.open(tmp_path / "p.png").size == (19, 14)
    world = [float(v) for v in (tmp_path / "p.pgw").read_text().split()]
    assert world == pytest.approx([90.0, 0.0, 0.0, -90.0, 500015.0, 3999985.0])   # pixel (0, 0) shows cell (0, 0)
    assert "<SRS>EPSG:32633</SRS>" in (tmp_path / "p.png.aux.xml").read_text()
    write_preview(tmp_path / "p.png", dem, 30.0, 30.0, 315, 20, max_size=20)   # not georeferenced: no sidecars
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]
    wkt = Raster(dem, 30.0, 30.0, georef={k: UTM[k] for k in (33550, 33922)}, crs_wkt=WKT_NO_EPSG)
    write_preview(tmp_path / "w.png", dem, 30.0, 30.0, 315, 20, like=wkt)
    assert "local_tm" in (tmp_path / "w.png.aux.xml").read_text()


@needs_gdal
def test_cli_preview_is_georeferenced_like_the_output(tmp_path, utm_tif):
    out, png = tmp_path / "out" / "m.tif", tmp_path / "out" / "m.png"
    assert main(["shadow", str(utm_tif), str(out), "--preview", str(png), "-q"]) == 0
    tif_info, png_info = gdalinfo(out), gdalinfo(png)
    assert png_info["geoTransform"] == tif_info["geoTransform"] == [500000.0, 30.0, 0.0, 4000000.0, 0.0, -30.0]
    assert png_info["coordinateSystem"]["wkt"] == tif_info["coordinateSystem"]["wkt"]


# ----------------------------------------------------------------------------- band names, EXR order, summary

def test_band_names_normalise_azimuths_and_exr_keeps_the_band_order(tmp_path, npy):
    import OpenEXR
    suns = ["--sun=-45,20", "--sun=370,10.5"] + [f"--sun={az},30" for az in range(0, 360, 40)]
    assert main(["shadow", str(npy), str(tmp_path / "o.tif"), "--cellsize", "30", "--output", "all", "-q",
                 *suns]) == 0
    names = tags(tmp_path / "o.tif")[42112]
    assert ">mask_az315_alt20<" in names and ">coefficient_az10_alt10p5<" in names and "az-45" not in names
    assert main(["shadow", str(npy), str(tmp_path / "o.exr"), "--cellsize", "30", "--output", "all", "-q",
                 *suns]) == 0
    with OpenEXR.File(str(tmp_path / "o.exr")) as exr:
        channels = list(exr.channels())
    assert channels[:4] == ["00_mask_az315_alt20", "01_self_az315_alt20", "02_coefficient_az315_alt20",
                            "03_mask_az10_alt10p5"]
    assert channels[-1] == "32_coefficient_az320_alt30" and len(channels) == 33
    tif = tifffile.imread(tmp_path / "o.tif")
    for k in (0, 2, 3, 32):    # band k of the EXR (read_dem -b, file order) is band k of the GeoTIFF
        np.testing.assert_array_equal(read_dem(tmp_path / "o.exr", cellsize=1, band=k + 1).heights, tif[k])


def test_summary_is_columns_by_rows(tmp_path, npy, capsys):
    assert main(["shadow", str(npy), str(tmp_path / "o.npy"), "--cellsize", "30"]) == 0
    assert "oclshade: 56x40 cells, 1 sun(s)" in capsys.readouterr().err   # 40 rows, 56 columns


# ----------------------------------------------------------------------------- streaming and memory

def test_writer_takes_bands_one_at_a_time_and_checks_them(tmp_path):
    with RasterWriter(tmp_path / "s.npy", (3, 4, 5), np.float32) as w:
        assert w.written == 0 and leftovers(tmp_path)          # the temporary file exists from the start
        for k in range(3):
            w.write(np.full((4, 5), k, np.float32))
    np.testing.assert_array_equal(np.load(tmp_path / "s.npy")[:, 0, 0], [0, 1, 2])
    with pytest.raises(RasterIOError, match=r"b.npy: band 1 has shape \(4, 4\), expected \(4, 5\)"):
        RasterWriter(tmp_path / "b.npy", (2, 4, 5), np.uint8).write(np.zeros((4, 4), np.uint8))
    with pytest.raises(RasterIOError, match="c.tif: band 1 of dtype float64 does not fit uint8"):
        RasterWriter(tmp_path / "c.tif", (1, 4, 5), np.uint8).write(np.zeros((4, 5)))
    w = RasterWriter(tmp_path / "d.exr", (2, 4, 5), np.float32)
    w.write(np.zeros((4, 5), np.float32))
    with pytest.raises(RasterIOError, match="d.exr: 1 of 2 bands written"):
        w.finish()
    assert leftovers(tmp_path) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["s.npy"]


def test_cli_streams_each_sun_to_the_writer(tmp_path, npy, monkeypatch):
    """The writer gets a sun's bands before the next sun is traced."""
    events = []
    write, iter_many = RasterWriter.write, cli.ShadowCaster.iter_many

    def traced(self, *args, **kwargs):
        for res in iter_many(self, *args, **kwargs):
            events.append("sun")
            yield res

    monkeypatch.setattr(RasterWriter, "write", lambda self, band: (events.append("band"), write(self, band))[1])
    monkeypatch.setattr(cli.ShadowCaster, "iter_many", traced)
    assert main(["shadow", str(npy), str(tmp_path / "o.tif"), "--cellsize", "30", "--output", "all", "-q",
                 "--sun", "10,10", "--sun", "100,20", "--sun", "200,30"]) == 0
    assert events == ["sun", "band", "band", "band"] * 3


def _peak_rss_kib(argv: list[str]) -> int:
    code = ("import resource, sys; from oclshade.cli import main; rc = main(sys.argv[1:]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(rc)")
    run = subprocess.run([sys.executable, "-c", code, *argv], cwd=REPO, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return int(run.stdout.split()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="ru_maxrss in KiB is Linux's unit")
def test_memory_does_not_grow_with_the_suns(tmp_path):
    """384^2 x 32 suns --output all is 57 MiB of bands (the old writer stacked them all: +~100 MiB);
    streamed, the peak is that of 2 suns within a few MiB."""
    np.save(tmp_path / "dem.npy", canyon_crater(384, 384, seed=3).astype(np.float32))
    peaks = {}
    for n in (2, 32):
        suns = [f"--sun={360 * k / n:.3f},{10 + k % 5 * 10}" for k in range(n)]
        peaks[n] = _peak_rss_kib(["shadow", str(tmp_path / "dem.npy"), str(tmp_path / f"o{n}.tif"),
                                  "--cellsize", "30", "--output", "all", "-q", *suns])
    assert peaks[32] - peaks[2] < 24 * 1024, peaks


# ----------------------------------------------------------------------------- faults before any work

@pytest.fixture()
def no_work(monkeypatch):
    """Tracing a sun fails the test: the faults below must be found before any work."""
    def refuse(*args, **kwargs):
        raise AssertionError("the shadows were computed before the outputs were checked")
    monkeypatch.setattr(cli.ShadowCaster, "__init__", refuse)


def test_unwritable_outputs_fail_before_any_work(tmp_path, npy, capsys, no_work):
    (tmp_path / "file").write_text("x")
    for args, message in [([str(tmp_path / "file" / "o.tif")], "o.tif: cannot create its directory"),
                          ([str(tmp_path / "o.tif"), "--preview", str(tmp_path / "file" / "p.png")],
                           "p.png: cannot create its directory"),
                          ([str(tmp_path / "d.tif")], "d.tif: is a directory")]:
        (tmp_path / "d.tif").mkdir(exist_ok=True)
        assert main(["shadow", str(npy), *args, "--cellsize", "30"]) in (1, 2)
        assert message in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "o.tif").exists() and leftovers(tmp_path) == []


def test_render_checks_every_output_before_any_work(tmp_path, npy, capsys, monkeypatch):
    from oclshade import frames

    def refuse(*args, **kwargs):
        raise AssertionError("the frame was rendered before the outputs were checked")
    monkeypatch.setattr(frames.TerrainScene, "__init__", refuse)
    (tmp_path / "g.exr").mkdir()
    (tmp_path / "file").write_text("x")
    base = ["render", str(npy), str(tmp_path / "v.png"), "--cellsize", "30", "--size", "32x24"]
    assert main(base + ["--gbuffer", str(tmp_path / "g.exr")]) == 1
    assert "g.exr: is a directory" in one_error_line(capsys.readouterr().err)
    assert main(base + ["--ao", "--ao-map", str(tmp_path / "file" / "ao.exr")]) == 1
    assert "ao.exr: cannot create its directory" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "v.png").exists() and leftovers(tmp_path) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_read_only_directory_fails_before_any_work(tmp_path, npy, capsys, no_work):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["shadow", str(npy), str(tmp_path / "o.tif"), "--preview", str(ro / "p.png"),
                     "--cellsize", "30"]) == 1
    finally:
        ro.chmod(0o755)
    assert "p.png: cannot write in" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "o.tif").exists() and leftovers(tmp_path) == []


def test_a_failed_preview_replaces_nothing(tmp_path, npy, capsys, monkeypatch):
    out, png = tmp_path / "o.tif", tmp_path / "p.png"
    out.write_bytes(b"previous result")

    def full_disk(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(rio, "_write_png", full_disk)
    assert main(["shadow", str(npy), str(out), "--preview", str(png), "--cellsize", "30", "-q"]) == 1
    assert "p.png: cannot write png raster: [Errno 28] No space left" in one_error_line(capsys.readouterr().err)
    assert out.read_bytes() == b"previous result" and not png.exists() and leftovers(tmp_path) == []


def test_replacing_keeps_permission_bits(tmp_path):
    out = tmp_path / "o.tif"
    out.write_bytes(b"old")
    out.chmod(0o640)
    write_raster(out, np.zeros((3, 3), np.uint8))
    assert stat.S_IMODE(out.stat().st_mode) == 0o640
    assert tifffile.imread(out).shape == (3, 3)


def test_an_output_symlink_is_written_through(tmp_path):
    real = tmp_path / "store" / "real.tif"
    real.parent.mkdir()
    real.write_bytes(b"old")
    link = tmp_path / "link.tif"
    link.symlink_to(real)
    like = Raster(np.zeros((3, 3)), 30.0, 30.0, georef=UTM, crs_wkt=WKT_NO_EPSG)
    write_raster(link, np.ones((3, 3), np.uint8), like=like)
    assert link.is_symlink() and os.readlink(link) == str(real)
    np.testing.assert_array_equal(tifffile.imread(real), 1)
    assert (tmp_path / "link.tif.aux.xml").exists() is False     # EPSG in the keys: no sidecar needed
    dangling = tmp_path / "dangling.npy"
    dangling.symlink_to(tmp_path / "store" / "new.npy")
    write_raster(dangling, np.ones((2, 2)))
    assert np.load(tmp_path / "store" / "new.npy").shape == (2, 2) and dangling.is_symlink()
    assert leftovers(tmp_path) == []


# ----------------------------------------------------------------------------- CLI flags and signals

def test_cli_creation_options_and_cog(tmp_path, npy, capsys):
    out = tmp_path / "o.tif"
    assert main(["shadow", str(npy), str(out), "--cellsize", "30", "-q", "--co", "compress=lzw",
                 "--co", "BLOCKSIZE=32", "--of", "cog"]) == 0
    t = tags(out)
    assert (t[259], t[322], t[317]) == (5, 32, 2)
    with open(out, "rb") as fh:
        assert b"LAYOUT=IFDS_BEFORE_DATA" in fh.read(200)
    assert len(tifffile.TiffFile(out).pages) == 2     # one overview: 28x20 fits a 32x32 tile
    for argv, message in [(["--co", "FOO=1"], "--co unknown creation option FOO; known: COMPRESS"),
                          (["--co", "COMPRESS"], "--co takes KEY=VALUE"),
                          (["--co", "PREDICTOR=3"], "PREDICTOR=3 does not suit uint8 bands: use 2"),
                          (["--of", "COG", "--co", "TILED=NO"], "a Cloud-Optimized GeoTIFF is tiled")]:
        assert main(["shadow", str(npy), str(out), "--cellsize", "30", *argv]) == 2
        assert message in one_error_line(capsys.readouterr().err)
    assert main(["shadow", str(npy), str(tmp_path / "o.npy"), "--cellsize", "30", "--of", "COG"]) == 2
    assert "apply to GeoTIFF output" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize("sig, status, word", [(signal.SIGTERM, 143, "terminated"),
                                               (signal.SIGINT, 130, "interrupted")])
def test_signals_leave_no_temporary_files(tmp_path, sig, status, word):
    np.save(tmp_path / "dem.npy", canyon_crater(256, 256, seed=5).astype(np.float32))
    out = tmp_path / "o.tif"
    suns = [f"--sun={k * 0.7:.1f},{5 + k % 40}" for k in range(400)]
    proc = subprocess.Popen([sys.executable, "-m", "oclshade", "shadow", str(tmp_path / "dem.npy"), str(out),
                             "--cellsize", "30", "--output", "all", "--preview", str(tmp_path / "p.png"), *suns],
                            cwd=REPO, stderr=subprocess.PIPE, text=True)
    line = ""
    while "suns" not in line:             # the progress bar's first line: a sun is done, the writers are open
        line = proc.stderr.readline()
        assert line, proc.stderr.read()
    assert leftovers(tmp_path)            # the temporary files are there
    proc.send_signal(sig)
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == status, err
    assert err.strip().splitlines()[-1] == f"oclshade: {word}"
    time.sleep(0.1)
    assert leftovers(tmp_path) == [] and not out.exists() and not (tmp_path / "p.png").exists()
