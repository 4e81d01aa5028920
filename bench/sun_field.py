#!/usr/bin/env python
"""The sun over a whole map (oclshade.solar.field): what one sun for the map gets wrong, what
tracing per block costs, and that the per-block masks stay exact.

    python bench/sun_field.py                       # the shared SRTM tiles and a 4096^2 UTM map
    python bench/sun_field.py --reduced             # a check that the script works (small maps)

Per map and per time (the first minutes after 2024-06-20T12:00Z when the sun at the map's
centre stands 3, 10 and 30 degrees high in the morning, and the local noon after), in one
process (``--from-json FILE``: only the markdown again, from a run's JSON):

* the field at the default tolerance (0.01 degrees): blocks, the largest deviation found
  (sun at a block corner against the block's), time to build it;
* the **spread**: the largest angle between the centre's sun and a corner's: how far one sun
  for the whole map is from the cells' own;
* time of the mask traced per block and of the mask of the centre's sun alone (best of 3,
  after a warm-up), and their ratio;
* **cells one sun gets wrong**: cells whose per-block mask differs from the one-sun mask;
* **exactness per block**: the per-block mask against the float64 twin
  (:func:`oclshade.reference.cast_field_shadows`) on the first 32 x 32 cells of a seeded sample
  of blocks (the twin walks every patch of every ray), mismatches outside float32 ties (must be
  0) and tied ones;
* **sunshine** over ``--sunshine-days`` from about the local solar midnight of 2024-06-21 (10-minute steps,
  each step's sun at its middle) on the SRTM tiles, by ``SunshineCaster`` per block and with
  the centre's sun, both routes (masks; horizons at 64 azimuths): times, and the difference of
  the hours of direct sun on land cells (height > 0): what one sun per map leaves out.

Writes bench/results/sun_field.{json,md} (``--out`` to change).  Figures depend on the machine;
the results record where they were taken.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from shadow_masks import log, metadata  # noqa: E402  (same metadata as the other benches)

from oclshade import ShadowCaster  # noqa: E402
from oclshade import reference as ref  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.io import Raster, read_dem  # noqa: E402
from oclshade.solar import map_places, sun_field, sun_position  # noqa: E402
from oclshade.solar.field import sun_spread  # noqa: E402
from oclshade.sun import Sun, SunBlock, SunField  # noqa: E402
from oclshade.synthetic import canyon_crater  # noqa: E402

SRTM = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy"
DAY = datetime(2024, 6, 21, tzinfo=timezone.utc)
ELEVATIONS = (3.0, 10.0, 30.0)
REDUCED_CROPS = {"N22W160": (817, 400, 384), "S16E166": (400, 817, 384)}   # (row, col, side) over land
UTM33N = {33550: (10.0, 10.0, 0.0), 33922: (0.0, 0.0, 0.0, 300000.0, 5420000.0, 0.0),
          34735: (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)}


def maps(reduced: bool) -> dict[str, Raster]:
    out = {}
    for name in ("N22W160", "S16E166"):
        path = SRTM / f"{name}v2.3a.hgt.zip"
        if path.is_file():
            raster = read_dem(path)
            if reduced:
                raster = crop(raster, *REDUCED_CROPS[name])
            out[f"SRTM {name}"] = raster
    side = 512 if reduced else 4096
    heights = canyon_crater(side).astype(np.float64)
    out[f"canyon {side}^2, 10 m, UTM 33N at 48.8 N"] = Raster(heights, 10.0, 10.0, None, False, UTM33N)
    return out


def crop(raster: Raster, r0: int, c0: int, side: int) -> Raster:
    """A square window of a north-up raster, its tie point moved to the window's corner."""
    georef = dict(raster.georef)
    sx, sy, _ = georef[33550]
    _, _, _, x0, y0, z0 = georef[33922]
    georef[33922] = (0.0, 0.0, 0.0, x0 + c0 * sx, y0 - r0 * sy, z0)
    return Raster(raster.heights[r0:r0 + side, c0:c0 + side], raster.dx, raster.dy, raster.path, raster.geographic,
                  georef)


