#!/usr/bin/env python
"""Horizon angles and sky-view factor (issue 19) against the float64 reference and the peers.

    python bench/solar.py                 # the record: SRTM N22W160 and S16E166 (1201^2), canyon 4096^2
    python bench/solar.py --reduced       # a check that the script works: 256^2 crops, canyon 256^2
    python bench/solar.py --maps N22W160,S16E166   # a subset of the maps
    python bench/solar.py --azimuths 16 --maps N22W160,S16E166 --out bench/results/solar_whitebox
    python bench/solar.py --maps canyon --azimuths 16 --grass-directions 4 --peers grass,rvt \
        --out bench/results/solar_canyon4096   # 4096^2: WhiteboxTools left out (6 min per azimuth)
    python bench/solar.py --maps puget --azimuths 16 --grass-directions 4 --peers grass,horayzon,rvt \
        --out bench/results/solar_puget4096    # the shared Puget Sound 4096^2 (not in the default maps)
    python bench/solar.py --maps canyon --azimuths 16 --whitebox-directions 1 --peers whitebox \
        --out bench/results/solar_canyon4096_whitebox   # WhiteboxTools at 4096^2 on one azimuth
    python bench/solar.py --maps canyon --azimuths 16 --whitebox-directions 2 --whitebox-start 22.5 \
        --peers whitebox --out bench/results/solar_canyon4096_whitebox_offaxis   # 22.5 and 202.5 deg
    python bench/solar.py --maps puget --azimuths 64 --grass-jobs 2 --grass-compare 0 --peers grass \
        --out bench/results/solar_puget4096_jobs64   # r.horizon on all 64 azimuths, timed, not compared

Writes bench/results/solar.{md,json,png} (``--out`` to change).  Per map and for
16 and 64 azimuths in the same run:

* **oclshade**: ``HorizonCaster.horizons(N)`` after a warm-up (pyramid and kernel
  built), the bands copied to the host: wall time;
* **error against the float64 reference** (:func:`oclshade.reference.horizon_angles`)
  on a seeded sample of valid cells (the reference walks every patch of every
  ray: the whole map would take hours): max |difference| in degrees, the float32
  band it must stay within (:func:`~oclshade.reference.angle_tolerance`) and the
  count of cells outside it (0 = exact);
* **GRASS r.horizon** (``grass-core``; skipped with the reason when absent): run in
  a throwaway location (``grass --tmp-location EPSG:3857``: spherical Mercator, the
  map centred on the equator and the prime meridian, so that r.horizon's correction
  of directions for the projection is nil: no meridian convergence, and its
  latitude/longitude steps are on a sphere), the float32 heights imported
  losslessly with r.in.bin on the same cell sizes (dx, dy) with a one-cell border
  of nulls on the west and south (see :func:`run_grass`), ``r.horizon -d
  step=360/N`` (its directions counter-clockwise from east are converted to
  azimuths); time of the r.horizon call alone (import and export outside it) and
  its difference from oclshade's exact angles on every cell where both see
  terrain (``--grass-directions K``: r.horizon computes only K of the N
  azimuths, every (N / K)-th from north, its time is scaled by N / K and marked
  as an estimate, and the differences are taken on those K bands: r.horizon's
  time per azimuth grows with the cells times the map's side, hours for 64
  azimuths at 4096^2; ``--grass-jobs J``: r.horizon, which runs on one core, as J
  processes at once on blocks of the directions, its time their wall time;
  ``--grass-compare C``: the differences on C of its K directions, every (K / C)-th,
  or none with 0, for a run that measures the time of all 64 at 4096^2, where each
  compared direction takes about 17 s), in all and split into the near field
  (either angle set within three cells of the cell), the rim and the far field
  (docs/solar.md, "r.horizon").  Maps with nodata are compared with their voids
  filled (:func:`fill_voids`, both sides): the two models differ there by design.
  r.horizon always lowers distant terrain by the Earth's curvature (checked: a 500 m
  tower 30 km away on flat ground reads 0.81998 degrees, the curved value, not
  0.95484), so it is compared with oclshade's ``Curvature()`` run (timed too);
* **WhiteboxTools** ``HorizonAngle`` (PyPI ``whitebox-workflows``; skipped when absent): the
  same N azimuths on the void-filled map, rays to the map's edge, time of its N calls and its
  difference from oclshade's flat-Earth angles (:func:`run_whitebox`; ``--whitebox-directions
  K``: K of the N azimuths, every (N / K)-th from north, its time scaled by N / K and marked as
  an estimate, as r.horizon's; ``--whitebox-start DEG``: those K from DEG east of north, so that
  a subset can leave the grid's axes, along which its linear interpolation is our surface);
* **HORAYZON** (PyPI ``horayzon-extpar``, Steger's Embree horizon code; skipped when absent): the
  map triangulated on a sphere of the Earth's radius (:func:`horayzon_mesh`), the N azimuths at
  ``--horayzon-accuracy`` (0.1 degrees), time of its horizon call and its difference from
  oclshade's ``Curvature()`` angles (:func:`run_horayzon`);
* **sky-view factor**: oclshade's solid-angle SVF (the definition RVT uses) from the
  same horizons against ``rvt.vis.sky_view_factor`` (PyPI ``rvt-py``, the bench
  extra; it requires the GDAL Python bindings, which build only where GDAL's
  development files are installed: ``pip install --no-deps rvt-py`` is enough for
  ``rvt.vis``, which needs numpy and scipy; nearest-cell samples within
  ``svf_r_max`` cells, square cells only: the mean of dx and dy is passed) at its
  default radius 10 and at a larger one;
* **error of N azimuths** for both SVF definitions, N = 16, 32, 64, 128 against
  N = 1024 on a crop of each map (``--svf-crop``), mean and max |difference|.

Figures depend on the machine; the committed results record where they were taken.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

from oclshade import reference as ref
from oclshade.bench.machine import machine_facts
from oclshade.heightmap import Heightmap
from oclshade.horizon import Curvature, HorizonCaster, azimuth_grid
from oclshade.horizon.caster import EARTH_RADIUS
from oclshade.io import Raster, read_dem, write_raster
from oclshade.runtime import get_runtime
from oclshade.sun import Sun
from oclshade.synthetic import canyon_crater

ROOT = Path(__file__).resolve().parents[1]
SRTM = ROOT.parent / "shared" / "data" / "dem" / "srtm3_srtmpy"
AZIMUTH_COUNTS = (16, 64)
SVF_COUNTS = (16, 32, 64, 128)
SVF_FINE = 1024


#: the maps --maps can name (puget: the shared Puget Sound heightmap, 4096^2 at 40 m, as bench/headlines.py)
MAP_KEYS = ("N22W160", "S16E166", "canyon", "puget")
#: the maps a run takes without --maps
DEFAULT_MAPS = ("N22W160", "S16E166", "canyon")
#: the outside peers the record runs (each skipped when not installed, or left out with --peers)
PEERS = ("grass", "whitebox", "rvt", "horayzon")
HORAYZON_ACCURACY = 0.1       # degrees: HORAYZON's horizon_acc (its angles within this of its surface's)
HORAYZON_LOWEST = -45.0       # degrees: HORAYZON's elev_angle_min (no search below)


def maps(reduced: bool, keys: tuple[str, ...] = DEFAULT_MAPS, side: int | None = None) -> dict[str, Heightmap]:
    """The benchmark's maps: the shared SRTM tiles and Puget Sound (when present) and the
    generated canyon (those of ``keys``); ``side``: the canyon's and Puget Sound's side in cells
    (default 4096, reduced 256)."""
    out = {}
    for tile, (r0, c0) in (("N22W160", (896, 384)), ("S16E166", (320, 704))):   # crops: the roughest 256^2
        path = SRTM / f"{tile}v2.3a.hgt.zip"
        if tile in keys and path.exists():
            r = read_dem(path)
            h = r.heights[r0:r0 + 256, c0:c0 + 256] if reduced else r.heights
            out[f"SRTM {tile}"] = Heightmap.from_array(h, (r.dx, r.dy))
    side = side or (256 if reduced else 4096)
    if "puget" in keys:
        if str(ROOT / "bench") not in sys.path:
            sys.path.insert(0, str(ROOT / "bench"))
        from shadow_masks import Skip, load_dataset
        try:
            d = load_dataset("puget", side, ROOT.parent / "shared" / "data")
            out[f"Puget {side}^2"] = Heightmap.from_array(d["heights"].astype(np.float32), (d["dx"], d["dy"]))
        except Skip:
            pass
    if "canyon" in keys:
        out[f"canyon {side}^2"] = Heightmap.from_array(canyon_crater(side, side, seed=0, relief=1500.0), 30.0)
    return out


def time_ours(caster: HorizonCaster, n: int) -> tuple[float, np.ndarray]:
    start = time.perf_counter()
    angles = caster.horizons(n)
    return time.perf_counter() - start, angles


def reference_error(hm: Heightmap, angles: np.ndarray, samples: int, seed: int = 19,
                    max_distance: float = np.inf, curvature: float = 0.0,
                    azimuths: np.ndarray | None = None) -> dict:
    """Max |oclshade - float64 reference| over a seeded sample of valid cells, every azimuth
    (within the search radius ``max_distance``, metres; ``curvature`` the drop per square metre
    the angles were computed with, :attr:`HorizonCaster.coefficient`); band k of ``angles`` at
    ``azimuths[k]`` (default: the grid of ``angles.shape[0]`` azimuths)."""
    valid = np.flatnonzero(~np.isnan(hm.heights))
    pick = np.random.default_rng(seed).choice(valid, size=min(samples, valid.size), replace=False)
    rows, cols = np.unravel_index(pick, hm.shape)
    worst, outside = 0.0, 0
    band = ref.angle_tolerance(hm, curvature)
    for k, az in enumerate(azimuth_grid(angles.shape[0]) if azimuths is None else azimuths):
        expected = ref.horizon_angles(hm, az, curvature, cells=(rows, cols), max_distance=max_distance)
        diff = np.abs(angles[k][rows, cols] - expected)
        worst = max(worst, float(diff.max()))
        outside += int((diff > band).sum())
    return {"cells": int(pick.size), "max_abs_deg": worst, "band_deg": band, "outside_band": outside}


# ----------------------------------------------------------------------------- GRASS r.horizon
GRASS_SCRIPT = """set -e
r.in.bin -f input={binary} output=dem bytes=4 order=native north={north!r} south={south!r} \
  east={east!r} west={west!r} rows={rows} cols={cols} anull=-9999 --quiet
