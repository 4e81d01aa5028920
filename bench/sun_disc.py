#!/usr/bin/env python
"""Soft shadows (issue 19): the error of K strips across the sun's disc against 256, and
their time, in one run.

    python bench/sun_disc.py               # generated canyon 96^2 + a 96^2 crop of SRTM S16E166
    python bench/sun_disc.py --reduced     # a check that the script works (32^2 maps)

For each map and sun: the float64 reference with 256 strips
(:func:`oclshade.reference.sun_disc_fraction`, the truth), then oclshade's
``HorizonCaster.sun_disc`` with K = 4, 8, 16, 32, 64 strips: max and 99th-percentile
|error| over the penumbra cells (0 < truth < 1) and over all cells, the share of the map
in penumbra, and the device time (K horizon passes).  Writes bench/results/sun_disc.{json,md}.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))
from shadow_masks import metadata  # noqa: E402

from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import SUN_RADIUS, HorizonCaster  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.reference.sun_disc import sun_disc_fraction  # noqa: E402
from oclshade.synthetic import canyon_crater  # noqa: E402

SRTM = REPO.parent / "shared" / "data" / "dem" / "srtm3_srtmpy" / "S16E166v2.3a.hgt.zip"
SUNS = [(300.0, 2.0), (135.0, 5.0), (45.0, 15.0)]
STRIPS = (4, 8, 16, 32, 64)


def maps(n: int) -> list[tuple[str, Heightmap]]:
    out = [(f"canyon {n}^2 (10 m)", Heightmap.from_array(canyon_crater(n, seed=3, relief=800.0), 10.0))]
    if SRTM.exists():
        r = read_dem(str(SRTM))
        h = r.heights[192:192 + 96, 720:720 + 96][:n, -n:]      # the steepest void-free 96^2 window
        out.append((f"S16E166 crop {n}^2", Heightmap.from_array(h, (r.dx, r.dy))))
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reduced", action="store_true")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    args = p.parse_args()
    n = 32 if args.reduced else 96
    rows = []
    for name, hm in maps(n):
        caster = HorizonCaster(hm)
        caster.sun_disc(SUNS[0], columns=1)                  # build the pyramid and the kernel
        for sun in SUNS:
            t0 = time.perf_counter()
            truth = sun_disc_fraction(hm, sun, SUN_RADIUS, columns=256)
            ref_s = time.perf_counter() - t0
            pen = (truth > 0) & (truth < 1)
            row = {"map": name, "sun": sun, "penumbra_share": float(pen.mean()), "reference_s": ref_s, "strips": {}}
            for k in STRIPS:
                t0 = time.perf_counter()
                f = caster.sun_disc(sun, columns=k)
                dt = time.perf_counter() - t0
                err = np.abs(f - truth)
                row["strips"][k] = {"s": dt, "max": float(err.max()),
                                    "p99_penumbra": float(np.percentile(err[pen], 99)) if pen.any() else 0.0,
                                    "mean_penumbra": float(err[pen].mean()) if pen.any() else 0.0}
            rows.append(row)
            print(name, sun, {k: round(v["max"], 4) for k, v in row["strips"].items()}, file=sys.stderr, flush=True)
    meta = metadata(sys.argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sun_disc.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    lines = ["# Soft shadows: strips across the sun's disc against 256", "",
             f"- {meta['date']}; {meta['cpu']}, {meta['cores']} cores; {meta['device']} ({meta['pocl_version']})",
             f"- command: `python bench/sun_disc.py{' --reduced' if args.reduced else ''}`; "
             f"disc radius {SUN_RADIUS} degrees", "",
             "Error = |share of the disc seen| against the float64 reference with 256 strips; max over "
             "all cells / 99th percentile and mean over the penumbra cells (0 < truth < 1).", "",
             "| map | sun az/el | penumbra | " + " | ".join(f"K = {k}" for k in STRIPS) + " |",
             "|---|---|---|" + "---|" * len(STRIPS)]
    for r in rows:
        cells = [f"{v['max']:.4f} / {v['p99_penumbra']:.4f} / {v['mean_penumbra']:.4f}" for v in r["strips"].values()]
        lines.append(f"| {r['map']} | {r['sun'][0]:g}/{r['sun'][1]:g} | {100 * r['penumbra_share']:.1f} % | "
                     + " | ".join(cells) + " |")
    lines += ["", "Time (s) of `HorizonCaster.sun_disc` (K horizon passes, bands copied to the host):", "",
              "| map | sun az/el | " + " | ".join(f"K = {k}" for k in STRIPS) + " |", "|---|---|" + "---|" * len(STRIPS)]
    for r in rows:
        lines.append(f"| {r['map']} | {r['sun'][0]:g}/{r['sun'][1]:g} | "
                     + " | ".join(f"{v['s']:.3f}" for v in r["strips"].values()) + " |")
    (args.out / "sun_disc.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
