"""``oclshade shadow --tile / --max-memory / --workers``: the tiled, streamed and distributed runs.

The options are added to the shadow command by :func:`add_arguments`; with any
of them :func:`run` replaces the in-memory run: the input is read a window at a
time (:func:`oclshade.io.open_dem`), the output written a tile at a time, on
this process's device (:func:`oclshade.tiles.stream.shadow_stream`) or on
``--workers`` local Dask worker processes (:mod:`oclshade.tiles.dask_adapter`).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import re
import sys
import time
import warnings

import numpy as np

from ..geotiff import tiff_options
from ..heightmap import InputWarning
from ..io import open_dem
from .stream import peak_rss_bytes, relief_pass, relief_stripe_bytes, shadow_stream

_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def memory_size(text: str) -> int:
    """``256M``, ``3G``, ``1.5G``, ``500000K`` or bytes, as a number of bytes (binary units)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([KMGT]?)(?:I?B)?\s*", text.upper())
    if m is None or float(m[1]) <= 0:
        raise argparse.ArgumentTypeError(f"a memory size is a positive number with K, M, G or T (e.g. 256M), "
                                         f"got {text!r}")
    return int(float(m[1]) * _UNITS[m[2]])


def _count(what: str, low: int):
    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            n = low - 1
        if n < low:
            raise argparse.ArgumentTypeError(f"{what} must be an integer >= {low}, got {text!r}")
        return n
    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("maps larger than memory (docs/scale.md)")
    group.add_argument("--tile", type=_count("--tile", 16), metavar="CELLS",
                       help="trace tile by tile, CELLS x CELLS cells a tile with exact halos toward the sun "
                            "(same masks); default with --max-memory/--workers: the largest that fits")
    group.add_argument("--max-memory", type=memory_size, metavar="SIZE",
                       help="read the input and write the output a tile at a time, keeping the run's peak "
                            "resident memory under SIZE (e.g. 256M, 3G); GeoTIFF or .npy input reads only "
                            "what each tile needs; output .tif or .npy")
    group.add_argument("--workers", type=_count("--workers", 1), metavar="N",
                       help="trace the tiles on N local Dask worker processes, each with its own OpenCL "
                            "context (pip install 'oclshade[dask]')")


def requested(args: argparse.Namespace) -> bool:
    return args.tile is not None or args.max_memory is not None or args.workers is not None


def run(args: argparse.Namespace, job) -> int:
    """The shadow command, tiled (``job``: the checked arguments of oclshade.cli.check_shadow_args)."""
    from .. import cli
    from ..solar import cli as solar_cli

    if args.preview is not None:
        raise cli.UsageError("--preview draws the whole map in memory; leave it out with --tile, --max-memory "
                             "or --workers")
    ext = cli._extension(args.output)
    if args.max_memory is not None and ext not in (".tif", ".tiff", ".npy"):
        raise cli.UsageError(f"--max-memory writes .tif or .npy output a tile at a time; {ext} is written whole")
    if args.workers is not None and args.max_memory is not None:
        raise cli.UsageError("--max-memory bounds this process; with --workers give each worker's memory to "
                             "Dask instead (docs/scale.md)")
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        try:
            windows = open_dem(args.input, cellsize=job.cellsize, band=args.band, nodata=args.nodata)
        except (OSError, ValueError) as exc:
            raise cli.CliError(str(exc)) from None
    with contextlib.closing(windows):
        raster = windows.raster
        cli.check_input_raster(args, raster, job.cellsize)
        with warnings.catch_warnings(record=True) as sentinels:      # (the relief pass's)
            warnings.simplefilter("always", InputWarning)
            relief = relief_pass(windows, args.z_factor, stripe_bytes=relief_stripe_bytes(args.max_memory))
        caught += sentinels
        for warning in caught:
            sys.stderr.write(f"{cli.PROG}: warning: {warning.message}\n")
        lo, hi = relief.ordinary          # the places' middle height and relief (the raster's units, before -z)
        raster.heights_range = tuple(sorted((lo / args.z_factor, hi / args.z_factor)))
        traced = None      # per time the sun over the map (per block), or None: job.suns
        if job.times:
            placed = solar_cli.suns_for(job.times, args, raster)
            job = cli.dataclasses.replace(job, suns=placed.suns)
            traced = placed.traced
            if not args.quiet and (blocks := placed.blocks_line()):
                sys.stderr.write(f"{cli.PROG}: {blocks}\n")
        else:
            traced = solar_cli.on_map_grid(job.suns, args, raster)
        dx, dy = raster.dx * args.scale, raster.dy * args.scale
        rows, cols = windows.shape
        cli._make_parents(args.output)
        names = cli.band_names(job.suns, job.outputs, exr=ext == ".exr")
        tiff = tiff_options(job.options, job.dtype, job.cog) if ext in (".tif", ".tiff") else None
        out_block = (tiff.block[1] or 1) if tiff is not None else 1
        bar = None if args.quiet else cli.ProgressBar(sys.stderr, "tiles")
        with cli.RasterWriter(args.output, (len(names), rows, cols), job.dtype, like=raster,
                              nodata=255.0 if job.dtype == np.uint8 else math.nan, band_names=names,
                              options=job.options, cog=job.cog) as out:
            common = dict(method=args.method, outputs=("mask", *job.outputs), k_dark=args.k_dark,
                          k_bright=args.k_bright)

            def bands(res):
                return cli._result_bands(res, job.outputs)

            t1 = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", InputWarning)
                if args.workers is None:
                    done = shadow_stream(windows, out, traced or job.suns, bands=bands, dx=dx, dy=dy, z_factor=args.z_factor,
                                         tile_size=args.tile, max_memory=args.max_memory, device=args.device,
                                         out_block=out_block, progress=bar, relief=relief, **common)
                    plan = done.plan
                else:
                    from .distributed import shadow_file_workers
                    plan = shadow_file_workers(args, windows, out, traced or job.suns, bands, dx, dy, args.workers,
                                               args.tile, bar, relief=relief, **common)
            for warning in caught:
                sys.stderr.write(f"{cli.PROG}: warning: {warning.message}\n")
            t2 = time.perf_counter()
    if not args.quiet:
        print(f"{cli.PROG}: {cols}x{rows} cells, {len(job.suns)} sun(s), method {args.method}: {len(plan.jobs)} "
              f"tile job(s) of {plan.tile_size}^2 cells, halo overhead {100 * plan.trace_overhead:.0f}% traced, "
              f"{t2 - t1:.2f} s (total {time.perf_counter() - t0:.2f} s), peak memory "
              f"{peak_rss_bytes() / 2**20:.0f} MiB -> {args.output}", file=sys.stderr)
    return 0
