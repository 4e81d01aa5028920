"""Raster input/output: DEMs in (GeoTIFF, SRTM .hgt/.zip, ESRI .asc, .npy, .exr, .png), results out.

Reading gives a :class:`Raster`: float64 heights with NaN for nodata, row 0
north, and cell sizes in metres (geographic rasters are converted at their
centre latitude on the WGS84 ellipsoid). Writing is atomic: a temporary file
in the destination directory is renamed over the target only once complete.
"""
from __future__ import annotations

import math
import os
import re
import secrets
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import OpenEXR
import tifffile
from PIL import Image

__all__ = ["Raster", "RasterIOError", "metres_per_degree", "read_dem", "write_raster"]

# GeoTIFF tags copied verbatim by write_raster (tifffile tag dtype codes: 12 double, 3 short, 2 ascii)
GEOTIFF_TAGS = {33550: 12, 33922: 12, 34264: 12, 34735: 3, 34736: 12, 34737: 2}
_TAG_NODATA = 42113
_TAG_GDAL_METADATA = 42112

_WGS84_A = 6378137.0
_WGS84_E2 = (1.0 / 298.257223563) * (2.0 - 1.0 / 298.257223563)



def _georef_4326(scale: float, west: float, north: float, pixel_is_point: bool) -> dict:
    """GeoTIFF tags of an EPSG:4326 raster whose raster point (0, 0) is at (west, north)."""
    geokeys = (1, 1, 0, 5, 1024, 0, 1, 2, 1025, 0, 1, 2 if pixel_is_point else 1,
               2048, 0, 1, 4326, 2049, 34737, 7, 0, 2054, 0, 1, 9102)
    return {33550: (scale, scale, 0.0), 33922: (0.0, 0.0, 0.0, west, north, 0.0),
            34735: geokeys, 34736: (298.257223563, 6378137.0), 34737: "WGS 84|"}


class RasterIOError(ValueError):
    """A raster file cannot be read or written; the message names the path and the problem."""


@dataclass
class Raster:
    """A DEM read from a file: float64 heights (NaN = nodata), row 0 north, cell sizes in metres."""

    heights: np.ndarray
    dx: float
    dy: float
    nodata: float | None = None
    geographic: bool = False
    georef: dict = field(default_factory=dict)
    path: str | None = None


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """(east-west metres per degree of longitude, north-south metres per degree of latitude), WGS84."""
    phi = math.radians(lat_deg)
    w = 1.0 - _WGS84_E2 * math.sin(phi) ** 2
    rad = math.pi / 180.0
    return (rad * _WGS84_A * math.cos(phi) / math.sqrt(w),
            rad * _WGS84_A * (1.0 - _WGS84_E2) / w ** 1.5)


def _err(path: object, what: str) -> RasterIOError:
    return RasterIOError(f"{os.fspath(path)}: {' '.join(str(what).split())}")


def _cellsize(path: object, cellsize: float | tuple[float, float]) -> tuple[float, float]:
    vals = cellsize if isinstance(cellsize, (tuple, list)) else (cellsize, cellsize)
    try:
        dx, dy = (float(v) for v in vals)
    except (TypeError, ValueError):
        raise _err(path, f"cellsize must be a positive number or (dx, dy), got {cellsize!r}") from None
    if not (math.isfinite(dx) and math.isfinite(dy) and dx > 0 and dy > 0):
        raise _err(path, f"cellsize must be positive and finite, got {cellsize!r}")
    return dx, dy


def _heights(path: object, raw: np.ndarray, nodata: float | None) -> np.ndarray:
    """float64 copy of a 2-D numeric array with nodata (compared in the file's dtype) as NaN."""
    raw = np.asarray(raw)
    if raw.dtype.kind not in "iuf":
        raise _err(path, f"expected a numeric raster, got dtype {raw.dtype}")
    if raw.ndim != 2 or raw.size == 0:
        raise _err(path, f"expected a non-empty 2-D raster (rows, cols), got shape {raw.shape}")
    out = raw.astype(np.float64)
    if nodata is not None:
        if math.isnan(nodata):
            pass  # NaN is already NaN
        elif raw.dtype.kind == "f":
            out[raw == raw.dtype.type(nodata)] = np.nan
        elif float(nodata).is_integer() and np.can_cast(np.min_scalar_type(int(nodata)), raw.dtype):
            out[raw == int(nodata)] = np.nan
    return out


# ----------------------------------------------------------------------------- GeoTIFF

def _first_band(page: tifffile.TiffPage, arr: np.ndarray) -> np.ndarray:
    axes = page.axes
    if "S" in axes and arr.ndim == len(axes):
        arr = np.take(arr, 0, axis=axes.index("S"))
    return arr.squeeze() if arr.ndim > 2 else arr


