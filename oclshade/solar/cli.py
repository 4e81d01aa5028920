"""``oclshade sun``: the sun's azimuth and elevation for dates, times and a place."""
from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from dataclasses import dataclass
from datetime import date, datetime
from typing import Callable
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import numpy as np

from ..heightmap import InputWarning
from .position import DEFAULT_PRESSURE_HPA, DEFAULT_TEMPERATURE_C, sun_position, suns_at
from ..sun import DEFAULT_SUN_TOLERANCE, SunField
from .field import MapPlaces, checked_places, sun_field
from .site import MapSite, map_site

EPILOG = """\
datetimes: ISO 8601 with a UTC offset (2024-06-21T12:00+02:00, 2024-06-21T10:00Z), or
  without one together with --tz NAME (an IANA zone: Europe/Zurich), which resolves
  daylight saving time; a local time the clocks skip or repeat there is an error.
  A datetime without an offset and without --tz is an error: UTC is never assumed.

output: one line per --datetime (datetime with its offset, azimuth in degrees clockwise
  from north, elevation in degrees above the horizon, 4 decimals), or with --json one
  object: {"latitude", "longitude", "refraction", "positions": [{"datetime", "azimuth",
  "elevation"}, ...]}. Algorithm: NREL SPA (Reda & Andreas 2008); see docs/solar.md.

examples:
  oclshade sun --lat 46.95 --lon 7.45 --datetime 2024-06-21T12:00+02:00
  oclshade sun --lat 46.95 --lon 7.45 --tz Europe/Zurich --datetime 2024-12-21T09:00 --datetime 2024-12-21T12:00
"""


def _number(what: str, expected: str, accept: Callable[[float], bool] = lambda value: True):
    """An argparse type: a finite number that ``accept`` takes, else an error naming ``what``."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and accept(value)):
            raise argparse.ArgumentTypeError(f"{what} must be {expected}, got {text!r}")
        return value
    return parse


_LAT = _number("latitude", "degrees in [-90, 90]", lambda v: -90.0 <= v <= 90.0)
_LON = _number("longitude", "degrees in [-180, 180]", lambda v: -180.0 <= v <= 180.0)
_TOLERANCE = _number("sun tolerance", "degrees above 0", lambda v: v > 0.0)
_ALTITUDE = _number("altitude", "a number of metres")
_PRESSURE = _number("pressure", "hPa above 0", lambda v: v > 0.0)
_TEMPERATURE = _number("temperature", "degrees Celsius above -273", lambda v: v > -273.0)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``sun`` on the ``oclshade`` command's subparsers."""
    s = sub.add_parser("sun", help="the sun's azimuth and elevation for datetimes at a place (NREL SPA)",
                       description="The sun's topocentric azimuth and elevation (NREL Solar Position Algorithm).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("--lat", required=True, type=_LAT, metavar="DEG",
                   help="latitude, degrees north (south negative)")
    s.add_argument("--lon", required=True, type=_LON, metavar="DEG",
                   help="longitude, degrees east (west negative)")
    s.add_argument("--datetime", dest="datetimes", action="append", required=True, metavar="ISO",
                   help="date and time, ISO 8601 with a UTC offset (or see --tz); repeat for several")
    s.add_argument("--tz", metavar="NAME", help="IANA time zone of datetimes given without a UTC offset")
    s.add_argument("--no-refraction", dest="refraction", action="store_false",
                   help="the geometric elevation, without atmospheric refraction")
    s.add_argument("--altitude", type=_ALTITUDE, default=0.0, metavar="M",
                   help="observer's height above sea level, metres (parallax; default 0)")
    s.add_argument("--pressure", type=_PRESSURE, default=DEFAULT_PRESSURE_HPA, metavar="HPA",
                   help=f"air pressure for refraction, hPa (default {DEFAULT_PRESSURE_HPA:g})")
    s.add_argument("--temperature", type=_TEMPERATURE, default=DEFAULT_TEMPERATURE_C, metavar="C",
                   help=f"air temperature for refraction, degrees Celsius (default {DEFAULT_TEMPERATURE_C:g})")
    s.add_argument("--json", action="store_true", help="print JSON instead of text")


