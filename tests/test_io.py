"""Raster I/O (oclshade.io) and previews (oclshade.preview)."""
from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest
import tifffile
from PIL import Image

from oclshade import gdal_reader
from oclshade import io as rio
from oclshade.heightmap import InputWarning
from oclshade.io import Raster, RasterIOError, metres_per_degree, read_dem, write_raster
from oclshade.preview import hillshade, shadow_overlay, write_preview

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
DEM = SHARED / "dem"


ESRI_WGS84 = ('GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],'
              'PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]')


def need_shared(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"shared data not available: {path}")
    return path


def _dem(rows: int = 12, cols: int = 17, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(500.0, 50.0, (rows, cols))


def _leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if ".tmp-" in p.name)


# ----------------------------------------------------------------------------- metres_per_degree

def test_metres_per_degree_reference_values():
    ew, ns = metres_per_degree(0.0)
    assert ew == pytest.approx(111319.49, abs=0.1)
    assert ns == pytest.approx(110574.28, abs=0.1)
    ew60, ns60 = metres_per_degree(60.0)
    assert ew60 == pytest.approx(55800.0, rel=1e-3)
    assert ns60 > ns  # meridian degrees lengthen towards the poles
    assert metres_per_degree(-35.0) == pytest.approx(metres_per_degree(35.0))


# ----------------------------------------------------------------------------- round trips

def test_npy_round_trip_and_cellsize(tmp_path):
    h = _dem()
    np.save(tmp_path / "in.npy", h.astype(np.float32))
    r = read_dem(tmp_path / "in.npy", cellsize=(2.0, 3.0))
    assert r.heights.dtype == np.float64 and r.heights.shape == h.shape
    assert (r.dx, r.dy) == (2.0, 3.0) and r.georef == {} and not r.geographic
    np.testing.assert_allclose(r.heights, h.astype(np.float32))
    assert read_dem(tmp_path / "in.npy").dx == 1.0

    mask = (h > 500).astype(np.uint8)
    write_raster(tmp_path / "mask.npy", mask)
    back = np.load(tmp_path / "mask.npy")
    assert back.dtype == np.uint8 and np.array_equal(back, mask)
    write_raster(tmp_path / "two.npy", [mask, 1 - mask])
    assert np.load(tmp_path / "two.npy").shape == (2,) + h.shape


def test_tif_round_trip_keeps_georef_and_nodata(tmp_path):
    h = _dem().astype(np.float32)
    h[3, 4] = -9999.0
    georef = rio._georef_4326(1 / 1200, -105.5, 40.2, pixel_is_point=False)
    tifffile.imwrite(tmp_path / "in.tif", h,
                     extratags=[(c, rio.GEOTIFF_TAGS[c], 0 if c == 34737 else len(v), v, True)
                                for c, v in georef.items()] + [(42113, 2, 0, "-9999", True)])
    r = read_dem(tmp_path / "in.tif")
    assert r.geographic and r.nodata == -9999.0
    assert np.isnan(r.heights[3, 4]) and np.isnan(r.heights).sum() == 1
    mx, my = metres_per_degree(40.2 - h.shape[0] / 2400)
    assert r.dx == pytest.approx(mx / 1200) and r.dy == pytest.approx(my / 1200)

    coef = np.random.default_rng(1).random((2,) + h.shape).astype(np.float32)
    write_raster(tmp_path / "out.tif", coef, like=r, nodata=-1.0, band_names=["sun0", "sun1"])
    with tifffile.TiffFile(tmp_path / "out.tif") as tif:
        page = tif.pages[0]
        tags = {t.code: t.value for t in page.tags.values()}
        data = tif.asarray()
    assert data.shape == coef.shape and data.dtype == np.float32
    np.testing.assert_array_equal(data, coef)
    for code, value in r.georef.items():
        assert tags[code] == (pytest.approx(value) if code != 34737 else value)
    assert float(tags[42113]) == -1.0
    assert "sun1" in tags[42112]
    with pytest.warns(InputWarning, match="2 bands; reading band 1"):
        again = read_dem(tmp_path / "out.tif")  # first band, same georeferencing
    np.testing.assert_array_equal(again.heights, coef[0])
    assert (again.dx, again.dy, again.geographic) == pytest.approx((r.dx, r.dy, True))

    write_raster(tmp_path / "mask.tiff", (coef[0] > 0.5).astype(np.uint8), like=r)
    assert tifffile.imread(tmp_path / "mask.tiff").dtype == np.uint8


