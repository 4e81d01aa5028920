#!/usr/bin/env python
"""Rays along the grid's lines against the true vertical planes: how far the horizons of
georeferenced DEMs, traced as ``oclshade horizon --curvature`` does (a straight line of the grid
from each cell), are from the horizons over the geodesic leaving the cell at the same azimuth.

    python bench/geodesic_rays.py              # the shared geographic DEMs, N22W160 moved north, two projections
    python bench/geodesic_rays.py --reduced    # a check that the script works (fewer cells)

A straight line of a geographic grid keeps its ratio of degrees of longitude to latitude, so
its far end lies off the geodesic (the great circle: the vertical plane a sun's ray and a
horizon look along) by about D^2 tan(latitude) / 2R at D metres: terrain 30 km away is seen
some 0.13 degree of azimuth off at 45 N.  A projected grid's lines are the projection's
straight lines: Web Mercator's are rhumb lines (as a geographic grid's), UTM's bend from the
geodesics by about x D^2 / 2R^2 at x metres from the central meridian.  The kernels, their float64
twin, r.horizon and SAGA all trace the grid's lines; HORAYZON traces ECEF rays.

Two float64 brute forces in ECEF (WGS 84 heights, curvature by construction, no refraction),
over the same bilinear surface and seeded cells: ``grid line`` (:func:`ground_height.ecef_horizons`:
the kernel's own line; what it leaves out is the model's other residuals, heights and the
scale's change) and ``geodesic`` (:func:`geodesic_horizons`: the geodesic leaving the cell at the
traced direction's true azimuth, pyproj's ``Geod.fwd``, sampled every 1/8 cell to the map's
edge (found by bisection), refined around the 24 best samples and again around the best of
those: the grid lines it crosses put kinks in its profile; and the limit at the cell).  Per map, in one process: |traced - each| and |grid line -
geodesic| (mean, 99th percentile, max; the share of cell-azimuths past 0.01 and 0.1 degree),
the far ends' azimuth off the geodesic (how far off the grid's lines point at the map's
edge), the share of cells whose cast shadow the two horizons tell apart at a sun between 0
and 30 degrees up (a cell is in cast shadow iff its horizon at the sun's azimuth is above
the sun: the share of those elevations between its two horizons, averaged), the time
of the traced horizons, and :func:`oclshade.horizon.site_horizon` (one site's horizon along the
geodesics, float64 on the host) from each sampled cell at the same true azimuths against the
geodesic brute force, with its time per site.  Writes bench/results/geodesic_rays.{json,md};
figures depend on the machine, the results record where they were taken.
"""
from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from geographic_scale import moved, projected  # noqa: E402
from ground_height import (FINE, MAPS, NEAR, PER_PATCH, REFINED, bilinear, ecef,  # noqa: E402
                           ecef_horizons, eye_limit, load, seeded_cells, summary)
from shadow_masks import header, log, metadata, publish, results_arguments  # noqa: E402

from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import Curvature, HorizonCaster  # noqa: E402
from oclshade.horizon.site import site_horizon  # noqa: E402
from oclshade.io import Raster, read_dem  # noqa: E402
from oclshade.solar.field import MapPlaces, checked_places  # noqa: E402

SRTM = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip"
AZIMUTHS = 16
#: suns from 0 to this many degrees up: a cell's cast shadow differs where the sun lies between its two horizons
LOW_SUNS = 30.0
CELLS, REDUCED_CELLS = 200, 24
#: N22W160's heights (Kauai) moved north on their geographic grid, and on two projected grids
NORTH = (46.0, 61.0)
PROJECTIONS = (("Web Mercator, 45 N", 3857, 10.0, 45.0), ("UTM 33N, 2.9 deg east of its meridian", 32633, 17.9, 47.0))


