#!/usr/bin/env python
"""A grid's scale: what tracing a geographic grid at the centre latitude's cell width, or a
projected one in its CRS's metres, got wrong, and what tracing each band of rows with its own
scale costs (oclshade.solar.MapPlaces.on_grid for the masks, HorizonCaster(row_scales=...) for
the horizons).

    python bench/geographic_scale.py            # the shared SRTM tiles, N22W160's heights at 45.5 N,
                                                # on six projected grids (bench's PROJECTED) and on
                                                # three whole EU-DEM tiles' extents (TILES)
    python bench/geographic_scale.py --reduced  # a check that the script works (384^2 crops)
    python bench/geographic_scale.py --radius   # only the horizons within a search radius (RADIUS_CELLS)

Per map, in one process:

* **masks**, four suns given by their angles: the sun as the grid traces it per block of rows
  (``sun_field(places, Sun(...))``: blocks, build time) against the sun traced as given at the
  centre's cell width (what every version before did): time of each (best of 3 after a
  warm-up), their ratio, the cells where the masks differ, the largest angle between the sun
  as given and as the grid must trace it at the map's edges (the old geometry's error), and the
  per-block mask against the float64 twin on a seeded sample of 32 x 32 cells in 12 blocks
  (mismatches outside float32 ties: must be 0), and against the horizons at its azimuth (per
  band of rows): the cells where "in cast shadow" and "horizon above the sun" differ, and how
  far from the sun their horizons are (ties: within float32 rounding);
* **horizons** at 16 and 64 azimuths: time per block (bands of rows, by column bands on a
  projected grid whose scale changes along its rows) against the centre's cell width alone, and
  on a projected grid cut into column bands against one scale per row (the middle of the row's,
  as before 2026-12-05; one run each), the blocks, the largest and the 99th-percentile difference of the
  angles, and the banded angles against the float64 twin of each band's cells on 400 seeded
  cells per azimuth (16 azimuths; must be within the float32 band); on the projected maps, the
  ground check: 16 azimuths' angles on 64 seeded cells near the map's highest cell against the
  float64 twin on the grid at that direction's true metres there (the geodesic between grid points
  500 m either side, reference.ground_metre, not the tracing's model), and what one scale for every
  direction (the square root of the area, as before 2026-12-05) leaves against the same; on the
  whole tiles, the spread ground check: 16 azimuths' angles on 48 seeded cells all over the map
  (a third of them within 10 % of its width of its west or east edge), each against the twin at
  its own cell's true metres that way, for the blocks and for one scale per row.

Per map also **far terrain's bound** (MapPlaces.far_residual): how fast a grid metre's length
changes along a ray, the map's relief, and what a ray keeping its cell's scale leaves at most.

With ``--radius``, per map only the **horizons within a search radius** of RADIUS_CELLS cells (the
sweep): time per block against the grid as drawn and one scale per row (best of 3 after a
warm-up), and the twin within the
same radius, into bench/results/geographic_scale_radius.{json,md}.

Writes bench/results/geographic_scale.{json,md} (``--out`` to change).  Figures depend on the
machine; the results record where they were taken.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import tifffile

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from shadow_masks import log, metadata  # noqa: E402  (same metadata as the other benches)
from sun_field import best_of, crop, sample_field  # noqa: E402

from oclshade import ShadowCaster  # noqa: E402
from oclshade import reference as ref  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.io import Raster, read_dem  # noqa: E402
from oclshade.solar import map_places, sun_field  # noqa: E402
from oclshade.solar.scale import column_edges  # noqa: E402
from oclshade.sun import Sun  # noqa: E402

SRTM = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy"
SUNS = (Sun(90.0, 20.0), Sun(270.0, 10.0), Sun(135.0, 15.0), Sun(315.0, 45.0))
REDUCED_CROPS = {"N22W160": (817, 400, 384), "S16E166": (400, 817, 384)}
WGS84 = (1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326)
TWIN_CELLS = 400


def moved(raster: Raster, north: float, folder: Path) -> Raster:
    """The raster's heights on a geographic grid of its cells whose north edge is at ``north``."""
    sx, sy, _ = raster.georef[33550]
    _, _, _, west, _, _ = raster.georef[33922]
    path = folder / f"moved_{north:g}.tif"
    tifffile.imwrite(path, raster.heights.astype(np.float32), extratags=[
        (34735, 3, len(WGS84), WGS84, True), (33550, 12, 3, (sx, sy, 0.0), True),
        (33922, 12, 6, (0, 0, 0, west, north, 0), True)])
    return read_dem(path)