def test_projected_tif_uses_pixel_scale(tmp_path):
    tifffile.imwrite(tmp_path / "utm.tif", _dem().astype(np.int16),
                     extratags=[(33550, 12, 3, (25.0, 30.0, 0.0), True),
                                (33922, 12, 6, (0, 0, 0, 500000.0, 4e6, 0), True),
                                (34735, 3, 8, (1, 1, 0, 1, 1024, 0, 1, 1), True)])
    r = read_dem(tmp_path / "utm.tif")
    assert (r.dx, r.dy, r.geographic, r.nodata) == (25.0, 30.0, False, None)
    assert read_dem(tmp_path / "utm.tif", cellsize=5).dx == 5.0


def test_compressed_geotiffs_round_trip(tmp_path):
    """LZW and DEFLATE with the floating-point predictor, as GDAL writes DEMs."""
    import tifffile

    h = _dem().astype(np.float32)
    for compression in ("lzw", "zlib"):
        path = tmp_path / f"c_{compression}.tif"
        tifffile.imwrite(path, h, compression=compression, predictor=3,
                         extratags=[(33550, 12, 3, (10.0, 10.0, 0.0), True)])
        r = read_dem(path)
        np.testing.assert_array_equal(r.heights, h.astype(np.float64))
        assert r.dx == 10.0


def test_exr_round_trip(tmp_path):
    h = _dem()
    write_raster(tmp_path / "one.exr", h)
    r = read_dem(tmp_path / "one.exr", cellsize=2.0)
    np.testing.assert_allclose(r.heights, h.astype(np.float32))
    assert r.dx == 2.0
    mask = np.zeros(h.shape, np.uint8)
    mask[2, 3] = 1
    write_raster(tmp_path / "two.exr", [mask, h], band_names=["mask", "Z"])
    with pytest.warns(InputWarning, match=r"2 bands; reading band 1 \(Z\)"):
        np.testing.assert_allclose(read_dem(tmp_path / "two.exr").heights, h.astype(np.float32))


def test_png_16bit_round_trip_and_rgb(tmp_path):
    h = (np.arange(12 * 17).reshape(12, 17) * 300).astype(np.uint16)
    write_raster(tmp_path / "dem.png", h)
    assert Image.open(tmp_path / "dem.png").mode.startswith("I;16")
    r = read_dem(tmp_path / "dem.png", cellsize=30.0)
    np.testing.assert_array_equal(r.heights, h)
    assert r.dx == r.dy == 30.0
    rgb = np.zeros((4, 5, 3), np.uint8)
    write_raster(tmp_path / "rgb.png", rgb)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "rgb.png")), rgb)
    with pytest.raises(RasterIOError, match="rgb.png"):
        read_dem(tmp_path / "rgb.png")  # not greyscale
    with pytest.raises(RasterIOError, match="bad.png"):
        write_raster(tmp_path / "bad.png", h.astype(np.float32))


def test_asc_reader(tmp_path):
    text = ("ncols 3\nnrows 2\nxllcorner 500000\nyllcorner 4000000\ncellsize 10\n"
            "NODATA_value -9999\n1 2 3\n4 -9999\n6\n")
    (tmp_path / "g.asc").write_text(text)
    with pytest.warns(InputWarning, match="no g.prj next to the file: cell size 10 x 10 taken as metres"):
        r = read_dem(tmp_path / "g.asc")
    assert not r.geographic and (r.dx, r.dy) == (10.0, 10.0)
    np.testing.assert_array_equal(np.isnan(r.heights), [[0, 0, 0], [0, 1, 0]])
    assert r.georef[33922][4] == 4000020.0
    (tmp_path / "short.asc").write_text(text.replace("\n6\n", "\n"))
    with pytest.raises(RasterIOError, match=r"short.asc: .*2x3 values, found 5"):
        read_dem(tmp_path / "short.asc")


# ----------------------------------------------------------------------------- atomic writes

@pytest.mark.parametrize("name", ["out.tif", "out.npy", "out.exr", "out.png"])
def test_atomic_write_leaves_nothing_on_failure(tmp_path, monkeypatch, name):
    target = tmp_path / name
    target.write_bytes(b"previous result")

    def half_write_then_fail(path, *args, **kwargs):
        Path(path).write_bytes(b"trunc")
        raise OSError("disk full")

    monkeypatch.setattr(rio, {".tif": "_write_tif", ".npy": "_write_npy", ".exr": "_write_exr",
                              ".png": "_write_png"}[target.suffix], half_write_then_fail)
    with pytest.raises(RasterIOError, match=r"out\.\w+: .*disk full"):
        write_raster(target, np.zeros((3, 4), np.uint8))
    assert target.read_bytes() == b"previous result"
    assert _leftovers(tmp_path) == []


