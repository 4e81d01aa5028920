#!/usr/bin/env python
"""Ground metres at the map's middle height, against the true geometry: the horizons of real
geographic DEMs, traced with curvature as ``oclshade horizon --curvature`` does (the row scales
at the middle of the map's heights, ``MapPlaces.height``) and as before 2026-12-05's nineteenth
session (the ellipsoid's metres: height 0), against a float64 brute force in ECEF.

    python bench/ground_height.py              # the shared high-relief geographic DEMs
    python bench/ground_height.py --reduced    # a check that the script works (fewer cells)

The brute force (:func:`ecef_horizons`) is independent of the tracing's model: for each sampled
cell and azimuth it follows the same straight grid line as the kernel (leaving the cell at that
true azimuth, by the cell's own cell sizes on the ground), takes the bilinear surface's height
at both ends and 7 inner points of every patch it crosses to the map's edge (from 0.001 cell
on; then 257 points in each of the 24 best patches: a patch's profile is smooth, its kinks at
the patch edges; and the limit at the cell, the slope there, from 0.001 and 0.002 cell), places
each point on the WGS 84 ellipsoid at its height (ECEF) and keeps the largest elevation angle
above the cell's own tangent plane (its geodetic normal).  So it counts what the grid's metres
leave out: the heights above the ellipsoid, the Earth's curvature on the ellipsoid, the scale's
change along the ray; not the geodesic (the line is the grid's, as traced).

Per map, in one process: |traced - brute force| over the sampled cells and azimuths (mean, 99th
percentile, max) for the middle height and for the ellipsoid's metres, the bound the run states
(``checked_places`` with curvature: far terrain and heights) and the time of the 16 horizons
both ways (best of 3 in turn after a warm-up).  Writes bench/results/ground_height.{json,md};
figures depend on the machine, the results record where they were taken.
"""
from __future__ import annotations

import math
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from shadow_masks import header, log, metadata, publish, results_arguments  # noqa: E402

from oclshade import reference as ref  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import Curvature, HorizonCaster  # noqa: E402
from oclshade.io import Raster, read_dem  # noqa: E402
from oclshade.solar.field import MapPlaces, checked_places  # noqa: E402

DEM = REPO.parent / "shared" / "data" / "dem"
MAPS = {"Front Range (landlab, 3 arc-sec)": DEM / "landlab" / "SRTMGL3_40.09_-105.55_40.21_-105.35.asc",
        "central Japan (SRTM30, 30 arc-sec)": DEM / "srtm30_qgis2threejs" / "dem_srtm30.tif"}
WGS84_A, WGS84_E2 = 6378137.0, 6.69437999014e-3
AZIMUTHS = 16
PER_PATCH, FINE, REFINED = 9, 257, 24   # samples per patch a ray crosses (its ends included), per patch refined,
                                        # and the patches refined (the best so far)
NEAR = np.array([1e-3])                 # cells: where a ray's samples start (the sup's limit at the cell, its
                                        # slope there; nearer, ECEF's float64 rounding of 6e6 m would show)


def load(path: Path, scratch: Path) -> Raster:
    """The DEM; an ESRI ASCII grid in degrees gets the .prj its source leaves out (WGS 84)."""
    if path.suffix == ".asc":
        import pyproj
        copy = scratch / path.name
        shutil.copy(path, copy)
        copy.with_suffix(".prj").write_text(pyproj.CRS.from_epsg(4326).to_wkt())
        path = copy
    return read_dem(path)


def ecef(lon: np.ndarray, lat: np.ndarray, h: np.ndarray) -> np.ndarray:
    """(..., 3) WGS 84 earth-centred coordinates of geodetic places, metres."""
    phi, lam = np.radians(lat), np.radians(lon)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(phi) ** 2)
    return np.stack([(n + h) * np.cos(phi) * np.cos(lam), (n + h) * np.cos(phi) * np.sin(lam),
                     (n * (1.0 - WGS84_E2) + h) * np.sin(phi)], axis=-1)


