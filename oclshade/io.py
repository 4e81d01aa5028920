"""Raster input/output: DEMs in (GeoTIFF, SRTM .hgt/.zip, ESRI .asc, .npy, .exr, .png), results out.

Reading gives a :class:`Raster`: float64 heights with NaN for nodata, row 0
north, and cell sizes in metres (geographic rasters are converted at their
centre latitude on the WGS84 ellipsoid: the grid's scale; each row's own is
traced through oclshade.solar, docs/methods.md "Geographic grids"). Writing is atomic: a temporary file
in the destination directory is renamed over the target only once complete.
"""
from __future__ import annotations

import math
import os
import re
import secrets
import stat
import tempfile
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Callable, Mapping, NoReturn, Sequence
from xml.sax.saxutils import escape as xml_escape

import numpy as np
import OpenEXR
import tifffile
from PIL import Image

from . import gdal_reader
from .geotiff import GeoTiffWriter, tiff_options
from .heightmap import InputWarning, extrema, nodata_value, ordinary_extrema

__all__ = ["DemWindows", "Raster", "RasterIOError", "RasterWriter", "decimated", "geotransform", "metres_per_degree",
           "open_dem", "read_dem", "write_raster"]

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


def _georef_crs(cx: float, cy: float, west: float, north: float, geographic: bool, epsg: int | None) -> dict:
    """GeoTIFF tags of a north-up raster whose top-left corner is (west, north); the CRS as an
    EPSG code in the geokeys when one is known (GeoTIFF keys are 16-bit: codes 1..32766)."""
    georef = {33550: (cx, cy, 0.0), 33922: (0.0, 0.0, 0.0, west, north, 0.0)}
    if epsg is not None and 0 < epsg < 32767:
        georef[34735] = (1, 1, 0, 3, 1024, 0, 1, 2 if geographic else 1, 1025, 0, 1, 1,
                         2048 if geographic else 3072, 0, 1, epsg)
    return georef


class RasterIOError(ValueError):
    """A raster file cannot be read or written; the message names the path and the problem."""


@dataclass
class Raster:
    """A DEM read from a file: float64 heights (NaN = nodata), row 0 north, cell sizes in metres.

    ``crs_wkt`` is the CRS as WKT where the file gives it so (an ESRI ASCII grid's
    ``.prj``), else None: GeoTIFF and SRTM input keep theirs in the geokeys of ``georef``.
    ``heights_range``: :meth:`extremes` where ``heights`` does not hold them (a windowed
    raster's placeholder, :func:`open_dem`, once a pass over its windows has read them); None:
    read from ``heights``.
    """

    heights: np.ndarray
    dx: float
    dy: float
    nodata: float | None = None
    geographic: bool = False
    georef: dict = field(default_factory=dict)
    path: str | None = None
    crs_wkt: str | None = None
    heights_range: tuple[float, float] | None = None

    def extremes(self) -> tuple[float, float]:
        """(min, max) of the valid heights but those equal to an undeclared nodata sentinel
        (:func:`oclshade.heightmap.ordinary_extrema`: the range the map's ground metres and
        scale bounds take), :attr:`heights_range` where given; (nan, nan) when none is valid."""
        if self.heights_range is not None:
            return self.heights_range
        return ordinary_extrema(self.heights, *extrema(self.heights))


@dataclass
class _Source:
    """What a reader found: the chosen band's samples (in the file's dtype) and what the file says."""

    raw: np.ndarray
    nodata: float | None = None
    geographic: bool = False
    georef: dict = field(default_factory=dict)
    cell: tuple[float, float] | None = None      # metres; None: the file does not say
    crs_wkt: str | None = None
    bands: int = 1                                # bands in the file
    band: int = 1                                 # the band read, 1-based
    band_name: str = ""
    notes: list[str] = field(default_factory=list)   # warnings for the user
    scale: float = 1.0                            # heights = raw x scale + offset (GDAL's band scale, offset)
    offset: float = 0.0
    valid: np.ndarray | None = None               # False: masked (GDAL's internal mask, an alpha band)


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """(east-west metres per degree of longitude, north-south metres per degree of latitude), WGS84."""
    phi = math.radians(lat_deg)
    w = 1.0 - _WGS84_E2 * math.sin(phi) ** 2
    rad = math.pi / 180.0
    return (rad * _WGS84_A * math.cos(phi) / math.sqrt(w),
            rad * _WGS84_A * (1.0 - _WGS84_E2) / w ** 1.5)


def _degree_cells(cx: float, cy: float, centre_lat: float) -> tuple[float, float]:
    """Cell sizes in degrees to metres at the raster's centre latitude."""
    if not -90.0 <= centre_lat <= 90.0:
        raise ValueError(f"geographic raster centred at latitude {centre_lat:.9g}, outside -90..90")
    mx, my = metres_per_degree(centre_lat)
    return cx * mx, cy * my


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


def _band_index(path: Path, count: int, band: int | None, default: int = 0) -> int:
    """0-based index of the 1-based ``band`` (``default`` when None) among ``count`` bands."""
    if band is None:
        return default
    if band > count:
        raise _err(path, f"band {band} requested but the file has {count} band(s)")
    return band - 1


def _heights(path: object, raw: np.ndarray, nodata: float | None, scale: float = 1.0,
             offset: float = 0.0, valid: np.ndarray | None = None) -> np.ndarray:
    """float64 copy of a 2-D numeric array with nodata (compared in the file's dtype) and the
    cells ``valid`` marks False as NaN, unscaled (raw x ``scale`` + ``offset``)."""
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
    if scale != 1.0 or offset != 0.0:
        out *= scale
        out += offset
    if valid is not None:
        out[~valid] = np.nan
    return out


def gdal_band_scaling(metadata: str | None, band_index: int) -> tuple[float, float]:
    """(scale, offset) of a band (0-based) from GDAL's metadata XML (TIFF tag 42112: Items with
    role "scale" and "offset"); (1, 0) where it says none."""
    import xml.etree.ElementTree as ET

    found = {"scale": 1.0, "offset": 0.0}
    if not metadata:
        return found["scale"], found["offset"]
    try:
        root = ET.fromstring(metadata)
    except ET.ParseError:
        return found["scale"], found["offset"]
    for item in root.iter("Item"):
        role, sample = item.get("role"), item.get("sample")
        if role in found and sample is not None and sample.strip() == str(band_index) and (item.text or "").strip():
            try:
                found[role] = float(item.text)
            except ValueError:
                raise ValueError(f"GDAL metadata {role} {item.text!r} of band {band_index + 1} is not a number") \
                    from None
    if not (math.isfinite(found["scale"]) and found["scale"] != 0.0 and math.isfinite(found["offset"])):
        raise ValueError(f"GDAL metadata scale {found['scale']!r} and offset {found['offset']!r} of band "
                         f"{band_index + 1}: expected a finite, non-zero scale and a finite offset")
    return found["scale"], found["offset"]


def scaling_note(scale: float, offset: float) -> str:
    """What a reader tells the user when it unscales a band."""
    return (f"heights unscaled by the file's band scale {scale:.10g} and offset {offset:.10g} (raw x scale + "
            f"offset, as gdal_translate -unscale); do not apply them again with -z")


# ----------------------------------------------------------------------------- GeoTIFF

