"""The ``oclshade`` command line: ``oclshade devices``, ``oclshade shadow`` and ``oclshade render``.

Errors are one line ``oclshade: error: ...`` on stderr: exit status 2 for bad
arguments, 1 for failures while running (unreadable file, device, ...); 130 when
interrupted (SIGINT), 143 when terminated (SIGTERM), with no temporary file left.
``OCLSHADE_DEBUG=1`` shows the traceback as well.
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import math
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from dataclasses import dataclass
from datetime import datetime
from typing import NoReturn, Sequence, TextIO
from zoneinfo import ZoneInfo

import numpy as np

from .heightmap import Heightmap, InputWarning
from .geotiff import tiff_options
from .io import Raster, RasterWriter, read_dem
from .preview import Preview
from . import runtime
from .tuning import cli as tuning_cli
from .bench import cli as bench_cli
from .solar import cli as solar_cli
from .tiles import cli as tiles_cli
from .envmap import cli as envmap_cli
from .scene import cli as scene_cli
from .horizon import EARTH_RADIUS, Curvature
from .shadows import DEFAULT_K_BRIGHT, DEFAULT_K_DARK, METHODS, ShadowCaster, ShadowResult
from .ssao import DEFAULT_M
from .sun import DEFAULT_AZIMUTH, DEFAULT_ELEVATION, Sun

PROG = "oclshade"
RASTER_EXTENSIONS = (".tif", ".tiff", ".exr", ".npy", ".png")
OUTPUT_CHOICES = ("mask", "self", "coefficient", "all")
CELL_TAGS = {33550, 34264}  # GeoTIFF ModelPixelScale, ModelTransformation: the file knows its cell size


class CliError(Exception):
    """A failure the command line reports as one line; ``status`` is the exit status."""

    status = 1


class UsageError(CliError):
    """A bad argument found after parsing."""

    status = 2


class CliParser(argparse.ArgumentParser):
    """argparse with one-line errors: ``oclshade: error: <message>`` and exit 2."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{PROG}: error: {message} (see '{self.prog} --help')\n")
        raise SystemExit(2)


# --- argument types ------------------------------------------------------------------

def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{what} must be finite, got {text!r}")
    return value


def _azimuth(text: str) -> float:
    return _number(text, "azimuth")


def _elevation(text: str) -> float:
    value = _number(text, "elevation")
    if not -90.0 <= value <= 90.0:
        raise argparse.ArgumentTypeError(f"elevation must be in [-90, 90] degrees, got {text}")
    return value


def _positive(text: str) -> float:
    value = _number(text, "value")
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def _band(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"a band is a number 1, 2, ... (1-based, as GDAL), got {text!r}")
    return value


def _nodata(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"nodata must be a number (or nan), got {text!r}") from None


def add_input_arguments(parser: argparse.ArgumentParser) -> None:
    """-b and --nodata: which band of INPUT, and its nodata value (shadow and render)."""
    parser.add_argument("-b", dest="band", type=_band, default=None, metavar="BAND",
                        help="band of INPUT to read, 1-based as GDAL (default 1; a warning when INPUT has more)")
    parser.add_argument("--nodata", type=_nodata, default=None, metavar="VALUE",
                        help="INPUT's nodata value, overriding the file's (as gdalwarp -srcnodata)")


def _nonzero(text: str) -> float:
    value = _number(text, "z factor")
    if value == 0.0:
        raise argparse.ArgumentTypeError("z factor must not be 0")
    return value


def _unit(text: str) -> float:
    value = _number(text, "coefficient")
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1] (paper 000 eq. 1), got {text}")
    return value


def _sun(text: str) -> Sun:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"a sun is AZ,ALT in degrees (e.g. 315,20), got {text!r}")
    return Sun(_azimuth(parts[0].strip()), _elevation(parts[1].strip()))


#: --suns header names: column role (0 azimuth, 1 elevation); "zenith" is not one (90 - elevation)
SUN_COLUMNS = {"azimuth": 0, "az": 0, "elevation": 1, "elev": 1, "el": 1, "altitude": 1, "alt": 1}
#: --suns header name of a column of ISO 8601 datetimes (suns by NREL SPA instead of azimuth/elevation)
DATETIME_COLUMN = "datetime"


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_suns_csv(path: str, zone: ZoneInfo | None = None) -> tuple[list[Sun], list[datetime]]:
    """Suns from a CSV file: columns azimuth,elevation, or any columns when a header names
    them (azimuth/az and elevation/elev/el/altitude/alt, any case); the header is the first
    line when its first cell is not a number. Or, when the header names a ``datetime`` column
    (and no azimuth or elevation column), datetimes: ISO 8601 with a UTC offset, or local
    times in ``zone`` (--tz). UTF-8 with or without a BOM (Excel), any line ends; blank lines
    and lines starting with # are skipped; errors name the line. Returns (suns, datetimes),
    one of them empty."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(f)
            rows = [(reader.line_num, [c.strip() for c in r]) for r in reader
                    if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise UsageError(f"--suns {path}: cannot read: {exc}") from None
    cols = (0, 1)
    if rows and not _is_number(rows[0][1][0]):
        n, header = rows.pop(0)
        found: dict[int, list[int]] = {0: [], 1: []}
        for i, name in enumerate(header):
            if name.lower() in SUN_COLUMNS:
                found[SUN_COLUMNS[name.lower()]].append(i)
        dated = [i for i, name in enumerate(header) if name.lower() == DATETIME_COLUMN]
        if dated:
            if found[0] or found[1] or len(dated) > 1:
                raise UsageError(f"--suns {path}, line {n}: the header must name one datetime column and no "
                                 f"azimuth or elevation column (the sun one way), got {','.join(header)}")
            return [], _csv_datetimes(path, rows, dated[0], zone)
        if len(found[0]) != 1 or len(found[1]) != 1:
            raise UsageError(f"--suns {path}, line {n}: the header must name one azimuth column (azimuth or az) "
                             f"and one elevation column (elevation, elev, el, altitude or alt), got {','.join(header)}")
        cols = (found[0][0], found[1][0])
    suns = []
    for n, row in rows:
        if len(row) <= max(cols):
            raise UsageError(f"--suns {path}, line {n}: expected AZ,ALT"
                             f"{'' if cols == (0, 1) else f' in columns {cols[0] + 1} and {cols[1] + 1}'}, "
                             f"got {','.join(row)!r}")
        try:
            suns.append(_sun(f"{row[cols[0]]},{row[cols[1]]}"))
        except argparse.ArgumentTypeError as exc:
            raise UsageError(f"--suns {path}, line {n}: {exc}") from None
    if not suns:
        raise UsageError(f"--suns {path}: no sun positions in the file")
    return suns, []


def _csv_datetimes(path: str, rows: list[tuple[int, list[str]]], col: int, zone: ZoneInfo | None) -> list[datetime]:
    """The datetime column ``col`` of the --suns rows (after the header)."""
    times = []
    for n, row in rows:
        if len(row) <= col or not row[col]:
            raise UsageError(f"--suns {path}, line {n}: expected a datetime in column {col + 1}, got {','.join(row)!r}")
        times.append(solar_cli.parse_datetime(row[col], zone, f"--suns {path}, line {n}: datetime"))
    if not times:
        raise UsageError(f"--suns {path}: no sun positions in the file")
    return times


# --- parser ----------------------------------------------------------------------------

SHADOW_EPILOG = """\
output bands:
  mask         uint8, 1 = cast shadow, 0 = lit, 255 = nodata
  self         uint8, 1 = sun at or below the local tangent plane, 0 = not, 255 = nodata
  coefficient  float32, paper 000 eq. (1): 1 when lit, else
               k_dark + (k_bright - k_dark) * sin(elevation); NaN = nodata
  all          mask, self, coefficient per sun, all as float32 with NaN = nodata
               (mask and self keep their 0/1 values)
  With several suns the bands are ordered sun by sun (for each sun, its
  outputs); a single band is written as a 2-D array (.npy) or one-band image.
  Band names (GeoTIFF descriptions, EXR channels): mask_az315_alt22p5 etc.
  (azimuth in [0, 360)).

formats: by OUTPUT's extension: .tif/.tiff (GeoTIFF: georeferencing of the input
  kept, nodata tag 255 for uint8 bands, NaN for float32; tiled 256x256, DEFLATE with
  a predictor; --co and --of COG as GDAL), .exr (float channels, named with a
  zero-padded band number first so that they keep the band order: 0_mask_az315_alt20),
  .npy (2-D, or (bands, rows, cols)), .png (uint8 outputs only). A georeferenced
  PNG (OUTPUT or --preview) gets a world file (.pgw) and its CRS in PNG.aux.xml.
  Bands are written as each sun finishes: memory does not grow with the suns.

curvature: --curvature lowers terrain at distance d from a cell, along its ray, by
  (1 - k) d^2 / (2 R) (R = --radius, k = --refraction), as r.horizon and HORAYZON
  do; the result stays exact (the float64 reference has the same drop).