def grid_of(places: MapPlaces, to_grid, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(row y, column x) in sample units (sample (i, j) at (i, j)) of geodetic places: the inverse
    of ``places.lonlat`` (``to_grid``: the CRS's transformer from its geodetic CRS, or None)."""
    x0, xc, xr, y0, yc, yr = places.transform
    if to_grid is not None:
        lon, lat = (np.asarray(v, np.float64) for v in to_grid.transform(lon, lat))
    else:
        lon = x0 + np.mod(lon - x0 + 180.0, 360.0) - 180.0
    det = xc * yr - xr * yc
    return ((lat - y0) * xc - (lon - x0) * yc) / det - 0.5, ((lon - x0) * yr - (lat - y0) * xr) / det - 0.5


def traced_direction(places: MapPlaces, ground: MapPlaces, raster: Raster, i: int, j: int, azimuth: float
                     ) -> tuple[float, float]:
    """(vx, vy): one cell unit of the grid line the kernel traces from sample (i, j) at this
    azimuth (degrees: true on a geographic grid, the grid's on a projected one)."""
    from ground_height import grid_line

    east, north = (float(v[0]) for v in ground.grid_scales(np.array([i + 0.5]), np.array([j + 0.5]))[:2])
    return grid_line(np.radians(azimuth), raster.dx * east, raster.dy * north)


def geodesic_horizons(raster: Raster, places: MapPlaces, cells: tuple[np.ndarray, np.ndarray],
                      azimuths: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """((azimuths, cells) float64 degrees: the largest elevation angle over the geodesic leaving
    each cell at its traced direction's true azimuth; the same shape: the true azimuth of the
    traced grid line's far end less that of its start, degrees; and that true azimuth)."""
    import pyproj

    geod = pyproj.Geod(ellps="WGS84")
    to_grid = None if places.crs is None else pyproj.Transformer.from_crs(places.crs.geodetic_crs, places.crs,
                                                                          always_xy=True)
    h = raster.heights.astype(np.float64)
    rows, cols = h.shape
    ground = MapPlaces(places.transform, places.shape, places.crs)
    cell = min(raster.dx, raster.dy)
    step = cell / (PER_PATCH - 1)
    out, turn = np.full((azimuths.size, cells[0].size), -90.0), np.zeros((azimuths.size, cells[0].size))
    true = np.zeros_like(turn)
    for c, (i, j) in enumerate(zip(*cells)):
        lon0, lat0 = (float(v[0]) for v in places.lonlat(np.array([i + 0.5]), np.array([j + 0.5])))
        eye = ecef(np.array(lon0), np.array(lat0), np.array(h[i, j]))
        phi, lam = np.radians(lat0), np.radians(lon0)
        up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
        for a, az in enumerate(azimuths):
            vx, vy = traced_direction(places, ground, raster, i, j, float(az))
            reach = min(((cols - 1 - j) / vx if vx > 0 else j / -vx) if vx else np.inf,
                        ((rows - 1 - i) / vy if vy > 0 else i / -vy) if vy else np.inf)
            if reach <= NEAR[0]:
                continue
            (start, end) = (places.lonlat(np.array([i + 0.5 + vy * t]), np.array([j + 0.5 + vx * t]))
                            for t in (1e-3, reach))
            true_az = geod.inv(lon0, lat0, float(start[0][0]), float(start[1][0]))[0]
            true[a, c] = true_az
            far_az = geod.inv(lon0, lat0, float(end[0][0]), float(end[1][0]))[0]
            turn[a, c] = (far_az - true_az + 180.0) % 360.0 - 180.0
            metres = reach * np.hypot(vx * raster.dx, vy * raster.dy) * 1.2 + 10 * cell

            def angles(s: np.ndarray) -> np.ndarray:
                lon, lat, _ = geod.fwd(np.full(s.shape, lon0), np.full(s.shape, lat0), np.full(s.shape, true_az), s)
                y, x = grid_of(places, to_grid, lon, lat)
                inside = (y >= 0) & (y <= rows - 1) & (x >= 0) & (x <= cols - 1)
                sight = ecef(lon, lat, bilinear(h, y, x)) - eye
                return np.where(inside, np.degrees(np.arcsin(sight @ up / np.linalg.norm(sight, axis=-1))), -np.inf)

            s = NEAR[0] * cell + step * np.arange(int(metres / step) + 1)
            coarse = angles(s)
            leave = np.flatnonzero(np.isneginf(coarse) & (s > cell))
            if leave.size:                          # the first sample past the map's edge: the path ends at the
                lo_s, hi_s = s[leave[0] - 1], s[leave[0]]          # edge, found by bisection and sampled too
                for _ in range(40):
                    mid = (lo_s + hi_s) / 2.0
                    lo_s, hi_s = (lo_s, mid) if np.isneginf(angles(np.array([mid]))[0]) else (mid, hi_s)
                s = np.append(s[:leave[0]], lo_s)
                coarse = np.append(coarse[:leave[0]], angles(np.array([lo_s])))
            if not np.any(np.isfinite(coarse)):     # (NaN: nodata under the path)
                continue
            top = np.argsort(np.where(np.isfinite(coarse), coarse, -np.inf))[-REFINED:]
            lo, hi = s[np.maximum(top - 1, 0)], s[np.minimum(top + 1, s.size - 1)]
            spots = (lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, FINE)).ravel()
            fine = angles(spots)
            at = int(np.argmax(np.where(np.isfinite(fine), fine, -np.inf)))      # then around the best of those
            zoom = angles(np.linspace(spots[max(at - 1, 0)], spots[min(at + 1, spots.size - 1)], FINE))   # (a kink)
            out[a, c] = float(np.nanmax([np.nanmax(coarse), np.nanmax(fine), np.nanmax(zoom), eye_limit(angles, s[0])]))
    return out, turn, true


def share_past(error: np.ndarray, limit: float) -> float:
    return float(np.mean(error > limit))


def maps(folder: Path) -> dict[str, Raster | None]:
    out: dict[str, Raster | None] = {name: load(path, folder) if path.exists() else None for name, path in MAPS.items()}
    srtm = read_dem(SRTM) if SRTM.exists() else None
    out["SRTM N22W160 (Kauai, 3 arc-sec, 22 N)"] = srtm
    for north in NORTH:
        out[f"N22W160's heights at {north - 0.5:g} N"] = None if srtm is None else moved(srtm, north, folder)
    for name, epsg, lon, lat in PROJECTIONS:
        out[f"N22W160's heights, {name}"] = None if srtm is None else projected(srtm, name, epsg, lon, lat, folder)
    return out


def run(reduced: bool) -> dict:
    curvature = Curvature()
    azimuths = np.arange(AZIMUTHS) * (360.0 / AZIMUTHS)
    out = {"meta": metadata(sys.argv), "azimuths": AZIMUTHS, "maps": {}}
    with tempfile.TemporaryDirectory() as scratch:
        for name, raster in maps(Path(scratch)).items():
            if raster is None:
                log(f"{name}: its data is absent, skipped")
                out["maps"][name] = {"skipped": "data absent"}
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                heightmap = Heightmap.from_raster(raster)
            places, notes = checked_places(raster, 1.0, curvature.coefficient)
            caster = HorizonCaster(heightmap, curvature=curvature, cache=False)
            traced = caster.horizons(azimuths)                       # (also the warm-up)
            seconds = []
            for _ in range(3):
                t0 = time.perf_counter()
                caster.horizons(azimuths)
                seconds.append(time.perf_counter() - t0)
            inner = np.zeros(raster.heights.shape, bool)     # off the border ring: a geodesic along the map's
            inner[1:-1, 1:-1] = True                          # edge leaves it at once, a grid line does not
            pick = seeded_cells(raster.heights, REDUCED_CELLS if reduced else CELLS, inner)
            cells = (pick[:, 0], pick[:, 1])
            log(f"{name}: {raster.heights.shape}, brute forces on {pick.shape[0]} cells x {AZIMUTHS} azimuths")
            line = ecef_horizons(raster, places, cells, azimuths)
            geodesic, turn, true = geodesic_horizons(raster, places, cells, azimuths)
            lon, lat = places.lonlat(cells[0] + 0.5, cells[1] + 0.5)
            t0 = time.perf_counter()
            site = np.stack([site_horizon(raster, float(lat[c]), float(lon[c]), true[:, c], curvature=curvature)
                             for c in range(lat.size)], axis=1)
            per_site = (time.perf_counter() - t0) / lat.size
            seen = (line > -90.0) & (geodesic > -90.0)
            at_cells = traced[:, cells[0], cells[1]].astype(np.float64)
            errors = {"traced - grid line": np.abs(at_cells - line)[seen],
                      "traced - geodesic": np.abs(at_cells - geodesic)[seen],
                      "grid line - geodesic": np.abs(line - geodesic)[seen],
                      "site - geodesic": np.abs(site - geodesic)[seen]}
            low, high = (np.clip(f(at_cells, geodesic)[seen], 0.0, LOW_SUNS) for f in (np.minimum, np.maximum))
            row = {"shape": list(raster.heights.shape), "cells": int(pick.shape[0]), "warning": notes,
                   "masks_differ_ppm": float(1e6 * np.mean(high - low) / LOW_SUNS),
                   "centre_latitude": places.centre_latitude, "seconds": min(seconds), "seconds_per_site": per_site,
                   "far_end_turn_deg": {"median": float(np.median(np.abs(turn))), "max": float(np.abs(turn).max())},
                   "errors": {k: {**summary(e), "past_0.01": share_past(e, 0.01), "past_0.1": share_past(e, 0.1)}
                              for k, e in errors.items()}}
            out["maps"][name] = row
            log(f"  {row['errors']}")
    return out


def markdown(result: dict) -> str:
    m = result["meta"]
    lines = ["# Rays along the grid's lines against the geodesics", "", header(m, "python bench/geodesic_rays.py"),
             f"{result['azimuths']} azimuths with curvature (no refraction), seeded cells off the map's border; float64 "
             "ECEF brute forces "
             "along the kernel's grid line and along the geodesic at its true azimuth; |difference| in degrees "
             "(mean / 99th percentile / max, and the share of cell-azimuths past 0.01 and 0.1 degree); the grid "
             "lines' far ends' azimuth off their start's (median / max); the share of cells whose cast shadow differs "
             f"(traced against geodesic horizon) at a sun 0-{LOW_SUNS:g} degrees up, all elevations alike, in parts per "
             "million; time of the 16 traced horizons (best of 3); `site_horizon` (float64 on the host, along the "
             "geodesics: docs/methods.md) from each sampled cell at the same true azimuths against the geodesic brute "
             "force, and its time per site.",
             "", "| map | lat | cells | traced - grid line | traced - geodesic | grid line - geodesic | "
             "past 0.01 / 0.1 (traced - geodesic) | far ends' turn (deg) | masks differ (ppm) | time (s) | "
             "site - geodesic | s per site |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in result["maps"].items():
        if "skipped" in r:
            lines.append(f"| {name} | skipped: {r['skipped']} | | | | | | | | | | |")
            continue
        fmt = "{mean:.4f} / {p99:.4f} / {max:.4f}"
        e = r["errors"]
        g = e["traced - geodesic"]
        lines.append(f"| {name} | {r['centre_latitude']:.1f} | {r['cells']} | {fmt.format(**e['traced - grid line'])} | "
                     f"{fmt.format(**g)} | {fmt.format(**e['grid line - geodesic'])} | "
                     f"{100 * g['past_0.01']:.1f} % / {100 * g['past_0.1']:.1f} % | "
                     f"{r['far_end_turn_deg']['median']:.3f} / {r['far_end_turn_deg']['max']:.3f} | "
                     f"{r['masks_differ_ppm']:.0f} | {r['seconds']:.3f} | {fmt.format(**e['site - geodesic'])} | "
                     f"{r['seconds_per_site']:.3f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = results_arguments(argv, __doc__, "geodesic_rays", f"{REDUCED_CELLS} cells per map")
    result = run(args.reduced)
    return publish(args.out, result, markdown(result))


if __name__ == "__main__":
    sys.exit(main())