def test_atomic_write_success_leaves_no_temp(tmp_path):
    for ext in (".tif", ".npy", ".exr", ".png"):
        write_raster(tmp_path / f"x{ext}", np.ones((3, 4), np.uint8))
    assert _leftovers(tmp_path) == [] and len(list(tmp_path.iterdir())) == 4


def test_write_refuses_to_overwrite_input(tmp_path):
    np.save(tmp_path / "dem.npy", _dem())
    r = read_dem(tmp_path / "dem.npy")
    with pytest.raises(RasterIOError, match="dem.npy.*overwrite"):
        write_raster(tmp_path / "dem.npy", r.heights, like=r)


# ----------------------------------------------------------------------------- errors

def test_read_errors_name_the_path(tmp_path, monkeypatch):
    monkeypatch.setattr(gdal_reader, "available", lambda: False)  # the built-in readers' messages
    with pytest.raises(RasterIOError, match="missing.tif: no such file"):
        read_dem(tmp_path / "missing.tif")
    (tmp_path / "dem.xyz").write_text("1")
    with pytest.raises(RasterIOError, match=r"dem.xyz: unknown raster extension"):
        read_dem(tmp_path / "dem.xyz")
    np.save(tmp_path / "cube.npy", np.zeros((2, 3, 4)))
    with pytest.raises(RasterIOError, match=r"cube.npy: .*2-D"):
        read_dem(tmp_path / "cube.npy")
    np.save(tmp_path / "text.npy", np.array([["a", "b"]]))
    with pytest.raises(RasterIOError, match=r"text.npy: .*numeric"):
        read_dem(tmp_path / "text.npy")
    (tmp_path / "junk.tif").write_bytes(b"not a tiff at all")
    with pytest.raises(RasterIOError, match=r"junk.tif: cannot read") as info:
        read_dem(tmp_path / "junk.tif")
    assert "\n" not in str(info.value)
    (tmp_path / "N10E010.hgt").write_bytes(b"\0" * 100)
    with pytest.raises(RasterIOError, match="N10E010.hgt: .*1201x1201"):
        read_dem(tmp_path / "N10E010.hgt")


def test_write_errors_name_the_path(tmp_path):
    with pytest.raises(RasterIOError, match="out.jpg: unknown output extension"):
        write_raster(tmp_path / "out.jpg", np.zeros((2, 2)))
    with pytest.raises(RasterIOError, match="out.tif: bands must be equally shaped"):
        write_raster(tmp_path / "out.tif", [np.zeros((2, 2)), np.zeros((3, 2))])
    with pytest.raises(RasterIOError, match="nodir"):
        write_raster(tmp_path / "nodir" / "out.npy", np.zeros((2, 2)))


# ----------------------------------------------------------------------------- real data

