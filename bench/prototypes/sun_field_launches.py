"""Sunshine per block of a sun field, timed in this checkout and another (prototype: the cost
of launching a field's blocks, docs/solar.md "The sun over a map").

    python bench/prototypes/sun_field_launches.py OTHER_CHECKOUT [--rounds 2]

Each round runs this file's ``--child`` once per checkout, alternating (each in its own
process, its own ``oclshade`` on ``sys.path``): a day of 10-minute sun fields over the shared
SRTM N22W160 tile (as bench/sun_field.py's sunshine part), ``SunshineCaster.accumulate`` per
block (masks route) and with the centre sun, timed after a warm-up; the hours are saved and
compared bit for bit between the checkouts.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from datetime import timedelta
from pathlib import Path

HERE = Path(__file__).resolve()


def child(repo: Path, out: Path) -> None:
    sys.path.insert(0, str(repo))
    sys.path.insert(0, str(HERE.parents[1]))
    import numpy as np
    from sun_field import DAY, maps

    from oclshade.heightmap import Heightmap
    from oclshade.solar import map_places, sun_field
    from oclshade.sunshine import SunshineCaster, time_steps

    raster = maps(False)["SRTM N22W160"]
    hm = Heightmap.from_array(raster.heights, (raster.dx, raster.dy))
    places = map_places(raster)
    lon, _ = places.lonlat(np.array([hm.shape[0] / 2]), np.array([hm.shape[1] / 2]))
    start = DAY - timedelta(hours=round(float(lon[0]) / 15.0))
    steps = time_steps(start, start + timedelta(days=1), timedelta(minutes=10))
    fields = [sun_field(places, t) for t in steps.times]
    caster = SunshineCaster(hm)
    caster.accumulate([f for f in fields if f.centre.elevation > 5][:1], 600)      # warm-up
    t0 = time.perf_counter()
    per_block = caster.accumulate(fields, steps.seconds)
    t1 = time.perf_counter()
    caster.accumulate([f.centre for f in fields], steps.seconds)
    t2 = time.perf_counter()
    np.save(out / f"{repo.name}_hours.npy", per_block.hours)
    print(json.dumps({"repo": str(repo), "per_block_s": t1 - t0, "one_sun_s": t2 - t1,
                      "daylight_steps": per_block.daylight_suns}))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("other", type=Path, nargs="?")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--child", type=Path)
    ap.add_argument("--out", type=Path, default=Path("/tmp/sun_field_launches"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.child:
        child(args.child.resolve(), args.out)
        return 0
    repos = [HERE.parents[2], args.other.resolve()]
    for r in range(args.rounds):
        for repo in repos if r % 2 == 0 else repos[::-1]:
            done = subprocess.run([sys.executable, str(HERE), "--child", str(repo), "--out", str(args.out)],
                                  capture_output=True, text=True, check=True)
            print(f"round {r}: {done.stdout.strip()}", flush=True)
    import numpy as np
    a, b = (np.load(args.out / f"{repo.name}_hours.npy") for repo in repos)
    print("hours equal bit for bit:", a.tobytes() == b.tobytes())
    return 0


if __name__ == "__main__":
    sys.exit(main())
