"""``oclshade envmap convert IN OUT``: environment maps between layouts and formats."""
from __future__ import annotations

import argparse
import os
import sys

from .files import LAYOUTS, convert

EPILOG = """\
layouts (docs/reflections.md): latlong (2:1), cube (OpenEXR's ENVMAP_CUBE strip, 1:6),
  hcross (4:3), vcross (3:4), faces (six files: a path with {face}, replaced by posx, negx,
  posy, negy, posz, negz).  Input layout: --from, else the EXR envmap attribute, else the
  aspect ratio.  Output layout: --to, else faces for a path with {face}, cube from lat-long
  input, latlong from any cube layout.
formats by extension: .exr (float), .hdr (Radiance RGBE), .png (8-bit sRGB; values above 1
  are clipped).
--size N: the cube's face size (lat-long input; default width / 4) or the lat-long map's
  height (cube input; default 2 x face size; its width is twice that).

examples:
  oclshade envmap convert sky_latlong.exr sky_cube.exr --size 512
  oclshade envmap convert sky_cube.exr sky_latlong.hdr
  oclshade envmap convert sky.hdr 'faces/sky_{face}.png' --size 256
"""


def _size(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"size must be a positive integer, got {text!r}")
    return value


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``envmap`` on the ``oclshade`` command's subparsers."""
    env = sub.add_parser("envmap", help="environment maps: convert between lat-long and cube layouts",
                         description="Environment maps (paper 002).")
    actions = env.add_subparsers(dest="envmap_command", metavar="ACTION", required=True)
    cv = actions.add_parser("convert", help="convert an environment map between layouts and formats",
                            description="Convert an environment map: lat-long <-> cube, EXR / HDR / PNG.",
                            epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    cv.add_argument("input", metavar="IN", help="environment map (.exr, .hdr, .png; or a path with {face})")
    cv.add_argument("output", metavar="OUT", help="output map (.exr, .hdr, .png; or a path with {face})")
    cv.add_argument("--size", type=_size, metavar="N", help="cube face size or lat-long height (see below)")
    cv.add_argument("--from", dest="layout_in", choices=LAYOUTS, help="input layout (default: detected)")
    cv.add_argument("--to", dest="layout_out", choices=LAYOUTS, help="output layout (default: see below)")
    cv.add_argument("--device", metavar="SPEC", help="OpenCL device: index or name substring")
    cv.add_argument("--quiet", "-q", action="store_true", help="no summary line")


def run(args: argparse.Namespace) -> int:
    from ..cli import PROG, CliError, UsageError

    if "{face}" not in args.input and not os.path.exists(args.input):
        raise CliError(f"{args.input}: no such file")
    if os.path.abspath(args.input) == os.path.abspath(args.output):
        raise UsageError("OUT must differ from IN (the input is never overwritten)")
    cube = convert(args.input, args.output, args.size, args.layout_in, args.layout_out, args.device)
    if not args.quiet:
        print(f"{PROG}: {args.input} -> {args.output} (cube faces {cube.size}x{cube.size})", file=sys.stderr)
    return 0
