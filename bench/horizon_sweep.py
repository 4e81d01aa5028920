"""The sweep against the walk within a search radius, same maps, one process (issue 19).

kernels/horizon.cl, "The sweep": within a short radius the cells of a row step through the
same patches together on vector lanes, without the pyramid; the hosts sweep an azimuth whose
ray crosses at most the tuning knob ``sweep_cells`` patch columns and rows within the radius,
and past that the knob ``sweep_far`` decides: by default (1) the Python host's pilot times both
on bands of rows at the first such azimuth and takes the faster on that map
(oclshade/horizon/caster.py, pilot.py).  This script measures where each pays.  Per map and radius
(``--radii``, cells of RVT's cell size 0.5 (dx + dy), as bench/solar.py), ``--azimuths``
azimuths of the solid-angle sky-view factor, alternating (minimum of ``--reps``; every kernel
built and warmed up before):

* ``sweep``: every azimuth swept (``sweep_far`` 2); ``walk``: every azimuth walked (the pyramid
  walk cut at R; ``sweep_cells`` 0, ``sweep_far`` 0); ``default``: the Python host's choice (the
  device's knobs: past ``sweep_cells`` the pilot, which runs once per caster, in the one-azimuth
  warm-up or the first timed run, so the minimum leaves it out; its own seconds are in the table);
* the mean number of patch columns and rows a ray crosses within R, R (|ux| + |uy|);
* the angles that differ between the sweep and the walk (the run fails if any does: they are
  the same bits), and both against the float64 reference on ``--samples`` seeded cells
  (bench/solar.py's ``reference_error``): the run fails if any angle is outside the float32 band;
* RVT's sky-view factor at the same radius and azimuths (``rvt-py``, when installed), same run.

Maps: the generated canyon (``--side``), and the shared SRTM tiles when ``../shared/data``
is present.  Writes ``horizon_sweep.json`` and ``.md`` to ``--out``.

    python bench/horizon_sweep.py --out bench/results
    python bench/horizon_sweep.py --quick --out /tmp/x      # a check: canyon 96^2, 5 and 200 cells
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from solar import MAP_KEYS, maps, reference_error, rvt_svf  # noqa: E402

from oclshade.bench.machine import machine_facts  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.horizon.pilot import RUNS as PILOT_RUNS  # noqa: E402
from oclshade import tuning  # noqa: E402
from oclshade.runtime import Runtime, get_runtime  # noqa: E402
from oclshade.sun import Sun  # noqa: E402

#: the knobs of each mode (None: the device's own)
MODES = {"sweep": {"sweep_far": 2}, "walk": {"sweep_cells": 0, "sweep_far": 0}, "default": None}


def svf_seconds(caster: HorizonCaster, n: int) -> tuple[float, np.ndarray]:
    start = time.perf_counter()
    svf = caster.sky_view_factor(n, "solid-angle")
    return time.perf_counter() - start, svf


def measure(rt: Runtime, hm: Heightmap, radius_cells: float, n: int, reps: int, samples: int,
            with_rvt: bool) -> dict:
    radius = radius_cells * 0.5 * (hm.dx + hm.dy)
    casters = {name: HorizonCaster(hm, rt, cache=False, max_distance=radius,
                                   knobs=knobs)
               for name, knobs in MODES.items()}
    caster = casters["default"]
    for name, c in casters.items():      # warm-up: the pyramid and every kernel build
        svf_seconds(c, 1)
    seconds: dict[str, list[float]] = {name: [] for name in MODES}
    svf: dict[str, np.ndarray] = {}
    for _ in range(reps):                # alternate, so that drift hits all alike
        for name, c in casters.items():
            t, svf[name] = svf_seconds(c, n)
            seconds[name].append(t)
    crossings = [caster.radius * (abs(ux) + abs(uy))
                 for ux, uy, _ in (Sun(float(az), 0.0).ray(hm.dx, hm.dy) for az in azimuth_grid(n))]
    swept, walked = casters["sweep"].horizons(n), casters["walk"].horizons(n)
    differ = swept.view(np.uint32) != walked.view(np.uint32)
    if differ.any():                     # kernels/horizon.cl, "The sweep": the same bits
        raise SystemExit(f"{int(differ.sum())} angles differ between the sweep and the walk on {hm.shape}, "
                         f"R {radius_cells} cells")
    checks = {name: reference_error(hm, a, samples, max_distance=caster.radius)
              for name, a in (("sweep", swept), ("walk", walked))}
    for name, check in checks.items():
        if check["outside_band"]:
            raise SystemExit(f"{name}: {check['outside_band']} angles outside the float32 band "
                             f"(max {check['max_abs_deg']:.3g} deg) on {hm.shape}, R {radius_cells} cells")
    best = {name: min(s) for name, s in seconds.items()}
    row = {"radius_cells": radius_cells, "radius_m": caster.radius, "azimuths": n,
           "crossings_mean": float(np.mean(crossings)), "crossings_max": float(np.max(crossings)),
           "sweep_cells": caster.knobs["sweep_cells"],
           "sweep_far": caster.knobs["sweep_far"],
           "swept_azimuths": int(sum(bool(caster.takes_sweep(az)) for az in azimuth_grid(n))),
           "pilot": None if caster.pilot is None else vars(caster.pilot),
           "seconds": best, "walk_over_sweep": best["walk"] / best["sweep"],
           "walk_over_default": best["walk"] / best["default"],
           "angles_differing": int(differ.sum()), "angles": int(differ.size),
           "svf_max_abs_difference": float(np.nanmax(np.abs(svf["sweep"] - svf["walk"]))),
           "reference": checks}
    if with_rvt:
        rvt_seconds, rvt = rvt_svf(hm, n, int(radius_cells))
        row["rvt_seconds"] = rvt_seconds
        row["rvt_over_default"] = rvt_seconds / best["default"]
        row["rvt_minus_ours_svf_mean_abs"] = float(np.nanmean(np.abs(rvt - svf["default"])))
    return row


def markdown(res: dict) -> str:
    m = res["machine"]
    lines = ["# The sweep against the walk within a search radius (issue 19)", "",
             f"Machine: {m['cpu']}, {m['cores']} cores; device {m['device']} ({m['device_version']}). "
             f"`{res['command']}`, {res['when']}.", "",
             f"Solid-angle sky-view factor over {res['azimuths']} azimuths within R (cells of 0.5 (dx + dy)), "
             f"minimum of {res['reps']} alternating runs: every azimuth swept, every azimuth "
             f"walked (the pyramid walk cut at R), and the default (an azimuth is swept where its ray crosses at "
             f"most the device's knob sweep_cells = {res['sweep_cells']} patch columns and rows within R; past "
             f"that, sweep_far = {res['sweep_far']}: 1 the pilot's choice, timed on bands of rows once, in the warm-up "
             f"or the first run; pilot: its walk / sweep seconds, and the seconds it timed). Crossings: R (|ux| + |uy|), "
             f"mean / max over the azimuths. Angles compared bit for bit (sweep against walk) and against the "
             f"float64 reference on {res['samples']} cells x every azimuth.", "",
             "| map | R (cells) | crossings mean / max | swept azimuths | sweep s | walk s | default s | "
             "walk / sweep | walk / default | pilot | angles differing | ref. max diff sweep / walk (deg) | "
             "RVT s | RVT / default |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---|---:|---:|"]
    for name, rows in res["maps"].items():
        for r in rows:
            s = r["seconds"]
            ref_s, ref_w = r["reference"]["sweep"], r["reference"]["walk"]
            rvt = (f"{r['rvt_seconds']:.2f} | {r['rvt_over_default']:.2f}x" if "rvt_seconds" in r else "- | -")
            p = r.get("pilot")
            pilot = "-" if p is None else (f"{p['walk_seconds'] / p['sweep_seconds']:.2f}x, "
                                           f"{PILOT_RUNS * (p['walk_seconds'] + p['sweep_seconds']):.2f} s")
            lines.append(
                f"| {name} | {r['radius_cells']:g} | {r['crossings_mean']:.1f} / {r['crossings_max']:.1f} | "
                f"{r['swept_azimuths']} of {r['azimuths']} | {s['sweep']:.2f} | {s['walk']:.2f} | {s['default']:.2f} | "
                f"{r['walk_over_sweep']:.2f}x | {r['walk_over_default']:.2f}x | {pilot} | "
                f"{r['angles_differing']} of {r['angles']} | "
                f"{ref_s['max_abs_deg']:.1e} / {ref_w['max_abs_deg']:.1e} | {rvt} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="N22W160,S16E166,canyon", help=f"comma-separated, of {', '.join(MAP_KEYS)}")
    ap.add_argument("--side", type=int, default=1024, help="the canyon's side in cells")
    ap.add_argument("--radii", default="5,10,20,30,40,60", help="search radii in cells, comma-separated")
    ap.add_argument("--azimuths", type=int, default=16)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--samples", type=int, default=300, help="cells checked against the float64 reference")
    ap.add_argument("--no-rvt", action="store_true", help="leave RVT out")
    ap.add_argument("--quick", action="store_true", help="smoke run: a 96^2 canyon, 5 and 200 cells, 4 azimuths, "
                    "1 rep, 20 cells")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    if args.quick:
        args.maps, args.side, args.radii, args.azimuths, args.reps, args.samples = "canyon", 96, "5,200", 4, 1, 20
    keys = tuple(k.strip() for k in args.maps.split(",") if k.strip())
    unknown = [k for k in keys if k not in MAP_KEYS]
    if unknown:
        ap.error(f"--maps: unknown {', '.join(unknown)}; expected some of {', '.join(MAP_KEYS)}")
    radii = [float(r) for r in args.radii.split(",")]
    try:
        import rvt.vis  # noqa: F401
        with_rvt = not args.no_rvt
    except ImportError:
        with_rvt = False
    rt = get_runtime(None)
    res = {"machine": {**machine_facts(), "device": rt.label, "device_version": rt.device.version.strip()},
           "command": "python " + " ".join(sys.argv),
           "when": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "azimuths": args.azimuths, "reps": args.reps,
           "samples": args.samples,
           **{k: tuning.settings(rt, "horizon").values[k] for k in ("sweep_cells", "sweep_far")}, "maps": {}}
    for name, hm in maps(False, keys, args.side).items():
        res["maps"][name] = []
        for radius in radii:
            res["maps"][name].append(measure(rt, hm, radius, args.azimuths, args.reps, args.samples, with_rvt))
            print(json.dumps({name: res["maps"][name][-1]["seconds"], "R": radius}), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "horizon_sweep.json").write_text(json.dumps(res, indent=2, default=str))
    (args.out / "horizon_sweep.md").write_text(markdown(res))
    print(markdown(res))


if __name__ == "__main__":
    main()