g.region raster=dem
start=$(date +%s.%N)
r.horizon -d elevation=dem step={step} start={start} end={end} output=hz --quiet
end=$(date +%s.%N)
echo "RHORIZON_SPAN $start $end"
i=0
for m in $(g.list raster pattern="hz_*"); do
  r.out.bin -f input=$m output={out}/$i.bin null=-9999 --quiet
  i=$((i + 1))
done
"""
#: r.horizon's Earth radius (raster/r.horizon/main.c, EARTHRADIUS): it lowers terrain by d^2 / 2R
GRASS_EARTH_RADIUS = 6371000.0


def grass_version() -> str | None:
    exe = shutil.which("grass")
    if exe is None:
        return None
    proc = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=120)
    return ((proc.stdout + proc.stderr).strip().splitlines() or ["?"])[0]


def fill_voids(heights: np.ndarray) -> np.ndarray:
    """A copy with every nodata (NaN) cell set to the mean of its valid 4-neighbours, ring by ring
    inwards from the voids' borders.  r.horizon reads nodata as a height of -9999 m and samples
    the valid cells at a void's border, where oclshade's surface drops every patch touching a void;
    the peer comparison runs on the filled map so that both see the same terrain."""
    h = np.array(heights, np.float64)
    if np.isnan(h).all():
        raise ValueError("heights has no valid cell to fill the voids from")
    while True:
        void = np.isnan(h)
        if not void.any():
            return h.astype(np.float32)
        total, count = np.zeros_like(h), np.zeros_like(h)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            nb = np.roll(h, shift, axis)
            edge = [slice(None)] * 2
            edge[axis] = 0 if shift == 1 else -1          # np.roll wraps around: no neighbour there
            nb[tuple(edge)] = np.nan
            ok = ~np.isnan(nb)
            total += np.where(ok, nb, 0.0)
            count += ok
        fill = void & (count > 0)
        h[fill] = total[fill] / count[fill]


def run_grass(hm: Heightmap, n: int, jobs: int = 1) -> dict:
    """r.horizon's angles as (n, rows, cols) azimuth-ordered (band i at 360 i / n), and its time
    (r.horizon's directions are independent searches, so its time grows with n).

    r.horizon (GRASS 8.2) runs on one core.  ``jobs`` > 1 splits the n directions into that many
    contiguous blocks, each an r.horizon of its own in its own throwaway location, all started
    together (what a user of r.horizon does with more cores): ``seconds`` is then the wall time
    from the first r.horizon's start to the last one's end, ``process_seconds`` the sum of their
    times.  The angles do not depend on ``jobs`` (tests/test_solar_peers.py).

    The map gets a one-cell border of nulls on its west and south sides: r.horizon tests "outside
    the map" on its sample's cell index truncated towards zero ((int)(x / dx + 0.5)), so without
    the border a sample up to one cell beyond the west or south edge reads the edge column or row
    (terrain that is not there, at the distance of that cell's centre: up to 90 degrees off near
    those edges; docs/solar.md).  With it such a sample reads a null (-9999 m: never the horizon
    unless it is the only sample), as past the north and east edges, where the test is exact.
    """
    if n % 4:
        raise ValueError(f"n must be a multiple of 4 (r.horizon's directions start in the east), got {n}")
    if not 1 <= jobs <= n:
        raise ValueError(f"jobs must be between 1 and n = {n}, got {jobs}")
    rows, cols = hm.shape
    padded = np.full((rows + 1, cols + 1), -9999.0, np.float32)     # row 0 is north: the border is
    padded[:rows, 1:] = np.nan_to_num(hm.heights, nan=-9999.0)     # the last row and column 0
    north, west = (rows + 1) * hm.dy / 2.0, -(cols + 1) * hm.dx / 2.0     # centred on (0, 0)
    step = 360.0 / n
    first = [n * j // jobs for j in range(jobs + 1)]      # job j: directions first[j] .. first[j + 1] - 1
    with tempfile.TemporaryDirectory(prefix="oclshade-grass-") as tmp:
        binary = Path(tmp) / "dem.bin"
        padded.tofile(binary)
        procs = []
        for j in range(jobs):
            out = Path(tmp) / f"job{j}"
            out.mkdir()
            script = out / "run.sh"
            # r.horizon makes floor((end - start) / step) directions and refuses an end past 360: the
            # end is half a step past the next block's first direction, 360 for the last block
            end = 360.0 if j == jobs - 1 else (first[j + 1] + 0.5) * step
            script.write_text(GRASS_SCRIPT.format(
                binary=binary, north=north, south=north - (rows + 1) * hm.dy, west=west,
                east=west + (cols + 1) * hm.dx, rows=rows + 1, cols=cols + 1, step=repr(step),
                start=repr(first[j] * step), end=repr(end), out=out))
            procs.append(subprocess.Popen(["grass", "--tmp-location", "EPSG:3857", "--exec", "bash", str(script)],
                                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        spans = []
        try:
            for proc in procs:
                stdout, stderr = proc.communicate()
                lines = [ln for ln in stdout.splitlines() + stderr.splitlines() if "RHORIZON_SPAN" in ln]
                if proc.returncode != 0 or not lines:
                    raise RuntimeError(f"grass failed ({proc.returncode}): {stderr.strip()[-500:]}")
                spans.append(tuple(float(v) for v in lines[-1].split()[1:3]))
        finally:                  # one job failed (or was interrupted): stop the others before the cleanup
            for proc in procs:
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
        ccw = np.stack([np.fromfile(Path(tmp) / f"job{j}" / f"{i}.bin", np.float32).reshape(rows + 1, cols + 1)
                        [:rows, 1:] for j in range(jobs) for i in range(first[j + 1] - first[j])])
    ccw[ccw == -9999.0] = np.nan
    # map i is direction i * 360/n counter-clockwise from east = azimuth 90 - that
    order = [int(round(((90.0 - az) % 360.0) / step)) % n for az in azimuth_grid(n)]
    return {"seconds": max(e for _, e in spans) - min(s for s, _ in spans),
            "process_seconds": sum(e - s for s, e in spans), "jobs": jobs, "angles": ccw[order]}


#: cells from the cell within which the two models' differences are called near-field
NEAR_CELLS = 3.0


def grass_near_samples(heights: np.ndarray, dx: float, dy: float, azimuth: float,
                       reach: float = NEAR_CELLS) -> np.ndarray:
    """The highest angle (degrees) r.horizon gives each cell's samples at ``azimuth`` whose cells'
    centres lie within ``reach`` times the larger cell size: its steps of (dx + dy) / 2 from the
    cell's centre, each reading the nearest cell, seen at the distance of that cell's centre and
    lowered by r.horizon's curvature; -inf where none is on the map."""
    a = np.radians(90.0 - azimuth)                   # r.horizon's direction: counter-clockwise from east
    c, s = np.cos(a), np.sin(a)
    c, s = (0.0 if abs(c) < 1e-7 else c), (0.0 if abs(s) < 1e-7 else s)
    step = 0.5 * (dx + dy)
    h = np.asarray(heights, np.float64)
    rows, cols = h.shape
    best = np.full(h.shape, -np.inf)
    seen = set()
    for m in range(1, int(np.ceil(reach * max(dx, dy) / step)) + 2):
        dj, dn = int(np.floor(0.5 + m * step * c / dx)), int(np.floor(0.5 + m * step * s / dy))
        length = float(np.hypot(dj * dx, dn * dy))
        if (dj, dn) in seen or length == 0.0 or length > reach * max(dx, dy):
            continue
        seen.add((dj, dn))
        di = -dn                                     # rows count southwards
        z = np.full(h.shape, np.nan)
        r0, r1, c0, c1 = max(0, -di), rows - max(0, di), max(0, -dj), cols - max(0, dj)
        if r0 < r1 and c0 < c1:
            z[r0:r1, c0:c1] = h[r0 + di:r1 + di, c0 + dj:c1 + dj]
        best = np.fmax(best, (z - h - length * length / (2.0 * GRASS_EARTH_RADIUS)) / length)
    return np.degrees(np.arctan(best))


def near_horizon(hm: Heightmap, azimuth: float, curvature: float, reach: float = NEAR_CELLS,
                 samples: int = 8) -> np.ndarray:
    """A lower bound (degrees) of the highest angle of the bilinear surface within ``reach`` cells
    of each cell along ``azimuth``: the surface sampled at t = 1e-6 and 1e-3 cell, every
    1 / samples cell, and where the ray crosses grid lines (the kinks of the profile), in units of
    the smaller cell size; -90 where its first sample is off the map.

    At one t every cell's sample sits at the same offset (ox, oy) cells from it, so the surface
    there is one weighted sum of four shifted copies of the map (slices: 10 s a band at 4096^2
    where indexing every cell took 57 s, which made comparing 64 azimuths impractical)."""
    h = hm.heights.astype(np.float64)
    rows, cols = h.shape
    padded = np.pad(h, ((0, 1), (0, 1)), mode="edge")     # the +1 corner of a sample on the last line
    ux, uy, _ = Sun(azimuth, 0.0).ray(hm.dx, hm.dy)     # cells per metre: the kernel's and the reference's ray
    cell = min(hm.dx, hm.dy)
    ts = [1e-6 * cell, 1e-3 * cell] + list(np.arange(1, int(reach * samples) + 1) / samples * cell)
    ts += [k / abs(u) for u in (ux, uy) if abs(u) > 1e-12
           for k in range(1, int(reach) + 2) if k / abs(u) <= reach * cell]
    best = np.full(h.shape, -np.inf)
    for t in sorted(ts):
        ox, oy = ux * t, uy * t
        kx, ky = math.floor(ox), math.floor(oy)
        fx, fy = ox - kx, oy - ky
        # the cells whose sample is on the map: 0 <= j + ox <= cols - 1, 0 <= i + oy <= rows - 1
        j0, j1 = max(0, math.ceil(-ox)), min(cols, math.floor(cols - 1 - ox) + 1)
        i0, i1 = max(0, math.ceil(-oy)), min(rows, math.floor(rows - 1 - oy) + 1)
        if j0 >= j1 or i0 >= i1:
            continue

        def corner(di: int, dj: int) -> np.ndarray:
            return padded[i0 + ky + di:i1 + ky + di, j0 + kx + dj:j1 + kx + dj]
        s = (corner(0, 0) * ((1 - fx) * (1 - fy)) + corner(0, 1) * (fx * (1 - fy))
             + corner(1, 0) * ((1 - fx) * fy) + corner(1, 1) * (fx * fy))
        tangent = (s - h[i0:i1, j0:j1] - curvature * t * t) / t
        np.fmax(best[i0:i1, j0:j1], tangent, out=best[i0:i1, j0:j1])
    return np.degrees(np.arctan(best))


def grass_rim_samples(heights: np.ndarray, dx: float, dy: float, azimuth: float) -> np.ndarray:
    """The highest angle (degrees) r.horizon gives each cell's samples in the rim of the map, the
    half cell between the outermost cell centres (where oclshade's bilinear surface ends) and the
    map's border (where r.horizon's cells end); -inf where none.  A sample there reads the edge
    cell, seen at the distance of its centre (as :func:`grass_near_samples`)."""
    h = np.asarray(heights, np.float64)
    rows, cols = h.shape
    a = np.radians(90.0 - azimuth)
    c, s = np.cos(a), np.sin(a)
    c, s = (0.0 if abs(c) < 1e-7 else c), (0.0 if abs(s) < 1e-7 else s)
    step = 0.5 * (dx + dy)
    vx, vy = step * c / dx, -step * s / dy            # cells per step, columns east and rows south
    ii, jj = np.indices(h.shape, dtype=np.float64)

    def exits(p: np.ndarray, v: float, size: int) -> tuple[np.ndarray, np.ndarray]:
        """First step off the outermost centres, first step off the map, along one axis."""
        if v == 0.0:
            return np.full(p.shape, np.inf), np.full(p.shape, np.inf)
        if v > 0:
            return np.floor((size - 1 - p) / v) + 1, np.ceil((size - 0.5 - p) / v)
        return np.floor(p / -v) + 1, np.floor((p + 0.5) / -v) + 1

    m1x, m2x = exits(jj, vx, cols)
    m1y, m2y = exits(ii, vy, rows)
    m1, m2 = np.minimum(m1x, m1y), np.minimum(m2x, m2y)
    best = np.full(h.shape, -np.inf)
    span = m2 - m1
    for k in range(int(span[np.isfinite(span)].max(initial=0.0))):
        m = m1 + k
        ok = m < m2
        x, y = jj + m * vx, ii + m * vy
        col = np.clip(np.floor(x + 0.5), 0, cols - 1).astype(np.int64)
        row = np.clip(np.ceil(y - 0.5), 0, rows - 1).astype(np.int64)     # r.horizon rounds south-up
        length = np.hypot((col - jj) * dx, (row - ii) * dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            angle = (h[row, col] - h - length * length / (2.0 * GRASS_EARTH_RADIUS)) / length
        best = np.where(ok & (length > 0), np.fmax(best, angle), best)
    return np.degrees(np.arctan(best))


def _summary(parts: list[np.ndarray]) -> dict:
    """Mean, mean |.|, RMS, 99th percentile and max |.| of the float32 differences in ``parts``,
    taken without joining them: at 4096^2 x 64 azimuths they are a billion values (4 GB), and
    joined, with their absolute values and float64 squares beside the band stacks, they did not
    fit in 24 GB.  Sums in float64 part by part; the percentile is np.percentile's of the values
    in float64 (linear between the order statistics around 0.99 (n - 1); np.percentile of the
    float32 values interpolates in float32), its order statistics exact (:func:`_order_statistics`)."""
    cells = sum(p.size for p in parts)
    if cells == 0:
        return {"cells": 0}
    position = 0.99 * (cells - 1)
    below = math.floor(position)
    low, high = _order_statistics(parts, (below, min(below + 1, cells - 1)))
    t = position - below            # numpy's lerp, from the nearer end
    p99 = low + (high - low) * t if t < 0.5 else high - (high - low) * (1.0 - t)
    total = total_abs = squares = largest = 0.0
    for p in parts:                 # one |p| per part
        a = np.abs(p)
        total += float(p.sum(dtype=np.float64))
        total_abs += float(a.sum(dtype=np.float64))
        squares += float(np.square(p, dtype=np.float64).sum())
        largest = max(largest, float(a.max(initial=0.0)))
    return {"cells": cells, "mean_deg": total / cells, "mean_abs_deg": total_abs / cells,
            "rms_deg": math.sqrt(squares / cells), "p99_abs_deg": p99, "max_abs_deg": largest}


def _order_statistics(parts: list[np.ndarray], ranks: tuple[int, ...]) -> list[float]:
    """The values of the given 0-based ranks among the absolute values of the float32 ``parts``
    joined, without joining them: a non-negative float32's bits order like the value, so the
    values are counted by their top 16 bits, then the one bucket holding each rank is sorted."""
    def tops(p: np.ndarray) -> np.ndarray:
        return np.abs(p.astype(np.float32, copy=False)).view(np.uint32) >> 16
    counts = np.zeros(1 << 16, np.int64)
    for p in parts:
        counts += np.bincount(tops(p).ravel(), minlength=1 << 16)
    ends = np.cumsum(counts)
    buckets = [int(np.searchsorted(ends, rank, side="right")) for rank in ranks]
    sorted_bucket = {b: np.sort(np.concatenate([np.abs(p[tops(p) == b]) for p in parts]))
                     for b in set(buckets)}     # ranks side by side share one bucket: sorted once
    return [float(sorted_bucket[b][rank - (ends[b] - counts[b])]) for rank, b in zip(ranks, buckets)]


def _class_summaries(parts: dict[str, list[np.ndarray]]) -> dict:
    """The summary of all differences, and of each class's under its name."""
    return {**_summary([x for v in parts.values() for x in v]), **{c: _summary(v) for c, v in parts.items()}}


def peer_difference(hm: Heightmap, ours: np.ndarray, theirs: np.ndarray, curvature: float) -> dict:
    """r.horizon - oclshade (degrees) on the cells where both see terrain: all of them, then split
    in three classes (docs/solar.md, "r.horizon"): ``near``, r.horizon's angle is set by a sample
    within :data:`NEAR_CELLS` cells (nearest cells, off the ray by up to half a cell:
    :func:`grass_near_samples`) or oclshade's is reached within that reach (:func:`near_horizon`);
    ``rim``, else r.horizon's angle is set by a sample in the half cell of map past the outermost
    cell centres, beyond oclshade's surface; ``far``, the rest.  One band at a time."""
    parts: dict[str, list[np.ndarray]] = {"near": [], "rim": [], "far": []}
    for k, az in enumerate(azimuth_grid(ours.shape[0])):
        o, t = ours[k], theirs[k]
        both = np.isfinite(o) & np.isfinite(t) & (o > -90.0) & (t > -90.0)     # both see terrain
        with np.errstate(invalid="ignore"):
            near = ((grass_near_samples(hm.heights, hm.dx, hm.dy, az) >= t - 1e-4)
                    | (o <= near_horizon(hm, az, curvature) + 0.05))
            rim = grass_rim_samples(hm.heights, hm.dx, hm.dy, az) >= t - 1e-4
        d = t - o
        parts["near"].append(d[both & near])
        parts["rim"].append(d[both & ~near & rim])
        parts["far"].append(d[both & ~near & ~rim])
    return _class_summaries(parts)


# ----------------------------------------------------------------------------- WhiteboxTools
def whitebox_version() -> str | None:
    try:
        import whitebox_workflows as wbw
    except ImportError:
        return None
    return f"whitebox-workflows {wbw.WbEnvironment().version()}"


def run_whitebox(hm: Heightmap, n: int, start: float = 0.0) -> dict:
    """WhiteboxTools' HorizonAngle (PyPI ``whitebox-workflows``) at the n azimuths as (n, rows, cols)
    degrees (band i at ``start`` + 360 i / n, NaN = nodata), rays traced to the map's edge (``max_dist`` left
    unset), and the time of the n tool calls (the DEM is read once, before).  Its rays read the
    DEM by linear interpolation where they cross grid lines, without the Earth's curvature: it is
    compared with oclshade's flat-Earth run."""
    import whitebox_workflows as wbw
    wbe = wbw.WbEnvironment()
    wbe.verbose = False
    rows = hm.shape[0]
    like = Raster(hm.heights, hm.dx, hm.dy, georef={33550: (hm.dx, hm.dy, 0.0),
                                                    33922: (0.0, 0.0, 0.0, 0.0, rows * hm.dy, 0.0)})
    with tempfile.TemporaryDirectory(prefix="oclshade-wbt-") as tmp:
        path = Path(tmp) / "dem.tif"
        # plain strips: whitebox-workflows 2.0.6 reads a tiled, compressed GeoTIFF as zeros
        write_raster(path, np.nan_to_num(hm.heights, nan=-9999.0).astype(np.float32), like=like, nodata=-9999.0,
                     options={"TILED": "NO", "COMPRESS": "NONE"})
        dem = wbe.read_raster(str(path))
        azimuths = start + azimuth_grid(n)
        began = time.perf_counter()
        rasters = [wbe.horizon_angle(dem, azimuth=float(az)) for az in azimuths]
        seconds = time.perf_counter() - began
        angles = np.stack([np.asarray(r.to_numpy(), np.float32).reshape(hm.shape) for r in rasters])
    angles[:, np.isnan(hm.heights)] = np.nan
    return {"seconds": seconds, "angles": angles}


def near_band(hm: Heightmap, band: np.ndarray, azimuth: float, curvature: float = 0.0) -> np.ndarray:
    """The cells of one band of oclshade's angles whose angle is reached within :data:`NEAR_CELLS`
    cells (:func:`near_horizon`)."""
    with np.errstate(invalid="ignore"):
        return band <= near_horizon(hm, azimuth, curvature) + 0.05


def near_cells(hm: Heightmap, ours: np.ndarray, curvature: float = 0.0) -> list[np.ndarray]:
    """:func:`near_band` of every band of ``ours``."""
    return [near_band(hm, ours[k], az, curvature) for k, az in enumerate(azimuth_grid(ours.shape[0]))]


def near_far_difference(hm: Heightmap, ours: np.ndarray, theirs: np.ndarray, curvature: float = 0.0,
                        floor: float = -90.0, near: list[np.ndarray] | None = None,
                        azimuths: np.ndarray | None = None) -> dict:
    """A peer - oclshade (degrees) on the cells where oclshade's angle is above ``floor`` (-90: it
    sees terrain): all of them, ``near`` where oclshade's angle is reached within
    :data:`NEAR_CELLS` cells (:func:`near_band`, or ``near`` when given: the bilinear surface
    between grid lines, e.g. its slope at the cell, which WhiteboxTools' samples at grid-line
    crossings do not see and HORAYZON's triangles see differently) and ``far``, the rest.  Band i
    at ``azimuths[i]`` (default: the grid of as many bands from north).  One band at a time."""
    parts: dict[str, list[np.ndarray]] = {"near": [], "far": []}
    for k, az in enumerate(azimuth_grid(ours.shape[0]) if azimuths is None else azimuths):
        o, t = ours[k], theirs[k]
        both = np.isfinite(o) & np.isfinite(t) & (o > floor)
        near_k = near[k] if near is not None else near_band(hm, o, az, curvature)
        parts["near"].append((t - o)[both & near_k])
        parts["far"].append((t - o)[both & ~near_k])
    return _class_summaries(parts)


# ----------------------------------------------------------------------------- HORAYZON
def horayzon_version() -> str | None:
    try:
        import horayzon_extpar  # noqa: F401
    except ImportError:
        return None
    from importlib.metadata import version
    return f"horayzon-extpar {version('horayzon-extpar')} (Embree)"


def horayzon_mesh(hm: Heightmap, radius: float = EARTH_RADIUS) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                        np.ndarray]:
    """The heightmap as HORAYZON's triangle mesh on a sphere of ``radius``: (vertices float32 (n, 3)
    in metres, faces uint32 (m, 3), the sphere's centre, its north pole).  The map lies on the
    equator at the prime meridian, its centre at the origin: column j at longitude x / R, row i at
    latitude y / R (x east, y north of the centre, in metres), sample height h at radius R + h;
    so north is +y everywhere (meridians along the columns) and the coordinates stay small enough
    for float32 (HORAYZON's own practice: a local frame).  Two triangles per patch, split along
    its south-west to north-east diagonal, wound anticlockwise seen from above (HORAYZON checks);
    the bilinear surface and this one agree on every grid line."""
    rows, cols = hm.shape
    x = (np.arange(cols) - 0.5 * (cols - 1)) * hm.dx
    y = -(np.arange(rows) - 0.5 * (rows - 1)) * hm.dy
    lam, phi = np.meshgrid(x / radius, y / radius)
    r = radius + hm.heights.astype(np.float64)
    verts = np.stack([r * np.cos(phi) * np.sin(lam), r * np.sin(phi),
                      r * np.cos(phi) * np.cos(lam) - radius], axis=-1).reshape(-1, 3).astype(np.float32)
    idx = np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols)
    nw, ne, sw, se = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([sw, se, ne], -1).reshape(-1, 3),
                            np.stack([sw, ne, nw], -1).reshape(-1, 3)])
    centre = np.array([0.0, 0.0, -radius], np.float32)
    pole = np.array([0.0, radius, -radius], np.float32)
    return verts, np.ascontiguousarray(faces), centre, pole