def parse_datetime(text: str, zone: ZoneInfo | None, what: str = "--datetime") -> datetime:
    """An aware datetime from ISO 8601 text: its own UTC offset, or local time in ``zone``;
    errors name the value as ``what`` (the option or file line it came from)."""
    from ..cli import UsageError

    iso = text[:-1] + "+00:00" if text[-1:] in ("Z", "z") else text  # Python 3.10 reads no "Z"
    try:
        value = datetime.fromisoformat(iso)
    except ValueError:
        raise UsageError(f"{what} {text!r} is not an ISO 8601 date and time "
                         f"(e.g. 2024-06-21T12:00+02:00)") from None
    if _is_date(iso):
        raise UsageError(f"{what} {text!r} has no time of day (e.g. {text}T12:00+02:00)")
    if value.tzinfo is not None:
        if zone is not None:
            raise UsageError(f"{what} {text} has a UTC offset and --tz {zone.key} was given: give one or the other")
        return value
    if zone is None:
        raise UsageError(f"{what} {text} has no UTC offset: add one (e.g. {text}+02:00 or {text}Z) or give "
                         f"--tz NAME; UTC is not assumed")
    first, second = value.replace(tzinfo=zone, fold=0), value.replace(tzinfo=zone, fold=1)
    if first.utcoffset() != second.utcoffset():
        gap = first.utcoffset() < second.utcoffset()
        raise UsageError(f"{what} {text} {'does not exist' if gap else 'occurs twice'} in {zone.key} (the clocks "
                         f"{'skip' if gap else 'repeat'} it): give its UTC offset instead of --tz")
    return first


def _is_date(text: str) -> bool:
    try:
        date.fromisoformat(text)
    except ValueError:
        return False
    return True


def time_zone(name: str | None) -> ZoneInfo | None:
    """The IANA zone of --tz NAME (None without --tz)."""
    from ..cli import UsageError

    if name is None:
        return None
    try:
        return ZoneInfo(name)
    except (ZoneInfoNotFoundError, ValueError):
        raise UsageError(f"--tz {name!r} is not an IANA time zone name "
                         f"(e.g. Europe/Zurich, America/Denver, UTC)") from None


def run(args: argparse.Namespace) -> int:
    """The ``sun`` command: prints one position per --datetime; returns 0."""
    tz = time_zone(args.tz)
    times = [parse_datetime(text, tz) for text in args.datetimes]
    pos = sun_position(times, args.lat, args.lon, altitude=args.altitude, pressure=args.pressure,
                       temperature=args.temperature, refraction=args.refraction)
    rows = [(t.isoformat(), float(az), float(el)) for t, az, el in zip(times, pos.azimuth, pos.elevation)]
    if args.json:
        positions = [{"datetime": t, "azimuth": az, "elevation": el} for t, az, el in rows]
        print(json.dumps({"latitude": args.lat, "longitude": args.lon, "refraction": args.refraction,
                          "positions": positions}, indent=2))
        return 0
    width = max(len(t) for t, _, _ in rows)
    print(f"{'datetime':<{width}}  {'azimuth':>9}  {'elevation':>9}")
    for t, az, el in rows:
        print(f"{t:<{width}}  {az:9.4f}  {el:9.4f}")
    return 0


# --- suns for `oclshade shadow --datetime` -------------------------------------------------

def add_time_arguments(parser: argparse.ArgumentParser) -> None:
    """``--datetime``, ``--tz``, ``--lat``, ``--lon`` on a command that takes suns (``shadow``)."""
    parser.add_argument("--datetime", dest="datetimes", action="append", default=[], metavar="ISO",
                        help="the sun at this date and time (NREL SPA, with refraction; ISO 8601 with a "
                             "UTC offset, or see --tz); repeat for several, one band each")
    add_place_arguments(parser, "--datetime")