examples:
  oclshade shadow dem.tif shadow.tif -az 315 -alt 20 --preview shadow.png
  oclshade shadow dem.npy mask.npy --cellsize 30 -alt 10
  oclshade shadow srtm.hgt day.tif --sun 90,10 --sun 180,45 --sun 270,10
  oclshade shadow dem.tif year.tif --suns positions.csv --output coefficient
  oclshade shadow dem.tif day.tif --suns positions.csv --of COG --co COMPRESS=ZSTD
  oclshade shadow srtm.hgt.zip dusk.tif -az 280 -alt 1 --curvature --refraction 0.13
"""


def build_parser() -> CliParser:
    parser = CliParser(prog=PROG, description="Exact terrain cast shadows and terrain rendering on OpenCL devices.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    tuning_cli.add_parsers(sub)
    sh = sub.add_parser("shadow", help="cast-shadow mask / coefficient of a DEM",
                        description="Cast shadows of a DEM for one or several sun positions.",
                        epilog=SHADOW_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    sh.add_argument("input", metavar="INPUT", help="DEM: .tif/.tiff, .hgt, .zip (with .hgt), .asc, .exr, .png, .npy")
    sh.add_argument("output", metavar="OUTPUT", help="output raster: .tif/.tiff, .exr, .npy or .png")
    sh.add_argument("-az", dest="azimuth", type=_azimuth, default=None, metavar="DEG",
                    help=f"sun azimuth, degrees clockwise from north (default {DEFAULT_AZIMUTH:g})")
    sh.add_argument("-alt", dest="elevation", type=_elevation, default=None, metavar="DEG",
                    help=f"sun elevation above the horizon, degrees (default {DEFAULT_ELEVATION:g})")
    add_grid_arguments(sh)
    add_input_arguments(sh)
    sh.add_argument("--method", default="exact", choices=METHODS,
                    help="traversal (default exact; see README)")
    sh.add_argument("--output", dest="kind", default="mask", choices=OUTPUT_CHOICES,
                    help="what to write (default mask)")
    add_tiff_arguments(sh)
    sh.add_argument("--sun", dest="suns", action="append", type=_sun, default=[], metavar="AZ,ALT",
                    help="a sun position; repeat for several (one band each); "
                         "write --sun=AZ,ALT when AZ is negative")
    sh.add_argument("--suns", dest="suns_csv", metavar="FILE.csv",
                    help="sun positions, one per line: azimuth,elevation (header optional), or under a "
                         "header naming a datetime column, ISO 8601 datetimes (as --datetime)")
    solar_cli.add_time_arguments(sh)
    sh.add_argument("--k-dark", type=_unit, default=DEFAULT_K_DARK, metavar="K",
                    help=f"eq. (1) k_dark, shadow brightness with the sun at the horizon (default {DEFAULT_K_DARK:g})")
    sh.add_argument("--k-bright", type=_unit, default=DEFAULT_K_BRIGHT, metavar="K",
                    help=f"eq. (1) k_bright, shadow brightness with the sun at the zenith (default {DEFAULT_K_BRIGHT:g})")
    sh.add_argument("--preview", metavar="PNG", help="also write a hillshade PNG with the first sun's shadows")
    add_curvature_arguments(sh)
    sh.add_argument("--device", metavar="SPEC",
                    help="OpenCL device: index or name substring (default: $OCLSHADE_DEVICE, else PoCL CPU)")
    sh.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary")
    tiles_cli.add_arguments(sh)
    add_render_parser(sub)
    add_sunshine_parser(sub)
    add_horizon_parsers(sub)
    bench_cli.add_parser(sub)
    solar_cli.add_parser(sub)
    envmap_cli.add_parser(sub)
    return parser


def add_curvature_arguments(parser: argparse.ArgumentParser, only: str = "") -> None:
    """--curvature [--radius R] [--refraction K] (shadow, horizon, svf; sunshine's --site,
    ``only`` saying so in the help)."""
    parser.add_argument("--curvature", action="store_true",
                        help=f"{only}lower distant terrain by the Earth's curvature")
    parser.add_argument("--radius", type=_positive, default=None, metavar="METRES",
                        help=f"Earth radius of --curvature (default {EARTH_RADIUS:g})")
    parser.add_argument("--refraction", type=_refraction, default=None, metavar="K",
                        help="refraction coefficient of --curvature, in [0, 1) (default 0)")


def curvature_argument(args: argparse.Namespace) -> Curvature | None:
    """The Curvature of --curvature / --radius / --refraction, or None; raises UsageError."""
    if not args.curvature:
        if args.radius is not None or args.refraction is not None:
            raise UsageError("--radius and --refraction go with --curvature")
        return None
    return Curvature(args.radius or EARTH_RADIUS, args.refraction or 0.0)


def add_grid_arguments(parser: argparse.ArgumentParser) -> None:
    """-z, -s and --cellsize: INPUT's heights and cell size (shadow and sunshine)."""
    parser.add_argument("-z", dest="z_factor", type=_nonzero, default=1.0, metavar="ZFACTOR",
                        help="multiply heights by ZFACTOR (default 1)")
    parser.add_argument("-s", dest="scale", type=_positive, default=1.0, metavar="SCALE",
                        help="ratio of vertical units to horizontal, as gdaldem: horizontal cell sizes "
                             "are multiplied by SCALE (e.g. 111120 for a degree grid with metre heights "
                             "and no CRS; refused for input with a geographic CRS, which is converted "
                             "to metres automatically)")
    parser.add_argument("--cellsize", nargs="+", type=_positive, metavar=("DX", "DY"),
                        help="cell size (east-west, north-south); required for .npy/.exr/.png input, "
                             "overrides the file's otherwise")


def add_tiff_arguments(parser: argparse.ArgumentParser) -> None:
    """--of and --co: the GeoTIFF layout and creation options of OUTPUT (shadow and sunshine)."""
    parser.add_argument("--of", dest="tiff_format", type=str.upper, choices=("GTIFF", "COG"), default="GTIFF",
                        metavar="GTiff|COG", help="GeoTIFF layout, as GDAL's -of: GTiff (default) or COG "
                                                 "(Cloud-Optimized GeoTIFF: 512x512 tiles, overviews)")
    parser.add_argument("--co", dest="creation_options", action="append", default=[], metavar="KEY=VALUE",
                        help="GeoTIFF creation option, as GDAL's -co (repeatable): "
                             "COMPRESS=NONE|DEFLATE|LZW|ZSTD, PREDICTOR=1|2|3, ZLEVEL=1..12, ZSTD_LEVEL=1..22, "
                             "TILED=YES|NO, BLOCKXSIZE=N, BLOCKYSIZE=N, BLOCKSIZE=N, "
                             "BIGTIFF=YES|NO|IF_NEEDED|IF_SAFER, OVERVIEWS=AUTO|NONE")


def cellsize_argument(args: argparse.Namespace) -> float | tuple[float, float] | None:
    """--cellsize DX [DY] as read_input takes it (None: the file's)."""
    if args.cellsize is None:
        return None
    if len(args.cellsize) > 2:
        raise UsageError(f"--cellsize takes DX or DX DY, got {len(args.cellsize)} values")
    return args.cellsize[0] if len(args.cellsize) == 1 else (args.cellsize[0], args.cellsize[1])


RENDER_EPILOG = """\
outputs (by OUTPUT's extension):
  .png  the shaded frame: albedo x (sun x cast shadow + sky x AO), albedo a hypsometric
        tint, smooth shading normals, 8-bit sRGB; empty pixels show the sky colour
        (docs/methods.md, "Image quality in render")
  .exr  the G-buffer (oclshade/gbuffer.py), float32 channels:
        position.x/y/z/w (view space, w = 1 hit), normal.x/y/z, uv.u/v,
        uv_grad.dudc/dvdc/dudr/dvdr, Z (linear depth, +inf where empty), R/G/B/A (albedo)
  --gbuffer FILE.exr writes the G-buffer as well when OUTPUT is a PNG; for a scene file
        with mirror or glossy objects it adds reflection.x/y/z: the view-space reflection
        direction R = U - 2 (N.U) N on those objects' pixels, 0 elsewhere.
  shadow    (a .exr G-buffer of a frame with shadows) 1 where the light is hidden from
        the pixel's point by any caster (terrain, quadrics, meshes), 0 lit, on hit pixels;
        0 on empty pixels
  header    view and projection: the camera's 4x4 matrices (row-major, float64, on column
        vectors: world -> view, view -> OpenGL clip space), so any tool can rebuild world
        positions: world = inverse(view) . (position.x, position.y, position.z, 1)

camera: automatic by default (the map from --view AZ,EL, default 200,30: from the
  south-south-west, 30 degrees down; it fills the frame, up to --crop of the map left
  out, --crop 0 for the whole map); or --camera X,Y,Z,TX,TY,TZ: position and target in
  metres, x east from the first column, y north from the first row (so the map lies at
  y <= 0), z the height after -z.

examples:
  oclshade render dem.tif view.png --size 1920x1080
  oclshade render dem.tif view.png --view 315,20 --fov 60 --sun 135,25 --gbuffer view.exr
  oclshade render dem.npy gbuf.exr --cellsize 30 --camera 0,-9000,2500,6000,-3000,300
  oclshade render dem.tif view.png --sun 135,8 --ao 6 --ao-map ao.exr   # low sun, AO radius 6 cells
  oclshade render dem.tif view.png --ssaa 3        # 3 x 3 samples per pixel: smooth edges

passes: the G-buffer (ray casting), shading normals, per-pixel cast shadows (on;
  --no-shadows), ambient occlusion (off; --ao), compose; a pass switched off is not
  compiled.  --ssaa N runs every pass on N x N samples per pixel (N^2 times the work)
  and box-filters the frame.
"""