def _geokey(keys: Sequence[int], key_id: int) -> int | None:
    for k in range(4, len(keys) - 3, 4):
        if keys[k] == key_id and keys[k + 1] == 0:
            return int(keys[k + 3])
    return None


def _read_tif(path: Path) -> tuple[np.ndarray, float | None, bool, dict, tuple[float, float] | None]:
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        tags = {t.code: t.value for t in page.tags.values()}
        raw = _first_band(page, page.asarray())   # LZW/DEFLATE/predictors: imagecodecs
    georef = {code: tags[code] for code in GEOTIFF_TAGS if code in tags}
    nodata = None
    if _TAG_NODATA in tags and str(tags[_TAG_NODATA]).strip():
        nodata = float(str(tags[_TAG_NODATA]).strip())
    geographic = _geokey(tags.get(34735, ()), 1024) == 2
    rows, cols = raw.shape[:2]
    cell = None
    if 34264 in tags:  # ModelTransformation, row-major 4x4: x = a i + b j + d, y = e i + f j + h
        a, b, _, d, e, f, _, h = tags[34264][:8]
        cell = (math.hypot(a, e), math.hypot(b, f))
        centre_lat = e * cols / 2 + f * rows / 2 + h
    elif 33550 in tags:
        cell = (float(tags[33550][0]), float(tags[33550][1]))
        tie = tags.get(33922)
        centre_lat = None if tie is None else tie[4] + (tie[1] - rows / 2) * cell[1]
    if geographic and cell is not None:
        if centre_lat is None:
            raise ValueError("geographic GeoTIFF without ModelTiepoint: cannot convert degrees to "
                             "metres (pass cellsize)")
        mx, my = metres_per_degree(centre_lat)
        cell = (cell[0] * mx, cell[1] * my)
    return raw, nodata, geographic, georef, cell


# ----------------------------------------------------------------------------- SRTM .hgt

_HGT_NAME = re.compile(r"([NS])(\d{1,2})([EW])(\d{1,3})", re.IGNORECASE)


def _read_hgt(path: Path) -> Raster:
    name = path.name
    if path.suffix.lower() == ".zip":
        with zipfile.ZipFile(path) as zf:
            members = [m for m in zf.namelist() if m.lower().endswith(".hgt")]
            if len(members) != 1:
                raise ValueError(f"expected exactly one .hgt file in the zip, found {len(members)}")
            name, data = Path(members[0]).name, zf.read(members[0])
    else:
        data = path.read_bytes()
    match = _HGT_NAME.search(name) or _HGT_NAME.search(path.name)
    if match is None:
        raise ValueError(f"SRTM file name {name!r} does not give the tile corner (e.g. N22W160.hgt)")
    lat = int(match[2]) * (1 if match[1].upper() == "N" else -1)
    lon = int(match[4]) * (1 if match[3].upper() == "E" else -1)
    side = {1201 * 1201 * 2: 1201, 3601 * 3601 * 2: 3601}.get(len(data))
    if side is None:
        raise ValueError(f"SRTM .hgt must hold 1201x1201 or 3601x3601 int16 samples, got {len(data)} bytes")
    raw = np.frombuffer(data, dtype=">i2").reshape(side, side).astype(np.int16)
    step = 1.0 / (side - 1)
    mx, my = metres_per_degree(lat + 0.5)
    georef = _georef_4326(step, float(lon), float(lat + 1), pixel_is_point=True)  # samples on corners
    return Raster(_heights(path, raw, -32768.0), step * mx, step * my, -32768.0, True, georef, None)


# ----------------------------------------------------------------------------- ESRI ASCII grid

def _read_asc(path: Path) -> Raster:
    header: dict[str, float] = {}
    with open(path, encoding="ascii", errors="replace") as fh:
        while True:
            pos = fh.tell()
            line = fh.readline()
            parts = line.split()
            if not parts or not parts[0][0].isalpha():
                fh.seek(pos)
                break
            header[parts[0].lower()] = float(parts[1])
        body = fh.read()
    try:
        ncols, nrows = int(header["ncols"]), int(header["nrows"])
        cx = header.get("cellsize", header.get("dx"))
        cy = header.get("cellsize", header.get("dy"))
        centre = "xllcenter" in header
        x0 = header["xllcenter" if centre else "xllcorner"]
        y0 = header["yllcenter" if centre else "yllcorner"]
    except KeyError as exc:
        raise ValueError(f"ESRI ASCII grid header lacks {exc.args[0]}") from None
    if cx is None or cy is None:
        raise ValueError("ESRI ASCII grid header lacks cellsize")
    with warnings.catch_warnings():  # a bad token ends the parse early; the count check reports it
        warnings.simplefilter("ignore", DeprecationWarning)
        values = np.fromstring(body, dtype=np.float64, sep=" ")
    if values.size != nrows * ncols:
        raise ValueError(f"expected {nrows}x{ncols} values, found {values.size}")
    nodata = header.get("nodata_value")
    if centre:  # to lower-left corner
        x0, y0 = x0 - cx / 2, y0 - cy / 2
    geographic = cx < 1 and cy < 1 and abs(x0) <= 180 and abs(y0) <= 90
    dx, dy = cx, cy
    if geographic and cx == cy:
        georef = _georef_4326(cx, x0, y0 + nrows * cy, pixel_is_point=False)
    else:  # transform only: the CRS of a projected .asc is unknown
        georef = {33550: (cx, cy, 0.0), 33922: (0.0, 0.0, 0.0, x0, y0 + nrows * cy, 0.0)}
    if geographic:
        mx, my = metres_per_degree(y0 + nrows * cy / 2)
        dx, dy = cx * mx, cy * my
    heights = _heights(path, values.reshape(nrows, ncols), nodata)
    return Raster(heights, dx, dy, nodata, geographic, georef, None)