def add_place_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    """``--tz``, ``--lat``, ``--lon`` and ``--sun-tolerance`` for the datetimes of ``what`` (the
    options that give them)."""
    parser.add_argument("--tz", metavar="NAME", help=f"IANA time zone of {what} values given without an offset")
    parser.add_argument("--lat", type=_LAT, metavar="DEG",
                        help=f"latitude for {what} (default: the centre of INPUT, through its CRS; given, one "
                             f"sun for the whole map)")
    parser.add_argument("--lon", type=_LON, metavar="DEG",
                        help=f"longitude for {what} (default: the centre of INPUT, through its CRS)")
    parser.add_argument("--sun-tolerance", type=_TOLERANCE, default=DEFAULT_SUN_TOLERANCE, metavar="DEG",
                        help=f"without --lat/--lon, trace the map in blocks, each with the sun of its "
                             f"centre, so that every cell's own sun (its place through INPUT's CRS) is "
                             f"within DEG degrees of its block's; on a geographic INPUT, any sun also "
                             f"with the cell width of its rows (default {DEFAULT_SUN_TOLERANCE:g}; "
                             f"docs/solar.md)")


def parse_datetimes(args: argparse.Namespace, more: bool = False) -> list[datetime]:
    """The --datetime values as aware datetimes (usage errors before any file is read);
    ``more``: datetimes come from elsewhere too (datetime rows of --suns), so --tz, --lat
    and --lon may come without --datetime."""
    from ..cli import UsageError

    if not args.datetimes and not more and (args.tz is not None or args.lat is not None or args.lon is not None):
        raise UsageError("--tz, --lat and --lon go with --datetime (or datetime rows in --suns)")
    check_place(args)
    tz = time_zone(args.tz)
    return [parse_datetime(text, tz) for text in args.datetimes]


def check_place(args: argparse.Namespace) -> None:
    """--lat and --lon come together or not at all."""
    from ..cli import UsageError

    if (args.lat is None) != (args.lon is None):
        raise UsageError("give both --lat and --lon, or neither (the centre of INPUT, through its CRS)")


@dataclass
class PlacedSuns:
    """The suns of a command's datetimes: ``suns`` in grid azimuths (what the kernels trace),
    ``true`` as NREL SPA gives them, and the site (place and CRS) that turned one into the other."""

    suns: list
    true: list
    site: MapSite
    fields: list[SunField] | None = None   # per time, the sun over the map (None: --lat/--lon, one sun)

    @property
    def traced(self) -> list:
        """What the kernels trace: the fields, else the suns."""
        return list(self.suns) if self.fields is None else list(self.fields)

    def blocks_line(self) -> str | None:
        """A summary of the fields' blocks, or None when every time is one block."""
        if self.fields is None or all(f.uniform for f in self.fields):
            return None
        counts = [len(f.blocks) for f in self.fields]
        first = next(f for f in self.fields if not f.uniform).blocks[0]
        return (f"the sun per block of cells ({min(counts)}-{max(counts)} blocks, the first "
                f"{first.row1 - first.row0}x{first.col1 - first.col0} cells): each cell's own sun within "
                f"{max(f.deviation for f in self.fields):.4f} deg of its block's (--sun-tolerance "
                f"{self.fields[0].tolerance:g})")

    def describe(self, when: datetime) -> str:
        """One summary line: how many suns, where, and the first (at ``when``)."""
        true, grid = self.true[0], self.suns[0]
        turned = (f" ({grid.azimuth:.4f} on the grid of {self.site.crs_name})"
                  if self.site.crs is not None else "")
        return (f"{len(self.suns)} sun(s) at latitude {self.site.latitude:.5f}, longitude "
                f"{self.site.longitude:.5f} (NREL SPA); {when.isoformat()}: azimuth {true.azimuth:.4f}{turned}, "
                f"elevation {true.elevation:.4f}")


def _scaled_places(args: argparse.Namespace, raster) -> MapPlaces | None:
    """The raster's :class:`oclshade.solar.MapPlaces` as :func:`oclshade.solar.field.checked_places`
    gives them, its warnings on stderr; a geographic raster's problem is the run's error."""
    from ..cli import PROG, CliError, curvature_argument

    curvature = curvature_argument(args) if hasattr(args, "curvature") else None
    try:
        places, notes = checked_places(raster, getattr(args, "z_factor", 1.0),
                                       0.0 if curvature is None else curvature.coefficient)
    except ValueError as exc:
        raise CliError(f"INPUT {args.input!r}: {exc}") from None
    for note in notes:
        print(f"{PROG}: warning: INPUT {args.input!r}: {note}", file=sys.stderr)
    return places