#: N22W160's heights on projected grids of its cells' north-south size, centred on these places:
#: UTM on its central meridian (k = 0.9996) and near a zone's edge, Web Mercator at 45 N, ArcticDEM's
#: polar stereographic at 62 N, and two equal-area projections far from their centres (not
#: conformal: they stretch by direction, which the row scales' (p, q) follow since 2026-12-05)
PROJECTED = (("UTM 4N, central meridian", 32604, -159.0, 22.5), ("UTM 33N, 2.9 deg east of its meridian", 32633, 17.9, 47.0),
             ("Web Mercator, 45 N", 3857, 10.0, 45.0), ("EPSG:3413 polar stereographic, 62 N", 3413, -45.0, 62.0),
             ("EPSG:5070 CONUS Albers, 47 N", 5070, -120.0, 47.0), ("EPSG:3035 LAEA Europe, 60 N 25 E", 3035, 25.0, 60.0))


#: N22W160's heights over whole EU-DEM tiles' extents (EPSG:3035, 1000 km square: its 1201^2 cells
#: 833 m each), west and north edges in metres: LAEA Europe's scale changes along their rows by up
#: to 0.9 %, which one scale per row left as 0.07-0.2 degree before 2026-12-05
TILES = (("EU-DEM tile E30N20 (LAEA, 1000 km)", 3.0e6, 3.0e6), ("EU-DEM tile E40N30 (LAEA, 1000 km)", 4.0e6, 4.0e6),
         ("EU-DEM tile E50N40 (LAEA, 1000 km)", 5.0e6, 5.0e6))
SPREAD_CELLS = 48
#: ``--radius``'s search radius in cells (12 cells: 10 km on the tiles' 833 m cells)
RADIUS_CELLS = 12


def tile(raster: Raster, west: float, north: float, folder: Path) -> Raster:
    """The raster's heights over a 1000 km EU-DEM tile's extent in EPSG:3035 (square cells)."""
    cell = 1.0e6 / raster.heights.shape[1]
    keys = (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 3035)
    path = folder / f"tile_{west:g}_{north:g}.tif"
    tifffile.imwrite(path, raster.heights.astype(np.float32), extratags=[
        (34735, 3, len(keys), keys, True), (33550, 12, 3, (cell, cell, 0.0), True),
        (33922, 12, 6, (0, 0, 0, west, north, 0), True)])
    return read_dem(path)


def projected(raster: Raster, name: str, epsg: int, lon: float, lat: float, folder: Path) -> Raster:
    """The raster's heights on a grid of square cells (its north-south size) in ``epsg``, centred on
    (``lon``, ``lat``)."""
    import pyproj

    crs = pyproj.CRS.from_epsg(epsg)
    x, y = pyproj.Transformer.from_crs(crs.geodetic_crs, crs, always_xy=True).transform(lon, lat)
    rows, cols = raster.heights.shape
    cell = raster.dy
    keys = (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, epsg)
    path = folder / f"projected_{epsg}_{lon:g}_{lat:g}.tif"
    tifffile.imwrite(path, raster.heights.astype(np.float32), extratags=[
        (34735, 3, len(keys), keys, True), (33550, 12, 3, (cell, cell, 0.0), True),
        (33922, 12, 6, (0, 0, 0, x - cols / 2 * cell, y + rows / 2 * cell, 0), True)])
    return read_dem(path)


def maps(reduced: bool, folder: Path) -> dict[str, Raster]:
    out = {}
    for name in ("N22W160", "S16E166"):
        path = SRTM / f"{name}v2.3a.hgt.zip"
        if path.is_file():
            raster = read_dem(path)
            if reduced:
                raster = crop(raster, *REDUCED_CROPS[name])
            out[f"SRTM {name}"] = raster
    if "SRTM N22W160" in out:
        out["N22W160's heights at 45.5 N"] = moved(out["SRTM N22W160"], 46.0, folder)
        for name, epsg, lon, lat in PROJECTED:
            out[name] = projected(out["SRTM N22W160"], name, epsg, lon, lat, folder)
        for name, west, north in TILES:
            out[name] = tile(out["SRTM N22W160"], west, north, folder)
    return out


