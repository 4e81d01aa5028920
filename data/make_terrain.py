"""Write the synthetic canyon-and-crater terrain of :mod:`oclshade.synthetic` to a file.

    python data/make_terrain.py data/canyon_512.tif --size 512 --cellsize 30
    python data/make_terrain.py /tmp/canyon_4096.npy --size 4096

A .tif gets a projected georeference (a made-up origin in UTM zone 33N,
EPSG:32633, metres) so that readers, ``oclshade shadow`` included, take the
cell size from the file; .npy, .exr and .png hold the heights only.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from oclshade.io import Raster, write_raster
from oclshade.synthetic import canyon_crater

ORIGIN = (500000.0, 4000000.0)  # west, north edge in EPSG:32633 metres (made up)
EPSG = 32633


def projected_georef(cellsize: float) -> dict:
    """GeoTIFF tags (tifffile code -> value): pixel scale, tie point and an EPSG:32633 key directory."""
    keys = (1, 1, 0, 4,
            1024, 0, 1, 1,      # GTModelType: projected
            1025, 0, 1, 1,      # GTRasterType: PixelIsArea
            3072, 0, 1, EPSG,   # ProjectedCSType
            3076, 0, 1, 9001)   # ProjLinearUnits: metre
    return {33550: (cellsize, cellsize, 0.0), 33922: (0.0, 0.0, 0.0, *ORIGIN, 0.0), 34735: keys}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", help="output file: .tif/.tiff, .npy, .exr")
    parser.add_argument("--size", type=int, default=512, help="rows (default 512)")
    parser.add_argument("--cols", type=int, default=None, help="columns (default: --size)")
    parser.add_argument("--cellsize", type=float, default=30.0, help="cell size in metres (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--relief", type=float, default=1500.0, help="height range in metres (default 1500)")
    args = parser.parse_args(argv)
    dem = canyon_crater(args.size, args.cols, seed=args.seed, relief=args.relief)
    like = Raster(dem.astype(np.float64), args.cellsize, args.cellsize, georef=projected_georef(args.cellsize))
    write_raster(args.output, dem, like=like)
    print(f"{args.output}: {dem.shape[0]}x{dem.shape[1]} float32, {args.cellsize:g} m cells, "
          f"heights {dem.min():.1f}..{dem.max():.1f} m", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