def geokey(keys: Sequence[int], key_id: int) -> int | None:
    for k in range(4, len(keys) - 3, 4):
        if keys[k] == key_id and keys[k + 1] == 0:
            return int(keys[k + 3])
    return None


def _geokey_double(georef: dict, key_id: int) -> float | None:
    """A GeoTIFF key held in GeoDoubleParams (34736), e.g. ProjLinearUnitSizeGeoKey."""
    keys, doubles = georef.get(34735, ()), georef.get(34736, ())
    for k in range(4, len(keys) - 3, 4):
        if keys[k] == key_id and keys[k + 1] == 34736 and keys[k + 3] < len(doubles):
            return float(doubles[keys[k + 3]])
    return None


def _projected_unit(georef: dict) -> tuple[str, float] | None:
    """(name, metres) of a projected GeoTIFF's linear unit: ProjLinearUnitsGeoKey (an EPSG unit
    code, or user-defined with ProjLinearUnitSizeGeoKey), else the unit of the EPSG projected CRS
    (pyproj); None when the keys say neither."""
    import pyproj

    keys = georef.get(34735, ())
    code = geokey(keys, 3076)
    if code == 32767:
        size = _geokey_double(georef, 3077)
        return None if size is None or not (math.isfinite(size) and size > 0) else ("user-defined unit", size)
    if code is not None:
        return _linear_unit(code)
    crs_code = geokey(keys, 3072)
    if crs_code is None or not 0 < crs_code < 32767:
        return None
    try:
        axis = pyproj.CRS.from_epsg(crs_code).axis_info[0]
    except pyproj.exceptions.CRSError:
        return None
    return axis.unit_name, float(axis.unit_conversion_factor)


def _linear_unit(code: int) -> tuple[str, float]:
    """(name, metres) of an EPSG linear unit code (9001 metre, 9002 foot, 9003 US survey foot, ...)."""
    import pyproj

    for unit in pyproj.database.get_units_map(auth_name="EPSG", category="linear").values():
        if int(unit.code) == code:
            return unit.name, float(unit.conv_factor)
    raise ValueError(f"GeoTIFF key gives linear unit {code}, which is not an EPSG linear unit code")


def unit_note(name: str, metres: float) -> str:
    """What a reader tells the user when it converts a projected CRS's cells to metres."""
    return (f"cells in {name} ({metres:.10g} m) converted to metres; the heights are used as they are: "
            f"if they are in the same unit, add -z {metres:.10g}")


def _mask_page(tif: tifffile.TiffFile) -> tifffile.TiffPage | None:
    """GDAL's internal nodata mask of the first page (``GDAL_TIFF_INTERNAL_MASK``): a later IFD
    of NewSubfileType mask (4), not an overview (1), of the same size; None without one."""
    first = tif.pages[0]
    for number in range(1, len(tif.pages)):
        page = tif.pages[number]
        if (page.subfiletype & 4 and not page.subfiletype & 1
                and (page.imagelength, page.imagewidth) == (first.imagelength, first.imagewidth)):
            return page
    return None


def _alpha_sample(page: tifffile.TiffPage, index: int) -> int | None:
    """The sample index of the page's alpha (ExtraSamples 1 or 2), which GDAL takes as the mask
    of every other band (0: masked); None without one, or when the band read is the alpha."""
    extras = tuple(page.extrasamples or ())
    for k, kind in enumerate(extras):
        if int(kind) in (1, 2):
            sample = page.samplesperpixel - len(extras) + k
            return None if sample == index else sample
    return None


def _read_tif(path: Path, band: int | None) -> _Source:
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        every = page.asarray()                    # LZW/DEFLATE/predictors: imagecodecs
        bands = page.samplesperpixel if "S" in page.axes and every.ndim == len(page.axes) else 1
        index = _band_index(path, bands, band)
        raw = np.take(every, index, axis=page.axes.index("S")) if bands > 1 else every
        raw = raw.squeeze() if raw.ndim > 2 else raw
        src = _tif_source(page, raw, bands, index)
        mask, alpha = _mask_page(tif), _alpha_sample(page, index) if bands > 1 else None
        if mask is not None:
            src.valid = mask.asarray().astype(bool).reshape(raw.shape)
        elif alpha is not None:
            src.valid = np.take(every, alpha, axis=page.axes.index("S")).reshape(raw.shape) != 0
        return src


def _tif_source(page: tifffile.TiffPage, raw: np.ndarray, bands: int, index: int) -> _Source:
    """What a GeoTIFF's first page says (georeferencing, nodata, cell size), with its band ``raw``."""
    tags = {t.code: t.value for t in page.tags.values()}
    georef = {code: tags[code] for code in GEOTIFF_TAGS if code in tags}
    nodata = None
    if _TAG_NODATA in tags and str(tags[_TAG_NODATA]).strip():
        nodata = float(str(tags[_TAG_NODATA]).strip())
    geographic = geokey(tags.get(34735, ()), 1024) == 2
    rows, cols = page.imagelength, page.imagewidth
    cell = None
    if 34264 in tags:  # ModelTransformation, row-major 4x4: x = a i + b j + d, y = e i + f j + h
        a, b, _, d, e, f, _, h = tags[34264][:8]
        cell = (math.hypot(a, e), math.hypot(b, f))
        centre_lat = e * cols / 2 + f * rows / 2 + h
    elif 33550 in tags:
        cell = (float(tags[33550][0]), float(tags[33550][1]))
        tie = tags.get(33922)
        centre_lat = None if tie is None else tie[4] + (tie[1] - rows / 2) * cell[1]
    notes = []
    if geographic and cell is not None:
        if centre_lat is None:
            raise ValueError("geographic GeoTIFF without ModelTiepoint: cannot convert degrees to "
                             "metres (pass cellsize)")
        cell = _degree_cells(*cell, centre_lat)
    elif cell is not None and geokey(tags.get(34735, ()), 1024) == 1:
        unit = _projected_unit(georef)
        if unit is not None and unit[1] != 1.0:
            cell = (cell[0] * unit[1], cell[1] * unit[1])
            notes.append(unit_note(*unit))
    vertical = geokey(tags.get(34735, ()), 4099)              # VerticalUnitsGeoKey
    if vertical is not None and vertical not in (9001, 32767):
        name, metres = _linear_unit(vertical)
        notes.append(f"the file gives its heights in {name} (VerticalUnitsGeoKey): they are used as they are; "
                     f"add -z {metres:.10g} to use them as metres")
    scale, offset = gdal_band_scaling(tags.get(_TAG_GDAL_METADATA), index)
    if scale != 1.0 or offset != 0.0:
        notes.append(scaling_note(scale, offset))
    return _Source(raw, nodata, geographic, georef, cell, bands=bands, band=index + 1, notes=notes,
                   scale=scale, offset=offset)


