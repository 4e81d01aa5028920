"""Windowed raster I/O for tiled runs: GeoTIFF written window by window (byte-identical to whole
bands), RasterWriter.write_window, and open_dem's windowed reads."""
from __future__ import annotations

import io

import numpy as np
import pytest
import tifffile

from oclshade.geotiff import GeoTiffWriter, tiff_options
from oclshade.io import RasterIOError, RasterWriter, open_dem, read_dem, write_raster

OPTIONS = [({}, False), ({"TILED": "NO"}, False), ({"TILED": "NO", "BLOCKYSIZE": "7"}, False),
           ({"OVERVIEWS": "AUTO", "BLOCKSIZE": "32"}, False), ({"COMPRESS": "LZW", "BLOCKXSIZE": "48"}, False),
           ({"COMPRESS": "ZSTD", "BLOCKSIZE": "16"}, False), ({"COMPRESS": "NONE"}, False), ({}, True),
           ({"BLOCKSIZE": "32"}, True)]


def _saved(writer: GeoTiffWriter) -> bytes:
    out = io.BytesIO()
    writer.save(out)
    writer.close()
    return out.getvalue()


def _windows(shape, rows, cols):
    return [(r, c) for r in range(0, shape[0], rows) for c in range(0, shape[1], cols)]


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
@pytest.mark.parametrize("options,cog", OPTIONS, ids=str)
def test_geotiff_windows_give_the_whole_band_file_byte_for_byte(options, cog, dtype):
    rng = np.random.default_rng(7)
    shape = (3, 157, 203)
    bands = [(rng.random(shape[1:]) * 200).astype(dtype) for _ in range(shape[0])]
    bands[1][40:60] = 0                                    # something compressible
    opts = tiff_options(options, dtype, cog)
    whole = GeoTiffWriter(shape, dtype, opts, [(42113, 2, "255")])
    for band in bands:
        whole.write(band)
    expected = _saved(whole)
    for rows, cols in ((50, 70), (157, 203), (13, 200), (1, 1000)):
        windowed = GeoTiffWriter(shape, dtype, opts, [(42113, 2, "255")])
        parts = [(k, r, c) for k in range(shape[0]) for r, c in _windows(shape[1:], rows, cols)]
        for i in rng.permutation(len(parts)):              # any order
            k, r, c = parts[i]
            windowed.write_window(k, r, c, bands[k][r:r + rows, c:c + cols])
        assert _saved(windowed) == expected, (rows, cols)
    assert tifffile.imread(io.BytesIO(expected)).shape[-2:] == shape[1:]


def test_geotiff_windows_are_checked():
    opts = tiff_options({"BLOCKSIZE": "16"}, np.uint8)
    w = GeoTiffWriter((2, 40, 40), np.uint8, opts)
    w.write_window(0, 0, 0, np.ones((20, 20), np.uint8))
    with pytest.raises(ValueError, match="written twice"):
        w.write_window(0, 10, 10, np.ones((5, 5), np.uint8))
    with pytest.raises(ValueError, match="written twice"):
        w.write_window(0, 0, 0, np.ones((16, 16), np.uint8))   # a block already encoded
    with pytest.raises(ValueError, match="does not lie in"):
        w.write_window(1, 30, 30, np.ones((20, 20), np.uint8))
    with pytest.raises(ValueError, match="band 2 out of range"):
        w.write_window(2, 0, 0, np.ones((2, 2), np.uint8))
    with pytest.raises(ValueError, match="does not mix"):
        w.write(np.ones((40, 40), np.uint8))
    with pytest.raises(ValueError, match="blocks not completely written"):
        w.save(io.BytesIO())
    w.close()


@pytest.mark.parametrize("ext", [".tif", ".npy", ".exr", ".png"])
def test_raster_writer_windows_equal_whole_bands(tmp_path, ext):
    rng = np.random.default_rng(3)
    count = 1 if ext == ".png" else 2
    bands = (rng.random((count, 45, 61)) * 250).astype(np.uint8)
    write_raster(tmp_path / f"whole{ext}", bands if count > 1 else bands[0])
    with RasterWriter(tmp_path / f"windows{ext}", (count, 45, 61), np.uint8) as out:
        for k in range(count):
            for r, c in _windows((45, 61), 20, 25)[::-1]:
                out.write_window(k, r, c, bands[k, r:r + 20, c:c + 25])
    assert (tmp_path / f"whole{ext}").read_bytes() == (tmp_path / f"windows{ext}").read_bytes()


