"""GeoTIFF masks beyond a nodata value: GDAL's internal mask (an IFD of NewSubfileType 4) and an
alpha band mark cells as nodata, in whole reads and in windowed ones (they were read as heights)."""
import shutil
import subprocess
import warnings

import numpy as np
import pytest
import tifffile

from oclshade.io import open_dem, read_dem

UTM = [(33550, 12, 3, (30.0, 30.0, 0.0), True), (33922, 12, 6, (0, 0, 0, 500000.0, 6700000.0, 0), True),
       (34735, 3, 16, (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633), True)]


def heights_and_mask(rows=40, cols=56, seed=1):
    rng = np.random.default_rng(seed)
    heights = rng.integers(100, 900, (rows, cols)).astype(np.int16)
    keep = rng.random((rows, cols)) > 0.2
    return heights, keep


def quiet_read(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_dem(path, **kw).heights


def windows_of(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dem = open_dem(path)
    with dem:
        rows, cols = dem.shape
        return np.vstack([np.hstack([dem.read(r, min(r + 13, rows), c, min(c + 17, cols)) for c in range(0, cols, 17)])
                          for r in range(0, rows, 13)])


def expected(heights, keep):
    out = heights.astype(np.float64)
    out[~keep] = np.nan
    return out


@pytest.mark.parametrize("tile", [None, (16, 16)])
def test_an_internal_mask_ifd_marks_nodata(tmp_path, tile):
    heights, keep = heights_and_mask()
    path = tmp_path / "masked.tif"
    with tifffile.TiffWriter(path) as tif:
        tif.write(heights, extratags=UTM, tile=tile)
        tif.write(keep, subfiletype=4, tile=tile, photometric="minisblack")
    want = expected(heights, keep)
    np.testing.assert_array_equal(quiet_read(path), want)
    np.testing.assert_array_equal(windows_of(path), want)


def test_an_alpha_band_masks_the_others_but_not_itself(tmp_path):
    heights, keep = heights_and_mask()
    alpha = np.where(keep, 255, 0).astype(np.int16)
    path = tmp_path / "alpha.tif"
    tifffile.imwrite(path, np.stack([heights, alpha], -1), photometric="minisblack", extrasamples=[2],
                     extratags=UTM, tile=(16, 16))
    want = expected(heights, keep)
    np.testing.assert_array_equal(quiet_read(path), want)
    np.testing.assert_array_equal(windows_of(path), want)
    np.testing.assert_array_equal(quiet_read(path, band=2), alpha.astype(np.float64))


def test_an_overview_is_not_a_mask(tmp_path):
    heights, _ = heights_and_mask()
    path = tmp_path / "ovr.tif"
    with tifffile.TiffWriter(path) as tif:
        tif.write(heights, extratags=UTM)
        tif.write(heights[::2, ::2], subfiletype=1)
    np.testing.assert_array_equal(quiet_read(path), heights.astype(np.float64))


@pytest.mark.skipif(shutil.which("gdal_translate") is None, reason="gdal_translate (apt gdal-bin) not installed")
def test_gdal_internal_mask_agrees_with_gdal(tmp_path):
    """A mask made by GDAL (gdal_translate -mask, GDAL_TIFF_INTERNAL_MASK): the cells oclshade
    reads as nodata are those GDAL's mask band (-b mask) marks 0."""
    heights, keep = heights_and_mask(seed=4)
    src = tmp_path / "alpha.tif"
    tifffile.imwrite(src, np.stack([heights, np.where(keep, 255, 0).astype(np.int16)], -1),
                     photometric="minisblack", extrasamples=[2], extratags=UTM)
    masked, gdal_mask = tmp_path / "masked.tif", tmp_path / "gdal_mask.tif"
    subprocess.run(["gdal_translate", "-q", "-b", "1", "-mask", "2", "-co", "TILED=YES", "-co", "BLOCKXSIZE=16",
                    "-co", "BLOCKYSIZE=16", "--config", "GDAL_TIFF_INTERNAL_MASK", "YES", str(src), str(masked)],
                   check=True)
    subprocess.run(["gdal_translate", "-q", "-b", "mask", str(masked), str(gdal_mask)], check=True)
    gdal_keep = tifffile.imread(gdal_mask) != 0
    assert not gdal_keep.all() and np.array_equal(gdal_keep, keep)
    want = expected(heights, gdal_keep)
    np.testing.assert_array_equal(quiet_read(masked), want)
    np.testing.assert_array_equal(windows_of(masked), want)