def one_per_row(row_scales: np.ndarray) -> np.ndarray:
    """Row scales cut into column bands made one per row again: the middle of each row's (what a
    projected grid was traced at before 2026-12-05)."""
    if row_scales.ndim == 2:
        return row_scales
    return (row_scales.min(axis=1, keepdims=True) + row_scales.max(axis=1, keepdims=True)) / 2.0


def scale_row(name: str, places, hm: Heightmap) -> dict:
    """The map's grid metre on the ground (the row scales' range), its column bands, what its
    blocks, and one scale per row, leave (MapPlaces.residual_of), and the far terrain's bound
    under its relief (MapPlaces.far_residual)."""
    scales = places.row_scales()
    lo, hi = np.nanmin(hm.heights), np.nanmax(hm.heights)
    return {"map": name, "crs": "EPSG:4326" if places.crs is None else places.crs.to_string(),
            "relief_m": float(hi - lo), "far_rate_per_100km": 1e5 * places.far_scale_rate(hm.dx, hm.dy),
            "far_residual_deg": places.far_residual(float(hi - lo), hm.dx, hm.dy),
            "scale_min": float(scales[..., :2].min()), "scale_max": float(scales[..., :2].max()),
            "stretch_max": float(np.hypot(scales[..., 2], scales[..., 3]).max() / 2.0) if scales.shape[-1] == 4 else 0.0,
            "column_bands": int(scales.shape[1]) if scales.ndim == 3 else 1,
            "residual_deg": places.scale_residual, "one_per_row_residual_deg": places.residual_of(one_per_row(scales))}


def edge_error(places, sun: Sun) -> float:
    """The largest angle (degrees) between the sun as given and as the grid must trace it, over
    the rows' middles: how far the centre's cell width alone was off at the map's edges."""
    rows, cols = places.shape
    az, el = places.on_grid(np.array([0.5, rows - 0.5]), np.array([cols / 2.0] * 2), np.full(2, sun.azimuth),
                            np.full(2, sun.elevation))
    return float(max(np.abs((az - sun.azimuth + 180.0) % 360.0 - 180.0).max(), np.abs(el - sun.elevation).max()))


def masks(name: str, raster: Raster, hm: Heightmap, places) -> list[dict]:
    caster = ShadowCaster(hm, cache=False)
    horizon = HorizonCaster(hm, row_scales=places.row_scales(), cache=False)
    out = []
    for sun in SUNS:
        t0 = time.perf_counter()
        field = sun_field(places, sun)
        build = time.perf_counter() - t0
        caster.cast_many([field])
        caster.cast(sun)
        banded, flat = caster.cast_many([field])[0].mask, caster.cast(sun).mask
        t_field = best_of(lambda: caster.cast_many([field]))
        t_one = best_of(lambda: caster.cast(sun))
        valid = banded != 255
        sample = sample_field(field, 12, 7)
        got = caster.cast_many([sample])[0].mask
        twin = ref.cast_field_shadows(hm, sample)
        ties = twin.ties(ref.field_tie_tolerance(hm, sample))
        differ = got != twin.mask
        kept = [b for b in sample.blocks if b.sun.elevation > 0]
        angles = horizon.horizons([sun.azimuth])[0]
        disagree = valid & ((banded == 1) != (angles > sun.elevation))
        row = {"map": name, "sun": [sun.azimuth, sun.elevation], "blocks": len(field.blocks),
               "deviation_deg": field.deviation, "build_s": build, "per_block_s": t_field, "one_sun_s": t_one,
               "ratio": t_field / t_one, "edge_error_deg": edge_error(places, sun),
               "cells_differing": int((banded != flat)[valid].sum()), "valid_cells": int(valid.sum()),
               "twin_cells": int(sum((b.row1 - b.row0) * (b.col1 - b.col0) for b in kept)),
               "twin_mismatch": int((differ & ~ties).sum()), "twin_tied": int((differ & ties).sum()),
               "horizon_disagree": int(disagree.sum()),
               "horizon_disagree_max_deg": float(np.abs(angles - sun.elevation)[disagree].max()) if disagree.any() else 0.0}
        log(f"{name} sun {sun.azimuth:g}/{sun.elevation:g}: {row['blocks']} blocks, {t_field:.3f} s vs "
            f"{t_one:.3f} s, {row['cells_differing']} cells differ, edge error {row['edge_error_deg']:.3f} deg, "
            f"twin {row['twin_mismatch']}/{row['twin_tied']}, horizons disagree on {row['horizon_disagree']}")
        out.append(row)
    return out


