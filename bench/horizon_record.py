"""Exact horizon maps at the size of the GPU record (issue 19): Timonen & Westerholm 2010,
1024^2 heightmap, 64 azimuths, 23 frames/s on a GTX 280 (about 43 ms a frame).

Per map (1024^2: the generated canyon, and centre crops of the shared SRTM N22W160 tile
and the Puget Sound map when ``../shared/data`` is present), on one OpenCL device:

* ``frame``: a fresh caster (extrema pyramid built, caches off) and the horizon angles of
  all 64 azimuths on the device, ``queue.finish()`` at the end: what one frame of the
  record computes;
* ``frame + readback``: the same, the 64 bands copied to host memory (``horizons(64)``);
* ``svf``: the sky-view factor of the 64 azimuths summed on the device (no angles written);
* ``frame`` by each forced route (``--routes``): every azimuth swept (``sweep_far`` 2) and
  every azimuth walked over the pyramid (``sweep_cells`` 0, ``sweep_far`` 0).  The default
  frame takes the device's knobs: past ``sweep_cells`` crossings the pilot times both routes
  on bands of rows, once per caster, so inside every default frame here (a fresh caster); the
  route it took and its ratio are recorded.  The routes give the same bits (bench/horizon_sweep.py);

each the minimum (and median) of ``--reps`` runs after a warm-up that includes the builds.
The angles are checked against the float64 reference on ``--samples`` seeded cells x every
azimuth (bench/solar.py's ``reference_error``): the run fails if any is outside the float32
band.  Every map is timed before the first check (the slow part, on the host), and
``horizon_record.json`` and ``.md`` are written to ``--out`` after each map's timings and
each check, so a run cut short keeps what it measured.  Figures depend on the device; the
JSON records which.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from shadow_masks import DEFAULT_DATA, Skip, load_dataset  # noqa: E402
from solar import reference_error  # noqa: E402

from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.bench.timing import time_case  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade import tuning  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.runtime import get_runtime  # noqa: E402

#: the knobs of each forced route (bench/horizon_sweep.py's modes)
ROUTES = {"sweep": {"sweep_far": 2}, "walk": {"sweep_cells": 0, "sweep_far": 0}}
RECORD = {"paper": "Timonen & Westerholm 2010", "device": "NVIDIA GTX 280", "size": 1024, "azimuths": 64,
          "frames_per_s": 23.0}
MAPS = ("canyon", "srtm_N22W160", "puget")


def timed(fn: Callable[[], object], reps: int) -> dict:
    """Min and median ms of ``reps`` runs after a warm-up (oclshade.bench.timing.time_case)."""
    t = time_case(fn, reps, math.inf)
    return {"min_ms": round(1e3 * t.min_s, 3), "median_ms": round(1e3 * t.median_s, 3)}


def load(name: str, size: int, data: Path) -> Heightmap:
    d = load_dataset(name, size, data)
    return Heightmap.from_array(d["heights"].astype(np.float32), (d["dx"], d["dy"]))


def measure(hm: Heightmap, device: str | None, n: int, reps: int, routes: tuple[str, ...]) -> dict:
    """The timings of one map (no check)."""
    rt = get_runtime(device)
    last: list[HorizonCaster] = []

    def frame(knobs: dict | None = None) -> None:
        caster = HorizonCaster(hm, rt, cache=False, knobs=knobs)
        for _ in caster.angles_on_device(n):
            pass
        rt.queue.finish()
        last[:] = [caster]

    def frame_readback() -> np.ndarray:
        return HorizonCaster(hm, rt, cache=False).horizons(n)

    def svf() -> None:
        HorizonCaster(hm, rt, cache=False).sky_view_factor(n)

    out = {"frame": timed(frame, reps)}
    caster = last[0]
    out["swept_azimuths"] = int(sum(bool(caster.takes_sweep(az)) for az in azimuth_grid(n)))
    out["pilot"] = None if caster.pilot is None else vars(caster.pilot)
    out["frames_per_s"] = round(1e3 / out["frame"]["min_ms"], 2)
    out["routes"] = {route: timed(lambda: frame(ROUTES[route]), reps) for route in routes}
    out["frame_readback"], out["svf"] = timed(frame_readback, reps), timed(svf, reps)
    return out


def write(res: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "horizon_record.json").write_text(json.dumps(res, indent=1) + "\n")
    (out / "horizon_record.md").write_text(markdown(res))


def markdown(res: dict) -> str:
    r = res["record"]
    lines = [f"# Exact horizons at the record's size ({res['device']['name']})", "",
             f"{res['size']}^2, {res['azimuths']} azimuths; the record (1024^2, 64 azimuths): {r['paper']}, {r['frames_per_s']:g} frames/s "
             f"on an {r['device']} ({1e3 / r['frames_per_s']:.1f} ms). Min (median) of {res['reps']} runs, "
             "fresh pyramid each.", "",
             "| map | frame (ms) | frames/s | x record | azimuths swept (pilot walk / sweep) | "
             + "".join(f"{route} frame (ms) | " for route in res["routes"])
             + "+ readback (ms) | SVF (ms) | vs float64 (max deg, outside band) |",
             "|---" * (8 + len(res["routes"])) + "|"]
    for name, m in res["maps"].items():
        c = m.get("check")
        check = f"{c['max_abs_deg']:.2g}, {c['outside_band']} of {c['cells']} x {res['azimuths']}" if c else "not run"
        pilot = (f" ({m['pilot']['walk_seconds'] / m['pilot']['sweep_seconds']:.2f})" if m["pilot"] else "")
        lines.append(f"| {name} | {m['frame']['min_ms']:.1f} ({m['frame']['median_ms']:.1f}) | {m['frames_per_s']:.1f} "
                     f"| {m['frames_per_s'] / r['frames_per_s']:.2f} | {m['swept_azimuths']} of {res['azimuths']}{pilot} | "
                     + "".join(f"{m['routes'][route]['min_ms']:.1f} | " for route in res["routes"])
                     + f"{m['frame_readback']['min_ms']:.1f} | {m['svf']['min_ms']:.1f} | {check} |")
    d, mf = res["device"], res["machine"]
    lines += ["", f"Device: {d['name']} ({d['platform']}, driver {d['driver']}, {d['version']}); "
              f"host CPU {mf['cpu']}, {mf['cores']} cores; {mf['date']}.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default=None, help="OpenCL device: index or name substring")
    ap.add_argument("--size", type=int, default=RECORD["size"])
    ap.add_argument("--azimuths", type=int, default=RECORD["azimuths"])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--samples", type=int, default=500, help="reference cells per map")
    ap.add_argument("--routes", default=",".join(ROUTES),
                    help=f"comma-separated forced routes to time as well: a subset of {', '.join(ROUTES)} (default all; "
                         "'' for none)")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=Path("bench/results"))
    ap.add_argument("--quick", action="store_true", help="smoke run: 128^2, 8 azimuths, 1 rep, 20 cells")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.azimuths, args.reps, args.samples = 128, 8, 1, 20
    routes = tuple(r.strip() for r in args.routes.split(",") if r.strip())
    if not set(routes) <= set(ROUTES):
        ap.error(f"--routes takes a comma-separated subset of {', '.join(ROUTES)}, got {args.routes!r}")
    rt = get_runtime(args.device)
    res = {"record": RECORD, "size": args.size, "azimuths": args.azimuths, "reps": args.reps, "routes": list(routes),
           "knobs": {k: tuning.settings(rt, "horizon").values[k] for k in ("sweep_cells", "sweep_far")},
           "machine": machine_facts(), "command": " ".join(["python", *sys.argv]),
           "device": {"name": rt.device.name, "platform": rt.device.platform.name,
                      "driver": rt.device.driver_version, "version": rt.device.version}, "maps": {}}
    heightmaps = {}
    for name in MAPS:                  # every map's timings first, then the slow float64 checks
        try:
            heightmaps[name] = hm = load(name, args.size, args.data)
        except Skip as why:
            print(f"{name}: skipped ({why})", file=sys.stderr)
            continue
        res["maps"][name] = m = measure(hm, args.device, args.azimuths, args.reps, routes)
        print(f"{name}: frame {m['frame']['min_ms']:.1f} ms ({m['frames_per_s']:.1f}/s), "
              + "".join(f"{route} {m['routes'][route]['min_ms']:.1f} ms, " for route in routes)
              + f"readback {m['frame_readback']['min_ms']:.1f} ms, svf {m['svf']['min_ms']:.1f} ms", file=sys.stderr)
        write(res, args.out)
    for name, hm in heightmaps.items():
        m = res["maps"][name]
        m["check"] = reference_error(hm, HorizonCaster(hm, rt, cache=False).horizons(args.azimuths), args.samples)
        print(f"{name}: check {m['check']}", file=sys.stderr)
        write(res, args.out)
    print(markdown(res))
    bad = [n for n, m in res["maps"].items() if m["check"]["outside_band"]]
    if bad:
        print(f"horizon_record: angles outside the float32 band on {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