# ----------------------------------------------------------------------------- EXR / PNG

def _read_exr(path: Path) -> np.ndarray:
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        channels = exr.channels()
        if not channels:
            raise ValueError("EXR file has no channels")
        name = next((c for c in ("Z", "Y", "R") if c in channels), sorted(channels)[0])
        return np.array(channels[name].pixels, dtype=np.float64)


def _read_png(path: Path) -> np.ndarray:
    with Image.open(path) as img:
        if img.mode not in ("L", "I", "F") and not img.mode.startswith("I;16"):
            raise ValueError(f"expected a greyscale (8- or 16-bit) PNG, got mode {img.mode}")
        return np.asarray(img)


def read_dem(path: str | os.PathLike, cellsize: float | tuple[float, float] | None = None) -> Raster:
    """Read a DEM; the format follows the extension (.tif/.tiff, .hgt, .zip, .asc, .npy, .exr, .png).

    ``cellsize`` (one number or (dx, dy), metres) overrides the file's cell size;
    files without one (.npy, .png, .exr, plain TIFF) default to 1.0.
    Raises :class:`RasterIOError` naming the path on any problem.
    """
    p = Path(path)
    ext = p.suffix.lower()
    readers = (".tif", ".tiff", ".hgt", ".zip", ".asc", ".npy", ".exr", ".png")
    if ext not in readers:
        raise _err(p, f"unknown raster extension {p.suffix!r}; expected one of {', '.join(readers)}")
    if not p.is_file():
        raise _err(p, "no such file")
    try:
        if ext in (".hgt", ".zip"):
            raster = _read_hgt(p)
        elif ext == ".asc":
            raster = _read_asc(p)
        elif ext in (".tif", ".tiff"):
            raw, nodata, geographic, georef, cell = _read_tif(p)
            dx, dy = cell if cell is not None else (1.0, 1.0)
            raster = Raster(_heights(p, raw, nodata), dx, dy, nodata, geographic, georef, None)
        else:
            raw = {".npy": np.load, ".exr": _read_exr, ".png": _read_png}[ext](p)
            raster = Raster(_heights(p, raw, None), 1.0, 1.0)
    except RasterIOError:
        raise
    except (OSError, ValueError, TypeError, KeyError, IndexError, EOFError, zipfile.BadZipFile) as exc:
        raise _err(p, f"cannot read as {ext[1:]} raster: {exc}") from exc
    if cellsize is not None:
        raster.dx, raster.dy = _cellsize(p, cellsize)
    raster.path = str(p)
    return raster


# ----------------------------------------------------------------------------- writing

def _write_tif(tmp: str, data: np.ndarray, like: Raster | None, nodata: float | None,
               band_names: Sequence[str] | None) -> None:
    extratags = []
    for code, value in sorted((like.georef if like is not None else {}).items()):
        dtype = GEOTIFF_TAGS.get(code)
        if dtype is not None:
            value = str(value) if dtype == 2 else tuple(value)
            extratags.append((code, dtype, 0 if dtype == 2 else len(value), value, True))
    if nodata is not None:
        extratags.append((_TAG_NODATA, 2, 0, f"{float(nodata):.17g}", True))
    if band_names:
        items = "".join(f'<Item name="DESCRIPTION" sample="{i}" role="description">{n}</Item>'
                        for i, n in enumerate(band_names))
        extratags.append((_TAG_GDAL_METADATA, 2, 0, f"<GDALMetadata>{items}</GDALMetadata>", True))
    try:
        tifffile.TIFF.COMPRESSORS[8]
        compression = "zlib"
    except (KeyError, NotImplementedError):
        compression = None
    tifffile.imwrite(tmp, data[0] if data.shape[0] == 1 else data, photometric="minisblack",
                     planarconfig="separate", compression=compression, extratags=extratags)


