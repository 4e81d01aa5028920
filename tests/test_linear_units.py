"""Projected GeoTIFFs in feet: their cells are converted to metres, as an ESRI grid's with the
same CRS in its .prj (a 10 ft grid has 3.048 m cells), with a warning naming -z for the heights."""
import warnings

import numpy as np
import pytest
import tifffile

pyproj = pytest.importorskip("pyproj")

from oclshade.heightmap import InputWarning  # noqa: E402
from oclshade.io import read_dem  # noqa: E402

US_FOOT = 1200.0 / 3937.0


def projected_tif(path, keys, cell=10.0, doubles=None):
    tags = [(33550, 12, 3, (cell, cell, 0.0), True), (33922, 12, 6, (0, 0, 0, 6000000.0, 2000000.0, 0), True),
            (34735, 3, len(keys), keys, True)]
    if doubles is not None:
        tags.append((34736, 12, len(doubles), doubles, True))
    tifffile.imwrite(path, np.zeros((4, 5), np.float32), extratags=tags)
    return path


def read(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        raster = read_dem(path)
    return raster, [str(w.message) for w in caught]


@pytest.mark.parametrize("keys, doubles, metres, unit", [
    ((1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 2227), None, US_FOOT, "US survey foot"),
    ((1, 1, 0, 4, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32767, 3076, 0, 1, 9002), None, 0.3048, "foot"),
    ((1, 1, 0, 4, 1024, 0, 1, 1, 1025, 0, 1, 1, 3076, 0, 1, 32767, 3077, 34736, 1, 0), (0.201168,), 0.201168,
     "user-defined unit"),
])
def test_a_geotiff_in_feet_has_its_cells_in_metres(tmp_path, keys, doubles, metres, unit):
    raster, notes = read(projected_tif(tmp_path / "ft.tif", keys, doubles=doubles))
    assert (raster.dx, raster.dy) == (pytest.approx(10.0 * metres, rel=1e-12),) * 2
    assert len(notes) == 1 and unit in notes[0] and f"-z {metres:.10g}" in notes[0]


def test_a_geotiff_in_metres_is_read_as_before(tmp_path):
    raster, notes = read(projected_tif(tmp_path / "m.tif", (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1,
                                                            3072, 0, 1, 32633)))
    assert (raster.dx, raster.dy, notes) == (10.0, 10.0, [])


def test_a_geotiff_and_an_esri_grid_in_feet_read_alike(tmp_path):
    """The same 10 ft grid as a GeoTIFF keyed EPSG:2227 and as an ESRI ASCII grid whose .prj is
    that CRS's WKT: the same cell size in metres, and both warn."""
    tif, tif_notes = read(projected_tif(tmp_path / "ft.tif", (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1,
                                                              3072, 0, 1, 2227)))
    asc = tmp_path / "ft.asc"
    asc.write_text("ncols 5\nnrows 4\nxllcorner 6000000\nyllcorner 1999960\ncellsize 10\n"
                   + "0 0 0 0 0\n" * 4)
    (tmp_path / "ft.prj").write_text(pyproj.CRS.from_epsg(2227).to_wkt("WKT1_GDAL"))
    grid, grid_notes = read(asc)
    assert (grid.dx, grid.dy) == (pytest.approx(tif.dx, rel=1e-12), pytest.approx(tif.dy, rel=1e-12))
    assert tif_notes and grid_notes and all("-z 0.3048006096" in n for n in tif_notes + grid_notes)


def test_heights_the_file_says_are_in_feet_are_named(tmp_path):
    """VerticalUnitsGeoKey 9002 on a metre grid: the heights stay as they are (the convention:
    metres after -z) and the warning names -z 0.3048."""
    keys = (1, 1, 0, 4, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633, 4099, 0, 1, 9002)
    raster, notes = read(projected_tif(tmp_path / "zft.tif", keys))
    assert (raster.dx, raster.dy) == (10.0, 10.0)
    assert len(notes) == 1 and "heights in foot" in notes[0] and notes[0].endswith("add -z 0.3048 to use them as metres")