def run_horayzon(hm: Heightmap, n: int, accuracy: float = HORAYZON_ACCURACY,
                 lowest: float = HORAYZON_LOWEST) -> dict:
    """HORAYZON's horizons (PyPI ``horayzon-extpar``: Embree ray casting, the terrain a triangle mesh
    on the sphere, :func:`horayzon_mesh`) at the n azimuths as (n, rows, cols) degrees (band i at
    360 i / n, clockwise from north), each within ``accuracy`` degrees of its surface's horizon
    (HORAYZON steps the elevation by 2 ``accuracy`` from the last azimuth's angle and reports the
    middle of the bracket), angles below ``lowest`` not searched; rays to the map's edge.  Its time
    is the horizon call's alone (the BVH built before); ``rays`` is its rays per cell and azimuth.
    Nodata cells are not supported (the caller passes a filled map)."""
    import horayzon_extpar.horizon as hz
    verts, faces, centre, pole = horayzon_mesh(hm)
    terrain = hz.Terrain()
    reach = float(np.clip(math.hypot(hm.shape[0] * hm.dy, hm.shape[1] * hm.dx) * 1.01, 1000.0, 800000.0))
    with tempfile.TemporaryFile("w+") as log:       # its C++ prints to stdout: kept out of ours
        sys.stdout.flush()
        saved = os.dup(1)
        os.dup2(log.fileno(), 1)
        try:
            terrain.initialise(verts, faces, centre, pole)
            start = time.perf_counter()
            out = terrain.horizon_vertex(n, 0.0, np.array([0, verts.shape[0]], np.uint32), reach, 1.0,
                                         accuracy, lowest)
            seconds = time.perf_counter() - start
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        log.seek(0)
        text = log.read()
    rays = [float(line.rsplit(":", 1)[1]) for line in text.splitlines() if "rays per cell" in line]
    angles = np.ascontiguousarray(np.asarray(out, np.float32).T.reshape(n, *hm.shape))
    return {"seconds": seconds, "angles": angles, "rays": rays[0] if rays else None}