def morning_times(places) -> list[tuple[str, datetime]]:
    """The UTC minutes of the day when the centre's sun first reaches each of ELEVATIONS, and noon."""
    rows, cols = places.shape
    lon, lat = places.lonlat(np.array([rows / 2]), np.array([cols / 2]))
    minutes = [DAY - timedelta(hours=12) + timedelta(minutes=m) for m in range(48 * 60)]
    el = sun_position(minutes, lat[0], lon[0]).elevation
    rising = np.flatnonzero((el[1:] > el[:-1]) & (el[1:] > 0))
    out = []
    for target in ELEVATIONS:
        k = next(int(i) + 1 for i in rising if el[i + 1] >= target)
        out.append((f"elevation {target:g}", minutes[k]))
    k = k + int(np.argmax(el[k:k + 18 * 60]))
    out.append(("noon", minutes[k]))
    return out


def best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def sample_field(field: SunField, count: int, seed: int, side: int = 32) -> SunField:
    """The field with ``count`` seeded blocks cut to their first ``side`` x ``side`` cells, which
    keep their sun; every other cell gets a below-horizon sun, which the twin and the kernel both
    decide without a walk (the twin walks every patch of every ray: a whole 4096^2 map at a low
    sun would take hours)."""
    rng = np.random.default_rng(seed)
    keep = set(rng.choice(len(field.blocks), min(count, len(field.blocks)), replace=False).tolist())
    down = Sun(0.0, -10.0)
    blocks = []
    for k, b in enumerate(field.blocks):
        if k not in keep:
            blocks.append(SunBlock(b.row0, b.row1, b.col0, b.col1, down))
            continue
        r, c = min(b.row1, b.row0 + side), min(b.col1, b.col0 + side)
        blocks.append(SunBlock(b.row0, r, b.col0, c, b.sun))
        blocks += [SunBlock(b.row0, r, c, b.col1, down)] if c < b.col1 else []
        blocks += [SunBlock(r, b.row1, b.col0, b.col1, down)] if r < b.row1 else []
    return SunField(field.shape, tuple(blocks), field.centre)


def measure(name: str, raster: Raster, sample_blocks: int) -> list[dict]:
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    places = map_places(raster)
    caster = ShadowCaster(hm, cache=False)
    rows = []
    for label, when in morning_times(places):
        t0 = time.perf_counter()
        field = sun_field(places, when)
        build = time.perf_counter() - t0
        caster.cast_many([field])                     # warm-up: kernels of this column step
        caster.cast(field.centre)
        per_block = caster.cast_many([field])[0].mask
        one = caster.cast(field.centre).mask
        t_field = best_of(lambda: caster.cast_many([field]))
        t_one = best_of(lambda: caster.cast(field.centre))
        valid = per_block != 255
        sample = sample_field(field, sample_blocks, 7)
        got = caster.cast_many([sample])[0].mask
        twin = ref.cast_field_shadows(hm, sample)
        ties = twin.ties(ref.field_tie_tolerance(hm, sample))
        differ = got != twin.mask
        kept = set(b for b in sample.blocks if b.sun.elevation > 0)
        row = {"map": name, "shape": list(hm.shape), "time": label, "utc": when.isoformat(),
               "centre_sun": [field.centre.azimuth, field.centre.elevation],
               "blocks": len(field.blocks), "deviation_deg": field.deviation, "tolerance_deg": field.tolerance,
               "spread_deg": sun_spread(places, [when]), "field_build_s": build,
               "trace_per_block_s": t_field, "trace_one_sun_s": t_one, "ratio": t_field / t_one,
               "one_sun_wrong_cells": int((per_block != one)[valid].sum()), "valid_cells": int(valid.sum()),
               "twin_blocks": len(kept), "twin_cells": int(sum((b.row1 - b.row0) * (b.col1 - b.col0) for b in kept)),
               "twin_mismatch": int((differ & ~ties).sum()), "twin_tied": int((differ & ties).sum())}
        log(f"{name} {label}: {row['blocks']} blocks, dev {row['deviation_deg']:.4f}, spread "
            f"{row['spread_deg']:.3f} deg, {t_field:.3f} s vs {t_one:.3f} s, one sun wrong on "
            f"{row['one_sun_wrong_cells']} cells, twin {row['twin_mismatch']}/{row['twin_tied']}")
        rows.append(row)
    return rows


