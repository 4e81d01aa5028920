#!/usr/bin/env python
"""Sunshine over time (issue 19): a month at 10-minute steps on an SRTM tile, by both routes.

    python bench/sunshine.py                  # the record: June 2024, SRTM N22W160 (1201^2, Kauai)
    python bench/sunshine.py --reduced        # a check that the script works: one day, a 384^2 crop

Writes bench/results/sunshine.{md,json} (``--out`` to change).  The suns: NREL SPA at the
tile's centre (22.5 N, 159.5 W) for [--start, --start + --days) in steps of --step, each
sampled at its midpoint (``oclshade.sunshine.time_steps``); the night steps are skipped.
Each phase runs in a fresh child process (kernels compiled and cached by the parent first),
which reports its wall time (after reading the tile and a one-sun warm-up that loads the
kernels) and its peak resident memory (``ru_maxrss``):

* **masks**: ``SunshineCaster.accumulate(..., outputs=all)``, the exact route: one
  mask per daylight step traced into a device buffer and summed on the device;
* **masks, first day only**: the same for the first day: its peak memory against the
  month's shows that memory does not grow with the steps;
* **masks, each cell's own sun**: the suns over the map (``oclshade.solar.sun_field``, each
  cell's own sun within 0.01 degree of its block's, what ``oclshade sunshine`` sums by
  default), made in the phase (timed) and summed one launch a step; what the tile centre's
  one sun leaves out: its hours against these on land cells;
* **per-sun masks summed on the host**: ``ShadowCaster.iter_many`` with the mask and
  self outputs copied to the host each step and summed there in float64 (what a user
  of the shadow command would do); the agreement of its hours and cast fraction with
  the masks route (cells that differ; 0 is the claim: same kernels, same bits);
* **horizons, N = 16, 32, 64, 128, 360**: ``accumulate(method="horizons")``: time
  and the error of its hours, cast fraction and irradiation against the masks
  route over the valid cells, and over the land cells (height > 0: the tile is
  mostly sea at 0 m, where every route agrees): mean, 99th percentile and max
  |difference|.

Figures depend on the machine (and on other work sharing it); the results record
where they were taken.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import resource
import sys
import time
from datetime import datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))                           # the source tree's oclshade and kernels
sys.path.insert(0, str(Path(__file__).resolve().parent))
from shadow_masks import log, metadata  # noqa: E402  (same metadata as the other benches)

TILE = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy" / "N22W160v2.3a.hgt.zip"
ZONE = "Pacific/Honolulu"
AZIMUTH_COUNTS = (16, 32, 64, 128, 360)
REDUCED_CROP = (slice(817, 1201), slice(400, 784))   # 384^2 over Kauai (64 % land)
OUTPUTS = ("hours", "fraction", "irradiation")


def load(reduced: bool):
    """The tile as a heightmap and its centre (latitude, longitude)."""
    from oclshade.heightmap import Heightmap
    from oclshade.io import read_dem
    from oclshade.solar import map_site

    raster = read_dem(TILE)
    heights = raster.heights[REDUCED_CROP] if reduced else raster.heights
    site = map_site(raster)
    return Heightmap.from_array(heights, (raster.dx, raster.dy)), (site.latitude, site.longitude)


def suns_and_seconds(start: datetime, days: float, step: timedelta, place: tuple[float, float]):
    """The steps' suns at ``place``, their seconds and their times."""
    from oclshade.solar import suns_at
    from oclshade.sunshine import time_steps

    steps = time_steps(start, start + timedelta(days=days), step)
    return suns_at(steps.times, *place), steps.seconds, steps.times


def places(reduced: bool):
    """Where the tile's (or the crop's) cells lie (oclshade.solar.map_places)."""
    from oclshade.io import read_dem
    from oclshade.solar import map_places
    from sun_field import crop

    raster = read_dem(TILE)
    if reduced:
        raster = crop(raster, REDUCED_CROP[0].start, REDUCED_CROP[1].start, REDUCED_CROP[0].stop - REDUCED_CROP[0].start)
    return map_places(raster)


# --- phases (each in a child process) ------------------------------------------------------------

