#!/usr/bin/env python
"""One site's horizon against HORAYZON: ``oclshade.horizon.site_horizon`` (float64 on the host,
along the geodesics) and HORAYZON's ``Terrain.horizon_arbitrary`` (PyPI ``horayzon-extpar``:
Embree rays in Cartesian space against a triangle mesh), both with the Earth's curvature and no
refraction, on a real geographic tile.

    python bench/site_peers.py              # 12 seeded land sites on SRTM N22W160, 360 azimuths
    python bench/site_peers.py --reduced    # 3 sites, 72 azimuths: a check that the script works

The mesh is every sample of the tile placed on the WGS 84 ellipsoid at its height (ECEF), in a
local east-north-up frame at the tile's centre (float32 vertices within 100 km of it: 1 cm), two
triangles per patch (the bilinear surface's own samples, not its patches).  HORAYZON's
elevation angles are above the plane normal to the line from its ``earth_centre``: for each site
that centre is put on the site's geodetic normal (where the normal meets the polar axis), so its
"up" is the ellipsoid's there, and a point of the polar axis gives north.  One BVH per site (an
object initialises once).  HORAYZON takes ``horizon_acc`` 0.01 degree, the search to the map's
diagonal, the site 0.5 m above the surface on both sides (HORAYZON's least ``height_min``).

Per site and azimuth: |site - HORAYZON| in degrees (mean / p99 / max), split into *near*
(oclshade's horizon is reached within 30 cells, 2.7 km: there the triangles and the bilinear
patches, different surfaces metres apart on Kauai's slopes, are seen from 0.5 m as degrees)
and *far* (the rest: the geometry, which both trace along the vertical plane); the time of oclshade's call per site, HORAYZON's per site (its BVH apart) and its BVH
build.  Writes bench/results/site_peers.{json,md}.
"""
from __future__ import annotations

import dataclasses
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from ground_height import WGS84_A, WGS84_E2, ecef, seeded_cells, summary  # noqa: E402
from shadow_masks import header, log, metadata, publish, results_arguments  # noqa: E402

from oclshade.horizon import EARTH_RADIUS, Curvature, site_horizon  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.solar import map_places  # noqa: E402

SRTM = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip"
ACCURACY = 0.01                 # HORAYZON's horizon_acc, degrees
ABOVE = 0.5                     # metres over the surface: HORAYZON's least height_min, both sides
NEAR_CELLS = 30


def enu_frame(lon: float, lat: float) -> tuple[np.ndarray, np.ndarray]:
    """(origin ECEF, rotation rows east, north, up) of the local frame at a place on the ellipsoid."""
    phi, lam = math.radians(lat), math.radians(lon)
    east = np.array([-math.sin(lam), math.cos(lam), 0.0])
    north = np.array([-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi)])
    up = np.array([math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi)])
    return ecef(np.array(lon), np.array(lat), np.array(0.0)), np.stack([east, north, up])


def mesh(heights: np.ndarray, lon: np.ndarray, lat: np.ndarray, frame) -> tuple[np.ndarray, np.ndarray]:
    """(float32 vertices in the frame, uint32 faces): two triangles per patch, anticlockwise from above."""
    origin, rotation = frame
    verts = ((ecef(lon, lat, heights) - origin) @ rotation.T).reshape(-1, 3).astype(np.float32)
    rows, cols = heights.shape
    idx = np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols)
    nw, ne, sw, se = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([sw, se, ne], -1).reshape(-1, 3), np.stack([sw, ne, nw], -1).reshape(-1, 3)])
    return verts, np.ascontiguousarray(faces)


def horayzon_site(verts, faces, frame, lon: float, lat: float, height: float, n: int, reach: float
                  ) -> tuple[np.ndarray, float, float]:
    """(HORAYZON's n angles at the site, clockwise from north from 0; its horizon call's seconds;
    its BVH build's seconds), its up the site's geodetic normal."""
    import horayzon_extpar.horizon as hz

    origin, rotation = frame
    phi = math.radians(lat)
    normal_n = WGS84_A / math.sqrt(1.0 - WGS84_E2 * math.sin(phi) ** 2)
    site = ecef(np.array(lon), np.array(lat), np.array(height))
    site_up = np.array([math.cos(phi) * math.cos(math.radians(lon)), math.cos(phi) * math.sin(math.radians(lon)),
                        math.sin(phi)])
    centre = site - (normal_n + height) * site_up        # the geodetic normal meets the polar axis here
    pole = np.array([0.0, 0.0, centre[2] + 1.0e6])
    to_frame = (lambda p: (p - origin) @ rotation.T)
    terrain = hz.Terrain()
    with tempfile.TemporaryFile("w+") as quiet:          # its C++ prints to stdout
        sys.stdout.flush()
        saved = os.dup(1)
        os.dup2(quiet.fileno(), 1)
        try:
            t0 = time.perf_counter()
            terrain.initialise(verts, faces, to_frame(centre).astype(np.float32), to_frame(pole).astype(np.float32))
            t1 = time.perf_counter()
            angles, _ = terrain.horizon_arbitrary(to_frame(site)[None, :].astype(np.float64), n, reach, ABOVE,
                                                  ACCURACY, -30.0)
            t2 = time.perf_counter()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
    return np.asarray(angles, np.float64)[0], t2 - t1, t1 - t0