def test_raster_writer_windows_are_checked(tmp_path):
    out = RasterWriter(tmp_path / "o.npy", (1, 10, 10), np.uint8)
    out.write_window(0, 0, 0, np.zeros((5, 10), np.uint8))
    with pytest.raises(RasterIOError, match="5 x 10|50 of 100 cells written"):
        out.finish()
    assert not list(tmp_path.iterdir())                  # the failure removed the temporary file
    out = RasterWriter(tmp_path / "o.npy", (1, 10, 10), np.uint8)
    with pytest.raises(RasterIOError, match="does not fit uint8"):
        out.write_window(0, 0, 0, np.zeros((2, 2), np.float32))
    out = RasterWriter(tmp_path / "o.tif", (1, 10, 10), np.uint8)
    with pytest.raises(RasterIOError, match="does not lie in"):
        out.write_window(0, 8, 0, np.zeros((5, 5), np.uint8))


# ----------------------------------------------------------------------------- windowed reads

@pytest.fixture(scope="module")
def dem() -> np.ndarray:
    h = np.random.default_rng(11).normal(500.0, 80.0, (131, 97)).astype(np.float32)
    h[20:30, 40:50] = -9999.0
    return h


@pytest.mark.parametrize("layout", ["tiled", "strips", "one strip", "cog", "planar", "contig"])
def test_open_dem_windows_equal_read_dem(tmp_path, dem, layout):
    path = tmp_path / "dem.tif"
    extratags = [(42113, "s", 0, "-9999", True), (33550, "d", 3, (30.0, 30.0, 0.0), True)]
    data, band = dem, None
    if layout in ("planar", "contig"):
        data, band = np.stack([dem * 0, dem, dem + 1]), 2
        if layout == "contig":
            data = np.moveaxis(data, 0, -1)
    kwargs = {"tiled": dict(tile=(32, 48)), "strips": dict(rowsperstrip=10), "one strip": dict(rowsperstrip=131),
              "cog": {}, "planar": dict(tile=(32, 32), planarconfig="separate", photometric="rgb"),
              "contig": dict(rowsperstrip=9, planarconfig="contig", photometric="rgb")}[layout]
    if layout == "cog":
        write_raster(path, dem, nodata=-9999.0, cog=True, options={"BLOCKSIZE": "32"})
    else:
        tifffile.imwrite(path, data, compression="zlib", extratags=extratags, **kwargs)
    whole = read_dem(path, band=band)
    with open_dem(path, band=band) as windows:
        assert windows.shape == whole.heights.shape
        assert (windows.raster.dx, windows.raster.nodata) == (whole.dx, whole.nodata)
        for r0, r1, c0, c1 in ((0, 131, 0, 97), (5, 6, 90, 97), (15, 70, 33, 81), (100, 131, 0, 1)):
            got = windows.read(r0, r1, c0, c1)
            assert got.dtype == np.float64
            np.testing.assert_array_equal(got, whole.heights[r0:r1, c0:c1])
        with pytest.raises(ValueError, match="not inside"):
            windows.read(0, 132, 0, 5)


def test_open_dem_decodes_only_the_blocks_a_window_touches(tmp_path, dem):
    path = tmp_path / "dem.tif"
    tifffile.imwrite(path, dem, tile=(32, 32), compression="zlib")
    with tifffile.TiffFile(path) as tif:                 # corrupt the last tile
        page = tif.pages[0]
        offset, count = page.dataoffsets[-1], page.databytecounts[-1]
    raw = bytearray(path.read_bytes())
    raw[offset:offset + count] = b"\0" * count
    path.write_bytes(bytes(raw))
    with open_dem(path) as windows:
        np.testing.assert_array_equal(windows.read(0, 64, 0, 64), dem[:64, :64])
        with pytest.raises(RasterIOError, match="cannot read rows 100:131"):
            windows.read(100, 131, 90, 97)
        assert windows.segment_bytes == 32 * 32 * 4


def test_open_dem_maps_npy_and_reads_other_formats_whole(tmp_path, dem):
    np.save(tmp_path / "dem.npy", dem)
    with open_dem(tmp_path / "dem.npy", cellsize=30.0, nodata=-9999.0) as windows:
        assert windows.raster.dx == 30.0
        expected = np.where(dem == -9999.0, np.nan, dem.astype(np.float64))
        np.testing.assert_array_equal(windows.read(10, 40, 30, 60), expected[10:40, 30:60])
    np.save(tmp_path / "bad.npy", np.zeros((2, 3, 4)))
    with pytest.raises(RasterIOError, match="2-D"):
        open_dem(tmp_path / "bad.npy")
    write_raster(tmp_path / "dem.exr", dem)
    with open_dem(tmp_path / "dem.exr", cellsize=30.0) as windows:
        np.testing.assert_array_equal(windows.read(3, 9, 4, 8), dem[3:9, 4:8].astype(np.float64))