def _ao_samples(text: str) -> int:
    try:
        m = int(text)
    except ValueError:
        m = 0
    if not 4 <= m <= 256:
        raise argparse.ArgumentTypeError(f"expected an integer 4..256, got {text!r}")
    return m


def _ssaa(text: str) -> int:
    from .compose import MAX_SSAA
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 1 <= n <= MAX_SSAA:
        raise argparse.ArgumentTypeError(f"expected an integer 1..{MAX_SSAA} (samples per pixel along each axis), "
                                         f"got {text!r}")
    return n


def _crop(text: str) -> float:
    value = _number(text, "--crop")
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1) of the map, got {text!r}")
    return value


def _size(text: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    try:
        w, h = int(parts[0]), int(parts[1])
        if len(parts) != 2:
            raise ValueError
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"a size is WIDTHxHEIGHT in pixels (e.g. 1920x1080), got {text!r}") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError(f"width and height must be in 1..16384, got {text!r}")
    return w, h


def _floats(text: str, count: int, what: str) -> tuple[float, ...]:
    parts = text.split(",")
    if len(parts) != count:
        raise argparse.ArgumentTypeError(f"{what} takes {count} comma-separated numbers, got {text!r}")
    return tuple(_number(p.strip(), what) for p in parts)


def _shadow_level(text: str):
    """``--shadow-level``: a fixed level q >= 0 or ``auto`` (Algo 1)."""
    from .screen_shadows import LodOptions
    if text == "auto":
        return LodOptions.automatic()
    if text.isdigit():
        return LodOptions(force_q=int(text))
    raise argparse.ArgumentTypeError(f"expected a level 0, 1, 2, ... or 'auto', got {text!r}")


def _fov(text: str) -> float:
    value = _number(text, "fov")
    if not 0.0 < value < 180.0:
        raise argparse.ArgumentTypeError(f"fov must be in (0, 180) degrees, got {text}")
    return value


