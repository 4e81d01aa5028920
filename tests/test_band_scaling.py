"""A GeoTIFF band with GDAL's scale and offset (heights stored as integers, e.g. decimetres):
the heights are raw x scale + offset, nodata compared raw, in read_dem and in windowed reads,
with a warning; GDAL's own unscaling agrees where gdal-bin is installed."""
import shutil
import subprocess
import warnings

import numpy as np
import pytest
import tifffile

from oclshade.heightmap import InputWarning
from oclshade.io import gdal_band_scaling, open_dem, read_dem

METADATA = ('<GDALMetadata><Item name="OFFSET" sample="0" role="offset">100</Item>'
            '<Item name="SCALE" sample="0" role="scale">0.1</Item></GDALMetadata>')


def scaled_tif(path, raw, metadata=METADATA, tile=None):
    tags = [(33550, 12, 3, (30.0, 30.0, 0.0), True), (33922, 12, 6, (0, 0, 0, 500000.0, 6700000.0, 0), True),
            (34735, 3, 16, (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633), True),
            (42113, 2, 0, "-32768", True), (42112, 2, 0, metadata, True)]
    tifffile.imwrite(path, raw, extratags=tags, tile=tile)
    return path


def test_a_scaled_band_is_unscaled_and_its_nodata_compared_raw(tmp_path):
    raw = np.arange(-50, 78, dtype=np.int16).reshape(8, 16) * 37
    raw[2, 3] = -32768
    path = scaled_tif(tmp_path / "dm.tif", raw)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        heights = read_dem(path).heights
    expect = raw.astype(np.float64) * 0.1 + 100.0
    expect[2, 3] = np.nan
    np.testing.assert_array_equal(heights, expect)
    assert any("scale 0.1 and offset 100" in str(w.message) for w in caught)
    tiled = scaled_tif(tmp_path / "tiled.tif", np.tile(raw, (4, 2)), tile=(16, 16))
    with pytest.warns(InputWarning, match="scale 0.1 and offset 100"):
        windows = open_dem(tiled)
    with windows:
        np.testing.assert_array_equal(windows.read(8, 24, 5, 29), np.tile(expect, (4, 2))[8:24, 5:29])


@pytest.mark.parametrize("metadata, expect", [
    (None, (1.0, 0.0)),
    ("<GDALMetadata><Item name='X' role='description' sample='0'>a</Item></GDALMetadata>", (1.0, 0.0)),
    ('<GDALMetadata><Item name="SCALE" sample="1" role="scale">2</Item></GDALMetadata>', (1.0, 0.0)),
    ('<GDALMetadata><Item name="SCALE" sample="0" role="scale">0.25</Item></GDALMetadata>', (0.25, 0.0)),
])
def test_gdal_band_scaling_reads_the_band_asked(metadata, expect):
    assert gdal_band_scaling(metadata, 0) == expect


def test_a_zero_scale_is_refused():
    with pytest.raises(ValueError, match="non-zero scale"):
        gdal_band_scaling('<GDALMetadata><Item name="SCALE" sample="0" role="scale">0</Item></GDALMetadata>', 0)


@pytest.mark.skipif(shutil.which("gdal_translate") is None, reason="gdal_translate (apt gdal-bin) not installed")
def test_gdal_unscales_the_same_way(tmp_path):
    """gdal_translate -a_scale/-a_offset writes the scaling; gdal_translate -unscale applies it:
    oclshade reads the scaled file as GDAL's unscaled float64 copy."""
    raw = (np.arange(12 * 20, dtype=np.int16).reshape(12, 20) * 13 - 1500)
    plain = scaled_tif(tmp_path / "plain.tif", raw, metadata="<GDALMetadata></GDALMetadata>")
    scaled, unscaled = tmp_path / "scaled.tif", tmp_path / "unscaled.tif"
    subprocess.run(["gdal_translate", "-q", "-a_scale", "0.01", "-a_offset", "-3.5", str(plain), str(scaled)],
                   check=True)
    subprocess.run(["gdal_translate", "-q", "-unscale", "-ot", "Float64", str(scaled), str(unscaled)], check=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        ours, gdal = read_dem(scaled).heights, read_dem(unscaled).heights
    np.testing.assert_allclose(ours, gdal, rtol=0, atol=1e-12)
    assert not np.allclose(ours, raw)