def on_map_grid(suns: list, args: argparse.Namespace, raster) -> list | None:
    """Suns given by their angles (--sun AZ,ALT), each as the raster's grid traces it over the map
    (:func:`oclshade.solar.sun_field` of the sun: per band of rows of the horizons, at the band's
    scale, to --sun-tolerance; :meth:`oclshade.solar.MapPlaces.on_grid`); None on a raster
    without a known place, whose grid traces them as they are."""
    from ..cli import PROG

    places = _scaled_places(args, raster)
    if places is None:
        return None
    fields = [sun_field(places, sun, args.sun_tolerance) for sun in suns]
    if not all(f.uniform for f in fields) and not getattr(args, "quiet", False):   # one band: as the map is
        counts = [len(f.blocks) for f in fields]
        print(f"{PROG}: {scale_line(places, args.sun_tolerance)}: each sun in {min(counts)}-{max(counts)} "
              f"band(s) of rows, within --sun-tolerance {args.sun_tolerance:g} deg", file=sys.stderr)
    return fields


def scale_line(places: MapPlaces, tolerance: float = DEFAULT_SUN_TOLERANCE) -> str:
    """What the grid's scale is, in a few words: a geographic grid's cell width per band of rows,
    or a projected one's ground metres per grid metre."""
    if places.crs is None:
        return "a geographic grid, each band of rows traced with its own cell width"
    scales = places.row_scales()
    stretch = float(np.max(np.hypot(scales[..., 2], scales[..., 3]))) / 2.0     # the largest share by direction
    by_direction = f" (up to {100.0 * stretch:.2f} % more or less by direction)" if stretch > 0.0 else ""
    return (f"a projected grid ({places.crs.name}) whose metre is {scales[..., 0].min():.6f}-{scales[..., 0].max():.6f} m "
            f"on the ground{by_direction}, traced at that scale")


def map_row_scales(args: argparse.Namespace, raster) -> np.ndarray | None:
    """The raster's :meth:`oclshade.solar.MapPlaces.row_scales` (its horizons are traced per
    band of rows with their own cell sizes); None on a raster without a known place."""
    places = _scaled_places(args, raster)
    return None if places is None else places.row_scales()


FIELDS_BAR = 100   # sun fields (about 8 ms each on a 1-degree SRTM tile) made silently


def suns_for(times: list[datetime], args: argparse.Namespace, raster, what: str = "--datetime") -> PlacedSuns:
    """The suns at ``times`` at --lat/--lon, else at the raster's centre (a geographic raster's, or
    a projected one's through its CRS), their azimuths turned to the raster's grid
    (:mod:`oclshade.solar.site`).  ``what``: the options the times came from (for the errors).
    Without --lat/--lon, on a map whose cells' places are known and given a --sun-tolerance, the
    sun over the map per time to it (:func:`oclshade.solar.sun_field`; a bar on stderr while
    more than :data:`FIELDS_BAR` are made, unless --quiet)."""
    from ..cli import PROG, CliError, ProgressBar, UsageError

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", InputWarning)
            site = map_site(raster, args.lat, args.lon)
    except ValueError as exc:
        raise CliError(f"{what}: INPUT {args.input!r}: {exc}") from None
    for warning in caught:
        sys.stderr.write(f"{PROG}: warning: {warning.message}\n")
    if site is None:
        raise UsageError(f"{what}: INPUT {args.input!r} has no CRS to take the place from; give --lat and --lon")
    true = suns_at(times, site.latitude, site.longitude)
    try:
        placed = PlacedSuns(site.grid_suns(true), true, site)
        places = _scaled_places(args, raster)      # (with --lat/--lon its CRS need not be known: map_site warned)
        if places is not None and getattr(args, "sun_tolerance", None) is not None:
            bar = ProgressBar(sys.stderr, "suns over the map") \
                if len(times) > FIELDS_BAR and not getattr(args, "quiet", False) else None
            placed.fields = []
            for t, sun in zip(times, placed.suns):      # with --lat/--lon: one sun, at the grid's scale
                placed.fields.append(sun_field(places, t if args.lat is None else sun, args.sun_tolerance))
                if bar is not None:
                    bar(len(placed.fields), len(times))
    except ValueError as exc:
        raise CliError(f"{what}: INPUT {args.input!r}: {exc}") from None
    return placed