def test_srtm_zip(tmp_path):
    path = need_shared(DEM / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip")
    meta = json.loads((path.parent / "N22W160.f32.json").read_text())
    r = read_dem(path)
    assert r.heights.shape == (1201, 1201) and r.geographic and r.nodata == -32768
    assert np.isnan(r.heights).sum() == meta["voids"]
    assert (np.nanmin(r.heights), np.nanmax(r.heights)) == (meta["min"], meta["max"])
    assert r.dx == pytest.approx(meta["cell_size_m_ew_at_centre"], rel=0.01)
    assert r.dy == pytest.approx(meta["cell_size_m_ns"], rel=0.01)
    assert r.georef[33922][3:5] == (-160.0, 23.0)

    small = Raster(r.heights[:50, :60], r.dx, r.dy, r.nodata, True, r.georef, r.path)
    write_raster(tmp_path / "srtm.tif", small.heights.astype(np.float32), like=small, nodata=np.nan)
    back = read_dem(tmp_path / "srtm.tif")
    assert back.geographic and back.nodata is not None and math.isnan(back.nodata)
    assert back.dx == pytest.approx(metres_per_degree(23 - 50 / 2400)[0] / 1200)  # its own centre

    hgt = tmp_path / "N22W160.hgt"
    with zipfile.ZipFile(path) as zf:
        hgt.write_bytes(zf.read("N22W160.hgt"))
    np.testing.assert_array_equal(read_dem(hgt).heights, r.heights)


@pytest.mark.parametrize("rel", ["srtm30_qgis2threejs/dem_srtm30.tif", "pysheds/dem.tif",
                                 "whiteboxR/DEM.tif", "landlab/SRTMGL3_40.09_-105.55_40.21_-105.35.asc"])
def test_real_cell_sizes_against_sidecars(rel, tmp_path):
    path = need_shared(DEM / rel)
    meta = json.loads(path.with_suffix(".f32.json").read_text())
    if path.suffix == ".asc":  # the grid comes without its .prj: give it one (without, it is refused)
        with pytest.raises(RasterIOError, match="could be degrees"):
            read_dem(path)
        (tmp_path / path.name).write_bytes(path.read_bytes())
        path = tmp_path / path.name
        path.with_suffix(".prj").write_text(ESRI_WGS84)
    r = read_dem(path)
    assert list(r.heights.shape) == meta["shape_rows_cols"]
    assert (np.nanmin(r.heights), np.nanmax(r.heights)) == pytest.approx((meta["min"], meta["max"]))
    ew = meta.get("cell_size_m_ew_at_centre", meta.get("cell_size_m"))
    ns = meta.get("cell_size_m_ns", meta.get("cell_size_m"))
    assert r.dx == pytest.approx(ew, rel=0.01)
    assert r.dy == pytest.approx(ns, rel=0.01)
    assert r.geographic == ("4326" in meta["crs"])


# ----------------------------------------------------------------------------- preview

@pytest.mark.parametrize("az,alt", [(315.0, 45.0), (90.0, 30.0), (200.0, 60.0)])
def test_hillshade_of_plane_matches_analytic(az, alt):
    p, q = 0.3, -0.2  # dz/d(east), dz/d(north)
    dx, dy = 10.0, 15.0
    rows, cols = 9, 11
    north = (rows - 1 - np.arange(rows))[:, None] * dy  # row 0 is the north edge
    east = np.arange(cols)[None, :] * dx
    h = p * east + q * north
    a, e = math.radians(az), math.radians(alt)
    want = (math.sin(e) - math.cos(e) * (p * math.sin(a) + q * math.cos(a))) / math.sqrt(1 + p * p + q * q)
    hs = hillshade(h, dx, dy, az, alt)
    assert hs.dtype == np.float32 and hs.shape == h.shape
    np.testing.assert_allclose(hs[1:-1, 1:-1], max(want, 0.0), atol=1e-6)


def test_hillshade_lights_slopes_facing_the_sun_and_marks_holes():
    x = np.arange(8) * 10.0
    rising_east = np.tile(x, (8, 1))          # faces west
    assert hillshade(rising_east, 10, 10, azimuth=270)[4, 4] > hillshade(rising_east, 10, 10, azimuth=90)[4, 4]
    h = rising_east.copy()
    h[4, 4] = np.nan
    hs = hillshade(h, 10, 10)
    assert np.isnan(hs[3:6, 3:6]).all() and np.isnan(hs).sum() == 9
    assert np.nanmax(hs) <= 1 and np.nanmin(hs) >= 0


def test_shadow_overlay_and_preview(tmp_path):
    h = _dem(20, 30)
    h[0, 0] = np.nan
    mask = np.zeros(h.shape, np.uint8)
    mask[5:10, 5:20] = 1
    mask[15, 15] = 255
    rgb = shadow_overlay(h, 30, 30, 315, 45, mask)
    plain = shadow_overlay(h, 30, 30, 315, 45, None)
    assert rgb.shape == h.shape + (3,) and rgb.dtype == np.uint8
    lum = rgb.astype(float) @ [0.299, 0.587, 0.114]
    plain_lum = plain.astype(float) @ [0.299, 0.587, 0.114]
    assert (lum[mask == 1] < plain_lum[mask == 1]).all()
    assert (rgb[mask == 1, 2] > rgb[mask == 1, 0]).all()  # blue tint
    assert np.array_equal(rgb[0, 0], rgb[15, 15]) and not np.array_equal(rgb[0, 0], plain[1, 1])

    write_preview(tmp_path / "p.png", h, 30, 30, 315, 45, mask, max_size=8)
    img = np.asarray(Image.open(tmp_path / "p.png"))
    assert img.shape == (5, 8, 3) and _leftovers(tmp_path) == []
    with pytest.raises(ValueError, match="mask"):
        shadow_overlay(h, 30, 30, 315, 45, mask[:-1])