def run(reduced: bool) -> dict:
    raster = read_dem(SRTM)
    places = map_places(raster)
    rows, cols = raster.heights.shape
    lon, lat = places.lonlat(*np.meshgrid(np.arange(rows) + 0.5, np.arange(cols) + 0.5, indexing="ij"))
    heights = np.nan_to_num(raster.heights, nan=0.0)       # (voids as sea level: HORAYZON takes no holes)
    filled = dataclasses.replace(raster, heights=heights)
    frame = enu_frame(float(lon[rows // 2, cols // 2]), float(lat[rows // 2, cols // 2]))
    verts, faces = mesh(heights, lon, lat, frame)
    inner = np.zeros(heights.shape, bool)
    inner[1:-1, 1:-1] = True
    pick = seeded_cells(np.where(heights > 100.0, heights, np.nan), 3 if reduced else 12, inner)
    n = 72 if reduced else 360
    azimuths = np.arange(n) * (360.0 / n)
    reach = 1.05 * math.hypot(rows * raster.dy, cols * raster.dx)
    curvature = Curvature(EARTH_RADIUS, 0.0)
    near_m = NEAR_CELLS * min(raster.dx, raster.dy)
    ours, theirs, near, seconds = [], [], [], {"oclshade": [], "horayzon": [], "horayzon_bvh": []}
    for i, j in pick:
        la, lo = float(lat[i, j]), float(lon[i, j])
        t0 = time.perf_counter()
        got = site_horizon(filled, la, lo, azimuths, above=ABOVE, curvature=curvature)
        seconds["oclshade"].append(time.perf_counter() - t0)
        close = site_horizon(filled, la, lo, azimuths, above=ABOVE, curvature=curvature, max_distance=near_m)
        peer, call, bvh = horayzon_site(verts, faces, frame, lo, la, float(heights[i, j]), n, reach)
        seconds["horayzon"].append(call)
        seconds["horayzon_bvh"].append(bvh)
        ours.append(got)
        theirs.append(peer)
        near.append(got <= close + 1e-12)
        log(f"site {i},{j}: mean |diff| {np.nanmean(np.abs(got - peer)):.4f}")
    ours, theirs, near = np.array(ours), np.array(theirs), np.array(near)
    diff = np.abs(ours - theirs)
    ok = np.isfinite(diff)
    return {"meta": metadata(sys.argv), "map": "SRTM N22W160 (Kauai, 3 arc-sec)", "sites": int(pick.shape[0]),
            "azimuths": n, "horayzon_accuracy_deg": ACCURACY,
            "all": summary(diff[ok]), "near": summary(diff[ok & near]), "far": summary(diff[ok & ~near]),
            "far_share": float(np.mean(~near[ok])),
            "signed_far_mean": float(np.mean((ours - theirs)[ok & ~near])),
            "far_median": float(np.median(diff[ok & ~near])),
            "far_past_0.1": float(np.mean(diff[ok & ~near] > 0.1)),
            "seconds": {k: float(np.median(v)) for k, v in seconds.items()}}


def markdown(r: dict) -> str:
    fmt = "{mean:.4f} / {p99:.4f} / {max:.4f}"
    s = r["seconds"]
    return "\n".join([
        "# One site's horizon against HORAYZON", "", header(r["meta"], "python bench/site_peers.py"),
        f"{r['map']}: {r['sites']} seeded land sites off the border, 0.5 m up, {r['azimuths']} azimuths, curvature "
        f"(mean radius, no refraction) on both sides; HORAYZON horizon_acc {r['horayzon_accuracy_deg']} degree, its up the site's "
        "geodetic normal; |site_horizon - HORAYZON| in degrees (mean / p99 / max); *near*: oclshade's horizon is "
        f"reached within {NEAR_CELLS} cells (bilinear patches against two triangles: different surfaces metres apart); *far*: "
        "the rest; times are medians per site.", "",
        "| all | near | far | far median | far past 0.1 | far share | far signed mean | site_horizon s | "
        "HORAYZON s (BVH apart) | BVH s |",
        "|---|---|---|---|---|---|---|---|---|---|",
        f"| {fmt.format(**r['all'])} | {fmt.format(**r['near'])} | {fmt.format(**r['far'])} | {r['far_median']:.4f} | "
        f"{100 * r['far_past_0.1']:.1f} % | {100 * r['far_share']:.0f} % | {r['signed_far_mean']:+.4f} | "
        f"{s['oclshade']:.3f} | {s['horayzon']:.3f} | {s['horayzon_bvh']:.2f} |", ""])


def main(argv: list[str] | None = None) -> int:
    args = results_arguments(argv, __doc__, "site_peers", "3 sites, 72 azimuths")
    if not SRTM.exists():
        log(f"{SRTM} absent: nothing to compare")
        return 0
    result = run(args.reduced)
    return publish(args.out, result, markdown(result))


if __name__ == "__main__":
    sys.exit(main())