def _write_exr(tmp: str, data: np.ndarray, band_names: Sequence[str] | None) -> None:
    names = list(band_names) if band_names else (["Y"] if len(data) == 1 else [f"B{i}" for i in range(len(data))])
    channels = {n: np.ascontiguousarray(b, dtype=np.float32) for n, b in zip(names, data)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as exr:
        exr.write(tmp)


def _write_npy(tmp: str, data: np.ndarray) -> None:
    np.save(tmp, data[0] if data.shape[0] == 1 else data)


def _write_png(tmp: str, image: np.ndarray) -> None:
    Image.fromarray(image).save(tmp, format="PNG")


def _png_image(path: object, bands: np.ndarray | Sequence[np.ndarray]) -> np.ndarray:
    img = np.asarray(bands)
    if img.ndim == 3 and img.shape[0] == 1:
        img = img[0]
    ok = (img.ndim == 2 and img.dtype in (np.uint8, np.uint16)) or \
         (img.ndim == 3 and img.shape[2] in (3, 4) and img.dtype == np.uint8)
    if not ok:
        raise _err(path, f"PNG output needs a uint8/uint16 (rows, cols) band or a uint8 "
                         f"(rows, cols, 3|4) RGB(A) image, got {img.dtype} {img.shape}")
    return img


def _stack_bands(path: object, bands: np.ndarray | Sequence[np.ndarray]) -> np.ndarray:
    if isinstance(bands, np.ndarray):
        data = bands[None] if bands.ndim == 2 else bands
    else:
        arrays = [np.asarray(b) for b in bands]
        if not arrays or any(a.ndim != 2 or a.shape != arrays[0].shape for a in arrays):
            raise _err(path, f"bands must be equally shaped 2-D arrays, got shapes "
                             f"{[a.shape for a in arrays]}")
        data = np.stack(arrays)
    if data.ndim != 3 or data.size == 0:
        raise _err(path, f"bands must be a 2-D array or a (bands, rows, cols) stack, got shape {data.shape}")
    if data.dtype.kind not in "buif":
        raise _err(path, f"bands must be numeric, got dtype {data.dtype}")
    return data.astype(np.uint8) if data.dtype.kind == "b" else data


def write_raster(path: str | os.PathLike, bands: np.ndarray | Sequence[np.ndarray],
                 like: Raster | None = None, nodata: float | None = None,
                 band_names: Sequence[str] | None = None) -> None:
    """Write one band or several equally shaped bands; the format follows the extension.

    ``.tif/.tiff``: planar bands, dtype kept, georeferencing copied from ``like``,
    GDAL_NODATA from ``nodata``, band names as GDAL descriptions. ``.exr``: float32
    channels named ``band_names`` (default "Y" for one band, else "B0", "B1", ...).
    ``.npy``: the 2-D array for one band, else (bands, rows, cols). ``.png``: a uint8 or
    uint16 band or a uint8 RGB(A) image. The write is atomic and never replaces ``like``'s file.
    """
    p = Path(path)
    ext = p.suffix.lower()
    writers: dict[str, Callable[[str], None]]
    if ext == ".png":
        image = _png_image(p, bands)
        writers = {".png": lambda tmp: _write_png(tmp, image)}
    else:
        data = _stack_bands(p, bands)
        if band_names is not None and len(band_names) != data.shape[0]:
            raise _err(p, f"{len(band_names)} band names given for {data.shape[0]} bands")
        if like is not None and like.heights.shape != data.shape[1:]:
            raise _err(p, f"bands of shape {data.shape[1:]} do not match the georeferenced "
                          f"raster {like.heights.shape}")
        writers = {
            ".tif": lambda tmp: _write_tif(tmp, data, like, nodata, band_names),
            ".exr": lambda tmp: _write_exr(tmp, data, band_names),
            ".npy": lambda tmp: _write_npy(tmp, data),
        }
        writers[".tiff"] = writers[".tif"]
    if ext not in writers:
        raise _err(p, f"unknown output extension {p.suffix!r}; expected .tif, .tiff, .exr, .npy or .png")
    if like is not None and like.path is not None and os.path.realpath(p) == os.path.realpath(like.path):
        raise _err(p, "refusing to overwrite the input raster")
    if not p.parent.is_dir():
        raise _err(p, "output directory does not exist")
    tmp = p.with_name(f".{p.stem}.tmp-{secrets.token_hex(4)}{p.suffix}")
    try:
        with open(tmp, "xb"):
            pass
        writers[ext](str(tmp))
        os.replace(tmp, p)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, (OSError, ValueError, TypeError, RuntimeError)):
            raise _err(p, f"cannot write {ext[1:]} raster: {exc}") from exc
        raise