def horizons(name: str, raster: Raster, hm: Heightmap, places) -> list[dict]:
    scales = places.row_scales()
    banded_caster = HorizonCaster(hm, row_scales=scales, cache=False)
    flat_caster = HorizonCaster(hm, cache=False)
    per_row = one_per_row(scales)
    row_caster = HorizonCaster(hm, row_scales=per_row, cache=False) if per_row is not scales else None
    for caster in (flat_caster, banded_caster, row_caster):   # kernels and pyramid made before the clocks
        if caster is not None:
            caster.horizons([0.0])
    out = []
    for n in (16, 64):
        t0 = time.perf_counter()
        banded = banded_caster.horizons(n)
        t_banded = time.perf_counter() - t0
        t0 = time.perf_counter()
        flat = flat_caster.horizons(n)
        t_flat = time.perf_counter() - t0
        diff = np.abs(banded - flat)[np.isfinite(banded) & (banded > -90.0)]
        blocks = banded_caster.scale_blocks.scales.shape
        row = {"map": name, "azimuths": n, "bands": int(blocks[0]), "column_bands": int(blocks[1]),
               "banded_s": t_banded, "flat_s": t_flat, "ratio": t_banded / t_flat, "diff_max_deg": float(diff.max()),
               "diff_p99_deg": float(np.percentile(diff, 99)), "diff_mean_deg": float(diff.mean())}
        if row_caster is not None:
            t0 = time.perf_counter()
            by_row = row_caster.horizons(n)
            row.update(per_row_s=time.perf_counter() - t0)
        if n == 16:
            row.update(twin(hm, scales, banded, azimuth_grid(n)))
            if places.crs is not None:
                row.update(ground(hm, places, banded, azimuth_grid(n)))
            if name.startswith("EU-DEM"):
                row.update(spread_ground(hm, places, banded, by_row, azimuth_grid(n)))
        log(f"{name} {n} azimuths: {row['bands']} x {row['column_bands']} blocks, {t_banded:.2f} s vs {t_flat:.2f} s"
            + (f" ({row['per_row_s']:.2f} s per row)" if "per_row_s" in row else "")
            + f", max diff {row['diff_max_deg']:.3f} deg"
            + (f", twin {row['twin_outside']} of {row['twin_cells']} outside" if n == 16 else ""))
        out.append(row)
    return out


def radius_horizons(name: str, hm: Heightmap, places) -> list[dict]:
    """Horizons within a search radius of :data:`RADIUS_CELLS` cells (the sweep where the device's
    knobs take it, kernels/horizon.cl "The sweep"), 16 and 64 azimuths, a warm-up then best of 3
    taken in turn: per block
    against the grid as drawn and (projected grids in column bands) one scale per row; the twin
    within the same radius on 400 seeded cells per azimuth at 16."""
    scales = places.row_scales()
    radius = RADIUS_CELLS * hm.dx
    casters = {"blocks": HorizonCaster(hm, row_scales=scales, max_distance=radius, cache=False),
               "drawn": HorizonCaster(hm, max_distance=radius, cache=False)}
    per_row = one_per_row(scales)
    if per_row is not scales:
        casters["per_row"] = HorizonCaster(hm, row_scales=per_row, max_distance=radius, cache=False)
    for caster in casters.values():              # kernels made before the clocks
        caster.horizons([0.0])
    out = []
    for n in (16, 64):
        row = {"map": name, "azimuths": n, "radius_cells": RADIUS_CELLS,
               "swept": int(sum(bool(casters["blocks"].takes_sweep(a)) for a in azimuth_grid(n))),
               "blocks": list(casters["blocks"].scale_blocks.scales.shape[:2])}
        for rep in range(4):                     # a warm-up, then best of 3, the casters in turn
            for key, caster in casters.items():
                t0 = time.perf_counter()
                caster.horizons(n)
                if rep:
                    row[f"{key}_s"] = min(row.get(f"{key}_s", np.inf), time.perf_counter() - t0)
        row.update(twin(hm, scales, casters["blocks"].horizons(n), azimuth_grid(n), radius) if n == 16 else {})
        row["ratio"] = row["blocks_s"] / row["drawn_s"]
        log(f"{name} within {RADIUS_CELLS} cells, {n} azimuths ({row['swept']} swept): "
            f"{row['blocks'][0]} x {row['blocks'][1]} blocks {row['blocks_s']:.2f} s vs {row['drawn_s']:.2f} s as drawn"
            + (f", {row['per_row_s']:.2f} s per row" if "per_row_s" in row else "")
            + (f", twin {row['twin_outside']} of {row['twin_cells']} outside" if n == 16 else ""))
        out.append(row)
    return out