def _phase(name: str, reduced: bool, suns, seconds, extra: dict) -> dict:
    """One phase on a fresh process; the time excludes reading the tile and loading the kernels
    (a one-sun warm-up on the same map first)."""
    from oclshade.sunshine import SunshineCaster

    hm, _ = load(reduced)
    method, azimuths = extra.get("method", "masks"), extra.get("azimuths", 64)
    warm = [s for s in suns if s.elevation > 5][:1]
    SunshineCaster(hm).accumulate(warm, 600, OUTPUTS, method=method, azimuths=4 if method == "horizons" else 64)
    t0 = time.perf_counter()
    out: dict = {"phase": name}
    if name == "masks":
        maps = SunshineCaster(hm).accumulate(suns, seconds, OUTPUTS, method=method, azimuths=azimuths)
        out["arrays"] = {o: getattr(maps, o) for o in OUTPUTS}
        out["daylight_suns"] = maps.daylight_suns
    elif name == "fields":
        from oclshade.solar import sun_field
        where = places(reduced)
        fields = [sun_field(where, t) for t in extra["times"]]
        out["fields_seconds"] = time.perf_counter() - t0
        out["blocks_mean"] = float(np.mean([len(f.blocks) for f in fields if not f.uniform] or [1]))
        maps = SunshineCaster(hm).accumulate(fields, seconds, OUTPUTS)
        out["arrays"] = {o: getattr(maps, o) for o in OUTPUTS}
        out["daylight_suns"] = maps.daylight_suns
    elif name == "host":
        from oclshade.shadows import ShadowCaster
        day = [(s, w) for s, w in zip(suns, seconds) if s.elevation > 0]
        sun_s, cast_s = np.zeros(hm.shape), np.zeros(hm.shape)
        caster = ShadowCaster(hm, cache=False)
        for (_, w), res in zip(day, caster.iter_many([s for s, _ in day], outputs=("mask", "self"))):
            sun_s += w * ((res.mask == 0) & (res.self_shadow == 0))
            cast_s += w * (res.mask == 1)
        total = sum(w for _, w in day)
        nodata = np.isnan(hm.heights)
        out["arrays"] = {"hours": np.where(nodata, np.nan, sun_s / 3600).astype(np.float32),
                         "fraction": np.where(nodata, np.nan, cast_s / total).astype(np.float32)}
    out["seconds"] = time.perf_counter() - t0
    out["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return out


def run_phase(name: str, reduced: bool, suns, seconds, **extra) -> dict:
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(_phase, (name, reduced, suns, seconds, extra))


def differences(a: np.ndarray, b: np.ndarray, where: np.ndarray | None = None) -> dict:
    """|a - b| over the cells valid in both (and in ``where``): mean, p99, max, how many differ."""
    ok = ~(np.isnan(a) | np.isnan(b)) & (True if where is None else where)
    d = np.abs(a[ok].astype(np.float64) - b[ok])
    return {"mean": float(d.mean()), "p99": float(np.percentile(d, 99)), "max": float(d.max()),
            "cells_differing": int(np.count_nonzero(d)), "cells": int(ok.sum())}


# --- report -------------------------------------------------------------------------------------

def write_markdown(path: Path, r: dict) -> None:
    m = r["meta"]
    masks, host = r["masks"], r["host"]
    lines = [
        "# Sunshine over time (issue 19)", "",
        f"- date: {m['date']}; command: `{m['command']}`",
        f"- CPU: {m['cpu']}, {m['cores']} cores; device: {m['device']}; {m['pocl_version']}",
        f"- map: {r['map']}; place {r['place'][0]:.4f}, {r['place'][1]:.4f} (tile centre, NREL SPA)",
        f"- period: {r['period']}: {r['steps']} steps, {masks['daylight_suns']} in daylight",
        "- each phase in a fresh process (kernels cached, one-sun warm-up untimed); peak memory = that "
        "process's maxrss; a shared machine: times are indicative", "",
        "## Exact route and memory", "",
        "| phase | time s | s per daylight step | peak RSS MiB |", "|---|---:|---:|---:|",
    ]
    for label, p in (("masks, summed on the device", masks), ("masks, first day only", r["masks_day"]),
                     ("masks, each cell's own sun (making the fields: "
                      f"{r['fields']['fields_seconds']:.1f} s, {r['fields']['blocks_mean']:.0f} blocks a daylight "
                      "field)", r["fields"]),
                     ("per-sun masks + self copied and summed on the host", host)):
        per = p["seconds"] / max(p.get("daylight_suns", masks["daylight_suns"]), 1)
        lines.append(f"| {label} | {p['seconds']:.1f} | {per:.3f} | {p['peak_rss_mib']:.0f} |")
    agree = r["agreement"]
    lines += ["", f"Agreement of the device sums with the host sums of the per-sun masks: hours differ on "
                  f"**{agree['hours']['cells_differing']}** of {agree['hours']['cells']} cells (max "
                  f"{agree['hours']['max']:.3g} h), cast fraction on **{agree['fraction']['cells_differing']}** "
                  f"(max {agree['fraction']['max']:.3g}).", "",
              "What the tile centre's one sun leaves out against each cell's own (land cells, height > 0): "
              + ", ".join(f"{o} differ on {e['cells_differing']} of {e['cells']} (mean {e['mean']:.4f}, p99 "
                          f"{e['p99']:.3f}, max {e['max']:.3f})" for o, e in r["own_sun"].items()) + ".", "",
              "## Horizon route: time and error against the masks route", "",
              "Per valid cell; hours and irradiation in hours, fraction as a share of daylight.", "",
              "| N | time s | hours mean | hours p99 | hours max | fraction mean | fraction max | "
              "irradiation mean | irradiation max | over |", "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for cells, key in (("all valid cells", "error"), ("land cells (height > 0)", "error_land")):
        for n, h in r["horizons"].items():
            e = h[key]
            lines.append(f"| {n} | {h['seconds']:.1f} | {e['hours']['mean']:.4f} | {e['hours']['p99']:.3f} | "
                         f"{e['hours']['max']:.3f} | {e['fraction']['mean']:.5f} | {e['fraction']['max']:.3f} | "
                         f"{e['irradiation']['mean']:.4f} | {e['irradiation']['max']:.3f} | {cells} |")
    lines.append("")
    path.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reduced", action="store_true", help="one day on a 384^2 crop (a check, not a record)")
    parser.add_argument("--start", default="2024-06-01T00:00", help=f"local time in {ZONE} (default June 2024)")
    parser.add_argument("--days", type=float, default=None, help="length of the period (default 30; 1 reduced)")
    parser.add_argument("--step", default="10min")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    args = parser.parse_args(argv)
    if not TILE.is_file():
        print(f"skipped: {TILE} is absent", file=sys.stderr)
        return 0
    from oclshade.sunshine import SunshineCaster, parse_step

    days = args.days if args.days is not None else (1.0 if args.reduced else 30.0)
    start = datetime.fromisoformat(args.start).replace(tzinfo=ZoneInfo(ZONE))
    hm, place = load(args.reduced)
    suns, seconds, times = suns_and_seconds(start, days, parse_step(args.step), place)
    first_day = int(np.searchsorted(np.cumsum(seconds), 86400, side="right"))
    log(f"{hm.shape[1]}x{hm.shape[0]} cells, {len(suns)} steps; compiling kernels")
    warm = [s for s in suns if s.elevation > 5][:1]                      # the kernel caches on disk
    SunshineCaster(hm).accumulate(warm, 600, OUTPUTS)
    SunshineCaster(hm).accumulate(warm, 600, OUTPUTS, method="horizons", azimuths=4)

    result = {"meta": metadata(sys.argv), "map": f"SRTM N22W160 {hm.shape[1]}x{hm.shape[0]}"
              + (" (crop rows 817:1201, cols 400:784)" if args.reduced else ""),
              "place": list(place), "period": f"{start.isoformat()} + {days:g} days, step {args.step}",
              "steps": len(suns)}
    log("masks route")
    masks = run_phase("masks", args.reduced, suns, seconds)
    log(f"  {masks['seconds']:.1f} s; first day only")
    result["masks_day"] = {k: v for k, v in run_phase("masks", args.reduced, suns[:max(first_day, 1)],
                                                      seconds[:max(first_day, 1)]).items() if k != "arrays"}
    log("masks, each cell's own sun")
    fields = run_phase("fields", args.reduced, suns, seconds, times=times)
    land = hm.heights > 0.0            # the tile is mostly sea at 0 m, where every route agrees
    result["own_sun"] = {o: differences(masks["arrays"][o], fields["arrays"][o], land) for o in OUTPUTS}
    result["fields"] = {k: v for k, v in fields.items() if k != "arrays"}
    log(f"  {fields['seconds']:.1f} s ({fields['fields_seconds']:.1f} s making the fields)")
    log("per-sun masks summed on the host")
    host = run_phase("host", args.reduced, suns, seconds)
    result["agreement"] = {o: differences(masks["arrays"][o], host["arrays"][o]) for o in ("hours", "fraction")}
    result["horizons"] = {}
    for n in AZIMUTH_COUNTS:
        log(f"horizons, N = {n}")
        h = run_phase("masks", args.reduced, suns, seconds, method="horizons", azimuths=n)
        result["horizons"][n] = {"seconds": h["seconds"], "peak_rss_mib": h["peak_rss_mib"],
                                 "error": {o: differences(h["arrays"][o], masks["arrays"][o]) for o in OUTPUTS},
                                 "error_land": {o: differences(h["arrays"][o], masks["arrays"][o], land)
                                                for o in OUTPUTS}}
    result["masks"] = {k: v for k, v in masks.items() if k != "arrays"}
    result["host"] = {k: v for k, v in host.items() if k != "arrays"}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sunshine.json").write_text(json.dumps(result, indent=1) + "\n")
    write_markdown(args.out / "sunshine.md", result)
    log(f"wrote {args.out / 'sunshine.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