def sunshine_days(name: str, raster: Raster, days: float) -> dict:
    """Sunshine sums over ``days`` from the centre's local midnight of 2024-06-21 (10-minute
    steps): per block and with one sun, by both routes of :class:`SunshineCaster`."""
    from oclshade.sunshine import SunshineCaster, time_steps

    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    places = map_places(raster)
    rows, cols = hm.shape
    lon, _ = places.lonlat(np.array([rows / 2]), np.array([cols / 2]))
    start = DAY - timedelta(hours=round(float(lon[0]) / 15.0))
    steps = time_steps(start, start + timedelta(days=days), timedelta(minutes=10))
    t0 = time.perf_counter()
    fields = [sun_field(places, t) for t in steps.times]
    build = time.perf_counter() - t0
    one = [f.centre for f in fields]
    caster = SunshineCaster(hm)
    caster.accumulate([f for f in fields if f.centre.elevation > 5][:1], 600, ("hours", "fraction"))   # warm-up
    land = hm.heights > 0.0
    out = {"map": name, "days": days, "steps": len(steps.times), "land_cells": int(land.sum()),
           "field_build_s": build, "blocks_mean": float(np.mean([len(f.blocks) for f in fields if not f.uniform]
                                                                or [1]))}
    for route, options in (("masks", {}), ("horizons 64", {"method": "horizons", "azimuths": 64})):
        t0 = time.perf_counter()
        per_block = caster.accumulate(fields, steps.seconds, ("hours", "fraction"), **options)
        t1 = time.perf_counter()
        single = caster.accumulate(one, steps.seconds, ("hours", "fraction"), **options)
        t2 = time.perf_counter()
        diff = np.abs(per_block.hours.astype(np.float64) - single.hours)[land]
        out[route] = {"per_block_s": t1 - t0, "one_sun_s": t2 - t1, "daylight_steps": per_block.daylight_suns,
                      "hours_mean": float(np.nanmean(per_block.hours[land])), "diff_mean_h": float(diff.mean()),
                      "diff_p99_h": float(np.percentile(diff, 99)), "diff_max_h": float(diff.max()),
                      "cells_differing": int(np.count_nonzero(diff))}
        log(f"{name} sunshine {days:g} d, {route}: per block {t1 - t0:.1f} s, one sun {t2 - t1:.1f} s; "
            f"{out[route]['cells_differing']} of {out['land_cells']} land cells differ, mean "
            f"{out[route]['diff_mean_h']:.4f} h, max {out[route]['diff_max_h']:.3f} h")
    return out


def sunlit_rows(name: str, raster: Raster, columns: int = 16) -> list[dict]:
    """Soft shadows (``HorizonCaster.sun_disc``, ``columns`` strips) at the 3-degree morning sun:
    per block against the centre's sun alone (one warm-up each, then one timed run each)."""
    from oclshade.horizon import HorizonCaster

    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    places = map_places(raster)
    label, when = morning_times(places)[0]
    field = sun_field(places, when)
    caster = HorizonCaster(hm, cache=False)
    caster.sun_disc(field.centre, columns=columns)
    caster.sun_disc(field, columns=columns)
    t0 = time.perf_counter()
    one = caster.sun_disc(field.centre, columns=columns)
    t1 = time.perf_counter()
    per_block = caster.sun_disc(field, columns=columns)
    t2 = time.perf_counter()
    land = hm.heights > 0.0
    diff = np.abs(per_block.astype(np.float64) - one)[land]
    row = {"map": name, "time": label, "utc": when.isoformat(), "blocks": len(field.blocks), "columns": columns,
           "per_block_s": t2 - t1, "one_sun_s": t1 - t0, "land_cells": int(land.sum()),
           "cells_differing": int(np.count_nonzero(diff)), "diff_max": float(diff.max()),
           "diff_mean": float(diff.mean())}
    log(f"{name} sunlit {label}: per block {t2 - t1:.2f} s, one sun {t1 - t0:.2f} s, "
        f"{row['cells_differing']} land cells differ, max {row['diff_max']:.3f}")
    return [row]