def bilinear(heights: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The bilinear surface at (row y, column x) in sample units (NaN where a corner is nodata)."""
    rows, cols = heights.shape
    i = np.clip(np.floor(y).astype(np.int64), 0, rows - 2)
    j = np.clip(np.floor(x).astype(np.int64), 0, cols - 2)
    fy, fx = y - i, x - j
    return ((heights[i, j] * (1 - fx) + heights[i, j + 1] * fx) * (1 - fy)
            + (heights[i + 1, j] * (1 - fx) + heights[i + 1, j + 1] * fx) * fy)


def grid_line(azimuth: float, east: float, north: float) -> tuple[float, float]:
    """(vx, vy): one cell unit of the grid line leaving a cell at true ``azimuth`` (radians), the
    cell ``east`` by ``north`` metres (a component within rounding of 0 is 0: along a grid line)."""
    vx, vy = math.sin(azimuth) / east, -math.cos(azimuth) / north
    vx, vy = (0.0 if abs(v) < 1e-12 * math.hypot(vx, vy) else v for v in (vx, vy))
    norm = math.hypot(vx, vy)
    return vx / norm, vy / norm


def patch_ends(i: int, j: int, vx: float, vy: float, rows: int, cols: int) -> np.ndarray:
    """The distances s (cell units) along the line from sample (i, j) at which it crosses a grid
    line (the profile's kinks), from :data:`NEAR` to the map's edge; empty where it leaves at once."""
    reach = min(((cols - 1 - j) / vx if vx > 0 else j / -vx) if vx else math.inf,
                ((rows - 1 - i) / vy if vy > 0 else i / -vy) if vy else math.inf)
    if reach <= 0.0:
        return np.empty(0)
    crossings = [(np.arange(np.floor(p0) + 1, np.ceil(p0 + v * reach)) - p0) / v if v > 0 else
                 (np.arange(np.ceil(p0) - 1, np.floor(p0 + v * reach), -1) - p0) / v if v < 0 else
                 np.empty(0) for p0, v in ((j, vx), (i, vy))]
    ends = np.unique(np.concatenate([[NEAR[0], reach], *crossings]))
    return ends[(ends >= NEAR[0]) & (ends <= reach)]


def eye_limit(angles, near: float) -> float:
    """The angle's limit at the cell itself, the surface's slope where the path starts (the sup
    there when the profile starts concave, which samples from ``near`` on miss by up to its
    curvature times ``near``): linear in s to first order, extrapolated from ``near`` and twice it."""
    a = angles(np.array([near, 2.0 * near]))
    return float(2.0 * a[0] - a[1])


def highest(angles, ends: np.ndarray) -> float:
    """The largest of ``angles(s)`` (degrees) over the patches between ``ends``: each patch's ends
    and inner points, then :data:`REFINED` best patches finely, and the limit at the cell
    (:func:`eye_limit`; -90 where nothing is seen)."""
    if ends.size < 2:
        return -90.0
    lo, hi = ends[:-1], ends[1:]
    coarse = angles((lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, PER_PATCH)).ravel())
    best = np.nanmax(coarse.reshape(lo.size, PER_PATCH), axis=1)
    if np.all(np.isnan(best)):
        return -90.0
    top = np.argsort(np.where(np.isnan(best), -np.inf, best))[-REFINED:]
    fine = angles((lo[top, None] + (hi - lo)[top, None] * np.linspace(0.0, 1.0, FINE)).ravel())
    return float(np.nanmax([np.nanmax(best), np.nanmax(fine), eye_limit(angles, ends[0])]))


def ecef_horizons(raster: Raster, places: MapPlaces, cells: tuple[np.ndarray, np.ndarray],
                  azimuths: np.ndarray) -> np.ndarray:
    """(azimuths, cells) float64 degrees: the brute force of the module docstring."""
    h = raster.heights.astype(np.float64)
    rows, cols = h.shape
    ground = MapPlaces(places.transform, places.shape, places.crs)        # the ellipsoid's metres per grid metre
    out = np.full((azimuths.size, cells[0].size), -90.0)
    for c, (i, j) in enumerate(zip(*cells)):
        east, north = (float(v[0]) for v in ground.grid_scales(np.array([i + 0.5]), np.array([j + 0.5]))[:2])
        lon0, lat0 = places.lonlat(np.array([i + 0.5]), np.array([j + 0.5]))
        eye = ecef(lon0, lat0, np.array([h[i, j]]))[0]
        phi, lam = np.radians(lat0[0]), np.radians(lon0[0])
        up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
        for a, az in enumerate(np.radians(azimuths)):
            vx, vy = grid_line(float(az), raster.dx * east, raster.dy * north)

            def angles(s: np.ndarray) -> np.ndarray:
                y, x = i + vy * s, j + vx * s
                lon, lat = places.lonlat(y + 0.5, x + 0.5)
                sight = ecef(lon, lat, bilinear(h, y, x)) - eye
                return np.degrees(np.arcsin(sight @ up / np.linalg.norm(sight, axis=-1)))

            out[a, c] = highest(angles, patch_ends(i, j, vx, vy, rows, cols))
    return out


def seeded_cells(heights: np.ndarray, count: int, where: np.ndarray | None = None) -> np.ndarray:
    """(count, 2) rows and columns of valid cells (and ``where``), drawn with seed 19."""
    valid = np.argwhere(np.isfinite(heights) & (True if where is None else where))
    return valid[np.random.default_rng(19).choice(len(valid), size=min(len(valid), count), replace=False)]


def summary(error: np.ndarray) -> dict:
    return {"mean": float(error.mean()), "p99": float(np.percentile(error, 99)), "max": float(error.max())}


def run(reduced: bool) -> dict:
    curvature = Curvature()
    azimuths = np.arange(AZIMUTHS) * (360.0 / AZIMUTHS)
    out = {"meta": metadata(sys.argv), "azimuths": AZIMUTHS, "maps": {}}
    with tempfile.TemporaryDirectory() as scratch:
        for name, path in MAPS.items():
            if not path.exists():
                log(f"{name}: {path} absent, skipped")
                out["maps"][name] = {"skipped": f"{path.name} absent"}
                continue
            raster = load(path, Path(scratch))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                middle = Heightmap.from_raster(raster)
            places, notes = checked_places(raster, 1.0, curvature.coefficient)
            ellipsoid = Heightmap.from_array(raster.heights, (raster.dx, raster.dy),
                                             row_scales=MapPlaces(places.transform, places.shape, places.crs).row_scales())
            casters = {"middle": HorizonCaster(middle, curvature=curvature, cache=False),
                       "ellipsoid": HorizonCaster(ellipsoid, curvature=curvature, cache=False)}
            angles = {k: c.horizons(azimuths) for k, c in casters.items()}      # (also the warm-up)
            seconds = {k: [] for k in casters}
            for _ in range(3):
                for k, c in casters.items():
                    t0 = time.perf_counter()
                    c.horizons(azimuths)
                    seconds[k].append(time.perf_counter() - t0)
            pick = seeded_cells(raster.heights, 40 if reduced else 300)
            cells = (pick[:, 0], pick[:, 1])
            log(f"{name}: {raster.heights.shape}, brute force on {pick.shape[0]} cells x {AZIMUTHS} azimuths")
            truth = ecef_horizons(raster, places, cells, azimuths)
            seen = truth > -90.0
            row = {"shape": list(raster.heights.shape), "middle_height_m": places.height,
                   "relief_m": float(np.nanmax(raster.heights) - np.nanmin(raster.heights)),
                   "cells": int(pick.shape[0]), "warning": notes,
                   "float32_band_deg": ref.angle_tolerance(middle, curvature.coefficient),
                   "seconds": {k: min(v) for k, v in seconds.items()}}
            for k, a in angles.items():
                row[k] = summary(np.abs(a[:, cells[0], cells[1]].astype(np.float64) - truth)[seen])
            out["maps"][name] = row
            log(f"  middle {row['middle']}, ellipsoid {row['ellipsoid']}")
    return out


def markdown(result: dict) -> str:
    m = result["meta"]
    lines = ["# Ground metres at the map's middle height against ECEF", "", header(m, "python bench/ground_height.py"),
             f"{result['azimuths']} azimuths with curvature (no refraction), seeded cells; |traced - float64 "
             "ECEF brute force| in degrees (mean / 99th percentile / max); the bound the run states with "
             "--curvature (far terrain and heights; plus the float32 band); time of the 16 horizons "
             "(best of 3 in turn).", "",
             "| map | relief, middle (m) | cells | middle height: mean / p99 / max | ellipsoid's metres: "
             "mean / p99 / max | stated bound | float32 band | time middle / ellipsoid (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, r in result["maps"].items():
        if "skipped" in r:
            lines.append(f"| {name} | skipped: {r['skipped']} | | | | | | |")
            continue
        bound = r["warning"][0].split("within ")[1].split(" deg")[0] if r["warning"] else "<= 0.01"
        fmt = "{mean:.5f} / {p99:.5f} / {max:.5f}"
        lines.append(f"| {name} | {r['relief_m']:.0f}, {r['middle_height_m']:.0f} | {r['cells']} | "
                     f"{fmt.format(**r['middle'])} | {fmt.format(**r['ellipsoid'])} | {bound} | "
                     f"{r['float32_band_deg']:.4f} | {r['seconds']['middle']:.3f} / {r['seconds']['ellipsoid']:.3f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = results_arguments(argv, __doc__, "ground_height", "40 cells per map")
    result = run(args.reduced)
    return publish(args.out, result, markdown(result))


if __name__ == "__main__":
    sys.exit(main())
