"""Where a batched horizon frame's time goes on one device, and launch and build variants
(prototype for issue 19's GPU record; docs/gpu.md, "The horizon record").

Per map (1024^2 by default, 64 azimuths, the maps of bench/horizon_record.py): the pyramid's
build, then the seeded walk of all azimuths as two launches (horizon_seeds_batch and
horizon_cells_batch, kernels/horizon.cl "Batches"), each timed alone (``queue.finish()``
around it, the minimum of ``--reps``).  Then the cells launch again under variants:

* work-group shapes (the launch alone; the angles must be the same bits),
* extra build options (``--option``, e.g. NVIDIA's ``-cl-nv-maxrregcount=32``; same bits),
* the pyramid's knob ``in_place`` the other way (its build, and the walk over it),
* other seed strides (``--stride``: the kernel's OCLS_SEED_STRIDE; part of the algorithm, so
  a few cells' last bits may differ: counted, with the largest difference in degrees).

With ``--verbose-build`` on NVIDIA's platform the default build's log (registers, spills) is printed.
Writes ``horizon_gpu_profile.json`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pyopencl as cl

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from horizon_record import load  # noqa: E402
from shadow_masks import DEFAULT_DATA, Skip  # noqa: E402

from oclshade import tuning  # noqa: E402
from oclshade.horizon import HorizonCaster, azimuth_grid  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.pyramid import build_extrema_pyramid  # noqa: E402
from oclshade.runtime import define_options, get_runtime, kernel_source, rounding_options  # noqa: E402

SHAPES = ((16, 4), (8, 8), (32, 2), (64, 1), (32, 1), (8, 4), (16, 16), (32, 8))


def build(rt, stride: int = 8, extra: tuple[str, ...] = ()) -> cl.Program:
    src = kernel_source("horizon.cl")
    if stride != 8:
        src = src.replace("#define OCLS_SEED_STRIDE 8", f"#define OCLS_SEED_STRIDE {stride}")
    options = [*define_options({"OCLS_OUT_ANGLE": True}), "-cl-std=CL1.2", *rounding_options(rt.device), *extra]
    return cl.Program(rt.context, src).build(options=options)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default=None)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--azimuths", type=int, default=64)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--maps", default="canyon,srtm_N22W160,puget")
    ap.add_argument("--option", action="append", default=[], help="an extra build option to try (repeatable)")
    ap.add_argument("--stride", type=int, action="append", default=[], help="a seed stride to try (repeatable)")
    ap.add_argument("--verbose-build", action="store_true")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--out", type=Path, default=Path("/tmp"))
    args = ap.parse_args()
    rt = get_runtime(args.device)
    n = args.azimuths
    res = {"device": rt.device.name, "driver": rt.device.driver_version, "size": args.size, "azimuths": n,
           "maps": {}}
    verbose = args.verbose_build and "NVIDIA" in rt.device.platform.name    # an NVIDIA build option
    default = build(rt, extra=("-cl-nv-verbose",) if verbose else ())
    if verbose:
        log = default.get_build_info(rt.device, cl.program_build_info.LOG)
        print("build log:\n" + "\n".join(line for line in log.splitlines() if "horizon_" in line or "registers" in line
                                         or "spill" in line or "Used" in line), file=sys.stderr)
    build_extrema_pyramid(Heightmap.from_array(np.zeros((8, 8))), rt)   # its programs built before any timing
    kernels: dict[cl.Program, tuple[cl.Kernel, cl.Kernel]] = {}
    programs = {("stride", s): build(rt, stride=s) for s in args.stride}
    programs.update({("option", o): build(rt, extra=(o,)) for o in args.option})
    for name in args.maps.split(","):
        try:
            hm = load(name, args.size, args.data)
        except Skip as why:
            print(f"{name}: skipped ({why})", file=sys.stderr)
            continue
        rows, cols = hm.shape
        caster = HorizonCaster(hm, rt, cache=False)
        rt.queue.finish()
        t = time.perf_counter()
        pyr = caster.pyramid
        rt.queue.finish()
        m = {"pyramid_ms": 1e3 * (time.perf_counter() - t)}
        rays = rt.to_device(np.stack([caster._ray(float(a)) for a in azimuth_grid(n)]), "rays")
        fixed = (pyr.heights, np.int32(rows), np.int32(cols), pyr.buffer, pyr.offsets, np.int32(pyr.levels))
        angle = rt.empty(4 * rows * cols * n, "angles")
        cell = np.array([hm.dx, hm.dy], np.float32)

        def run(prog: cl.Program, local: tuple[int, int] = (16, 4), stride: int = 8) -> tuple[float, float, np.ndarray]:
            hs, ws = (rows - 1) // stride + 2, (cols - 1) // stride + 2
            seeds = rt.empty(8 * hs * ws * n, "seeds")
            if prog not in kernels:
                kernels[prog] = (cl.Kernel(prog, "horizon_seeds_batch"), cl.Kernel(prog, "horizon_cells_batch"))
            seeder, walker = kernels[prog]
            seeder.set_args(*fixed, rays, seeds, np.int32(0))
            walker.set_args(*fixed, rays, angle, caster._dummy, seeds, cell, np.int32(rows * cols), np.int32(0),
                            np.int32(n))
            times = []
            for _ in range(args.reps + 1):
                rt.queue.finish()
                t0 = time.perf_counter()
                cl.enqueue_nd_range_kernel(rt.queue, seeder, (-(-ws // 16) * 16, -(-hs // 4) * 4, n), (16, 4, 1))
                rt.queue.finish()
                t1 = time.perf_counter()
                cl.enqueue_nd_range_kernel(rt.queue, walker, (-(-cols // local[0]) * local[0],
                                                             -(-rows // local[1]) * local[1], n), (*local, 1))
                rt.queue.finish()
                times.append((1e3 * (t1 - t0), 1e3 * (time.perf_counter() - t1)))
            out = np.empty((n, rows, cols), np.float32)
            cl.enqueue_copy(rt.queue, out, angle)
            times = times[1:]
            return min(t[0] for t in times), min(t[1] for t in times), out

        m["seeds_ms"], m["cells_ms"], base = run(default)
        print(f"{name}: pyramid {m['pyramid_ms']:.1f} ms, seeds {m['seeds_ms']:.1f} ms, cells {m['cells_ms']:.1f} ms",
              file=sys.stderr)
        m["variants"] = {}
        variants = [(f"local {lx}x{ly}", default, (lx, ly), 8) for lx, ly in SHAPES[1:]]
        variants += [(f"option {o}", programs[("option", o)], (16, 4), 8) for o in args.option]
        variants += [(f"stride {s}", programs[("stride", s)], (16, 4), s) for s in args.stride]
        for label, prog, local, stride in variants:
            try:
                s_ms, c_ms, got = run(prog, local, stride)
            except cl.Error as exc:
                print(f"  {label}: {exc}", file=sys.stderr)
                continue
            differ = ~((got == base) | (np.isnan(got) & np.isnan(base)))
            diff = float(np.nanmax(np.abs(got - base))) if differ.any() else 0.0
            m["variants"][label] = {"seeds_ms": s_ms, "cells_ms": c_ms, "cells_differing": int(differ.sum()),
                                    "max_diff_deg": diff}
            print(f"  {label}: seeds {s_ms:.1f} ms, cells {c_ms:.1f} ms ({m['cells_ms'] / c_ms:.2f}x), "
                  f"{int(differ.sum())} angles differ (max {diff:.2g} deg)", file=sys.stderr)
        # the pyramid's knob in_place the other way: its build, and the cells' walk over it
        knobs = dict(tuning.settings(rt, "pyramid").values)
        knobs["in_place"] = 1 - knobs["in_place"]
        builds = []
        for _ in range(args.reps + 1):
            rt.queue.finish()
            t = time.perf_counter()
            other = build_extrema_pyramid(hm, rt, knobs)
            rt.queue.finish()
            builds.append(1e3 * (time.perf_counter() - t))
        fixed = (other.heights, np.int32(rows), np.int32(cols), other.buffer, other.offsets, np.int32(other.levels))
        s_ms, c_ms, got = run(default)
        label = f"pyramid in_place={knobs['in_place']}"
        m["variants"][label] = {"pyramid_ms": min(builds[1:]), "seeds_ms": s_ms, "cells_ms": c_ms,
                                "same_bits": bool(np.array_equal(got, base, equal_nan=True))}
        print(f"  {label}: pyramid {min(builds[1:]):.1f} ms, seeds {s_ms:.1f} ms, cells {c_ms:.1f} ms, "
              f"same bits {m['variants'][label]['same_bits']}", file=sys.stderr)
        res["maps"][name] = m
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "horizon_gpu_profile.json").write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