def write_markdown(path: Path, result: dict) -> None:
    m = result["meta"]
    lines = ["# The sun over a map: per block against one sun", "",
             f"- date: {m['date']}; command: `{m['command']}`",
             f"- CPU: {m['cpu']}, {m['cores']} cores; device: {m['device']}; {m['pocl_version']}",
             "- mask times: best of 3 after a warm-up; default tolerance 0.01 deg; the first morning after "
             "2024-06-20T12:00Z at each map's centre (UTC times in the table)", "",
             "| map | time (UTC) | centre sun az / el | spread deg | blocks | deviation deg | per block s | "
             "one sun s | ratio | cells one sun gets wrong | twin: cells checked, mismatches / ties |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in result["rows"]:
        wrong = f"{r['one_sun_wrong_cells']} ({100 * r['one_sun_wrong_cells'] / max(r['valid_cells'], 1):.2f}%)"
        lines.append(f"| {r['map']} | {r['time']}: {r['utc'][11:16]} | {r['centre_sun'][0]:.1f} / "
                     f"{r['centre_sun'][1]:.2f} | {r['spread_deg']:.3f} | {r['blocks']} | {r['deviation_deg']:.4f} | "
                     f"{r['trace_per_block_s']:.3f} | {r['trace_one_sun_s']:.3f} | {r['ratio']:.1f} | {wrong} | "
                     f"{r['twin_cells']} in {r['twin_blocks']} blocks: {r['twin_mismatch']} / {r['twin_tied']} |")
    lines += ["", "## Sunshine: per block against one sun", "",
              "Hours of direct sun over a day from about the local solar midnight of 2024-06-21 (00:00Z minus the "
              "centre's longitude / 15, whole hours), 10-minute steps, `SunshineCaster`; "
              "differences on land cells (height > 0); field build time is for all steps.", "",
              "| map | days | route | daylight steps | mean blocks | fields s | per block s | one sun s | mean hours | "
              "cells differing | mean abs diff h | p99 h | max h |",
              "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in result["sunshine"]:
        for route in ("masks", "horizons 64"):
            e = r[route]
            lines.append(f"| {r['map']} | {r['days']:g} | {route} | {e['daylight_steps']} | {r['blocks_mean']:.0f} | "
                         f"{r['field_build_s']:.1f} | {e['per_block_s']:.1f} | {e['one_sun_s']:.1f} | "
                         f"{e['hours_mean']:.2f} | {e['cells_differing']} of {r['land_cells']} | {e['diff_mean_h']:.4f} | "
                         f"{e['diff_p99_h']:.3f} | {e['diff_max_h']:.3f} |")
    if result.get("sunlit"):
        lines += ["", "## Soft shadows (`sunlit`): per block against one sun", "",
                  "| map | time (UTC) | blocks | strips | per block s | one sun s | land cells differing | "
                  "mean abs diff | max abs diff (share of the disc) |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
        for r in result["sunlit"]:
            lines.append(f"| {r['map']} | {r['time']}: {r['utc'][11:16]} | {r['blocks']} | {r['columns']} | "
                         f"{r['per_block_s']:.2f} | {r['one_sun_s']:.2f} | {r['cells_differing']} of {r['land_cells']} | "
                         f"{r['diff_mean']:.5f} | {r['diff_max']:.3f} |")
    lines.append("")
    path.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reduced", action="store_true", help="384^2 crops and a 512^2 canyon (a check)")
    parser.add_argument("--sample-blocks", type=int, default=12, help="blocks checked against the twin")
    parser.add_argument("--sunshine-days", type=float, default=1.0, help="length of the sunshine period (0: none)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "sun_field")
    parser.add_argument("--sunlit-only", action="store_true",
                        help="only soft shadows (sunlit) per block against one sun, on the SRTM tiles")
    parser.add_argument("--from-json", type=Path, help="write the markdown of this run's JSON and stop")
    args = parser.parse_args(argv)
    if args.from_json is not None:
        write_markdown(args.from_json.with_suffix(".md"), json.loads(args.from_json.read_text()))
        return 0
    result = {"meta": metadata(sys.argv), "rows": [], "sunshine": [], "sunlit": []}
    for name, raster in maps(args.reduced).items():
        if args.sunlit_only:
            result["sunlit"] += sunlit_rows(name, raster) if name.startswith("SRTM") else []
            continue
        result["rows"] += measure(name, raster, args.sample_blocks)
        if name.startswith("SRTM") and args.sunshine_days > 0:
            result["sunshine"].append(sunshine_days(name, raster, args.sunshine_days))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=1))
    write_markdown(args.out.with_suffix(".md"), result)
    log(f"wrote {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
