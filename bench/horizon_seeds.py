"""The seeded horizon walk against the walk from nothing, same maps, one process (issue 19).

kernels/horizon.cl, "Seeds": over the whole map each cell's walk starts from a lower bound
carried from the exact walk on every 8th row and column.  The walk from nothing is the same
kernel with a search radius beyond the map (``max_distance`` = twice the map's diagonal: the
same rays, no seeds, plus one radius comparison per step).  Per map and azimuth, alternating
the two (minimum of ``--reps``; both built and warmed up on the first azimuth):

* both times and their ratio;
* the cells whose angles differ (the last float32 bits, where a skipped tile changes the order
  of patch boundaries) and the largest difference;
* both against the float64 reference on ``--samples`` seeded cells (bench/solar.py's
  ``reference_error``): the run fails if any angle is outside the float32 band.

Maps: the generated canyon (``--side``), and the shared SRTM tiles when ``../shared/data`` is
present.  Writes ``horizon_seeds.json`` and ``.md`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from solar import maps, reference_error  # noqa: E402

from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import Curvature, HorizonCaster  # noqa: E402
from oclshade.runtime import Runtime, get_runtime  # noqa: E402


def measure(rt: Runtime, hm: Heightmap, azimuths: list[float], curved: bool, reps: int, samples: int) -> dict:
    curvature = Curvature() if curved else None
    diagonal = math.hypot(hm.shape[0] * hm.dy, hm.shape[1] * hm.dx)
    seeded = HorizonCaster(hm, rt, cache=False, curvature=curvature)
    from_nothing = HorizonCaster(hm, rt, cache=False, curvature=curvature, max_distance=2.0 * diagonal)
    casters = {"seeded": seeded, "from_nothing": from_nothing}
    for caster in casters.values():      # warm-up: pyramid and kernel builds
        caster.horizons(azimuths[:1])
    rows = []
    for az in azimuths:
        got: dict[str, np.ndarray] = {}
        seconds: dict[str, list[float]] = {name: [] for name in casters}
        for _ in range(reps):            # alternate, so that drift hits both alike
            for name, caster in casters.items():
                start = time.perf_counter()
                got[name] = caster.horizons([az])[0]
                seconds[name].append(time.perf_counter() - start)
        a, b = got["seeded"], got["from_nothing"]
        differ = (a != b) & ~(np.isnan(a) & np.isnan(b))
        checks = {name: reference_error(hm, got[name][None], samples, curvature=seeded.coefficient,
                                        azimuths=np.array([az]))
                  for name in got}
        for name, check in checks.items():
            if check["outside_band"]:
                raise SystemExit(f"{name} at azimuth {az}: {check['outside_band']} angles outside the band")
        rows.append({"azimuth": az, "seeded_s": min(seconds["seeded"]),
                     "from_nothing_s": min(seconds["from_nothing"]),
                     "speedup": min(seconds["from_nothing"]) / min(seconds["seeded"]),
                     "cells_differing": int(differ.sum()), "cells": int(a.size),
                     "max_abs_difference_deg": float(np.max(np.abs(a - b)[differ])) if differ.any() else 0.0,
                     "reference": checks})
    return {"shape": list(hm.shape), "curved": curved, "azimuths": rows}


def markdown(result: dict) -> str:
    m = result["machine"]
    lines = ["# The seeded horizon walk against the walk from nothing (issue 19)", "",
             f"Machine: {m['cpu']}, {m['cores']} cores; device {m['device']} ({m['device_version']}); "
             f"{m['date']}.", "", f"`{result['command']}`", "",
             "Seeded: the whole-map walk from its seeds' bound (kernels/horizon.cl, \"Seeds\"); from "
             "nothing: the same rays with a search radius beyond the map (no seeds). Minimum of "
             f"{result['reps']} alternated runs per azimuth, one caster each, its pyramid and kernels "
             "built on a warm-up. Both sets of angles are within the float32 band of the float64 reference on "
             f"{result['samples']} sampled cells (the run fails otherwise).", "",
             "| map | curvature | azimuth | seeded s | from nothing s | speed-up | cells differing (max abs deg) |",
             "|---|---|---:|---:|---:|---:|---|"]
    for name, entry in result["maps"].items():
        for r in entry["azimuths"]:
            lines.append(f"| {name} {entry['shape'][1]}x{entry['shape'][0]} | "
                         f"{'yes' if entry['curved'] else 'no'} | {r['azimuth']:g} | {r['seeded_s']:.2f} | "
                         f"{r['from_nothing_s']:.2f} | {r['speedup']:.2f}x | {r['cells_differing']} of "
                         f"{r['cells']} ({r['max_abs_difference_deg']:.1e}) |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--side", type=int, default=2048, help="the canyon's side in cells (default 2048)")
    ap.add_argument("--maps", default="canyon,N22W160,S16E166",
                    help="comma-separated subset of canyon, N22W160, S16E166 (default all)")
    ap.add_argument("--azimuths", default="37,200", help="comma-separated azimuths in degrees (default 37,200)")
    ap.add_argument("--curved", action="store_true", help="with the Earth's curvature (mean radius)")
    ap.add_argument("--reps", type=int, default=2, help="alternated runs per azimuth (default 2)")
    ap.add_argument("--samples", type=int, default=500, help="reference cells per map (default 500)")
    ap.add_argument("--quick", action="store_true", help="smoke run: a 96^2 canyon, 1 rep, 20 cells")
    ap.add_argument("--out", type=Path, default=Path("bench/results"))
    args = ap.parse_args(argv)
    side, keys = (96, ("canyon",)) if args.quick else (args.side, tuple(args.maps.split(",")))
    reps, samples = (1, 20) if args.quick else (args.reps, args.samples)
    azimuths = [float(a) for a in args.azimuths.split(",")]
    rt = get_runtime()
    result = {"machine": {**machine_facts(), "device": rt.label, "device_version": rt.device.version.strip()}, "command": "python bench/horizon_seeds.py " +
              " ".join(argv if argv is not None else sys.argv[1:]), "reps": reps, "samples": samples, "maps": {}}
    for name, hm in maps(False, keys, side).items():
        result["maps"][name] = measure(rt, hm, azimuths, args.curved, reps, samples)
        print(f"{name}: {json.dumps(result['maps'][name]['azimuths'], default=str)[:300]}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "horizon_seeds.json").write_text(json.dumps(result, indent=1))
    (args.out / "horizon_seeds.md").write_text(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