class _TiffWindows:
    """Windows of one band of a GeoTIFF's first page, decoding only the tiles or strips each
    window touches (tifffile's per-segment offsets and decoder)."""

    def __init__(self, path: Path, band: int | None):
        self.tif = tifffile.TiffFile(path)
        try:
            page = self.page = self.tif.pages[0]
            if page.is_tiled and page.tiledepth > 1:
                raise ValueError("volumetric (3-D tiled) TIFF is not a DEM")
            self.segment = self._segment(page)
            self.shape = (page.imagelength, page.imagewidth)
            self.bands = page.samplesperpixel
            self.index = _band_index(path, self.bands, band)
            self.source = _tif_source(page, np.empty((0, 0), page.dtype), self.bands, self.index)
            self.separate = page.planarconfig == 2 and self.bands > 1
            self.mask = _mask_page(self.tif)
            self.alpha = _alpha_sample(page, self.index) if self.bands > 1 else None
        except BaseException:
            self.tif.close()
            raise

    @staticmethod
    def _segment(page: tifffile.TiffPage) -> tuple[int, int]:
        """(rows, columns) of the page's tiles or strips."""
        if page.is_tiled:
            return page.tilelength, page.tilewidth
        return min(page.rowsperstrip, page.imagelength), page.imagewidth

    @property
    def segment_bytes(self) -> int:
        """Bytes of one decoded tile or strip (all its samples): the least a window read holds."""
        return self.segment[0] * self.segment[1] * self.page.dtype.itemsize * (1 if self.separate else self.bands)

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Samples [r0, r1) x [c0, c1) of the band, in the file's dtype."""
        return self._samples(self.page, self.index, r0, r1, c0, c1)

    def valid(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray | None:
        """Where the file's mask (internal, else alpha) keeps cells [r0, r1) x [c0, c1); None: no mask."""
        if self.mask is not None:
            return self._samples(self.mask, 0, r0, r1, c0, c1).astype(bool)
        if self.alpha is not None:
            return self._samples(self.page, self.alpha, r0, r1, c0, c1) != 0
        return None

    def _samples(self, page: tifffile.TiffPage, index: int, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Sample ``index`` of ``page`` over [r0, r1) x [c0, c1), decoding only the segments there."""
        sl, sw = self._segment(page)
        out = np.empty((r1 - r0, c1 - c0), page.dtype)
        down, across = -(-self.shape[0] // sl), -(-self.shape[1] // sw)
        separate = page.planarconfig == 2 and page.samplesperpixel > 1
        plane = index * down * across if separate else 0
        extra = {"jpegtables": page.jpegtables} if page.compression in (6, 7, 34892, 33007) else {}
        fh = self.tif.filehandle
        for br in range(r0 // sl, (r1 - 1) // sl + 1):
            for bc in range(c0 // sw, (c1 - 1) // sw + 1):
                number = plane + br * across + bc
                offset, count = page.dataoffsets[number], page.databytecounts[number]
                data = None
                if offset and count:
                    fh.seek(offset)
                    data = fh.read(count)
                segment, _, shape = page.decode(data, number, _fullsize=page.is_tiled, **extra)
                a0, a1 = max(r0, br * sl), min(r1, (br + 1) * sl)
                b0, b1 = max(c0, bc * sw), min(c1, (bc + 1) * sw)
                target = out[a0 - r0:a1 - r0, b0 - c0:b1 - c0]
                if segment is None:                      # a sparse file's empty block
                    nodata = self.source.nodata if page is self.page else None
                    target[...] = 0 if nodata is None or np.isnan(nodata) and out.dtype.kind != "f" else nodata
                    continue
                segment = segment.reshape(shape)[0, :, :, 0 if separate else index]
                target[...] = segment[a0 - br * sl:a1 - br * sl, b0 - bc * sw:b1 - bc * sw]
        return out

    def close(self) -> None:
        self.tif.close()


# ----------------------------------------------------------------------------- SRTM .hgt

_HGT_NAME = re.compile(r"([NS])(\d{1,2})([EW])(\d{1,3})", re.IGNORECASE)


def _read_hgt(path: Path, band: int | None) -> _Source:
    _band_index(path, 1, band)
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
    georef = _georef_4326(step, float(lon), float(lat + 1), pixel_is_point=True)  # samples on corners
    return _Source(raw, -32768.0, True, georef, _degree_cells(step, step, lat + 0.5))


# ----------------------------------------------------------------------------- ESRI ASCII grid and its .prj

_WKT_TOKEN = re.compile(r'\s*(?:"((?:[^"]|"")*)"|([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)'
                        r'|([A-Za-z_][\w.]*)|([\[\](),]))')
_WKT_GEOGRAPHIC = ("GEOGCS", "GEOGCRS", "GEOGRAPHICCRS")
_WKT_PLANAR = ("PROJCS", "PROJCRS", "PROJECTEDCRS", "LOCAL_CS", "ENGCRS", "ENGINEERINGCRS")
_WKT_COMPOUND = ("COMPD_CS", "COMPOUNDCRS")


@dataclass
class _Wkt:
    """One WKT node: KEYWORD[arg, ...] with args strings, numbers, bare words or nodes."""

    keyword: str
    args: list

    def children(self, *keywords: str) -> list["_Wkt"]:
        return [a for a in self.args if isinstance(a, _Wkt) and a.keyword in keywords]


def _parse_wkt(text: str) -> _Wkt:
    """Parse WKT 1 (OGC or ESRI flavour) or WKT 2; raises ValueError on malformed text."""
    tokens, pos = [], 0
    text = text.strip()
    while pos < len(text):
        m = _WKT_TOKEN.match(text, pos)
        if m is None:
            raise ValueError(f"not WKT: unexpected {text[pos:pos + 20]!r} at character {pos}")
        tokens.append(m)
        pos = m.end()
    at = 0

    def value() -> object:
        nonlocal at
        if at >= len(tokens):
            raise ValueError("not WKT: ends early")
        string, number, word, punct = tokens[at].groups()
        at += 1
        if string is not None:
            return string.replace('""', '"')
        if number is not None:
            return float(number)
        if word is None:
            raise ValueError(f"not WKT: unexpected {punct!r}")
        if at < len(tokens) and tokens[at][4] in ("[", "("):
            at += 1
            args = [value()]
            while at < len(tokens) and tokens[at][4] == ",":
                at += 1
                args.append(value())
            if at >= len(tokens) or tokens[at][4] not in ("]", ")"):
                raise ValueError(f"not WKT: {word}[ is not closed")
            at += 1
            return _Wkt(word.upper(), args)
        return word

    root = value()
    if not isinstance(root, _Wkt) or at != len(tokens):
        raise ValueError("not WKT: expected one KEYWORD[...] node")
    return root


@dataclass(frozen=True)
class _Crs:
    geographic: bool
    metres_per_unit: float        # of the coordinates (1 for geographic: degrees, converted later)
    epsg: int | None
    wkt: str


def _wkt_unit(node: _Wkt, keywords: tuple[str, ...]) -> tuple[str, float] | None:
    """(name, factor) of the node's own unit, or of its first axis's (WKT 2)."""
    for holder in (node, *node.children("AXIS")):
        for unit in holder.children(*keywords):
            if len(unit.args) >= 2 and isinstance(unit.args[1], float):
                return str(unit.args[0]), unit.args[1]
    return None


def _read_prj(prj: Path) -> _Crs:
    """The CRS of an ESRI ASCII grid from its .prj (WKT); raises ValueError naming the .prj."""
    wkt = prj.read_text(encoding="utf-8-sig", errors="replace").strip()
    try:
        root = _parse_wkt(wkt)
    except ValueError as exc:
        raise ValueError(f"{prj.name}: {exc} (expected the CRS as WKT, e.g. from 'gdalsrsinfo -o wkt EPSG:CODE')") \
            from None
    node = root
    if root.keyword in _WKT_COMPOUND:   # its horizontal part
        node = next(iter(root.children(*_WKT_GEOGRAPHIC, *_WKT_PLANAR)), root)
    if node.keyword not in _WKT_GEOGRAPHIC + _WKT_PLANAR:
        raise ValueError(f"{prj.name}: unsupported CRS {node.keyword}[...]; expected a geographic "
                         f"(GEOGCS/GEOGCRS) or projected (PROJCS/PROJCRS) CRS")
    epsg = None
    for ident in node.children("AUTHORITY", "ID"):
        if len(ident.args) >= 2 and str(ident.args[0]).upper() == "EPSG":
            epsg = int(float(ident.args[1]))
    geographic = node.keyword in _WKT_GEOGRAPHIC
    if geographic:
        unit = _wkt_unit(node, ("UNIT", "ANGLEUNIT"))
        if unit is not None and not math.isclose(unit[1], math.pi / 180.0, rel_tol=1e-9):
            raise ValueError(f"{prj.name}: angular unit {unit[0]!r} ({unit[1]:.9g} rad) is not supported; "
                             f"expected degrees")
        return _Crs(True, 1.0, epsg, wkt)
    unit = _wkt_unit(node, ("UNIT", "LENGTHUNIT"))
    if unit is None or not (math.isfinite(unit[1]) and unit[1] > 0):
        raise ValueError(f"{prj.name}: the projected CRS names no linear unit (UNIT[\"metre\",1])")
    return _Crs(False, unit[1], epsg, wkt)


def _could_be_degrees(cx: float, cy: float, west: float, south: float, cols: int, rows: int) -> bool:
    """Cells under 1 unit and the whole extent within longitude -180..180, latitude -90..90."""
    return (cx < 1 and cy < 1 and -180 <= west and west + cols * cx <= 180
            and -90 <= south and south + rows * cy <= 90)


def _read_asc(path: Path, band: int | None, cell_given: bool) -> _Source:
    _band_index(path, 1, band)
    header: dict[str, float] = {}
    with open(path, encoding="ascii", errors="replace") as fh:
        while True:
            pos = fh.tell()
            line = fh.readline()
            parts = line.split()
            if not parts or not parts[0][0].isalpha():
                fh.seek(pos)
                break
            try:
                name, value = parts
                header[name.lower()] = float(value)
            except ValueError:
                raise ValueError(f"ESRI ASCII grid header line {line.strip()[:40]!r}: expected NAME NUMBER") from None
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
    if centre:  # to lower-left corner
        x0, y0 = x0 - cx / 2, y0 - cy / 2
    source = _Source(values.reshape(nrows, ncols), header.get("nodata_value"))
    prj = next((p for p in (path.with_suffix(".prj"), path.with_suffix(".PRJ")) if p.is_file()), None)
    if prj is not None:
        crs = _read_prj(prj)
        source.geographic, source.crs_wkt = crs.geographic, crs.wkt
        source.georef = _georef_crs(cx, cy, x0, y0 + nrows * cy, crs.geographic, crs.epsg)
        source.cell = (_degree_cells(cx, cy, y0 + nrows * cy / 2) if crs.geographic else
                       (cx * crs.metres_per_unit, cy * crs.metres_per_unit))
        if not crs.geographic and crs.metres_per_unit != 1.0:
            source.notes.append(unit_note(f"the unit of {prj.name}", crs.metres_per_unit))
        return source
    source.georef = _georef_crs(cx, cy, x0, y0 + nrows * cy, False, None)
    source.cell = (cx, cy)
    if cell_given:
        return source
    prj_name = path.with_suffix(".prj").name
    if _could_be_degrees(cx, cy, x0, y0, ncols, nrows):
        raise _err(path, f"no {prj_name} next to the file, and cell size {cx:g} with corner ({x0:g}, {y0:g}) "
                         f"could be degrees or metres: put the CRS as WKT in {prj_name} (e.g. from "
                         f"'gdalsrsinfo -o wkt EPSG:CODE'), or give the cell size in metres (--cellsize, "
                         f"or cellsize= in the API)")
    source.notes.append(f"no {prj_name} next to the file: cell size {cx:g} x {cy:g} taken as metres, "
                        f"in an unknown projected CRS")
    return source


# ----------------------------------------------------------------------------- EXR / PNG / NPY

_EXR_HEIGHT_CHANNELS = ("Z", "Y", "R")


def _read_exr(path: Path, band: int | None) -> _Source:
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        channels = exr.channels()
        if not channels:
            raise ValueError("EXR file has no channels")
        names = list(channels)
        preferred = next((names.index(c) for c in _EXR_HEIGHT_CHANNELS if c in channels), 0)
        index = _band_index(path, len(names), band, default=preferred)
        raw = np.array(channels[names[index]].pixels, dtype=np.float64)
    return _Source(raw, bands=len(names), band=index + 1, band_name=names[index])


def _read_png(path: Path, band: int | None) -> _Source:
    _band_index(path, 1, band)
    with Image.open(path) as img:
        if img.mode not in ("L", "I", "F") and not img.mode.startswith("I;16"):
            raise ValueError(f"expected a greyscale (8- or 16-bit) PNG, got mode {img.mode}")
        return _Source(np.asarray(img))


def _read_npy(path: Path, band: int | None) -> _Source:
    _band_index(path, 1, band)
    return _Source(np.load(path))


# ----------------------------------------------------------------------------- read_dem

READ_EXTENSIONS = (".tif", ".tiff", ".hgt", ".zip", ".asc", ".npy", ".exr", ".png")
_URL = re.compile(r"^([a-z][a-z0-9+.-]*://|/vsi[a-z0-9]+/)", re.IGNORECASE)


def _input_file(path: str | os.PathLike) -> Path:
    """``path`` as an existing regular file with a known extension, else a RasterIOError saying why."""
    text = os.fspath(path)
    if isinstance(text, str) and _URL.match(text):
        raise _err(text, "URLs and GDAL virtual paths need the optional GDAL reader "
                         "(pip install 'oclshade[gdal]'); or download the file and give its path")
    p = Path(path)
    if p.is_dir():
        raise _err(p, "is a directory, not a raster file")
    if p.exists() and not p.is_file():
        raise _err(p, "is not a regular file (a FIFO, socket or device)")
    if p.suffix.lower() not in READ_EXTENSIONS:
        raise _err(p, f"unknown raster extension {p.suffix!r}; expected one of {', '.join(READ_EXTENSIONS)}")
    if not p.exists():
        raise _err(p, "is a broken symbolic link" if p.is_symlink() else "no such file")
    return p


def read_dem(path: str | os.PathLike, cellsize: float | tuple[float, float] | None = None,
             band: int | None = None, nodata: float | None = None) -> Raster:
    """Read a DEM; the format follows the extension (.tif/.tiff, .hgt, .zip, .asc, .npy, .exr, .png).

    ``cellsize`` (one number or (dx, dy), metres) overrides the file's cell size;
    files without one (.npy, .png, .exr, plain TIFF) default to 1.0.  An ESRI ASCII
    grid takes its CRS from the ``.prj`` beside it (see docs/io.md).
    ``band`` (1-based, as GDAL): the band (TIFF samples, EXR channels in file order)
    to read; None reads band 1 (an EXR: its Z, Y or R channel) and warns
    (:class:`~oclshade.heightmap.InputWarning`) when the file has more.
    ``nodata`` declares the nodata value, overriding the file's (as gdalwarp's -srcnodata).
    Other extensions, URLs and GDAL virtual paths go to :mod:`oclshade.gdal_reader` when
    rasterio is installed (``pip install 'oclshade[gdal]'``).
    Raises :class:`RasterIOError` naming the path on any problem with the file.
    """
    if band is not None and (isinstance(band, bool) or not isinstance(band, (int, np.integer)) or band < 1):
        raise ValueError(f"band must be a 1-based band number (1, 2, ...), got {band!r}")
    nodata = nodata_value(nodata)
    text = os.fspath(path)
    if isinstance(text, str) and (_URL.match(text) or Path(text).suffix.lower() not in READ_EXTENSIONS
                                  and not Path(text).is_dir()) and gdal_reader.available():
        raster = gdal_reader.read_with_gdal(text, band, nodata)   # optional GDAL reader: URLs, VRT, other formats
        if cellsize is not None:
            raster.dx, raster.dy = _cellsize(text, cellsize)
        return raster
    p = _input_file(path)
    cell = None if cellsize is None else _cellsize(p, cellsize)
    ext = p.suffix.lower()
    readers: dict[str, Callable[[Path, int | None], _Source]] = {
        ".tif": _read_tif, ".tiff": _read_tif, ".hgt": _read_hgt, ".zip": _read_hgt, ".npy": _read_npy,
        ".exr": _read_exr, ".png": _read_png,
        ".asc": lambda asc, b: _read_asc(asc, b, cell is not None)}
    try:
        src = readers[ext](p, band)
        heights = _heights(p, src.raw, src.nodata if nodata is None else nodata, src.scale, src.offset, src.valid)
    except RasterIOError:
        raise
    except Exception as exc:  # noqa: BLE001 - a corrupt file can fail in any decoder; name the file
        raise _err(p, f"cannot read as {ext[1:]} raster: {str(exc) or type(exc).__name__}") from exc
    return _raster(p, src, heights, band, cell, nodata)


def require_north_up(path: object, georef: dict) -> None:
    """Refuse a georeferenced grid whose columns do not run west to east and rows north to south.

    Every kernel traces azimuths in the grid (columns east, rows south, as the heights are held),
    so a rotated, sheared or mirrored (south-up) grid would put every shadow and horizon in a
    wrong direction without a sign of it; gdalwarp makes such a file north-up.  Raises
    :class:`RasterIOError` naming ``path``; a grid without a transform passes (it is taken as
    north-up, docs/io.md)."""
    gt = geotransform(georef)
    if gt is None:
        return
    _, a, b, _, d, e = gt
    size = max(abs(a), abs(b), abs(d), abs(e))
    if abs(b) > 1e-9 * size or abs(d) > 1e-9 * size:
        raise _err(path, f"the grid is rotated or sheared (geotransform row and column terms "
                         f"{a:.9g}, {b:.9g}, {d:.9g}, {e:.9g}), and oclshade traces azimuths along a "
                         f"north-up grid: warp it north-up first (gdalwarp IN OUT)")
    wrong = [what for what, bad in (("its columns run east to west", a < 0),
                                    ("its rows run south to north (south-up)", e > 0)) if bad]
    if wrong:
        raise _err(path, f"the grid is mirrored: {' and '.join(wrong)}, and oclshade traces azimuths along a "
                         f"north-up grid: warp it north-up first (gdalwarp IN OUT)")


def _raster(p: Path, src: _Source, heights: np.ndarray, band: int | None, cell: tuple[float, float] | None,
            nodata: float | None) -> Raster:
    """The Raster of a read file, after warning about what the reader noted (stacklevel: read_dem's caller)."""
    require_north_up(p, src.georef)
    if band is None and src.bands > 1:
        src.notes.append(f"the file has {src.bands} bands; reading band {src.band}"
                         f"{f' ({src.band_name})' if src.band_name else ''} (choose one with -b BAND, or band=)")
    for note in src.notes:
        warnings.warn(f"{p}: {note}", InputWarning, stacklevel=3)
    dx, dy = cell or src.cell or (1.0, 1.0)
    return Raster(heights, dx, dy, src.nodata if nodata is None else nodata, src.geographic, src.georef,
                  str(p), src.crs_wkt)


class DemWindows:
    """A DEM read a window at a time (:func:`open_dem`): :attr:`raster` is what :func:`read_dem`
    gives but for its heights (a read-only NaN view of the map's shape, holding no memory), and
    :meth:`read` gives a window's heights as :func:`read_dem` would (float64, nodata as NaN).
    :attr:`segment_bytes`: what decoding one tile or strip of the file holds (a window read
    holds at least that)."""

    def __init__(self, raster: Raster, read: Callable[[int, int, int, int], np.ndarray], segment_bytes: int,
                 close: Callable[[], None] = lambda: None):
        self.raster, self._read, self.segment_bytes, self._close = raster, read, segment_bytes, close

    @property
    def shape(self) -> tuple[int, int]:
        return self.raster.heights.shape  # type: ignore[return-value]

    def read(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Heights of rows [r0, r1) and columns [c0, c1)."""
        rows, cols = self.shape
        if not (0 <= r0 < r1 <= rows and 0 <= c0 < c1 <= cols):
            raise ValueError(f"window rows {r0}:{r1}, cols {c0}:{c1} is not inside the {rows}x{cols} map")
        return self._read(r0, r1, c0, c1)

    def close(self) -> None:
        self._close()

    def __enter__(self) -> "DemWindows":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_dem(path: str | os.PathLike, cellsize: float | tuple[float, float] | None = None,
             band: int | None = None, nodata: float | None = None) -> DemWindows:
    """:func:`read_dem` a window at a time: a GeoTIFF (tiled, a COG, or in strips) decodes only
    the tiles or strips a window touches, a .npy file is memory-mapped; other formats, URLs and
    the GDAL reader's are read whole now and served from memory.  Same arguments, checks and
    warnings as :func:`read_dem`."""
    if band is not None and (isinstance(band, bool) or not isinstance(band, (int, np.integer)) or band < 1):
        raise ValueError(f"band must be a 1-based band number (1, 2, ...), got {band!r}")
    nodata = nodata_value(nodata)
    text = os.fspath(path)
    ext = Path(text).suffix.lower() if isinstance(text, str) else ""
    if ext not in _GEOTIFF + (".npy",) or _URL.match(text):
        raster = read_dem(path, cellsize, band, nodata)
        heights = raster.heights
        raster.heights = np.broadcast_to(np.float64(np.nan), heights.shape)
        return DemWindows(raster, lambda r0, r1, c0, c1: heights[r0:r1, c0:c1].copy(), heights.nbytes)
    p = _input_file(path)
    cell = None if cellsize is None else _cellsize(p, cellsize)
    try:
        if ext == ".npy":
            _band_index(p, 1, band)
            raw = np.load(p, mmap_mode="r")
            src, segment, close = _Source(raw[:0, :0] if raw.ndim == 2 else raw), raw.dtype.itemsize * raw.shape[-1], \
                (lambda: None)
            if raw.ndim != 2 or raw.size == 0 or raw.dtype.kind not in "iuf":
                _heights(p, raw, None)              # raises the read_dem error
            shape = raw.shape

            def window(r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
                return raw[r0:r1, c0:c1]

            def valid(r0: int, r1: int, c0: int, c1: int) -> None:
                return None
        else:
            tiff = _TiffWindows(p, band)
            src, segment, close, shape, window = tiff.source, tiff.segment_bytes, tiff.close, tiff.shape, tiff.read
            valid = tiff.valid
    except RasterIOError:
        raise
    except Exception as exc:  # noqa: BLE001 - as read_dem: name the file
        raise _err(p, f"cannot read as {ext[1:]} raster: {str(exc) or type(exc).__name__}") from exc
    declared = src.nodata if nodata is None else nodata

    def read(r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        try:
            return _heights(p, window(r0, r1, c0, c1), declared, src.scale, src.offset, valid(r0, r1, c0, c1))
        except RasterIOError:
            raise
        except Exception as exc:  # noqa: BLE001 - a corrupt block fails in its decoder
            raise _err(p, f"cannot read rows {r0}:{r1}, cols {c0}:{c1}: {str(exc) or type(exc).__name__}") from exc

    raster = _raster(p, src, np.broadcast_to(np.float64(np.nan), shape), band, cell, nodata)
    return DemWindows(raster, read, segment, close)


# ----------------------------------------------------------------------------- writing

WRITE_EXTENSIONS = (".tif", ".tiff", ".exr", ".npy", ".png")
_GEOTIFF = (".tif", ".tiff")


def crs_text(like: Raster) -> str | None:
    """The raster's CRS as text (for a GDAL sidecar, or pyproj): its WKT, else ``EPSG:code`` from
    its GeoTIFF keys; None when it has neither."""
    return like.crs_wkt or _epsg_text(like.georef)


def _epsg_text(georef: dict) -> str | None:
    keys = georef.get(34735, ())
    model = geokey(keys, 1024)
    code = geokey(keys, {1: 3072, 2: 2048}[model]) if model in (1, 2) else None
    return f"EPSG:{code}" if code is not None and 0 < code < 32767 else None


def geotransform(georef: dict) -> tuple[float, float, float, float, float, float] | None:
    """GDAL's geotransform (x0, dx/dcol, dx/drow, y0, dy/dcol, dy/drow; (x0, y0) the top-left
    pixel's outer corner) of GeoTIFF tags, as GDAL reads them (PixelIsPoint: the tie point is a
    pixel centre); None without a transform or with several tie points (GCPs)."""
    point = geokey(georef.get(34735, ()), 1025) == 2
    shift = 0.5 if point else 0.0
    if 34264 in georef:
        a, b, _, d, e, f, _, h = (float(v) for v in georef[34264][:8])
        return d - (a + b) * shift, a, b, h - (e + f) * shift, e, f
    tie, scale = georef.get(33922, ()), georef.get(33550, ())
    if len(tie) != 6 or len(scale) < 2:
        return None
    i, j, _, x, y, _ = (float(v) for v in tie)
    sx, sy = float(scale[0]), float(scale[1])
    return x - (i + shift) * sx, sx, 0.0, y + (j + shift) * sy, 0.0, -sy


def decimated(raster: Raster, step: int) -> Raster:
    """Every ``step``-th cell of every ``step``-th row (as previews are drawn), georeferenced so
    that each kept cell stays where it was: cells ``step`` times larger about the same centres."""
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise ValueError(f"step must be a positive integer, got {step!r}")
    georef = dict(raster.georef)
    # raster-space coordinate u of the source = step * u' + off (PixelIsArea: keep the kept cells' centres)
    off = 0.0 if geokey(georef.get(34735, ()), 1025) == 2 else (1 - step) / 2
    if 34264 in georef:
        m = list(georef[34264])
        m[3] += (m[0] + m[1]) * off
        m[7] += (m[4] + m[5]) * off
        m[0], m[1], m[4], m[5] = m[0] * step, m[1] * step, m[4] * step, m[5] * step
        georef[34264] = tuple(m)
    if 33922 in georef:
        tie = list(georef[33922])
        for k in range(0, len(tie) - 5, 6):
            tie[k], tie[k + 1] = (tie[k] - off) / step, (tie[k + 1] - off) / step
        georef[33922] = tuple(tie)
    if 33550 in georef:
        sx, sy, *rest = georef[33550]
        georef[33550] = (sx * step, sy * step, *rest)
    return Raster(raster.heights[::step, ::step], raster.dx * step, raster.dy * step, raster.nodata,
                  raster.geographic, georef, raster.path, raster.crs_wkt)


def _pam(srs: str) -> str:
    """A GDAL .aux.xml (PAM) holding a CRS (WKT or EPSG:code)."""
    return f"<PAMDataset>\n  <SRS>{xml_escape(srs)}</SRS>\n</PAMDataset>\n"


def _world_file(gt: tuple[float, ...]) -> str:
    """An ESRI world file: pixel sizes and rotations, then the top-left pixel's centre."""
    x0, a, b, y0, d, e = gt
    return "".join(f"{v!r}\n" for v in (a, d, b, e, x0 + (a + b) / 2, y0 + (d + e) / 2))


def _sidecars(path: Path, like: Raster | None) -> dict[Path, str | None]:
    """The GDAL sidecar files of an output at ``path`` (beside the name given, where GDAL looks)
    and their text; None: not needed, so a stale one is removed."""
    aux = path.with_name(path.name + ".aux.xml")
    ext = path.suffix.lower()
    if ext in _GEOTIFF:    # the GeoTIFF keys hold an EPSG code; a CRS without one goes to the .aux.xml
        wkt = None if like is None else like.crs_wkt
        return {aux: _pam(wkt) if wkt and _epsg_text(like.georef) is None else None}
    if ext == ".png":
        gt = None if like is None else geotransform(like.georef)
        srs = None if like is None else crs_text(like)
        return {path.with_suffix(".pgw"): None if gt is None else _world_file(gt),
                aux: None if srs is None or gt is None else _pam(srs)}
    return {}


def _geotiff_tags(like: Raster | None, nodata: float | None,
                  band_names: Sequence[str] | None) -> list[tuple[int, int, object]]:
    tags: list[tuple[int, int, object]] = []
    for code, value in sorted((like.georef if like is not None else {}).items()):
        kind = GEOTIFF_TAGS.get(code)
        if kind is not None:
            tags.append((code, kind, str(value) if kind == 2 else tuple(value)))
    if nodata is not None:
        tags.append((_TAG_NODATA, 2, f"{float(nodata):.17g}"))
    if band_names:
        items = "".join(f'<Item name="DESCRIPTION" sample="{i}" role="description">{xml_escape(n)}</Item>'
                        for i, n in enumerate(band_names))
        tags.append((_TAG_GDAL_METADATA, 2, f"<GDALMetadata>{items}</GDALMetadata>"))
    return tags


class _Replacement:
    """A temporary file beside ``target`` (hidden, ``.NAME.tmp-XXXXXXXX.EXT``) that replaces it
    by a rename, keeping an existing target's permission bits."""

    def __init__(self, target: Path):
        self.target = target
        self.tmp = target.with_name(f".{target.stem}.tmp-{secrets.token_hex(4)}{target.suffix}")
        with open(self.tmp, "xb"):
            pass

    def commit(self) -> None:
        try:
            os.chmod(self.tmp, stat.S_IMODE(os.stat(self.target).st_mode))
        except FileNotFoundError:
            pass
        os.replace(self.tmp, self.target)

    def discard(self) -> None:
        self.tmp.unlink(missing_ok=True)


def _write_tif(tmp: str, tiff: GeoTiffWriter) -> None:
    with open(tmp, "wb") as fh:
        tiff.save(fh)


def _write_exr(tmp: str, data: np.ndarray, band_names: Sequence[str]) -> None:
    channels = {n: np.ascontiguousarray(b, dtype=np.float32) for n, b in zip(band_names, data)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as exr:
        exr.write(tmp)


def _write_npy(tmp: str, shape: tuple[int, ...], dtype: np.dtype) -> int:
    """Create the .npy file (header, then room for the data); returns where the data starts."""
    array = np.lib.format.open_memmap(tmp, mode="w+", dtype=dtype, shape=shape)
    offset = array.offset
    del array
    return offset


def _write_png(tmp: str, image: np.ndarray) -> None:
    Image.fromarray(image).save(tmp, format="PNG")


class _Staged:
    """Bands appended raw, as ``dtype``, to an anonymous temporary file (formats written whole at the end)."""

    def __init__(self, shape: tuple[int, int, int], dtype: np.dtype, directory: Path):
        self.shape, self.dtype = shape, dtype
        self.file = tempfile.TemporaryFile(dir=directory)

    def write(self, band: np.ndarray) -> None:
        self.file.write(np.ascontiguousarray(band, dtype=self.dtype).tobytes())

    def array(self) -> np.ndarray:
        """The bands (bands, rows, cols), mapped from the file (paged in as they are read)."""
        self.file.flush()
        return np.memmap(self.file, dtype=self.dtype, mode="r", shape=self.shape)

    def close(self) -> None:
        self.file.close()


class RasterWriter:
    """Write a raster band by band, in constant memory for GeoTIFF and .npy; the format follows the extension.

    ``shape`` is (bands, rows, cols) and ``dtype`` the bands' type, both given before any band:
    the writer checks everything and creates its temporary file in the destination directory
    when made, so an unwritable destination fails before any work. :meth:`write` takes the
    bands in order; :meth:`finish` completes the temporary file (and sidecars); :meth:`commit`
    renames it over ``path``, keeping an existing file's permission bits (an output that is a
    symbolic link is written through: the file it points to is replaced, the link stays);
    :meth:`abort` removes what was written. As a context manager it finishes and commits on
    success and aborts on an exception.

    ``.tif/.tiff``: tiled, compressed GeoTIFF (:mod:`oclshade.geotiff`; ``options``: GDAL
    creation options, ``cog``: a Cloud-Optimized GeoTIFF), georeferencing copied from ``like``,
    GDAL_NODATA from ``nodata``, band names as GDAL band descriptions; a ``like.crs_wkt`` without
    an EPSG code in the GeoTIFF keys goes into ``PATH.aux.xml``. ``.exr``: float32 channels named
    ``band_names`` (default "Y" for one band, else "B0", "B1", ...; OpenEXR stores channels sorted
    by name), staged on disk and mapped back when the file is written. ``.npy``: the 2-D array
    for one band, else (bands, rows, cols). ``.png``: 1 (grey: uint8 or uint16), 3 (RGB) or 4
    (RGBA) uint8 bands; with a georeferenced ``like``, a world file ``.pgw`` and the CRS in
    ``PATH.aux.xml``. Raises :class:`RasterIOError` naming the path.
    """

    def __init__(self, path: str | os.PathLike, shape: tuple[int, int, int], dtype: np.dtype | type,
                 like: Raster | None = None, nodata: float | None = None,
                 band_names: Sequence[str] | None = None, options: Mapping[str, str] | None = None,
                 cog: bool = False):
        p = self.path = Path(path)
        self.ext = ext = p.suffix.lower()
        if ext not in WRITE_EXTENSIONS:
            raise _err(p, f"unknown output extension {p.suffix!r}; expected .tif, .tiff, .exr, .npy or .png")
        if len(shape) != 3 or any(isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1
                                  for n in shape):
            raise _err(p, f"shape must be (bands, rows, cols), positive integers, got {shape!r}")
        self.shape = count, rows, cols = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype)
        if self.dtype.kind not in "uif":
            raise _err(p, f"bands must be numeric, got dtype {self.dtype}")
        if band_names is not None and len(band_names) != count:
            raise _err(p, f"{len(band_names)} band names given for {count} bands")
        if like is not None and like.heights.shape != (rows, cols):
            raise _err(p, f"bands of shape {(rows, cols)} do not match the georeferenced raster {like.heights.shape}")
        if ext == ".png" and not (count in (3, 4) and self.dtype == np.uint8 or
                                  count == 1 and self.dtype in (np.uint8, np.uint16)):
            raise _err(p, f"PNG output needs a uint8/uint16 (rows, cols) band or a uint8 (rows, cols, 3|4) "
                          f"RGB(A) image, got {count} band(s) of {self.dtype}")
        if (options or cog) and ext not in _GEOTIFF:
            raise _err(p, "creation options and COG apply to GeoTIFF output (.tif, .tiff)")
        try:
            tiff = tiff_options(options, self.dtype, cog) if ext in _GEOTIFF else None
        except ValueError as exc:
            raise _err(p, exc) from None
        if like is not None and like.path is not None and os.path.realpath(p) == os.path.realpath(like.path):
            raise _err(p, "refusing to overwrite the input raster")
        target = Path(os.path.realpath(p)) if p.is_symlink() else p
        if not target.parent.is_dir():
            raise _err(p, "output directory does not exist")
        if target.is_dir():
            raise _err(p, "is a directory")
        width = len(str(count - 1))
        self.band_names = list(band_names) if band_names else (
            ["Y"] if count == 1 else [f"B{i:0{width}d}" for i in range(count)])
        self.written, self.finished, self.committed = 0, False, False
        self.window_cells = 0                     # cells written by write_window (which excludes write)
        self._data_offset = 0
        self._sidecars = _sidecars(p, like)
        self._replacements: list[_Replacement] = []
        self._sink: GeoTiffWriter | _Staged | BinaryIO | None = None
        try:
            self._out = self._replacement(target)
            for side, text in self._sidecars.items():
                if text is not None:
                    self._replacement(side)
            tmp = str(self._out.tmp)
            if tiff is not None:
                self._sink = GeoTiffWriter(self.shape, self.dtype, tiff, _geotiff_tags(like, nodata, band_names),
                                           target.parent)
            elif ext == ".npy":
                self._data_offset = _write_npy(tmp, self.shape[1:] if count == 1 else self.shape, self.dtype)
                self._sink = open(tmp, "r+b")
                self._sink.seek(self._data_offset)
            else:
                self._sink = _Staged(self.shape, np.dtype(np.float32) if ext == ".exr" else self.dtype,
                                     target.parent)
        except BaseException as exc:
            self._fail(exc)

    def _replacement(self, target: Path) -> _Replacement:
        try:
            made = _Replacement(target)
        except OSError as exc:
            raise _err(self.path, f"cannot write in {target.parent}: {exc.strerror or exc}") from None
        self._replacements.append(made)
        return made

    def _fail(self, exc: BaseException) -> NoReturn:
        """Remove everything written, then raise ``exc`` (as a RasterIOError naming the path)."""
        self.abort()
        if isinstance(exc, (OSError, ValueError, TypeError, RuntimeError)) and not isinstance(exc, RasterIOError):
            raise _err(self.path, f"cannot write {self.ext[1:]} raster: {exc}") from exc
        raise exc

    def write(self, band: np.ndarray) -> None:
        """Add the next band (rows, cols); its dtype must cast safely to the writer's."""
        band = np.asarray(band)
        k = self.written + 1
        try:
            if self.window_cells:
                raise _err(self.path, "bands are being written as windows (write_window); write does not mix with it")
            if k > self.shape[0]:
                raise _err(self.path, f"all {self.shape[0]} bands are already written")
            if band.shape != self.shape[1:]:
                raise _err(self.path, f"band {k} has shape {band.shape}, expected {self.shape[1:]}")
            if not np.can_cast(band.dtype, self.dtype, "safe"):
                raise _err(self.path, f"band {k} of dtype {band.dtype} does not fit {self.dtype}")
            self._sink.write(np.ascontiguousarray(band, dtype=self.dtype))
        except BaseException as exc:
            self._fail(exc)
        self.written = k

    def write_window(self, band: int, row0: int, col0: int, data: np.ndarray) -> None:
        """Cells [row0, row0 + rows) x [col0, col0 + cols) of band ``band`` (0-based), instead of
        :meth:`write`: windows of any band in any order, each cell once.  GeoTIFF encodes each
        block as soon as windows complete it (memory: the partly written blocks); .npy writes in
        place; .exr and .png stage the cells on disk."""
        data = np.asarray(data)
        try:
            count, rows, cols = self.shape
            if self.written:
                raise _err(self.path, "bands are being written whole (write); write_window does not mix with it")
            if isinstance(band, bool) or not isinstance(band, (int, np.integer)) or not 0 <= band < count:
                raise _err(self.path, f"band {band!r} out of range: {count} band(s), numbered from 0")
            if data.ndim != 2 or data.size == 0 or not (0 <= row0 and 0 <= col0 and row0 + data.shape[0] <= rows
                                                        and col0 + data.shape[1] <= cols):
                raise _err(self.path, f"window of shape {data.shape} at ({row0}, {col0}) does not lie in the "
                                      f"{rows}x{cols} bands")
            if not np.can_cast(data.dtype, self.dtype, "safe"):
                raise _err(self.path, f"window of dtype {data.dtype} does not fit {self.dtype}")
            if isinstance(self._sink, GeoTiffWriter):
                self._sink.write_window(int(band), int(row0), int(col0), np.ascontiguousarray(data, self.dtype))
            else:
                staged = isinstance(self._sink, _Staged)
                fh, dtype = (self._sink.file, self._sink.dtype) if staged else (self._sink, self.dtype)
                size = count * rows * cols * dtype.itemsize
                if staged and fh.seek(0, os.SEEK_END) < size:
                    fh.truncate(size)
                for r, line in enumerate(np.ascontiguousarray(data, dtype)):
                    fh.seek(self._data_offset + ((band * rows + row0 + r) * cols + col0) * dtype.itemsize)
                    fh.write(line.tobytes())
        except BaseException as exc:
            self._fail(exc)
        self.window_cells += data.size

    def finish(self) -> None:
        """Complete the temporary file and sidecars once every band is written; nothing is replaced yet."""
        try:
            total = self.shape[0] * self.shape[1] * self.shape[2]
            if self.window_cells and self.window_cells != total:
                raise _err(self.path, f"{self.window_cells} of {total} cells written")
            if not self.window_cells and self.written != self.shape[0]:
                raise _err(self.path, f"{self.written} of {self.shape[0]} bands written")
            tmp = str(self._out.tmp)
            if self.ext in _GEOTIFF:
                _write_tif(tmp, self._sink)
            elif self.ext == ".exr":
                _write_exr(tmp, self._sink.array(), self.band_names)
            elif self.ext == ".png":
                data = self._sink.array()
                _write_png(tmp, np.ascontiguousarray(data[0] if len(data) == 1 else np.moveaxis(data, 0, 2)))
            self._sink.close()
            for made in self._replacements[1:]:
                made.tmp.write_text(self._sidecars[made.target], encoding="utf-8")
        except BaseException as exc:
            self._fail(exc)
        self.finished = True

    def commit(self) -> None:
        """Rename the finished file (and its sidecars) into place; stale sidecars are removed."""
        try:
            if not self.finished:
                raise _err(self.path, "commit before finish")
            for made in self._replacements:
                made.commit()
            for side, text in self._sidecars.items():
                if text is None:
                    side.unlink(missing_ok=True)
        except BaseException as exc:
            self._fail(exc)
        self.committed = True

    def abort(self) -> None:
        """Remove the temporary files; the target is left as it was (unless already committed)."""
        if self._sink is not None:
            self._sink.close()
        for made in self._replacements:
            made.discard()

    def __enter__(self) -> "RasterWriter":
        return self

    def __exit__(self, kind: type | None, exc: BaseException | None, tb: object) -> None:
        if exc is not None:
            self.abort()
        elif not self.committed:
            if not self.finished:
                self.finish()
            self.commit()


def _band_list(path: Path, bands: np.ndarray | Sequence[np.ndarray]) -> list[np.ndarray]:
    """Equally shaped 2-D bands from a 2-D array, a (bands, rows, cols) stack or a sequence
    (a PNG also takes a (rows, cols, 3|4) image); booleans become uint8."""
    if isinstance(bands, np.ndarray):
        if bands.ndim == 3 and path.suffix.lower() == ".png" and bands.shape[2] in (3, 4):
            bands = np.moveaxis(bands, 2, 0)
        arrays = [bands] if bands.ndim == 2 else list(bands) if bands.ndim == 3 else None
        if arrays is None or bands.size == 0:
            raise _err(path, f"bands must be a 2-D array or a (bands, rows, cols) stack, got shape {bands.shape}")
    else:
        arrays = [np.asarray(b) for b in bands]
        if not arrays or any(a.ndim != 2 or a.shape != arrays[0].shape for a in arrays):
            raise _err(path, f"bands must be equally shaped 2-D arrays, got shapes {[a.shape for a in arrays]}")
    return [a.astype(np.uint8) if a.dtype.kind == "b" else a for a in arrays]


def write_raster(path: str | os.PathLike, bands: np.ndarray | Sequence[np.ndarray],
                 like: Raster | None = None, nodata: float | None = None,
                 band_names: Sequence[str] | None = None, options: Mapping[str, str] | None = None,
                 cog: bool = False) -> None:
    """Write one band or several equally shaped bands at once (:class:`RasterWriter` for the
    formats and arguments); the write is atomic and never replaces ``like``'s file."""
    p = Path(path)
    arrays = _band_list(p, bands)
    with RasterWriter(p, (len(arrays), *arrays[0].shape), np.result_type(*arrays), like, nodata, band_names,
                      options, cog) as writer:
        for band in arrays:
            writer.write(band)
