"""Optional GDAL reader (``pip install 'oclshade[gdal]'``, which brings rasterio): DEMs in
any format GDAL reads (VRT, NetCDF, JPEG2000, ...), and URLs or GDAL virtual paths
(``https://``, ``s3://``, ``/vsicurl/...``). :func:`oclshade.io.read_dem` hands over
what its own readers do not know when rasterio imports; without it they are refused
as before. One job: band N, its nodata, the transform and the CRS into a :class:`~oclshade.io.Raster`.
"""
from __future__ import annotations

import importlib.util
import math
import os
import warnings

import numpy as np

from . import io as rio
from .heightmap import InputWarning

__all__ = ["available", "read_with_gdal"]


def available() -> bool:
    """Whether rasterio (hence GDAL) is installed."""
    return importlib.util.find_spec("rasterio") is not None


def read_with_gdal(path: str | os.PathLike, band: int | None = None, nodata: float | None = None) -> rio.Raster:
    """Band ``band`` (1-based; None: band 1, with an InputWarning when there are more) of a raster
    GDAL opens, as :func:`oclshade.io.read_dem` gives it: float64 heights with NaN for nodata
    (the file's, or ``nodata``, compared in the file's data type) and for masked cells, cell
    sizes in metres (degrees converted at the centre latitude, projected units by the CRS's
    linear unit), the transform as GeoTIFF tags and the CRS as WKT (``crs_wkt``).
    Raises :class:`~oclshade.io.RasterIOError` naming the path."""
    import rasterio

    text = os.fspath(path)
    try:
        with rasterio.open(text) as ds:
            if band is not None and band > ds.count:
                raise rio.RasterIOError(f"{text}: band {band} requested but the file has {ds.count} band(s)")
            b = band or 1
            if band is None and ds.count > 1:
                name = ds.descriptions[0]
                warnings.warn(f"{text}: the file has {ds.count} bands; reading band 1{f' ({name})' if name else ''} "
                              f"(choose one with -b BAND, or band=)", InputWarning, stacklevel=3)
            if nodata is None:
                data = ds.read(b, masked=True)
            else:
                raw = ds.read(b)
                data = np.ma.masked_array(raw, raw == (raw.dtype.type(nodata) if raw.dtype.kind == "f" else nodata))
            file_nodata = ds.nodatavals[b - 1]
            scale, offset = float(ds.scales[b - 1]), float(ds.offsets[b - 1])
            transform, crs, (rows, cols) = ds.transform, ds.crs, data.shape
    except rio.RasterIOError:
        raise
    except Exception as exc:  # noqa: BLE001 - rasterio/GDAL raise their own kinds; name the path
        raise rio.RasterIOError(f"{text}: cannot read with GDAL: {' '.join(str(exc).split())}") from exc
    if data.dtype.kind not in "iuf":
        raise rio.RasterIOError(f"{text}: expected a numeric raster, got dtype {data.dtype}")
    heights = data.astype(np.float64).filled(np.nan)
    if scale != 1.0 or offset != 0.0:
        heights = heights * scale + offset
        warnings.warn(f"{text}: {rio.scaling_note(scale, offset)}", InputWarning, stacklevel=3)
    georef: dict = {}
    dx = dy = 1.0
    if crs is not None or not transform.is_identity:
        a, b_, c, d, e, f = transform.a, transform.b, transform.c, transform.d, transform.e, transform.f
        if b_ == 0.0 and d == 0.0:
            georef = {33550: (a, -e, 0.0), 33922: (0.0, 0.0, 0.0, c, f, 0.0)}
        else:
            georef = {34264: (a, b_, 0.0, c, d, e, 0.0, f, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)}
        rio.require_north_up(text, georef)
        dx, dy = math.hypot(a, d), math.hypot(b_, e)
        if crs is not None and crs.is_geographic:
            lat = d * cols / 2 + e * rows / 2 + f
            if not -90.0 <= lat <= 90.0:
                raise rio.RasterIOError(f"{text}: geographic raster centred at latitude {lat:.9g}, outside -90..90")
            mx, my = rio.metres_per_degree(lat)
            dx, dy = dx * mx, dy * my
        elif crs is not None:
            name, factor = crs.linear_units_factor
            dx, dy = dx * factor, dy * factor
            if factor != 1.0:
                warnings.warn(f"{text}: {rio.unit_note(name, factor)}", InputWarning, stacklevel=3)
        else:
            warnings.warn(f"{text}: no CRS: cell size {dx:g} x {dy:g} taken as metres", InputWarning, stacklevel=3)
    return rio.Raster(heights, dx, dy, file_nodata if nodata is None else nodata,
                      bool(crs is not None and crs.is_geographic), georef, text,
                      None if crs is None else crs.to_wkt())