def add_render_parser(sub) -> None:
    from .camera import DEFAULT_CROP
    from .terrain import METHODS as TERRAIN_METHODS

    rd = sub.add_parser("render", help="ray-cast a DEM into a shaded PNG and/or an EXR G-buffer",
                        description="Render a DEM as terrain seen by a camera (paper 004 voxel bisection).",
                        epilog=RENDER_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    rd.add_argument("input", metavar="INPUT", help="DEM: .tif/.tiff, .hgt, .zip (with .hgt), .asc, .exr, .png, .npy; "
                                                   "or a scene file .toml (terrain, quadrics, environment: docs/reflections.md)")
    rd.add_argument("output", metavar="OUTPUT", help="shaded frame (.png) or G-buffer (.exr)")
    rd.add_argument("--size", type=_size, default=(1280, 720), metavar="WxH", help="frame size (default 1280x720)")
    rd.add_argument("--camera", type=lambda t: _floats(t, 6, "--camera"), metavar="X,Y,Z,TX,TY,TZ",
                    help="camera position and target in metres (see below); default: automatic")
    rd.add_argument("--view", type=lambda t: _floats(t, 2, "--view"), default=(200.0, 30.0), metavar="AZ,EL",
                    help="automatic camera: direction from the map centre to the camera (default 200,30)")
    rd.add_argument("--crop", type=_crop, default=DEFAULT_CROP, metavar="F",
                    help=f"automatic camera: at most this fraction of the map may leave the frame so that the "
                         f"map fills it (default {DEFAULT_CROP:g}; 0: the whole map)")
    rd.add_argument("--fov", type=_fov, default=45.0, metavar="DEG", help="vertical field of view (default 45)")
    rd.add_argument("--ortho", action="store_true", help="orthographic camera (automatic framing only)")
    rd.add_argument("--method", default="bisect", choices=TERRAIN_METHODS,
                    help="ray caster (default bisect; march and dda are baselines)")
    rd.add_argument("--sun", type=_sun, default=Sun(DEFAULT_AZIMUTH, DEFAULT_ELEVATION), metavar="AZ,ALT",
                    help=f"sun for the shading (default {DEFAULT_AZIMUTH:g},{DEFAULT_ELEVATION:g})")
    rd.add_argument("--radius", type=_positive, default=None, metavar="METRES",
                    help="put the map on a sphere of this radius (e.g. 6371000)")
    rd.add_argument("--ssaa", type=_ssaa, default=1, metavar="N",
                    help="N x N samples per pixel (shadows and AO per sample), box-filtered (default 1; "
                         "PNG output without --gbuffer / --ao-map)")
    rd.add_argument("--gbuffer", metavar="EXR", help="also write the G-buffer (OUTPUT must be a .png)")
    rd.add_argument("--no-shadows", action="store_true",
                    help="leave out the per-pixel cast shadows (paper 000; on by default)")
    rd.add_argument("--shadow-method", default="exact", choices=METHODS,
                    help="per-pixel shadow traversal (default exact)")
    rd.add_argument("--shadow-level", type=_shadow_level, default=None, metavar="Q|auto",
                    help="level of detail of the per-pixel shadows: 0 (default) is exact; a level above 0 or "
                         "'auto' (paper 000's Algo 1) is faster and misses narrow shadows (docs/methods.md)")
    rd.add_argument("--ao", type=_positive, nargs="?", const=4.0, default=None, metavar="CELLS",
                    help="screen-space ambient occlusion (paper 001) of radius CELLS cells (default 4)")
    rd.add_argument("--ao-samples", type=_ao_samples, default=DEFAULT_M, metavar="M",
                    help=f"AO samples (line samples: oclshade.ssao.DEFAULT_FEATURES) per pixel, 4..256 (default {DEFAULT_M})")
    rd.add_argument("--ao-map", metavar="EXR", help="also write the AO factor (1 = unoccluded) as an EXR")
    rd.add_argument("-z", dest="z_factor", type=_nonzero, default=1.0, metavar="ZFACTOR",
                    help="multiply heights by ZFACTOR (default 1)")
    rd.add_argument("-s", dest="scale", type=_positive, default=1.0, metavar="SCALE",
                    help="horizontal cell sizes are multiplied by SCALE, as in 'oclshade shadow'")
    rd.add_argument("--cellsize", nargs="+", type=_positive, metavar=("DX", "DY"),
                    help="cell size (east-west, north-south); required for .npy/.exr/.png input")
    add_input_arguments(rd)
    rd.add_argument("--device", metavar="SPEC", help="OpenCL device: index or name substring")
    rd.add_argument("--quiet", "-q", action="store_true", help="no summary line")


# --- shadow command ---------------------------------------------------------------------

@dataclass(frozen=True)
class ShadowJob:
    suns: list[Sun]                 # empty until the input is read when they come from --datetime
    times: list                     # --datetime values (aware datetimes)
    outputs: tuple[str, ...]
    cellsize: float | tuple[float, float] | None
    dtype: np.dtype                 # of the output bands
    options: dict[str, str]         # GeoTIFF creation options (--co)
    cog: bool                       # --of COG
    curvature: Curvature | None = None   # --curvature


def _extension(path: str) -> str:
    return os.path.splitext(path)[1].lower()


def _same_file(a: str, b: str) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_shadow_args(args: argparse.Namespace) -> ShadowJob:
    """Cross-argument checks; raises UsageError (exit 2)."""
    if _extension(args.output) not in RASTER_EXTENSIONS:
        raise UsageError(f"OUTPUT {args.output!r}: unknown extension; expected one of {', '.join(RASTER_EXTENSIONS)}")
    if args.preview is not None and _extension(args.preview) != ".png":
        raise UsageError(f"--preview {args.preview!r}: must end with .png")
    if _extension(args.output) == ".png" and args.kind not in ("mask", "self"):
        raise UsageError(f"--output {args.kind}: PNG holds uint8 bands only (mask or self); use .tif, .exr or .npy")
    cellsize = cellsize_argument(args)
    explicit = args.azimuth is not None or args.elevation is not None
    csv_suns, csv_times = ([], []) if args.suns_csv is None else read_suns_csv(args.suns_csv,
                                                                               solar_cli.time_zone(args.tz))
    times = solar_cli.parse_datetimes(args, more=bool(csv_times)) + csv_times
    suns = list(args.suns) + csv_suns
    if sum(map(bool, (explicit, suns, times))) > 1:
        raise UsageError("give the sun one way: -az/-alt, --sun/--suns or --datetime")
    if not suns and not times:
        az = DEFAULT_AZIMUTH if args.azimuth is None else args.azimuth
        alt = DEFAULT_ELEVATION if args.elevation is None else args.elevation
        suns = [Sun(az, alt)]
    outputs = ("mask", "self", "coefficient") if args.kind == "all" else (args.kind,)
    if _extension(args.output) == ".png" and len(suns) + len(times) > 1:
        raise UsageError(f"PNG output holds one band; {len(suns) + len(times)} suns need .tif, .exr or .npy")
    dtype = np.dtype(np.uint8 if outputs in (("mask",), ("self",)) else np.float32)
    options, cog = creation_options(args, dtype)
    curvature = curvature_argument(args)
    if curvature is not None and tiles_cli.requested(args):
        raise UsageError("--curvature does not work with tiled runs (--tile, --max-memory, --workers) yet")
    return ShadowJob(suns, times, outputs, cellsize, dtype, options, cog, curvature)


def creation_options(args: argparse.Namespace, dtype: np.dtype) -> tuple[dict[str, str], bool]:
    """--co KEY=VALUE (the last of a key wins, as GDAL) and --of, checked for OUTPUT's bands."""
    cog = args.tiff_format == "COG"
    if (args.creation_options or cog) and _extension(args.output) not in (".tif", ".tiff"):
        raise UsageError(f"--co and --of COG apply to GeoTIFF output (.tif, .tiff), not {args.output!r}")
    options = {}
    for item in args.creation_options:
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise UsageError(f"--co takes KEY=VALUE (e.g. COMPRESS=ZSTD), got {item!r}")
        options[key.strip().upper()] = value.strip()
    try:
        tiff_options(options, dtype, cog)
    except ValueError as exc:
        raise UsageError(f"--co {exc}") from None
    return options, cog


def read_input(args: argparse.Namespace, cellsize: float | tuple[float, float] | None) -> tuple[Raster, Heightmap]:
    """INPUT as a raster and a heightmap (-b, --nodata, --cellsize, -s, -z); the library's
    warnings become ``oclshade: warning: ...`` lines once the input is accepted."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        raster = read_dem(args.input, cellsize=cellsize, band=args.band, nodata=args.nodata)
        check_input_raster(args, raster, cellsize)
        heightmap = Heightmap.from_array(raster.heights, cellsize=(raster.dx * args.scale, raster.dy * args.scale),
                                         z_factor=args.z_factor)
    for warning in caught:
        sys.stderr.write(f"{PROG}: warning: {warning.message}\n")
    return raster, heightmap


def check_input_raster(args: argparse.Namespace, raster: Raster,
                       cellsize: float | tuple[float, float] | None) -> None:
    """INPUT's cell size is known (from the file or --cellsize), and -s is not given for a geographic one."""
    if cellsize is None and not CELL_TAGS & raster.georef.keys():
        raise UsageError(f"INPUT {args.input!r} does not record its cell size; give --cellsize DX [DY] (metres)")
    if cellsize is None and raster.geographic and args.scale != 1.0:
        raise UsageError(f"-s {args.scale:g}: INPUT {args.input!r} has a geographic CRS, and its cell sizes "
                         f"are converted to metres automatically; drop -s")


class ProgressBar:
    """A dependency-free text bar on a stream; redraws in place on a terminal."""

    def __init__(self, stream: TextIO, what: str, width: int = 30):
        self.stream, self.what, self.width = stream, what, width
        self.tty = stream.isatty()
        self.shown = -1

    def __call__(self, done: int, total: int) -> None:
        tenth = 10 * done // total
        if not self.tty and tenth == self.shown and done != total:
            return  # in logs: one line per tenth
        self.shown = tenth
        fill = self.width * done // total
        line = f"[{'#' * fill}{'.' * (self.width - fill)}] {done}/{total} {self.what}"
        end = "\n" if (done == total or not self.tty) else ""
        self.stream.write(("\r" if self.tty else "") + line + end)
        self.stream.flush()


def _azimuth_360(azimuth: float) -> float:
    """An azimuth in [0, 360) degrees (-45 -> 315)."""
    a = azimuth % 360.0
    return 0.0 if a == 360.0 else a   # a tiny negative azimuth rounds up to 360


def band_names(suns: Sequence[Sun], outputs: tuple[str, ...], exr: bool = False) -> list[str]:
    """Output band names sun by sun: ``mask_az315_alt22p5``; for EXR, which sorts channels by
    name, prefixed with the zero-padded band number (``00_mask_...``) to keep the band order."""
    names = [f"{out}_az{_azimuth_360(sun.azimuth):g}_alt{sun.elevation:g}".replace(".", "p")
             for sun in suns for out in outputs]
    width = len(str(len(names) - 1))
    return [f"{k:0{width}d}_{name}" for k, name in enumerate(names)] if exr else names


def _result_bands(res: ShadowResult, outputs: tuple[str, ...]) -> list[np.ndarray]:
    """One sun's output bands; with several outputs all float32, uint8 nodata 255 as NaN."""
    bands = []
    for out in outputs:
        band = {"mask": res.mask, "self": res.self_shadow, "coefficient": res.coefficient}[out]
        if len(outputs) > 1 and band.dtype == np.uint8:
            band = np.where(band == 255, np.float32(np.nan), band.astype(np.float32))
        bands.append(band)
    return bands


def run_shadow(args: argparse.Namespace) -> int:
    job = check_shadow_args(args)
    if _same_file(args.output, args.input):
        raise CliError(f"OUTPUT {args.output!r} is the input file; refusing to overwrite it")
    if args.preview is not None and (_same_file(args.preview, args.input) or _same_file(args.preview, args.output)):
        raise CliError(f"--preview {args.preview!r} is the input or the output file; refusing to overwrite it")
    if tiles_cli.requested(args):
        return tiles_cli.run(args, job)
    t0 = time.perf_counter()
    raster, heightmap = read_input(args, job.cellsize)
    traced = None
    if job.times:
        placed = solar_cli.suns_for(job.times, args, raster)
        job = dataclasses.replace(job, suns=placed.suns)
        traced = placed.traced
        if not args.quiet:
            print(f"{PROG}: {placed.describe(job.times[0])}", file=sys.stderr)
            if blocks := placed.blocks_line():
                print(f"{PROG}: {blocks}", file=sys.stderr)
    else:
        traced = solar_cli.on_map_grid(job.suns, args, raster)
    dx, dy = heightmap.dx, heightmap.dy
    rows, cols = heightmap.shape
    _make_parents(args.output, args.preview)
    shadow = lit = 0
    with contextlib.ExitStack() as stack:   # both files are checked writable before any work
        preview = None if args.preview is None else stack.enter_context(Preview(args.preview, heightmap.shape, raster))
        names = band_names(job.suns, job.outputs, exr=_extension(args.output) == ".exr")
        out = stack.enter_context(RasterWriter(
            args.output, (len(names), rows, cols), job.dtype, like=raster,
            nodata=255.0 if job.dtype == np.uint8 else math.nan, band_names=names, options=job.options, cog=job.cog))
        caster = ShadowCaster(heightmap, device=args.device, cache=False,   # one run: no result is reused
                              curvature=job.curvature)
        show_bar = not args.quiet and len(job.suns) > 1
        t1 = time.perf_counter()
        for res in caster.iter_many(traced or job.suns, method=args.method, outputs=("mask", *job.outputs),
                                    k_dark=args.k_dark, k_bright=args.k_bright,
                                    progress=ProgressBar(sys.stderr, "suns") if show_bar else None):
            if preview is not None and not preview.written:
                preview.draw(heightmap.heights, dx, dy, res.sun.azimuth, res.sun.elevation, mask=res.mask)
            shadow += int(np.count_nonzero(res.mask == 1))
            lit += int(np.count_nonzero(res.mask == 0))
            for band in _result_bands(res, job.outputs):
                out.write(band)
        t2 = time.perf_counter()
        for writer in (out, preview):   # complete both before either replaces a file
            if writer is not None:
                writer.finish()
    if not args.quiet:
        bent = "" if job.curvature is None else \
            f", curvature R {job.curvature.radius:g} m k {job.curvature.refraction:g}"
        print(f"{PROG}: {cols}x{rows} cells, {len(job.suns)} sun(s), method {args.method}{bent}, "
              f"device {caster.runtime.label}: pyramid + shadows {t2 - t1:.2f} s "
              f"(total {time.perf_counter() - t0:.2f} s), {100 * shadow / max(shadow + lit, 1):.1f}% of cells "
              f"in cast shadow -> {args.output}", file=sys.stderr)
    return 0


def _make_parents(*paths: str | None) -> None:
    """Create the directories of the outputs (before any work)."""
    for path in paths:
        if path is not None and os.path.dirname(path):
            try:
                os.makedirs(os.path.dirname(path), exist_ok=True)
            except OSError as exc:
                raise CliError(f"{path}: cannot create its directory: {exc.strerror or exc}") from None


# --- render command ---------------------------------------------------------------------

GBUFFER_CHANNELS = {
    "position": ("position.x", "position.y", "position.z", "position.w"),
    "normal": ("normal.x", "normal.y", "normal.z", None),
    "uv": ("uv.u", "uv.v"),
    "uv_grad": ("uv_grad.dudc", "uv_grad.dvdc", "uv_grad.dudr", "uv_grad.dvdr"),
    "depth": ("Z",),
    "albedo": ("R", "G", "B", "A"),
}


GBUFFER_NAMES = [name for channels in GBUFFER_CHANNELS.values() for name in channels if name is not None]


def gbuffer_bands(gbuf, shadow: np.ndarray | None = None) -> tuple[list[np.ndarray], list[str]]:
    """The G-buffer as float32 EXR channels named :data:`GBUFFER_NAMES` (normal.w, always 0, is
    left out), then ``shadow`` when given: bool (height, width), True where the light is hidden
    from the pixel's point by any caster; written 1 on hit pixels, 0 elsewhere."""
    bands = []
    for field, channels in GBUFFER_CHANNELS.items():
        data = getattr(gbuf, field)
        bands += [data if data.ndim == 2 else data[..., k] for k, name in enumerate(channels) if name is not None]
    if shadow is None:
        return bands, list(GBUFFER_NAMES)
    if shadow.shape != gbuf.shape:
        raise ValueError(f"the shadow mask is {shadow.shape} pixels, the G-buffer {gbuf.shape}")
    return bands + [(shadow & gbuf.hit).astype(np.float32)], GBUFFER_NAMES + [SHADOW_NAME]


SHADOW_NAME = "shadow"


def frame_shadow_mask(frame) -> np.ndarray | None:
    """The :data:`SHADOW_NAME` channel's mask of a rendered frame (bool (height, width)): its
    shadow coefficient below 1, where a caster (terrain, quadric, mesh) wrote paper 000's
    eq. (1) coefficient; None when the frame has no shadows.  (With k_dark = k_bright = 1 a
    shadow writes 1 and is not seen: the renders here use k = 0.)"""
    if frame.shadow is None:
        return None
    import pyopencl as cl

    coef = np.empty(frame.gbuffer.shape, np.float32)
    queue = frame.gbuffer.runtime.queue
    cl.enqueue_copy(queue, coef, frame.shadow)
    queue.finish()
    return coef < 1.0


class GBufferExr:
    """The --gbuffer .exr writer: float32 channels and the camera's ``view`` and ``projection``
    4x4 matrices (row-major, float64 M44d) as header attributes.  The destination is checked
    when made (before any work); :meth:`write` writes a temporary file beside it and renames
    it over the destination."""

    def __init__(self, path: str):
        self.path = path
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise CliError(f"{path}: output directory does not exist")
        if os.path.isdir(path):
            raise CliError(f"{path}: is a directory")
        if not os.access(folder, os.W_OK):
            raise CliError(f"{path}: output directory is not writable")

    def write(self, bands: list[np.ndarray], names: list[str], camera) -> None:
        import tempfile

        import OpenEXR

        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "view": np.ascontiguousarray(camera.view, np.float64),
                  "projection": np.ascontiguousarray(camera.projection_matrix, np.float64)}
        channels = {name: np.ascontiguousarray(band, np.float32) for name, band in zip(names, bands)}
        fd, tmp = tempfile.mkstemp(suffix=".exr", dir=os.path.dirname(os.path.abspath(self.path)))
        os.close(fd)
        try:
            with OpenEXR.File(header, channels) as exr:
                exr.write(tmp)
            os.replace(tmp, self.path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise


def run_render(args: argparse.Namespace) -> int:
    from .camera import Camera, frame_heightmap
    from .compose import Lighting
    from .frames import AOSettings, FrameSettings, TerrainScene
    from .screen_shadows import LodOptions
    from .terrain import Heightfield

    if scene_cli.is_scene(args.input):
        return scene_cli.run(args)
    out_ext = _extension(args.output)
    if out_ext not in (".png", ".exr"):
        raise UsageError(f"OUTPUT {args.output!r}: expected .png (shaded frame) or .exr (G-buffer)")
    if args.gbuffer is not None and (out_ext != ".png" or _extension(args.gbuffer) != ".exr"):
        raise UsageError("--gbuffer takes an .exr path and needs OUTPUT to be a .png")
    if args.cellsize is not None and len(args.cellsize) > 2:
        raise UsageError(f"--cellsize takes DX or DX DY, got {len(args.cellsize)} values")
    if args.ortho and args.camera is not None:
        raise UsageError("--ortho works with the automatic camera only (leave out --camera)")
    if args.ssaa > 1 and (out_ext != ".png" or args.gbuffer is not None or args.ao_map is not None):
        raise UsageError(f"--ssaa {args.ssaa} makes the PNG frame only: the G-buffer and AO map have one sample "
                         "per pixel (leave out --ssaa, or --gbuffer / --ao-map / an .exr OUTPUT)")
    if args.ao_map is not None and (_extension(args.ao_map) != ".exr" or args.ao is None):
        raise UsageError("--ao-map takes an .exr path and needs --ao")
    if args.ao_map is not None and args.ao_map in (args.output, args.gbuffer):
        raise UsageError("--ao-map must differ from OUTPUT and --gbuffer")
    for path in (args.output, args.gbuffer, args.ao_map):
        if path is not None and _same_file(path, args.input):
            raise CliError(f"{path!r} is the input file; refusing to overwrite it")
    if args.gbuffer is not None and _same_file(args.gbuffer, args.output):
        raise UsageError("--gbuffer and OUTPUT must be different files")
    t0 = time.perf_counter()
    cellsize = None if args.cellsize is None else (
        args.cellsize[0] if len(args.cellsize) == 1 else (args.cellsize[0], args.cellsize[1]))
    _, heightmap = read_input(args, cellsize)
    width, height = args.size
    gbuffer_path = args.output if out_ext == ".exr" else args.gbuffer
    _make_parents(args.output, args.gbuffer, args.ao_map)
    with contextlib.ExitStack() as stack:   # every output is checked writable before any work

        def writer(path: str | None, count: int, names: list[str] | None = None) -> RasterWriter | None:
            return None if path is None else stack.enter_context(
                RasterWriter(path, (count, height, width), np.float32 if names else np.uint8, band_names=names))

        image = writer(args.output if out_ext == ".png" else None, 3)
        gbuffer = None if gbuffer_path is None else GBufferExr(gbuffer_path)
        ao_map = writer(args.ao_map, 1, ["AO"])
        field = Heightfield(heightmap, args.radius)
        if args.camera is None:
            camera = frame_heightmap(heightmap, width, height, azimuth=args.view[0], elevation=args.view[1],
                                     fov=args.fov, projection="orthographic" if args.ortho else "perspective",
                                     crop=args.crop)
        else:
            pos, target = np.array(args.camera[:3]), np.array(args.camera[3:])
            extent = float(np.hypot(heightmap.shape[1] * heightmap.dx, heightmap.shape[0] * heightmap.dy))
            reach = float(np.linalg.norm(pos - target)) + 2.0 * extent
            camera = Camera(pos, target, width, height, fov=args.fov, near=1e-4 * reach, far=reach)
        scene = TerrainScene(field, device=args.device)
        ao = None if args.ao is None else AOSettings(radius=args.ao * max(heightmap.dx, heightmap.dy),
                                                     m=args.ao_samples)
        settings = FrameSettings(caster=args.method, shadows=not args.no_shadows, shadow_method=args.shadow_method,
                                 lod=args.shadow_level or LodOptions(),
                                 ao=ao, lighting=Lighting(sun=args.sun), ssaa=args.ssaa)
        t1 = time.perf_counter()
        frame = scene.frame(camera, args.sun, settings)
        t2 = time.perf_counter()
        outputs = [(image, lambda: [frame.image[..., c] for c in range(3)]),
                   (ao_map, lambda: [frame.ao_factor()])]
        if gbuffer is not None:
            gbuffer.write(*gbuffer_bands(frame.gbuffer.to_host(), frame_shadow_mask(frame)), camera)
        for out, planes in outputs:
            for plane in planes() if out is not None else ():
                out.write(plane)
        for out, _ in outputs:   # complete every file before any replaces its target
            if out is not None:
                out.finish()
    if not args.quiet:
        rows, cols = heightmap.shape
        passes = ", ".join(f"{name} {ms:.0f} ms" for name, ms in frame.ms.items())
        samples = f" ({args.ssaa}x{args.ssaa} samples each)" if args.ssaa > 1 else ""
        print(f"{PROG}: {cols}x{rows} cells, {width}x{height} pixels{samples}, method {args.method}, device "
              f"{scene.runtime.label}: {passes} (with builds; total {t2 - t1:.2f} s, "
              f"run {time.perf_counter() - t0:.2f} s) -> {args.output}", file=sys.stderr)
    return 0


# --- sunshine command -------------------------------------------------------------------

SUNSHINE_OUTPUTS = ("hours", "fraction", "irradiation")

SUNSHINE_EPILOG = """\
output bands (float32, NaN = nodata; band names as below):
  hours        hours of direct sun: the sun above the horizon (elevation > 0), the
               cell not in cast shadow and its surface facing the sun (the sun above
               its tangent plane, as 'shadow --output self')
  fraction     the share of the daylight time the cell spends in cast shadow (0..1;
               NaN everywhere when the sun never rises in the period)
  irradiation  the sum of cos(incidence on the sloped surface) x hours over the
               direct-sun steps: hours of beam irradiance at normal incidence, i.e.
               Wh/m^2 per W/m^2 of direct-normal irradiance (no atmosphere model)

time steps: [--start, --end) cut into --step steps from --start (the last one shorter
  when --step does not divide the period); each step counts its length, with the sun
  (NREL SPA, with refraction) at its midpoint. Datetimes as for 'oclshade sun': ISO
  8601 with a UTC offset, or local times with --tz. The place: --lat/--lon (one sun
  for the whole map), else each cell's own place through INPUT's CRS: the map is cut
  into blocks, each summed with the sun of its centre, every cell's own sun within
  --sun-tolerance (default 0.01 degrees) of its block's, in one launch a step; on a
  projected map each true azimuth is turned to the grid (meridian convergence).

routes (--method): masks (default) traces the exact cast-shadow mask of every daylight
  step; horizons computes the horizon angles of --azimuths N directions once and
  compares each sun with the horizon interpolated linearly between the two azimuths
  around it (faster for many steps; its error against masks: docs/solar.md).
  Either way the sums stay on the device: memory does not grow with the steps.

formats: .tif/.tiff (georeferencing of the input kept; --co, --of COG), .exr, .npy.

examples:
  oclshade sunshine dem.tif june.tif --start 2024-06-01T00:00 --end 2024-07-01T00:00 --tz Europe/Zurich
  oclshade sunshine srtm.hgt.zip day.tif --start 2024-03-20T00:00Z --end 2024-03-21T00:00Z --step 5min --output all
  oclshade sunshine dem.npy year.npy --cellsize 30 --lat 46.9 --lon 7.4 --start 2024-01-01T00:00Z --end 2025-01-01T00:00Z --step 1h --method horizons
"""


def _sunshine_outputs(text: str) -> tuple[str, ...]:
    items = tuple(item.strip() for item in text.split(","))
    if items == ("all",):
        return SUNSHINE_OUTPUTS
    bad = [item for item in items if item not in SUNSHINE_OUTPUTS]
    if bad or not items:
        raise argparse.ArgumentTypeError(f"expected a comma-separated subset of {','.join(SUNSHINE_OUTPUTS)} "
                                         f"or all, got {text!r}")
    return tuple(out for out in SUNSHINE_OUTPUTS if out in items)


def _step(text: str):
    from .sunshine import parse_step
    try:
        return parse_step(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _azimuths(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if not 4 <= n <= 3600:
        raise argparse.ArgumentTypeError(f"expected a whole number of azimuths in 4..3600, got {text!r}")
    return n


def add_sunshine_parser(sub) -> None:
    ss = sub.add_parser("sunshine", help="hours of direct sun per cell over a period (and shadow frequency, "
                                         "beam irradiation)",
                        description="Sunshine over time: per cell, the hours of direct sun between two datetimes.",
                        epilog=SUNSHINE_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ss.add_argument("input", metavar="INPUT", help="DEM: .tif/.tiff, .hgt, .zip (with .hgt), .asc, .exr, .png, .npy")
    ss.add_argument("output", metavar="OUTPUT", help="output raster: .tif/.tiff, .exr or .npy")
    ss.add_argument("--start", required=True, metavar="ISO", help="start of the period (ISO 8601; see --tz)")
    ss.add_argument("--end", required=True, metavar="ISO", help="end of the period, not included")
    ss.add_argument("--step", type=_step, default=_step("10min"), metavar="STEP",
                    help="time step: a whole number with s, min, h or d (default 10min)")
    solar_cli.add_place_arguments(ss, "--start and --end")
    ss.add_argument("--output", dest="outputs", type=_sunshine_outputs, default=("hours",), metavar="LIST",
                    help="comma-separated bands to write: hours, fraction, irradiation, or all (default hours)")
    ss.add_argument("--method", default="masks", choices=("masks", "horizons"),
                    help="masks: an exact mask per step (default); horizons: compare with horizons of "
                         "--azimuths directions")
    ss.add_argument("--azimuths", type=_azimuths, default=None, metavar="N",
                    help="horizon directions of --method horizons (default 64)")
    ss.add_argument("--site", type=_site, metavar="LAT,LON",
                    help="the sunshine of one place instead of the map's: OUTPUT a .csv of each step's sun, the "
                         "site's horizon at its azimuth (along the geodesic) and whether it shines")
    ss.add_argument("--above", type=_above, default=0.0, metavar="METRES",
                    help="with --site: the eye's height over the surface there (default 0)")
    add_curvature_arguments(ss, "with --site: ")
    add_grid_arguments(ss)
    add_input_arguments(ss)
    add_tiff_arguments(ss)
    ss.add_argument("--device", metavar="SPEC",
                    help="OpenCL device: index or name substring (default: $OCLSHADE_DEVICE, else PoCL CPU)")
    ss.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary")


def sunshine_period(args: argparse.Namespace) -> tuple:
    """``sunshine``'s --tz, --start, --end and their --step's :class:`oclshade.sunshine.TimeSteps`,
    checked, and OUTPUT checked not to be INPUT."""
    from .sunshine import time_steps

    zone = solar_cli.time_zone(args.tz)
    start, end = (solar_cli.parse_datetime(getattr(args, name), zone, f"--{name}") for name in ("start", "end"))
    try:
        steps = time_steps(start, end, args.step)
    except ValueError as exc:
        raise UsageError(f"--start, --end, --step: {exc}") from None
    if _same_file(args.output, args.input):
        raise CliError(f"OUTPUT {args.output!r} is the input file; refusing to overwrite it")
    return zone, start, end, steps


def run_sunshine(args: argparse.Namespace) -> int:
    from .sunshine import DEFAULT_AZIMUTHS, SunshineCaster
    from .sunshine import daylight as sunshine_daylight

    if args.site is not None:
        return run_site_sunshine(args)
    if args.above:
        raise UsageError("--above is the eye's height at a --site; give --site LAT,LON")
    if args.curvature or args.radius is not None or args.refraction is not None:
        raise UsageError("--curvature goes with --site here: the map's sunshine has none (docs/cli.md)")
    if _extension(args.output) not in (".tif", ".tiff", ".exr", ".npy"):
        raise UsageError(f"OUTPUT {args.output!r}: expected .tif, .tiff, .exr or .npy (float32 bands)")
    if args.azimuths is not None and args.method != "horizons":
        raise UsageError("--azimuths goes with --method horizons")
    cellsize = cellsize_argument(args)
    options, cog = creation_options(args, np.dtype(np.float32))
    solar_cli.check_place(args)
    zone, start, end, steps = sunshine_period(args)
    t0 = time.perf_counter()
    raster, heightmap = read_input(args, cellsize)
    placed = solar_cli.suns_for(steps.times, args, raster, "--start and --end")
    suns, site = placed.traced, placed.site
    rows, cols = heightmap.shape
    _make_parents(args.output)
    with RasterWriter(args.output, (len(args.outputs), rows, cols), np.float32, like=raster, nodata=math.nan,
                      band_names=list(args.outputs), options=options, cog=cog) as out:
        caster = SunshineCaster(heightmap, device=args.device)
        daylight = len(sunshine_daylight(suns, steps.seconds)[0])
        if not args.quiet:
            print(f"{PROG}: {len(suns)} steps of {args.step} from {start.isoformat()} to {end.isoformat()} at "
                  f"latitude {site.latitude:.5f}, longitude {site.longitude:.5f} (NREL SPA"
                  f"{f'; azimuths turned to the grid of {site.crs_name}' if site.crs is not None else ''}): "
                  f"{daylight} in daylight", file=sys.stderr)
            if blocks := placed.blocks_line():
                print(f"{PROG}: {blocks}", file=sys.stderr)
        t1 = time.perf_counter()
        maps = caster.accumulate(suns, steps.seconds, args.outputs, method=args.method,
                                 azimuths=args.azimuths or DEFAULT_AZIMUTHS,
                                 progress=ProgressBar(sys.stderr, "suns") if not args.quiet and daylight > 1 else None)
        t2 = time.perf_counter()
        for name in args.outputs:
            out.write(getattr(maps, name))
    if not args.quiet:
        mean = "" if maps.hours is None or not np.isfinite(maps.hours).any() else \
            f", {float(np.nanmean(maps.hours)):.2f} h of direct sun on average"
        print(f"{PROG}: {cols}x{rows} cells, {maps.daylight_suns} daylight steps "
              f"({maps.daylight_seconds / 3600:.2f} h), method {args.method}, device {caster.runtime.label}: "
              f"{t2 - t1:.2f} s (total {time.perf_counter() - t0:.2f} s){mean} -> {args.output}", file=sys.stderr)
    return 0


def run_site_sunshine(args: argparse.Namespace) -> int:
    """``oclshade sunshine INPUT OUT.csv --site LAT,LON``: one place's steps
    (:func:`oclshade.sunshine.site_sunshine`), one CSV row each, the hours on stderr."""
    from .sunshine import site_sunshine

    if _extension(args.output) != ".csv":
        raise UsageError(f"OUTPUT {args.output!r}: --site writes a .csv (one row per step)")
    for flag, given in (("--lat/--lon", args.lat is not None or args.lon is not None),
                        ("--method/--azimuths", args.method != "masks" or args.azimuths is not None),
                        ("--output", tuple(args.outputs) != ("hours",)), ("-s", args.scale != 1.0)):
        if given:
            raise UsageError(f"{flag} does not go with --site (the site is the place; it writes one CSV)")
    zone, start, end, steps = sunshine_period(args)
    curvature = curvature_argument(args)
    t0 = time.perf_counter()
    raster, _ = read_input(args, cellsize_argument(args))
    lat, lon = args.site
    try:
        result = site_sunshine(raster, lat, lon, steps, above=args.above, curvature=curvature,
                               z_factor=args.z_factor)
    except ValueError as exc:
        raise CliError(f"--site {lat:g},{lon:g}: {exc}") from None
    local = zone if zone is not None else start.tzinfo
    rows = ["time,seconds,azimuth,elevation,horizon,sunlit\n"]
    for t, seconds, sun, horizon, lit in zip(result.times, result.seconds, result.suns, result.horizon, result.sunlit):
        rows.append(f"{t.astimezone(local).isoformat()},{int(seconds)},{sun.azimuth:.6f},{sun.elevation:.6f},"
                    f"{'' if np.isnan(horizon) else f'{horizon:.6f}'},{int(lit)}\n")
    _write_text(args.output, "".join(rows))
    if not args.quiet:
        bent = "" if curvature is None else f", curvature R {curvature.radius:g} m k {curvature.refraction:g}"
        print(f"{PROG}: site {lat:g}, {lon:g}, {args.above:g} m above the surface, {len(result.times)} steps of "
              f"{args.step}{bent}: {result.daylight_hours:.2f} h of daylight, {result.hours:.2f} h of direct sun "
              f"({time.perf_counter() - t0:.2f} s) -> {args.output}", file=sys.stderr)
    return 0


def _write_text(path: str, text: str) -> None:
    """``text`` into ``path`` atomically (a hidden file beside it, renamed over it)."""
    from pathlib import Path

    from .io import _Replacement

    _make_parents(path)
    replacement = _Replacement(Path(path))
    try:
        with open(replacement.tmp, "w", newline="") as fh:
            fh.write(text)
        replacement.commit()
    except BaseException:
        replacement.discard()
        raise


# --- horizon and svf commands ------------------------------------------------------------

HORIZON_EPILOG = """\
output: float32 bands, NaN = nodata; .tif/.tiff (georeferencing of the input kept; --co,
  --of COG), .exr or .npy.
  horizon  N bands, band i at azimuth 360 i / N (degrees clockwise from north), named
           horizon_az22p5 etc.: the elevation angle in degrees of the highest terrain
           seen from the cell over the bilinear surface (exact); -90 where the ray
           sees no terrain (the map's edge looking out: beyond the map there is none)
  svf      one band: the sky-view factor from the horizons of N azimuths, horizons
           below 0 counted as 0; --definition cosine (default): 1 - mean sin^2 h, the
           share of an isotropic sky's irradiance on a horizontal surface;
           solid-angle: 1 - mean sin h, the visible share of the hemisphere (Zaksek
           et al. 2011, RVT)
  sunlit   one band per sun: the share of the sun's disc the cell sees (soft shadows;
           1 = the whole disc, 0 = none), from its exact horizons at --columns azimuths
           across the disc (a uniform disc of angular radius --disc-radius); error
           against 256 strips in docs/methods.md "Soft shadows"
  --curvature lowers terrain at distance d by (1 - k) d^2 / (2 R) (R = --radius,
  k = --refraction), as r.horizon and HORAYZON do.
  --max-distance D (horizon, svf) sees only the terrain within D metres of the cell
  along each ray (r.horizon's maxdistance, RVT's radius x the cell size): exact within
  it, and faster for small D.

examples:
  oclshade horizon dem.tif horizons.tif --azimuths 64
  oclshade svf dem.tif svf10.tif --azimuths 16 --max-distance 300 --definition solid-angle
  oclshade horizon srtm.hgt.zip far.tif --azimuths 16 --curvature --refraction 0.13
  oclshade svf dem.tif svf.tif --azimuths 32 --definition solid-angle
  oclshade sunlit dem.tif dusk.tif --sun 280,2 --sun 285,1
"""


def _disc_radius(text: str) -> float:
    value = _number(text, "disc radius")
    if not 0.0 < value <= 5.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 5] degrees (the sun: about 0.27), got {text}")
    return value


def _columns(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= 1024:
        raise argparse.ArgumentTypeError(f"expected an integer 1..1024, got {text!r}")
    return int(text)


def _max_distance(text: str) -> float:
    from .horizon.caster import check_max_distance
    try:
        return check_max_distance(_number(text, "max distance"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number of metres, got {text}") from None


def _site(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        lat, lon = (float(v) for v in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LAT,LON in degrees, got {text!r}") from None
    if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90.0 and abs(lon) <= 360.0):
        raise argparse.ArgumentTypeError(f"expected a latitude in -90..90 and a longitude in -360..360, got {text!r}")
    return lat, lon


def _above(text: str) -> float:
    value = _number(text, "height above the surface")
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"must be metres >= 0, got {text}")
    return value


def _refraction(text: str) -> float:
    value = _number(text, "refraction coefficient")
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1) (about 0.13 by day), got {text}")
    return value


def add_horizon_parsers(sub) -> None:
    """``oclshade horizon`` and ``oclshade svf``: the same input, curvature and output options."""
    from .horizon import DEFAULT_COLUMNS, SUN_RADIUS, SVF_DEFINITIONS

    helps = {"horizon": ("horizon angles of a DEM, one band per azimuth",
                         "Horizon angles of a DEM: per cell and azimuth, the elevation angle of the highest terrain."),
             "svf": ("sky-view factor of a DEM from its horizons",
                     "Sky-view factor of a DEM from the horizon angles of N equally spaced azimuths."),
             "sunlit": ("soft shadows: the share of the sun's disc each cell sees",
                        "Soft shadows of a DEM: per cell and sun, the share of the sun's disc seen over the "
                        "terrain (1 = all of it), from exact horizons across the disc.")}
    for name, (summary, description) in helps.items():
        p = sub.add_parser(name, help=summary, description=description, epilog=HORIZON_EPILOG,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        p.add_argument("input", metavar="INPUT", help="DEM: .tif/.tiff, .hgt, .zip (with .hgt), .asc, .exr, .png, .npy")
        p.add_argument("output", metavar="OUTPUT", help="output raster: .tif/.tiff, .exr or .npy")
        if name == "sunlit":
            p.add_argument("--sun", dest="suns", action="append", default=[], type=_sun, metavar="AZ,ALT",
                           help="a sun position (degrees, grid azimuth); repeat for several (one band each)")
            solar_cli.add_time_arguments(p)
            p.add_argument("--disc-radius", type=_disc_radius, default=SUN_RADIUS, metavar="DEG",
                           help=f"the sun's angular radius (default {SUN_RADIUS:g}, the mean)")
            p.add_argument("--columns", type=_columns, default=DEFAULT_COLUMNS, metavar="K",
                           help=f"strips across the disc, one horizon each (default {DEFAULT_COLUMNS})")
        else:
            p.add_argument("--azimuths", type=_azimuths, default=16, metavar="N",
                           help="equally spaced azimuths, 360 i / N degrees (default 16)")
            p.add_argument("--max-distance", type=_max_distance, default=None, metavar="METRES",
                           help="search radius: terrain farther from the cell is not seen (default: the whole map)")
        if name == "horizon":
            p.add_argument("--true-north", action="store_true",
                           help="band i at the true azimuth 360 i / N (from north along the meridian, as r.horizon "
                                "and solar tools use), turned to a projected INPUT's grid through its CRS; "
                                "default: grid azimuths, from up the columns")
            p.add_argument("--site", type=_site, metavar="LAT,LON",
                           help="the horizon of one place instead of the map's (as r.horizon's coordinates=): "
                                "OUTPUT a .csv of true azimuths and elevation angles along the geodesics, in float64")
            p.add_argument("--above", type=_above, default=0.0, metavar="METRES",
                           help="with --site: the eye's height over the surface there (default 0)")
        if name == "svf":
            p.add_argument("--definition", default="cosine", choices=SVF_DEFINITIONS,
                           help="cosine (default): 1 - mean sin^2 h; solid-angle: 1 - mean sin h (RVT)")
        add_curvature_arguments(p)
        add_grid_arguments(p)
        add_input_arguments(p)
        add_tiff_arguments(p)
        p.add_argument("--device", metavar="SPEC",
                       help="OpenCL device: index or name substring (default: $OCLSHADE_DEVICE, else PoCL CPU)")
        p.add_argument("--quiet", "-q", action="store_true", help="no progress bar and no summary")


def true_north_azimuths(args: argparse.Namespace, raster: Raster, azimuths: np.ndarray) -> tuple[np.ndarray, str]:
    """``horizon --true-north``: the grid azimuths of these true azimuths at INPUT's centre (its
    CRS: the meridian convergence), and a note for the summary."""
    from .solar.site import map_site

    try:
        site = map_site(raster)
        if site is None:
            raise UsageError(f"--true-north: INPUT {args.input!r} has no CRS to find true north from")
        traced = site.grid_azimuths(azimuths)
    except ValueError as exc:
        raise CliError(f"--true-north: INPUT {args.input!r}: {exc}") from None
    if site.crs is None:
        return traced, " (true north: a geographic grid)"
    return traced, f" from true north (at grid azimuth {traced[0]:.4f} on {site.crs_name})"   # azimuths[0] is 0


def run_horizon(args: argparse.Namespace) -> int:
    """``oclshade horizon`` (N bands of angles, streamed), ``oclshade svf`` (one band) and
    ``oclshade sunlit`` (one band per sun)."""
    from .horizon import HorizonCaster, azimuth_grid
    from .solar.scale import SCALE_TOLERANCE

    if getattr(args, "site", None) is not None:
        return run_site_horizon(args)
    if getattr(args, "above", 0.0):
        raise UsageError("--above is the eye's height at a --site; give --site LAT,LON")
    if _extension(args.output) not in (".tif", ".tiff", ".exr", ".npy"):
        raise UsageError(f"OUTPUT {args.output!r}: expected .tif, .tiff, .exr or .npy (float32 bands)")
    curvature = curvature_argument(args)
    cellsize = cellsize_argument(args)
    options, cog = creation_options(args, np.dtype(np.float32))
    svf, sunlit = args.command == "svf", args.command == "sunlit"
    times = solar_cli.parse_datetimes(args) if sunlit else []
    if sunlit and bool(times) == bool(args.suns):
        raise UsageError("give the sun one way: --sun AZ,ALT or --datetime ISO (each repeatable)")
    if _same_file(args.output, args.input):
        raise CliError(f"OUTPUT {args.output!r} is the input file; refusing to overwrite it")
    t0 = time.perf_counter()
    raster, heightmap = read_input(args, cellsize)
    rows, cols = heightmap.shape
    suns = args.suns if sunlit else []
    discs = suns                          # what sun_disc traces: the suns, or per time the sun over the map
    if times:
        placed = solar_cli.suns_for(times, args, raster)
        suns, discs = placed.suns, placed.traced
        if not args.quiet:
            print(f"{PROG}: {placed.describe(times[0])}", file=sys.stderr)
            if blocks := placed.blocks_line():
                print(f"{PROG}: {blocks}", file=sys.stderr)
    elif sunlit:
        discs = solar_cli.on_map_grid(suns, args, raster) or suns
    azimuths = [] if sunlit else azimuth_grid(args.azimuths)
    traced = azimuths                     # the grid azimuths the kernel traces
    turned = ""
    if getattr(args, "true_north", False):
        traced, turned = true_north_azimuths(args, raster, azimuths)
    if svf:
        names = [f"svf_{args.definition}"]
    elif sunlit:
        names = [f"sunlit_az{s.azimuth:g}_el{s.elevation:g}".replace(".", "p").replace("-", "m") for s in suns]
    else:
        names = [f"horizon_az{az:g}".replace(".", "p") for az in azimuths]
    if _extension(args.output) == ".exr" and not svf:   # EXR sorts channels by name: keep the band order
        names = [f"{k:0{len(str(len(names) - 1))}d}_{name}" for k, name in enumerate(names)]
    _make_parents(args.output)
    bar = ProgressBar(sys.stderr, "azimuths") if not args.quiet and (len(azimuths) > 1 or sunlit) else None
    with RasterWriter(args.output, (len(names), rows, cols), np.float32, like=raster, nodata=math.nan,
                      band_names=names, options=options, cog=cog) as out:
        caster = HorizonCaster(heightmap, device=args.device, curvature=curvature,
                               max_distance=getattr(args, "max_distance", None), cache=False,
                               row_scales=None if sunlit else solar_cli.map_row_scales(args, raster))
        blocks = caster.scale_blocks
        if not args.quiet and blocks.scales.shape[0] * blocks.scales.shape[1] > 1:
            print(f"{PROG}: the grid's scale: {blocks.scales.shape[0]} band(s) of rows by {blocks.scales.shape[1]} "
                  f"of columns, each block traced with its own cell sizes (within {SCALE_TOLERANCE:g} deg)",
                  file=sys.stderr)
        t1 = time.perf_counter()
        if svf:
            out.write(caster.sky_view_factor(azimuths, args.definition, progress=bar))
        elif sunlit:
            for sun in discs:
                out.write(caster.sun_disc(sun, args.disc_radius, args.columns, progress=bar))
        else:
            for _, band in caster.iter_horizons(traced, progress=bar):
                out.write(band)
        t2 = time.perf_counter()
    if not args.quiet:
        what = f"sky-view factor ({args.definition})" if svf else \
            f"sun disc ({args.columns} strips per sun)" if sunlit else "horizons"
        bent = "" if curvature is None else f", curvature R {curvature.radius:g} m k {curvature.refraction:g}"
        if caster.radius is not None:
            bent += f", within {caster.radius:g} m"
        count = f"{len(suns)} sun(s)" if sunlit else f"{len(azimuths)} azimuths{turned}"
        print(f"{PROG}: {cols}x{rows} cells, {count}{bent}, device {caster.runtime.label}: "
              f"{what} {t2 - t1:.2f} s (total {time.perf_counter() - t0:.2f} s) -> {args.output}", file=sys.stderr)
    return 0


def run_site_horizon(args: argparse.Namespace) -> int:
    """``oclshade horizon INPUT OUT.csv --site LAT,LON``: one place's horizon along the geodesics
    (:func:`oclshade.horizon.site.site_horizon`), one CSV row per azimuth."""
    from .horizon import azimuth_grid
    from .horizon.site import site_horizon

    if _extension(args.output) != ".csv":
        raise UsageError(f"OUTPUT {args.output!r}: --site writes a .csv (azimuth, elevation)")
    if args.scale != 1.0:
        raise UsageError(f"-s {args.scale:g}: --site takes its distances from INPUT's CRS; drop -s (-z scales heights)")
    if _same_file(args.output, args.input):
        raise CliError(f"OUTPUT {args.output!r} is the input file; refusing to overwrite it")
    curvature = curvature_argument(args)
    t0 = time.perf_counter()
    raster, _ = read_input(args, cellsize_argument(args))
    azimuths = azimuth_grid(args.azimuths)
    lat, lon = args.site
    try:
        angles = site_horizon(raster, lat, lon, azimuths, above=args.above, curvature=curvature,
                              max_distance=args.max_distance, z_factor=args.z_factor)
    except ValueError as exc:
        raise CliError(f"--site {lat:g},{lon:g}: {exc}") from None
    _write_text(args.output, "azimuth,elevation\n" + "".join(
        f"{az:.6f},{angle:.6f}\n" for az, angle in zip(azimuths, np.round(angles, 6))))
    if not args.quiet:
        bent = "" if curvature is None else f", curvature R {curvature.radius:g} m k {curvature.refraction:g}"
        if args.max_distance is not None:
            bent += f", within {args.max_distance:g} m"
        print(f"{PROG}: site {lat:g}, {lon:g}, {args.above:g} m above the surface, {len(azimuths)} true azimuths "
              f"along the geodesics{bent}: {time.perf_counter() - t0:.2f} s -> {args.output}", file=sys.stderr)
    return 0


# --- entry point -------------------------------------------------------------------------

class Terminated(BaseException):
    """SIGTERM, raised like KeyboardInterrupt so that the run unwinds and removes its temporary files."""


def _terminate(signum: int, frame: object) -> NoReturn:
    raise Terminated()


def _fail(message: str, status: int) -> int:
    lines = str(message).strip().splitlines() or ["unknown error"]
    more = f" (set {runtime.DEBUG_ENV}=1 for details)" if len(lines) > 1 and not runtime.debug() else ""
    sys.stderr.write(f"{PROG}: error: {lines[0]}{more}\n")
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 bad arguments,
    130 interrupted by SIGINT, 143 terminated by SIGTERM; either removes its temporary files)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, or an argparse error already printed
        return int(exc.code or 0)
    command = {"devices": tuning_cli.run_devices, "tune": tuning_cli.run_tune, "shadow": run_shadow,
               "render": run_render, "sunshine": run_sunshine, "horizon": run_horizon, "svf": run_horizon, "sunlit": run_horizon, "bench": bench_cli.run,
               "sun": solar_cli.run, "envmap": envmap_cli.run}[args.command]
    debug = runtime.debug()
    runtime.NOTICES = not getattr(args, "quiet", False)
    on_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if on_main_thread else None
    if on_main_thread:
        signal.signal(signal.SIGTERM, _terminate)
    try:
        return command(args)
    except CliError as exc:
        if debug:
            traceback.print_exc()
        return _fail(str(exc), exc.status)
    except KeyboardInterrupt:
        sys.stderr.write(f"{PROG}: interrupted\n")
        return 130
    except Terminated:
        sys.stderr.write(f"{PROG}: terminated\n")
        return 128 + signal.SIGTERM
    except Exception as exc:  # noqa: BLE001 - the CLI turns every failure into one line
        if debug:
            traceback.print_exc()
        known = isinstance(exc, (ValueError, TypeError, OSError)) or type(exc).__module__.startswith("oclshade")
        return _fail(str(exc) if known else f"{type(exc).__name__}: {exc}", 1)
    finally:
        if on_main_thread:
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