def spread_ground(hm: Heightmap, places, angles: np.ndarray, by_row: np.ndarray, azimuths: np.ndarray) -> dict:
    """The blocks' angles, and one scale per row's, against the twin at each cell's own true
    metres that way (reference.ground_metre there), on :data:`SPREAD_CELLS` seeded cells all over
    the map, a third of them near its west or east edge."""
    rng = np.random.default_rng(17)
    rows, cols = hm.shape
    edge = cols // 10
    ii = rng.integers(0, rows, SPREAD_CELLS)
    jj = np.concatenate([rng.integers(0, edge, SPREAD_CELLS // 6), rng.integers(cols - edge, cols, SPREAD_CELLS // 6),
                         rng.integers(0, cols, SPREAD_CELLS - 2 * (SPREAD_CELLS // 6))])
    worst = worst_row = 0.0
    for a, az in enumerate(azimuths):
        for i, j in zip(ii.tolist(), jj.tolist()):
            g = ref.ground_metre(places, i + 0.5, j + 0.5, float(az))
            truth = float(ref.horizon_angles(Heightmap(hm.heights, hm.dx * g, hm.dy * g), float(az),
                                             cells=(np.array([i]), np.array([j])))[0])
            if truth > -90.0:
                worst = max(worst, abs(float(angles[a, i, j]) - truth))
                worst_row = max(worst_row, abs(float(by_row[a, i, j]) - truth))
    return {"spread_cells": int(ii.size * len(azimuths)), "spread_max_deg": worst, "spread_per_row_max_deg": worst_row}


def twin(hm: Heightmap, row_scales: np.ndarray, angles: np.ndarray, azimuths: np.ndarray,
         max_distance: float = np.inf) -> dict:
    """The banded angles against the float64 twin with each band's own cell sizes
    (:func:`oclshade.reference.banded_horizon_angles`, within ``max_distance`` metres), on seeded
    cells."""
    rng = np.random.default_rng(11)
    banded = Heightmap(hm.heights, hm.dx, hm.dy, row_scales=row_scales)
    valid = np.flatnonzero(~np.isnan(hm.heights).ravel())
    band = ref.angle_tolerance(hm)
    checked = outside = 0
    worst = 0.0
    for a, az in enumerate(azimuths):
        ii, jj = np.divmod(np.sort(rng.choice(valid, TWIN_CELLS, replace=False)), hm.shape[1])
        err = np.abs(angles[a, ii, jj] - ref.banded_horizon_angles(banded, float(az), cells=(ii, jj),
                                                                   max_distance=max_distance))
        outside += int(np.count_nonzero(err > band))
        worst = max(worst, float(np.nanmax(err)))
        checked += ii.size
    return {"twin_cells": checked, "twin_outside": outside, "twin_max_deg": worst, "twin_band_deg": band}


def ground(hm: Heightmap, places, angles: np.ndarray, azimuths: np.ndarray) -> dict:
    """The banded angles, and the float64 twin at one scale every way (the row's s), against the
    twin at each direction's true metres at the map's highest cell, on seeded cells within 16
    cells of it (where the scale is that cell's to 2e-5 or better; high ground: steep horizons)."""
    rng = np.random.default_rng(13)
    rows, cols = hm.shape
    top_r, top_c = np.unravel_index(int(np.nanargmax(hm.heights)), hm.shape)
    top_r, top_c = min(max(top_r, 16), rows - 17), min(max(top_c, 16), cols - 17)
    ii, jj = rng.integers(top_r - 16, top_r + 17, 64), rng.integers(top_c - 16, top_c + 17, 64)
    scales = places.row_scales()
    if scales.ndim == 3:                      # the top cell's column band's
        scales = scales[:, np.searchsorted(column_edges(cols, scales.shape[1]), top_c, side="right") - 1]
    one_scale = float(scales[top_r, 0])
    one = Heightmap(hm.heights, hm.dx * one_scale, hm.dy * one_scale)
    worst = worst_one = 0.0
    for a, az in enumerate(azimuths):
        g = ref.ground_metre(places, top_r + 0.5, top_c + 0.5, float(az))
        truth = ref.horizon_angles(Heightmap(hm.heights, hm.dx * g, hm.dy * g), float(az), cells=(ii, jj))
        seen = truth > -90.0
        worst = max(worst, float(np.nanmax(np.abs(angles[a, ii, jj] - truth)[seen])))
        old = ref.horizon_angles(one, float(az), cells=(ii, jj))
        worst_one = max(worst_one, float(np.nanmax(np.abs(old - truth)[seen])))
    return {"ground_cells": int(ii.size * len(azimuths)), "ground_max_deg": worst, "one_scale_max_deg": worst_one}


def masks_and_horizons_markdown(result: dict) -> list[str]:
    """The masks', horizons' and ground checks' tables (the whole run's, not ``--radius``'s)."""
    lines = ["",
             "| map | sun az / el | old geometry's error at the edges, deg | blocks | per block s | grid as drawn s | "
             "ratio | cells differing | twin: cells, mismatches / ties | mask vs horizon > el: cells, max abs(h - el) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---|---|"]
    for r in result["masks"]:
        lines.append(f"| {r['map']} | {r['sun'][0]:g} / {r['sun'][1]:g} | {r['edge_error_deg']:.3f} | {r['blocks']} | "
                     f"{r['per_block_s']:.3f} | {r['one_sun_s']:.3f} | {r['ratio']:.2f} | {r['cells_differing']} of "
                     f"{r['valid_cells']} | {r['twin_cells']}: {r['twin_mismatch']} / {r['twin_tied']} | "
                     f"{r['horizon_disagree']}, {r['horizon_disagree_max_deg']:.1e} |")
    lines += ["", "| map | azimuths | blocks (rows x columns) | per block s | one scale per row s | grid as drawn s | "
              "ratio to as drawn | angle difference max / p99 / mean, deg | twin (16 azimuths): cells, outside the "
              "float32 band, max error deg |",
              "|---|---:|---:|---:|---:|---:|---:|---|---|"]
    for r in result["horizons"]:
        check = (f"{r['twin_cells']}, {r['twin_outside']}, {r['twin_max_deg']:.2g} (band {r['twin_band_deg']:.2g})"
                 if "twin_cells" in r else "")
        per_row = f"{r['per_row_s']:.2f}" if "per_row_s" in r else "-"
        lines.append(f"| {r['map']} | {r['azimuths']} | {r['bands']} x {r['column_bands']} | {r['banded_s']:.2f} | "
                     f"{per_row} | {r['flat_s']:.2f} | {r['ratio']:.2f} | {r['diff_max_deg']:.3f} / "
                     f"{r['diff_p99_deg']:.3f} / {r['diff_mean_deg']:.4f} | {check} |")
    lines += ["", "Projected maps, against the ground (16 azimuths, 64 cells within 16 of the highest; the twin "
              "at each direction's geodesic metres there):", "",
              "| map | cells | traced by direction: max error, deg | one scale every way (before): max error, deg |",
              "|---|---:|---:|---:|"]
    for r in result["horizons"]:
        if "ground_cells" in r:
            lines.append(f"| {r['map']} | {r['ground_cells']} | {r['ground_max_deg']:.4f} | "
                         f"{r['one_scale_max_deg']:.4f} |")
    lines += ["", "Whole tiles, against the ground all over the map (16 azimuths, 48 cells, a third of them near the "
              "west or east edge; the twin at each cell's own geodesic metres that way):", "",
              "| map | cells | blocks: max error, deg | one scale per row (before): max error, deg |", "|---|---:|---:|---:|"]
    for r in result["horizons"]:
        if "spread_cells" in r:
            lines.append(f"| {r['map']} | {r['spread_cells']} | {r['spread_max_deg']:.4f} | "
                         f"{r['spread_per_row_max_deg']:.4f} |")
    return lines


def write_markdown(path: Path, result: dict) -> None:
    m = result["meta"]
    lines = ["# A grid's scale: per block of rows (and columns) against the grid's metres as the ground's", "",
             f"- date: {m['date']}; command: `{m['command']}`",
             f"- CPU: {m['cpu']}, {m['cores']} cores; device: {m['device']}; {m['pocl_version']}",
             *(["- masks: best of 3 after a warm-up; the sun as the grid traces it per block (tolerance "
                "0.01 deg) against the sun as given on the grid as drawn (a geographic grid at its centre's cell "
                "width, a projected one in its CRS's metres); horizons: one run each"] if result["masks"] else []),
             "- projected maps: N22W160's heights on square cells of its north-south size in each CRS", "",
             "| map | CRS | ground metres per grid metre (rows) | its stretch by direction, at most | column bands | "
             "left by the blocks, deg | left by one scale per row, deg | far terrain: scale change per 100 km, "
             "relief, bound deg |",
             "|---|---|---|---:|---:|---:|---:|---|"]
    for r in result["scales"]:
        far = (f"{100.0 * r['far_rate_per_100km']:.2f} %, {r['relief_m']:.0f} m, {r['far_residual_deg']:.4f}"
               if "far_residual_deg" in r else "")
        lines.append(f"| {r['map']} | {r['crs']} | {r['scale_min']:.6f}-{r['scale_max']:.6f} | "
                     f"{100.0 * r['stretch_max']:.3f} % | {r['column_bands']} | {r['residual_deg']:.4f} | "
                     f"{r['one_per_row_residual_deg']:.4f} | {far} |")
    if result["masks"]:
        lines += masks_and_horizons_markdown(result)
    if result.get("radius"):
        lines += ["", f"Within a search radius (`--radius`: {RADIUS_CELLS} cells, the sweep where the device's knobs take "
                  "it; a warm-up, then best of 3 in turn):", "",
                  "| map | azimuths | swept | blocks (rows x columns) | per block s | one scale per row s | grid as drawn s | "
                  "ratio to as drawn | twin (16 azimuths): cells, outside the float32 band |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
        for r in result["radius"]:
            per_row = f"{r['per_row_s']:.2f}" if "per_row_s" in r else "-"
            check = f"{r['twin_cells']}, {r['twin_outside']}" if "twin_cells" in r else ""
            lines.append(f"| {r['map']} | {r['azimuths']} | {r['swept']} | {r['blocks'][0]} x {r['blocks'][1]} | "
                         f"{r['blocks_s']:.2f} | {per_row} | {r['drawn_s']:.2f} | {r['ratio']:.2f} | {check} |")
    lines.append("")
    path.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reduced", action="store_true", help="384^2 crops (a check)")
    parser.add_argument("--radius", action="store_true",
                        help=f"only the horizons within {RADIUS_CELLS} cells (default --out geographic_scale_radius)")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    args.out = args.out or REPO / "bench" / "results" / ("geographic_scale_radius" if args.radius else "geographic_scale")
    result = {"meta": metadata(sys.argv), "scales": [], "masks": [], "horizons": [], "radius": []}
    with tempfile.TemporaryDirectory() as folder:
        for name, raster in maps(args.reduced, Path(folder)).items():
            hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
            places = map_places(raster)
            result["scales"].append(scale_row(name, places, hm))
            if args.radius:
                result["radius"] += radius_horizons(name, hm, places)
                continue
            result["masks"] += masks(name, raster, hm, places)
            result["horizons"] += horizons(name, raster, hm, places)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=1))
    write_markdown(args.out.with_suffix(".md"), result)
    log(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