# ----------------------------------------------------------------------------- sky-view factor
def rvt_svf(hm: Heightmap, n: int, radius: int) -> tuple[float, np.ndarray]:
    import rvt.vis
    heights = hm.heights.astype(np.float32)
    start = time.perf_counter()
    out = rvt.vis.sky_view_factor(heights, 0.5 * (hm.dx + hm.dy), compute_svf=True, svf_n_dir=n,
                                  svf_r_max=radius, no_data=np.nan)["svf"]
    return time.perf_counter() - start, out


def within_radius(hm: Heightmap, n: int, radius: int, rvt: np.ndarray, samples: int) -> dict:
    """oclshade's solid-angle SVF within RVT's search radius (``radius`` cells of RVT's cell size
    0.5 (dx + dy), as ``max_distance``): its time (the kernel built first), its angles against
    the float64 reference within the same radius, and its difference from RVT's SVF."""
    caster = HorizonCaster(hm, max_distance=radius * 0.5 * (hm.dx + hm.dy), cache=False)
    caster.sky_view_factor([0.0], "solid-angle")        # warm-up: pyramid and kernel build
    start = time.perf_counter()
    svf = caster.sky_view_factor(n, "solid-angle")
    seconds = time.perf_counter() - start
    d = np.abs(rvt - svf)
    return {"seconds": seconds, "max_distance_m": caster.radius,
            "reference": reference_error(hm, caster.horizons(n), samples, max_distance=caster.radius),
            "rvt_mean_abs": float(np.nanmean(d)), "rvt_max_abs": float(np.nanmax(d))}


