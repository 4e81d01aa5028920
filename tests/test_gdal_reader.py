"""The optional GDAL reader (oclshade.gdal_reader; pip install 'oclshade[gdal]'): read only
where rasterio is installed; without it, the built-in readers and their refusals stay."""
from __future__ import annotations

import numpy as np
import pytest

from oclshade import gdal_reader
from oclshade.cli import main
from oclshade.heightmap import InputWarning
from oclshade.io import Raster, RasterIOError, read_dem, write_raster
from oclshade.synthetic import canyon_crater

UTM = {33550: (30.0, 30.0, 0.0), 33922: (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0),
       34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}


def test_without_rasterio_the_builtin_readers_refuse(tmp_path, monkeypatch):
    monkeypatch.setattr(gdal_reader, "available", lambda: False)
    with pytest.raises(RasterIOError, match=r"https://example.org/dem.tif: URLs and GDAL virtual paths need "
                                            r"the optional GDAL reader \(pip install 'oclshade\[gdal\]'\)"):
        read_dem("https://example.org/dem.tif")
    (tmp_path / "dem.vrt").write_text("<VRTDataset/>")
    with pytest.raises(RasterIOError, match="dem.vrt: unknown raster extension '.vrt'"):
        read_dem(tmp_path / "dem.vrt")


@pytest.fixture()
def utm_tif(tmp_path):
    dem = canyon_crater(40, 56, seed=2, relief=600.0).astype(np.float32)
    dem[0, :3] = -9999
    path = tmp_path / "dem.tif"
    bands = np.stack([dem, np.where(dem == -9999, dem, dem + 1)])
    write_raster(path, bands, like=Raster(dem, 30.0, 30.0, georef=UTM), nodata=-9999, band_names=["height", "plus one"])
    return path, dem


def test_vrt_and_virtual_paths_read_as_the_geotiff(tmp_path, utm_tif):
    pytest.importorskip("rasterio")
    tif, _ = utm_tif
    with pytest.warns(InputWarning, match=r"the file has 2 bands; reading band 1"):
        want = read_dem(tif)
    band2 = read_dem(tif, band=2).heights                                  # the built-in reader
    vrt = tmp_path / "dem.vrt"
    vrt.write_text('<VRTDataset rasterXSize="56" rasterYSize="40"><SRS>EPSG:32633</SRS>'
                   '<GeoTransform>500000, 30, 0, 4000000, 0, -30</GeoTransform>'
                   '<VRTRasterBand dataType="Float32" band="1"><NoDataValue>-9999</NoDataValue>'
                   '<SimpleSource><SourceFilename relativeToVRT="1">dem.tif</SourceFilename>'
                   '<SourceBand>2</SourceBand></SimpleSource></VRTRasterBand></VRTDataset>')
    got = read_dem(vrt)
    np.testing.assert_array_equal(got.heights, band2)          # band 2 of the GeoTIFF, nodata kept
    assert (got.dx, got.dy, got.geographic) == (30.0, 30.0, False)
    assert got.crs_wkt.endswith('AUTHORITY["EPSG","32633"]]')
    assert got.georef == {33550: (30.0, 30.0, 0.0), 33922: (0.0, 0.0, 0.0, 500000.0, 4000000.0, 0.0)}
    assert read_dem(vrt, nodata=-9998).heights[0, 0] != read_dem(vrt).heights[0, 0]
    assert read_dem(vrt, cellsize=(2, 3)).dx == 2
    virtual = f"/vsizip/{tmp_path / 'dem.zip'}/dem.tif"                     # a GDAL virtual path
    import zipfile
    with zipfile.ZipFile(tmp_path / "dem.zip", "w") as zf:
        zf.write(tif, "dem.tif")
    np.testing.assert_array_equal(read_dem(virtual, band=2).heights, band2)
    with pytest.warns(InputWarning, match=r"dem.tif: the file has 2 bands; reading band 1 \(height\)"):
        np.testing.assert_array_equal(read_dem(virtual).heights, want.heights)
    with pytest.raises(RasterIOError, match="dem.tif: band 3 requested but the file has 2 band"):
        read_dem(virtual, band=3)
    with pytest.raises(RasterIOError, match="missing.vrt: cannot read with GDAL"):
        read_dem(tmp_path / "missing.vrt")


def test_geographic_cells_in_metres_and_the_cli(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import Affine

    dem = canyon_crater(48, 64, seed=4, relief=900.0).astype(np.float32)
    path = tmp_path / "dem.img"                                           # ERDAS Imagine: no built-in reader
    with rasterio.open(path, "w", driver="HFA", width=64, height=48, count=1, dtype="float32",
                       crs="EPSG:4326", transform=Affine(1 / 1200, 0, 10.0, 0, -1 / 1200, 46.0)) as ds:
        ds.write(dem, 1)
    r = read_dem(path)
    assert r.geographic and r.dx == pytest.approx(1 / 1200 * 77_640, rel=2e-3)   # metres at 46 N
    assert r.dy == pytest.approx(92.6, rel=2e-3)
    out = tmp_path / "mask.tif"
    assert main(["shadow", str(path), str(out), "-q"]) == 0
    assert main(["shadow", str(path), str(out), "-s", "111120"]) == 2     # the geographic check applies
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 4326 and ds.transform.c == pytest.approx(10.0)