def roughest_crop(heights: np.ndarray, crop: int) -> tuple[int, int]:
    """(row, column) of the crop x crop window, on a grid of half-crop steps, with the largest
    standard deviation of its valid heights (a centre crop of a coastal tile can be all sea,
    where every N gives the same SVF)."""
    rows, cols = heights.shape
    best, at = -1.0, (0, 0)
    for r0 in range(0, max(rows - crop, 0) + 1, max(crop // 2, 1)):
        for c0 in range(0, max(cols - crop, 0) + 1, max(crop // 2, 1)):
            window = heights[r0:r0 + crop, c0:c0 + crop]
            if np.isfinite(window).any():
                spread = float(np.nanstd(window))
                if spread > best:
                    best, at = spread, (r0, c0)
    return at


def svf_errors(hm: Heightmap, crop: int) -> tuple[list[int], dict]:
    """([row, column, side] of the map's roughest crop, mean and max |SVF(N) - SVF(1024)| there
    for both definitions)."""
    r0, c0 = roughest_crop(hm.heights, crop)
    sub = Heightmap.from_array(hm.heights[r0:r0 + crop, c0:c0 + crop], (hm.dx, hm.dy))
    caster = HorizonCaster(sub, cache=False)
    out = {}
    for definition in ("cosine", "solid-angle"):
        fine = caster.sky_view_factor(SVF_FINE, definition).astype(np.float64)
        out[definition] = {}
        for n in SVF_COUNTS:
            d = np.abs(caster.sky_view_factor(n, definition) - fine)
            out[definition][n] = {"mean_abs": float(np.nanmean(d)), "max_abs": float(np.nanmax(d))}
    return [r0, c0, min(crop, hm.shape[0] - r0, hm.shape[1] - c0)], out


# ----------------------------------------------------------------------------- report
def run(reduced: bool, samples: int, svf_crop: int, rvt_radius: int, keys: tuple[str, ...] = DEFAULT_MAPS,
        grass_directions: int | None = None, azimuth_counts: tuple[int, ...] = AZIMUTH_COUNTS,
        peers: tuple[str, ...] = PEERS, horayzon_accuracy: float = HORAYZON_ACCURACY,
        whitebox_directions: int | None = None, grass_jobs: int = 1, grass_compare: int | None = None,
        whitebox_start: float = 0.0) -> dict:
    if not compare_fits(grass_compare, grass_directions, azimuth_counts):   # before hours of r.horizon
        raise ValueError(f"grass_compare must be 0 or divide r.horizon's directions at every N, got {grass_compare}")
    rt = get_runtime()
    gv = grass_version() if "grass" in peers else None
    wv = whitebox_version() if "whitebox" in peers else None
    hv = horayzon_version() if "horayzon" in peers else None
    rvt_ok = False
    if "rvt" in peers:
        try:
            import rvt  # noqa: F401
            rvt_ok = True
        except ImportError:
            pass

    def absent(peer: str, install: str) -> str:
        return "not run (--peers)" if peer not in peers else f"not installed ({install})"

    result = {"machine": {**machine_facts(), "device": rt.label, "platform": platform.platform(),
                          "cpus": os.cpu_count(), "platform_version": rt.device.platform.version.strip(),
                          "device_version": rt.device.version.strip()},
              "reduced": reduced, "grass": gv or absent("grass", "apt-get install grass-core"),
              "rvt": "rvt-py" if rvt_ok else absent("rvt", "pip install rvt-py --no-deps"),
              "whitebox": wv or absent("whitebox", "pip install whitebox-workflows"),
              "horayzon": (f"{hv}, accuracy {horayzon_accuracy} deg, floor {HORAYZON_LOWEST} deg" if hv else
                           absent("horayzon", "pip install horayzon-extpar")), "maps": {},
              "map_keys": list(keys), "grass_directions": grass_directions, "grass_jobs": grass_jobs,
              "grass_compare": grass_compare,
              "whitebox_directions": whitebox_directions, "whitebox_start": whitebox_start,
              "azimuth_counts": list(azimuth_counts)}
    for name, hm in maps(reduced, keys).items():
        print(f"{name}: {hm.shape[1]}x{hm.shape[0]}, dx {hm.dx:.2f} dy {hm.dy:.2f}", flush=True)
        caster = HorizonCaster(hm, rt, cache=False)
        voids = int(np.isnan(hm.heights).sum())
        peer_map = Heightmap.from_array(fill_voids(hm.heights), (hm.dx, hm.dy)) if voids else hm
        curved_caster = HorizonCaster(peer_map, rt, cache=False, curvature=Curvature())
        flat_peer_caster = HorizonCaster(peer_map, rt, cache=False) if voids else caster
        for c in (caster, curved_caster):
            c.horizons([0.0])             # warm-up: pyramid and kernel build
        entry = {"shape": list(hm.shape), "dx": hm.dx, "dy": hm.dy, "voids_filled_for_peers": voids, "runs": {}}
        grass_runs: dict[int, dict] = {}
        grass_differences = SameBands()
        whitebox_runs: dict[int, dict] = {}
        for n in azimuth_counts:
            seconds, angles = time_ours(caster, n)
            row = {"oclshade_s": seconds, "reference": reference_error(hm, angles, samples)}
            if gv or hv:   # r.horizon and HORAYZON lower distant terrain by the Earth's curvature
                row["oclshade_curved_s"], curved = time_ours(curved_caster, n)
            if hv:
                z = run_horayzon(peer_map, n, horayzon_accuracy)
                row["horayzon_s"], row["horayzon_rays"] = z["seconds"], z["rays"]
                row["horayzon_vs_oclshade"] = near_far_difference(    # above its search floor
                    peer_map, curved, z["angles"], curved_caster.coefficient, floor=HORAYZON_LOWEST + 1.0)
            if gv:
                k, g = on_subset(row, "grass", grass_runs, grass_directions, n,
                                 lambda k: run_grass(peer_map, k, grass_jobs))
                compared = k if grass_compare is None else grass_compare
                if compared:
                    theirs = g["angles"][::k // compared]
                    row["grass_vs_oclshade"] = grass_differences.compare(
                        curved[::n // compared], theirs, lambda ours: peer_difference(
                            peer_map, ours, theirs, curved_caster.coefficient))
                if compared < k:
                    row["grass_compared_directions"] = compared
            if wv:     # on the filled map too (its rays read a void's -9999 m as terrain)
                k, w = on_subset(row, "whitebox", whitebox_runs, whitebox_directions, n,
                                 lambda k: run_whitebox(peer_map, k, whitebox_start))
                first = round(whitebox_start * n / 360.0)          # its bands among our n
                flat = (angles[first::n // k] if peer_map is hm else
                        flat_peer_caster.horizons(azimuth_grid(n)[first::n // k]))
                row["whitebox_vs_oclshade"] = near_far_difference(peer_map, flat, w["angles"],
                                                                  azimuths=whitebox_start + azimuth_grid(k))
            if rvt_ok:
                ours_svf = svf_by_band(angles, "solid-angle")
                for radius in (10, rvt_radius):
                    t, theirs = rvt_svf(hm, n, radius)
                    d = np.abs(theirs - ours_svf)
                    row[f"rvt_r{radius}"] = {"seconds": t, "mean_abs": float(np.nanmean(d)),
                                             "max_abs": float(np.nanmax(d))}
                    row[f"oclshade_r{radius}"] = within_radius(hm, n, radius, theirs, samples)
            entry["runs"][n] = row
            print(f"  N={n}: {json.dumps(row)}", flush=True)
        entry["svf_crop"], entry["svf_error_of_n"] = svf_errors(hm, svf_crop)
        result["maps"][name] = entry
    return result


def compare_fits(compare: int | None, directions: int | None, counts: tuple[int, ...]) -> bool:
    """Whether ``--grass-compare`` = ``compare`` takes every (K / C)-th of r.horizon's K directions
    at each N of ``counts`` (K = ``directions`` or N) with a whole stride: None (all), 0 (none), or
    a count dividing every K; a stride that is not whole would misalign the bands."""
    return compare is None or compare == 0 or (compare > 0 and not any((directions or n) % compare for n in counts))


class SameBands:
    """The peer difference of a band stack computed once: r.horizon on k of the azimuths is
    compared with the same k azimuths of ours at every N (``--grass-directions``), the same bits
    at each N, and the split into classes takes about 2 minutes a band at 4096^2.  Keyed by the
    bytes of both stacks (a digest), so a stack that differs in one bit is compared anew."""

    def __init__(self) -> None:
        self._done: dict[str, dict] = {}

    def compare(self, ours: np.ndarray, theirs: np.ndarray, difference: Callable[[np.ndarray], dict]) -> dict:
        digest = hashlib.blake2b()
        for band in (*ours, *theirs):
            digest.update(np.ascontiguousarray(band).data)
        key = digest.hexdigest()
        if key not in self._done:
            self._done[key] = difference(ours)
        return self._done[key]


def on_subset(row: dict, peer: str, runs: dict[int, dict], directions: int | None, n: int,
              run_peer: Callable[[int], dict]) -> tuple[int, dict]:
    """A slow peer (r.horizon, WhiteboxTools) on k = ``directions`` (None: all) of the n azimuths,
    every (n / k)-th from north: (k, its run), one run per k shared by every n (``runs``); its time
    scaled by n / k in ``row[peer + "_s"]``, and k in ``row[peer + "_directions"]`` when k < n."""
    k = min(directions or n, n)
    if k not in runs:
        runs[k] = run_peer(k)
    row[f"{peer}_s"] = runs[k]["seconds"] * n / k
    if runs[k].get("jobs", 1) > 1:     # in parallel processes: the sum of their times too
        row[f"{peer}_process_s"] = runs[k]["process_seconds"] * n / k
    if k < n:
        row[f"{peer}_directions"] = k
    return k, runs[k]


def _estimated(row: dict, peer: str, n: int, start: float = 0.0) -> str:
    """' (est. from k of n az.)' after a time :func:`on_subset` scaled (' from DEG', its first
    azimuth, when not north), else ''."""
    if peer + "_directions" not in row:
        return ""
    return f" (est. from {row[peer + '_directions']} of {n} az.{f' from {start:g} deg' if start else ''})"


def svf_by_band(angles: np.ndarray, definition: str) -> np.ndarray:
    """ref.sky_view_factor of an (n, rows, cols) stack summed one band at a time: the reference
    holds the whole stack in float64 several times over (4096^2 x 64 azimuths: over 24 GB, which
    stopped a run for memory); equal to it up to the order of the float64 sum."""
    total = np.zeros(angles.shape[1:], np.float64)
    for band in angles:
        s = np.sin(np.radians(np.maximum(band.astype(np.float64), 0.0)))
        total += s * s if definition == "cosine" else s
    return 1.0 - total / angles.shape[0]


def _class_cell(c: dict) -> str:
    if not c["cells"]:
        return "0"
    return f"{c['cells']}: {c['mean_abs_deg']:.3f} / {c['p99_abs_deg']:.2f} / {c['max_abs_deg']:.1f}"


def _near_far_cells(d: dict) -> str:
    """Table cells 'mean / p99 / max abs' of a :func:`near_far_difference`: all | near | far."""
    return " | ".join(f"{c['mean_deg']:+.3f} / {c['p99_abs_deg']:.3f} / {c['max_abs_deg']:.2f}" if c["cells"] else "-"
                      for c in (d, d["near"], d["far"]))


def _rows_with(res: dict, key: str) -> list[tuple[str, object, dict, dict, dict]]:
    """(map label with its size, N, map entry, run row, row[key]) of every run that has ``key``."""
    return [(f"{name} {e['shape'][1]}x{e['shape'][0]}", n, e, row, row[key])
            for name, e in res["maps"].items() for n, row in e["runs"].items() if key in row]


def _cpu_and_driver(machine: dict) -> str:
    """The CPU, PoCL version and LLVM target (device version) of a record, as '; CPU ..., driver
    ..., device ...' for the .md's machine line; '' for records before 2026-12-03, which lack
    them (their docs name the machine)."""
    facts = [f"{label} {machine[key]}" for label, key in
             (("CPU", "cpu"), ("driver", "platform_version"), ("device", "device_version")) if machine.get(key)]
    return "; " + ", ".join(facts) if facts else ""


def markdown(res: dict) -> str:
    m = res["machine"]
    lines = ["# Horizon angles and sky-view factor (issue 19)", "",
             f"Machine: {m['device']}, {m['cpus']} CPUs, {m['platform']}{_cpu_and_driver(m)}. GRASS: {res['grass']}. "
             f"RVT: {res['rvt']}. "
             f"WhiteboxTools: {res.get('whitebox', 'not run')}."
             + (" **Reduced run** (crops; a check of the script, not the record)." if res["reduced"] else "")
             + ("" if res.get("map_keys", list(DEFAULT_MAPS)) == list(DEFAULT_MAPS) else
                f" **Maps of this run: {', '.join(res['map_keys'])}** (`--maps`; the others not run).")
             + (f" Command: `{res['command']}`." if "command" in res else ""), "",
             "| map | N | oclshade s | ref. max diff (deg) | band (deg) | outside band | oclshade curved s | "
             "r.horizon s | r.horizon - oclshade curved mean / p99 / max abs (deg) | RVT r10 SVF mean / max abs diff |",
             "|---" * 10 + "|"]
    for name, e in res["maps"].items():
        for n, row in e["runs"].items():
            r = row["reference"]
            g = row.get("grass_vs_oclshade")
            jobs = (f" ({res['grass_jobs']} processes, {row['grass_process_s']:.0f} s summed)"
                    if "grass_process_s" in row else "")
            compared = (f" (on {row['grass_compared_directions']} of its directions)"
                        if "grass_compared_directions" in row else "")
            difference = (f"{g['mean_abs_deg']:.3f} / {g['p99_abs_deg']:.3f} / {g['max_abs_deg']:.2f}{compared}"
                          if g else "not compared (`--grass-compare 0`)")
            grass = (f"{row['oclshade_curved_s']:.2f} | {row['grass_s']:.2f}{_estimated(row, 'grass', n)}{jobs} | "
                     f"{difference}") if "grass_s" in row else "- | - | -"
            rv = row.get("rvt_r10")
            rvt = f"{rv['mean_abs']:.4f} / {rv['max_abs']:.3f}" if rv else "-"
            lines.append(f"| {name} {e['shape'][1]}x{e['shape'][0]} | {n} | {row['oclshade_s']:.2f} | "
                         f"{r['max_abs_deg']:.2e} ({r['cells']} cells) | {r['band_deg']:.2e} | {r['outside_band']} | "
                         f"{grass} | {rvt} |")
    lines += ["", "oclshade's angles are held to the float64 reference on the sampled cells (outside band = 0: "
              "exact). r.horizon and RVT are peers with their own surface models, so their differences are "
              "reported, not asserted. r.horizon runs on the map with its voids filled (both sides; "
              "`fill_voids`), in a spherical Mercator location centred on the equator (no correction of its "
              "directions) with a null border on the west and south (its edge test reads one cell past those "
              "edges); differences split by class below, explained in docs/solar.md, \"r.horizon\". RVT: "
              "nearest cells within its radius, mirrored edges.", ""]
    grass_rows, whitebox_rows = _rows_with(res, "grass_vs_oclshade"), _rows_with(res, "whitebox_vs_oclshade")
    if grass_rows:
        lines += ["r.horizon - oclshade curved by class, cells and mean / p99 / max |difference| (deg): *near*, "
                  f"either angle is set within {NEAR_CELLS:g} cells of the cell (r.horizon: by a nearest cell, "
                  "off the ray by up to half a cell, seen at the distance of its centre; oclshade: by the bilinear "
                  "surface, e.g. its slope at the cell); *rim*, else r.horizon's angle comes from the half cell of "
                  "map past the outermost cell centres, where oclshade's surface ends; *far*, the rest "
                  "(nearest-cell samples further out on steep ground; r.horizon's 100x100-cell skip, which misses "
                  "terrain under a negative horizon).", "",
                  "| map | N | voids filled | all | near | rim | far |", "|---|---|---|---|---|---|---|"]
        for label, n, e, row, g in grass_rows:
            lines.append(f"| {label} | {n} | {e['voids_filled_for_peers']} | "
                         + " | ".join(_class_cell(c) for c in (g, g["near"], g["rim"], g["far"])) + " |")
    if whitebox_rows:
        lines += ["", "WhiteboxTools HorizonAngle (whitebox-workflows; rays to the map's edge, linear interpolation "
                  "where they cross grid lines, flat Earth) against oclshade's flat-Earth angles, on the cells "
                  "where oclshade sees terrain (maps with voids: both on the filled map); time of its N tool "
                  f"calls, the DEM already read. *near*: oclshade's angle is reached within {NEAR_CELLS:g} cells "
                  "(the bilinear surface between grid lines, e.g. its slope at the cell, which samples at "
                  "grid-line crossings miss); *far*: the rest.", "",
                  "| map | N | oclshade s | WhiteboxTools s | WhiteboxTools / oclshade | WhiteboxTools - oclshade "
                  "mean / p99 / max abs (deg): all | near | far |", "|---|---|---|---|---|---|---|---|"]
        for label, n, e, row, w in whitebox_rows:
            lines.append(f"| {label} | {n} | {row['oclshade_s']:.2f} | "
                         f"{row['whitebox_s']:.2f}{_estimated(row, 'whitebox', n, res.get('whitebox_start', 0.0))} | "
                         f"{row['whitebox_s'] / row['oclshade_s']:.1f}x | "
                         + _near_far_cells(w) + " |")
        lines.append("")
    radius_rows = [(label, n, row, int(key[len("oclshade_r"):]), ours) for label, n, e, row, _ in
                   _rows_with(res, "reference") for key, ours in row.items() if key.startswith("oclshade_r")]
    if radius_rows:
        lines += ["", "Within RVT's search radius (`--max-distance`): oclshade's solid-angle SVF from its exact "
                  "horizons within R (R cells of RVT's cell size 0.5 (dx + dy)), time of `sky_view_factor` "
                  "(kernel built before), its angles against the float64 reference within R on the sampled "
                  "cells, and RVT's SVF at the same radius and N (nearest cells at whole-cell steps) against it.",
                  "", "| map | N | R (cells) | oclshade s | RVT s | RVT / oclshade | ref. max diff (deg) | "
                  "outside band | RVT - oclshade SVF mean / max abs |", "|---|---|---|---|---|---|---|---|---|"]
        for label, n, row, radius, ours in radius_rows:
            theirs, r = row[f"rvt_r{radius}"], ours["reference"]
            lines.append(f"| {label} | {n} | {radius} | {ours['seconds']:.2f} | {theirs['seconds']:.2f} | "
                         f"{theirs['seconds'] / ours['seconds']:.1f}x | {r['max_abs_deg']:.2e} | "
                         f"{r['outside_band']} | {ours['rvt_mean_abs']:.4f} / {ours['rvt_max_abs']:.3f} |")
    horayzon_rows = _rows_with(res, "horayzon_vs_oclshade")
    if horayzon_rows:
        lines += ["", f"HORAYZON ({res['horayzon']}: Embree rays against the map triangulated on a sphere of "
                  "the same radius, its elevation stepped by twice the accuracy from the last azimuth's angle; "
                  "rays to the map's edge) against oclshade's curved angles, on the cells where oclshade's "
                  "angle is above HORAYZON's floor plus 1 degree (maps with voids: both on the filled map); "
                  "time of its horizon call, the BVH built before. *near*: oclshade's angle is reached within "
                  f"{NEAR_CELLS:g} cells (bilinear patches against two triangles each); *far*: the rest.", "",
                  "| map | N | oclshade curved s (exact) | HORAYZON s | HORAYZON / oclshade | rays per cell and "
                  "azimuth | HORAYZON - oclshade mean / p99 / max abs (deg): all | near | far |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for label, n, e, row, z in horayzon_rows:
            rays = f"{row['horayzon_rays']:.1f}" if row.get("horayzon_rays") else "-"
            lines.append(f"| {label} | {n} | {row['oclshade_curved_s']:.2f} | {row['horayzon_s']:.2f} | "
                         f"{row['horayzon_s'] / row['oclshade_curved_s']:.1f}x | {rays} | "
                         + _near_far_cells(z) + " |")
        lines.append("")
    lines += ["", "Error of N azimuths: mean / max |SVF(N) - SVF(1024)| on the map's roughest crop (the window "
              "of largest height spread, rows / columns from its corner).", "",
              "| map | crop | definition | " + " | ".join(f"N = {n}" for n in SVF_COUNTS) + " |",
              "|---|---|---|" + "---|" * len(SVF_COUNTS)]
    for name, e in res["maps"].items():
        r0, c0, side = e.get("svf_crop", (None, None, None))
        where = f"{side}^2 at {r0}, {c0}" if side else "centre"
        for definition, errs in e["svf_error_of_n"].items():
            lines.append(f"| {name} | {where} | {definition} | " + " | ".join(
                f"{errs[n]['mean_abs']:.1e} / {errs[n]['max_abs']:.1e}" for n in SVF_COUNTS) + " |")
    return "\n".join(lines) + "\n"


def plot(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    labels, ours, grass, wbt, hzn = [], [], [], [], []
    for name, e in res["maps"].items():
        for n, row in e["runs"].items():
            labels.append(f"{name}\nN={n}")
            ours.append(row["oclshade_s"])
            grass.append(row.get("grass_s", np.nan))
            wbt.append(row.get("whitebox_s", np.nan))
            hzn.append(row.get("horayzon_s", np.nan))
    x = np.arange(len(labels))
    a.bar(x - 0.3, ours, 0.2, label="oclshade (exact)")
    a.bar(x - 0.1, grass, 0.2, label="GRASS r.horizon")
    a.bar(x + 0.1, wbt, 0.2, label="WhiteboxTools")
    a.bar(x + 0.3, hzn, 0.2, label="HORAYZON (Embree)")
    a.set_xticks(x, labels, fontsize=7)
    a.set_ylabel("seconds")
    a.set_yscale("log")
    a.legend()
    a.set_title("horizon maps: time")
    for name, e in res["maps"].items():
        for definition, errs in e["svf_error_of_n"].items():
            b.loglog(SVF_COUNTS, [errs[n]["mean_abs"] for n in SVF_COUNTS], "o-", label=f"{name}, {definition}")
    b.set_xlabel("azimuths N")
    b.set_ylabel(f"mean |SVF(N) - SVF({SVF_FINE})|")
    b.legend(fontsize=7)
    b.set_title("sky-view factor: error of N")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reduced", action="store_true", help="256^2 crops and a 256^2 canyon (checks the script)")
    parser.add_argument("--samples", type=int, default=None, help="reference cells per map (default 2000, reduced 200)")
    parser.add_argument("--svf-crop", type=int, default=None, help="crop side of the error-of-N study "
                                                                   "(default 256, reduced 64)")
    parser.add_argument("--rvt-radius", type=int, default=None, help="the larger RVT radius in cells "
                                                                     "(default 100, reduced 30)")
    parser.add_argument("--maps", default=",".join(DEFAULT_MAPS),
                        help=f"comma-separated subset of {', '.join(MAP_KEYS)} (default {','.join(DEFAULT_MAPS)})")
    parser.add_argument("--azimuths", default=",".join(map(str, AZIMUTH_COUNTS)),
                        help="comma-separated azimuth counts N (default 16,64)")
    parser.add_argument("--grass-directions", type=int, default=None, metavar="K",
                        help="r.horizon on K of the N azimuths (K a multiple of 4 dividing every N), its time "
                             "scaled by N / K (default: all N)")
    parser.add_argument("--grass-jobs", type=int, default=1, metavar="J",
                        help="r.horizon (one core each) in J processes at once, the directions split between "
                             "them; its time is then the wall time of all J (default 1)")
    parser.add_argument("--grass-compare", type=int, default=None, metavar="C",
                        help="r.horizon's angles compared with ours on C of its K directions (C dividing K: "
                             "every (K / C)-th from north; 0: not compared, times only), about 17 s a "
                             "direction at 4096^2 (default: all K)")
    parser.add_argument("--whitebox-directions", type=int, default=None, metavar="K",
                        help="WhiteboxTools on K of the N azimuths (K dividing every N: every (N / K)-th from "
                             "north), its time scaled by N / K (default: all N)")
    parser.add_argument("--whitebox-start", type=float, default=0.0, metavar="DEG",
                        help="WhiteboxTools' K azimuths from DEG east of north, an azimuth of every N's grid "
                             "(default 0; e.g. 22.5 with N = 16, K = 2 leaves the grid's axes)")
    parser.add_argument("--peers", default=",".join(PEERS),
                        help=f"comma-separated subset of {', '.join(PEERS)} to run (default all; WhiteboxTools "
                             "takes about 6 minutes per azimuth of a 4096^2 map on 2 cores)")
    parser.add_argument("--horayzon-accuracy", type=float, default=HORAYZON_ACCURACY, metavar="DEG",
                        help=f"HORAYZON's horizon accuracy in degrees (default {HORAYZON_ACCURACY})")
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "solar")
    args = parser.parse_args()
    try:
        counts = tuple(int(n) for n in args.azimuths.split(",") if n.strip())
    except ValueError:
        counts = ()
    if not counts or min(counts) < 1:
        parser.error(f"--azimuths takes comma-separated positive counts, got {args.azimuths!r}")
    k = args.grass_directions
    if k is not None and (k < 4 or k % 4 or any(n % k for n in counts)):
        parser.error(f"--grass-directions must be a multiple of 4 dividing every azimuth count {counts}, got {k}")
    if args.grass_jobs < 1 or args.grass_jobs > min(k or n for n in counts):
        parser.error(f"--grass-jobs must be between 1 and the fewest r.horizon directions of a run, got "
                     f"{args.grass_jobs}")
    if not compare_fits(args.grass_compare, k, counts):
        parser.error(f"--grass-compare must be 0 or a count dividing r.horizon's directions of every azimuth "
                     f"count {counts}, got {args.grass_compare}")
    kw = args.whitebox_directions
    if kw is not None and (kw < 1 or any(n % kw for n in counts)):
        parser.error(f"--whitebox-directions must be a positive count dividing every azimuth count {counts}, got {kw}")
    ws = args.whitebox_start
    if not 0.0 <= ws < 360.0 / (kw or min(counts)) or any(abs(ws * n / 360.0 - round(ws * n / 360.0)) > 1e-9
                                                         for n in counts):
        parser.error(f"--whitebox-start must be an azimuth of every N's grid {counts} below 360 / K, got {ws:g}")
    keys = tuple(key.strip() for key in args.maps.split(",") if key.strip())
    if not keys or not set(keys) <= set(MAP_KEYS):
        parser.error(f"--maps takes a comma-separated subset of {', '.join(MAP_KEYS)}, got {args.maps!r}")
    peers = tuple(peer.strip() for peer in args.peers.split(",") if peer.strip())
    if not set(peers) <= set(PEERS):
        parser.error(f"--peers takes a comma-separated subset of {', '.join(PEERS)}, got {args.peers!r}")
    res = run(args.reduced, args.samples or (200 if args.reduced else 2000),
              args.svf_crop or (64 if args.reduced else 256), args.rvt_radius or (30 if args.reduced else 100), keys,
              args.grass_directions, counts, peers, args.horayzon_accuracy, args.whitebox_directions,
              args.grass_jobs, args.grass_compare, args.whitebox_start)
    res["command"] = " ".join(["python", "bench/solar.py", *sys.argv[1:]])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps(res, indent=1) + "\n")
    args.out.with_suffix(".md").write_text(markdown(res))
    plot(res, args.out.with_suffix(".png"))
    print(markdown(res))


if __name__ == "__main__":
    main()
