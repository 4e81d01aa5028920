#!/usr/bin/env python
"""Skip what a scene does not need (issue 6): what each kind of skipping saves, in one run.

    python bench/skipping.py                 # full run (1024^2 canyon, Jacksboro DEM)
    python bench/skipping.py --quick --out /tmp/b

Sections (times are minima over interleaved repetitions; ratios within one run):

1. *Disabled feature.*  The shadow kernel (exact, mask only) built from the
   stock source with the self-shadow / coefficient / stats features' ``-D``
   off, against the same source with those features' code physically removed
   (:func:`oclshade.specialize.from_ifdefs` + :func:`oclshade.specialize`),
   and against the build with the two extra outputs compiled in and computed
   (what a non-specialised kernel would pay).  Kernel time only (launch to
   finish), same arguments.  Also records whether the two builds' device
   binaries are byte-identical.
2. *Repeated call.*  First ``cast_shadows`` / ``ShadowCaster.cast`` on a map
   (caches cleared, kernels compiled) against the same call again.
3. *Sun above the no-shadow bound.*  Full traversal (``analyse=False``)
   against the analysed call, both uncached; results compared.  Also the
   per-map analysis cost next to the pyramid build, and the head-room of any
   per-tile skipping: a full-map launch that traces nothing (zenith mode)
   against a trace at mid elevations.
4. *24-frame sun path over a fixed camera*: oclshade.frames.TerrainScene
   (G-buffer, per-pixel shadows, AO, compose), each pass keyed on a digest of
   its inputs; with caching a pass runs only when its digest changed.

Writes ``skipping.json``, ``skipping.md`` and ``skipping.png`` to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from shadow_masks import log, metadata  # noqa: E402  (same metadata as the other benches)

FEATURES_OFF = ("OCLS_OUT_SELF", "OCLS_OUT_COEF", "OCLS_STATS")
MID_SUNS = ((37.0, 20.0), (135.0, 45.0))


def _min_ms(fn: Callable[[], object], reps: int) -> tuple[float, list[float]]:
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        times.append(1e3 * (time.perf_counter() - t0))
    return min(times), times


def load_maps(size: int) -> dict:
    from matplotlib import cbook
    from oclshade.io import metres_per_degree
    from oclshade.synthetic import canyon_crater

    data = cbook.get_sample_data("jacksboro_fault_dem.npz")
    elev = (data if hasattr(data, "files") else np.load(data))["elevation"].astype(np.float64)
    ew, ns = metres_per_degree(36.2)
    return {
        "canyon": {"heights": canyon_crater(size, size, seed=0, relief=1500.0).astype(np.float64),
                   "cell": (30.0, 30.0), "source": f"canyon_crater({size}, seed=0, relief=1500), 30 m"},
        "jacksboro": {"heights": elev, "cell": (ew / 1200.0, ns / 1200.0),
                      "source": "matplotlib jacksboro_fault_dem.npz (1/1200 degree cells in metres)"},
    }


# ----------------------------------------------------------------------------- 1. disabled feature
def canyon_half(m: dict):
    """A centre crop of half the side: short kernel runs, so many repetitions fit."""
    from oclshade.heightmap import Heightmap
    h = m["heights"]
    r, c = h.shape[0] // 4, h.shape[1] // 4
    return Heightmap.from_array(h[r:r + max(2, h.shape[0] // 2), c:c + max(2, h.shape[1] // 2)], m["cell"])


def bench_disabled_feature(hm, reps: int) -> dict:
    import pyopencl as cl
    from oclshade.runtime import define_options, kernel_source
    from oclshade.shadows import ShadowCaster, ShadowFeatures
    from oclshade.specialize import from_ifdefs, specialize
    from oclshade.sun import Sun

    caster = ShadowCaster(hm, cache=False)
    rt = caster.runtime
    sun = Sun(*MID_SUNS[0])
    rows, cols = hm.shape
    mask = rt.empty(rows * cols, "mask")
    selfb = rt.empty(rows * cols, "self")
    coef = rt.empty(4 * rows * cols, "coef")
    stock_defines = ShadowFeatures("exact", ("mask",), certificate=False).defines()   # one launch per variant
    source = kernel_source("shadow.cl")
    stripped_src = specialize(from_ifdefs(source, FEATURES_OFF + ("OCLS_OUT_MASK",)), "OCLS_OUT_MASK")
    stripped_opts = [o for o in define_options(stock_defines) if not o.startswith("-DOCLS_OUT_")] + ["-cl-std=CL1.2"]
    variants = {
        "define_off": (rt.program("shadow.cl", stock_defines), (mask, selfb, coef)),
        "stripped": (cl.Program(rt.context, stripped_src).build(options=stripped_opts), (mask, selfb, coef)),
        "all_outputs_on": (rt.program("shadow.cl", ShadowFeatures("exact", ("mask", "self", "coefficient"), certificate=False).defines()),
                           (mask, selfb, coef)),
    }
    kernels = {}
    for name, (prog, outs) in variants.items():
        k = cl.Kernel(prog, "shadow_cells")
        k.set_args(*caster._args(sun, 0.25, 0.65), *outs)
        kernels[name] = (k, rt.grid_2d(k, cols, rows))
    times: dict[str, list[float]] = {n: [] for n in kernels}
    names = list(kernels)
    for r in range(reps):
        for name in names[r % len(names):] + names[:r % len(names)]:
            k, (g, l) = kernels[name]
            t0 = time.perf_counter()
            cl.enqueue_nd_range_kernel(rt.queue, k, g, l)
            rt.queue.finish()
            times[name].append(1e3 * (time.perf_counter() - t0))
    results = {}
    for name in names:
        out = np.empty((rows, cols), np.uint8)
        k, (g, l) = kernels[name]
        cl.enqueue_nd_range_kernel(rt.queue, k, g, l)
        cl.enqueue_copy(rt.queue, out, mask)
        rt.queue.finish()
        results[name] = out
    binaries = {n: variants[n][0].get_info(cl.program_info.BINARIES)[0] for n in ("define_off", "stripped")}
    best = {n: min(t) for n, t in times.items()}
    paired = sorted(a / b for a, b in zip(times["define_off"], times["stripped"]))
    return {
        "map": list(hm.shape), "sun": list(MID_SUNS[0]), "features_off": list(FEATURES_OFF),
        "time_ms": {n: {"min": best[n], "all": times[n]} for n in names},
        "define_off_over_stripped": best["define_off"] / best["stripped"],
        "paired_ratio_median": paired[len(paired) // 2],
        "all_outputs_over_define_off": best["all_outputs_on"] / best["define_off"],
        "source_lines": {"stock": source.count("\n"), "stripped": stripped_src.count("\n")},
        "binaries_identical": binaries["define_off"] == binaries["stripped"],
        "masks_identical": all(np.array_equal(results[n], results["define_off"]) for n in names),
    }


# ----------------------------------------------------------------------------- 2. repeated call
def bench_repeated(name: str, m: dict, reps: int) -> dict:
    from oclshade import cache
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import ShadowCaster, cast_shadows

    sun = MID_SUNS[0]
    out = {"map": name, "sun": list(sun)}
    for api in ("cast_shadows", "ShadowCaster.cast"):
        first, again, same = [], [], True
        for _ in range(reps):
            cache.clear()
            if api == "cast_shadows":
                call = lambda: cast_shadows(m["heights"], m["cell"], sun, outputs="all")  # noqa: E731
            else:
                caster = ShadowCaster(Heightmap.from_array(m["heights"], m["cell"]))
                call = lambda: caster.cast(sun, outputs="all")  # noqa: E731
            t0 = time.perf_counter()
            a = call()
            first.append(1e3 * (time.perf_counter() - t0))
            t, _ = _min_ms(call, 3)
            again.append(t)
            same &= np.array_equal(a.mask, call().mask)
        out[api] = {"first_ms": min(first), "repeat_ms": min(again), "speedup": min(first) / min(again),
                    "identical": bool(same)}
    out["cache_stats"] = cache.stats()
    return out


# ----------------------------------------------------------------------------- 3. above the bound
def bench_above_bound(name: str, m: dict, reps: int) -> dict:
    from oclshade.analysis import slope_fronts
    from oclshade.heightmap import Heightmap
    from oclshade.pyramid import build_extrema_pyramid
    from oclshade.shadows import ShadowCaster
    from oclshade.sun import Sun

    hm = Heightmap.from_array(m["heights"], m["cell"])
    full = ShadowCaster(hm, cache=False, analyse=False)
    fast = ShadowCaster(hm, cache=False)
    full.warm_up(outputs=("mask", "self", "coefficient"))
    fast.warm_up(outputs=("mask", "self", "coefficient"))
    rt = full.runtime
    pyr_ms, _ = _min_ms(lambda: (build_extrema_pyramid(hm, rt), rt.queue.finish()), reps)
    fronts_ms, _ = _min_ms(lambda: slope_fronts(hm), reps)
    full_fronts_ms, _ = _min_ms(lambda: slope_fronts(hm).fronts, max(1, reps // 3))
    out = {"map": name, "shape": list(hm.shape), "pyramid_ms": pyr_ms, "analysis_ms": fronts_ms,
           "analysis_with_fronts_ms": full_fronts_ms,
           "front_points": max(len(f) for f in fast.analysis.fronts.fronts.values()), "suns": []}
    for az in (37.0, 135.0, 270.0):
        bound = fast.analysis.no_shadow_bound(Sun(az, 45.0))
        sun = Sun(az, math.degrees(math.atan(bound * 1.01)))
        t_full, _ = _min_ms(lambda: full.cast(sun, outputs="all"), reps)
        t_fast, _ = _min_ms(lambda: fast.cast(sun, outputs="all"), reps)
        a, b = full.cast(sun, outputs="all"), fast.cast(sun, outputs="all")
        same = all(np.array_equal(getattr(a, n), getattr(b, n), equal_nan=True)
                   for n in ("mask", "self_shadow", "coefficient"))
        out["suns"].append({"azimuth": az, "bound_elevation_deg": math.degrees(math.atan(bound)),
                            "sun_elevation_deg": sun.elevation, "skipped": fast.analysis.casts_nothing(sun),
                            "full_ms": t_full, "skip_ms": t_fast, "ratio": t_fast / t_full, "identical": same})
    # head-room of per-tile skipping: a launch over every cell that traces nothing
    floor_ms, _ = _min_ms(lambda: full.cast((37.0, 90.0)), reps)
    out["tiles"] = {"no_trace_launch_ms": floor_ms, "trace_ms": {}}
    for az, el in MID_SUNS:
        t, _ = _min_ms(lambda: full.cast((az, el)), reps)
        lit = float(1.0 - full.cast((az, el)).mask.mean())
        out["tiles"]["trace_ms"][f"{az:g}/{el:g}"] = {"time_ms": t, "lit_fraction": lit}
    return out


# ----------------------------------------------------------------------------- 4. frames
def sun_path(n: int) -> list[tuple[float, float]]:
    """Sunrise to sunset: azimuth 90 -> 270, elevation up to 60 degrees and down."""
    return [(90.0 + 180.0 * (k + 0.5) / n, 3.0 + 57.0 * math.sin(math.pi * (k + 0.5) / n)) for k in range(n)]


def bench_frames(m: dict, n_frames: int, frame_size: tuple[int, int]) -> dict:
    """A sun path over a fixed camera through oclshade.frames.TerrainScene: G-buffer,
    per-pixel shadows, AO and compose; with caching only the sun-dependent passes rerun."""
    from oclshade.camera import frame_heightmap
    from oclshade.frames import PASSES, AOSettings, FrameSettings, TerrainScene
    from oclshade.heightmap import Heightmap
    from oclshade.terrain import Heightfield

    hm = Heightmap.from_array(m["heights"], m["cell"])
    camera = frame_heightmap(hm, *frame_size, azimuth=200.0, elevation=30.0)
    settings = FrameSettings(ao=AOSettings(radius=4.0 * hm.dx))
    out: dict = {"frames": n_frames, "frame_size": list(frame_size), "passes_pending": []}
    for _ in range(2):                      # alternate the modes twice; keep each mode's faster run
        for caching in (False, True):
            scene = TerrainScene(Heightfield(hm), caching=caching)
            scene.frame(camera, (180.0, 30.0), settings)            # builds and pyramid outside the timing
            scene = TerrainScene(Heightfield(hm), caching=caching)
            by_pass = {p: {"ms": 0.0, "runs": 0, "skips": 0} for p in PASSES}
            t0 = time.perf_counter()
            for sun in sun_path(n_frames):
                frame = scene.frame(camera, sun, settings)
                for p in PASSES:
                    if p in frame.ran:
                        by_pass[p]["runs"] += 1
                        by_pass[p]["ms"] += frame.ms[p]
                    else:
                        by_pass[p]["skips"] += 1
            total = 1e3 * (time.perf_counter() - t0)
            name = "cached" if caching else "uncached"
            if name not in out or total < out[name]["total_ms"]:
                out[name] = {"total_ms": total, "passes": by_pass}
    out["speedup"] = out["uncached"]["total_ms"] / out["cached"]["total_ms"]
    return out


# ----------------------------------------------------------------------------- reports
def write_markdown(path: Path, r: dict) -> None:
    meta, feat = r["meta"], r["disabled_feature"]
    lines = [
        "# Skipping what a scene does not need (issue 6)", "",
        f"- date: {meta['date']}; command: `{meta['command']}`",
        f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']}; PoCL {meta['pocl_version']}",
        "- times are minima over interleaved repetitions on a shared machine; ratios are within this run", "",
        "## 1. A disabled feature costs nothing", "",
        f"Shadow kernel (exact, mask only) on {feat['map'][0]}x{feat['map'][1]} canyon, sun {feat['sun']}; "
        f"features off: {', '.join(feat['features_off'])}.", "",
        "| build | kernel ms (min) |", "|---|---:|",
    ]
    labels = {"define_off": "stock source, features' -D off", "stripped": "features' code removed by specialize()",
              "all_outputs_on": "self + coefficient compiled in and computed"}
    lines += [f"| {labels[n]} | {v['min']:.2f} |" for n, v in feat["time_ms"].items()]
    lines += ["", f"- -D off / physically removed: **{feat['define_off_over_stripped']:.3f}** (ratio of minima; "
              f"median of per-repetition ratios {feat['paired_ratio_median']:.3f}; target <= 1.02)",
              f"- device binaries byte-identical: {feat['binaries_identical']}; masks identical: {feat['masks_identical']}",
              f"- what specialisation saves against computing every output: x{feat['all_outputs_over_define_off']:.2f}",
              f"- source lines: stock {feat['source_lines']['stock']}, stripped {feat['source_lines']['stripped']}", "",
              "## 2. Repeated call with unchanged inputs", "",
              "| map | API | first ms | repeat ms | speedup | identical |", "|---|---|---:|---:|---:|---|"]
    for rep in r["repeated"]:
        for api in ("cast_shadows", "ShadowCaster.cast"):
            e = rep[api]
            lines.append(f"| {rep['map']} | {api} | {e['first_ms']:.1f} | {e['repeat_ms']:.2f} | "
                         f"**{e['speedup']:.0f}x** | {e['identical']} |")
    lines += ["", "## 3. Sun above the no-shadow bound", "",
              "Per map, once: pyramid build; analysis screening data (O(N)); Pareto fronts (built only "
              "when a sun falls between the screening bounds).", "",
              "| map | pyramid ms | analysis ms | + fronts ms | azimuth | bound elevation | sun | full ms | skip ms | "
              "skip / full | identical |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for a in r["above_bound"]:
        for s in a["suns"]:
            lines.append(f"| {a['map']} {a['shape'][0]}x{a['shape'][1]} | {a['pyramid_ms']:.1f} | {a['analysis_ms']:.1f} | "
                         f"{a['analysis_with_fronts_ms']:.1f} | "
                         f"{s['azimuth']:g} | {s['bound_elevation_deg']:.2f} | {s['sun_elevation_deg']:.2f} | "
                         f"{s['full_ms']:.2f} | {s['skip_ms']:.3f} | **{100 * s['ratio']:.2f} %** | {s['identical']} |")
    lines += ["", "Per-tile skipping head-room (no kernel change possible here): a launch over every cell that "
              "traces nothing, against full traces:", "", "| map | no-trace launch ms | sun | trace ms | lit fraction |",
              "|---|---:|---|---:|---:|"]
    for a in r["above_bound"]:
        for sun, t in a["tiles"]["trace_ms"].items():
            lines.append(f"| {a['map']} | {a['tiles']['no_trace_launch_ms']:.2f} | {sun} | {t['time_ms']:.2f} | "
                         f"{t['lit_fraction']:.3f} |")
    fr = r["frames"]
    lines += ["", f"## 4. {fr['frames']}-frame sun path, fixed camera ({fr['frame_size'][0]}x{fr['frame_size'][1]}, "
              "oclshade.frames.TerrainScene: G-buffer, per-pixel shadows, AO, compose)", "",
              f"Caching reruns only the passes whose inputs changed: **x{fr['speedup']:.2f}** in total.", "",
              "| caching | total ms | pass | runs | skips | ms | share |", "|---|---:|---|---:|---:|---:|---:|"]
    for mode in ("uncached", "cached"):
        e = fr[mode]
        for pname, p in e["passes"].items():
            lines.append(f"| {mode} | {e['total_ms']:.0f} | {pname} | {p['runs']} | {p['skips']} | {p['ms']:.0f} | "
                         f"{100 * p['ms'] / e['total_ms']:.0f} % |")
    path.write_text("\n".join(lines) + "\n")


def write_plot(path: Path, r: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    feat = r["disabled_feature"]["time_ms"]
    axes[0].bar(list(feat), [v["min"] for v in feat.values()], color=["C0", "C1", "C3"])
    axes[0].set_ylabel("kernel ms (min)")
    axes[0].set_title("1. feature -D off vs removed vs on")
    labels, first, again = [], [], []
    for rep in r["repeated"]:
        for api in ("cast_shadows", "ShadowCaster.cast"):
            labels.append(f"{rep['map']}\n{api}")
            first.append(rep[api]["first_ms"])
            again.append(rep[api]["repeat_ms"])
    x = np.arange(len(labels))
    axes[1].bar(x - 0.2, first, 0.4, label="first")
    axes[1].bar(x + 0.2, again, 0.4, label="repeat (cached)")
    axes[1].set_xticks(x, labels, fontsize=7)
    axes[1].set_yscale("log")
    axes[1].set_ylabel("ms")
    axes[1].legend()
    axes[1].set_title("2. repeated call")
    labels, full, skip = [], [], []
    for a in r["above_bound"]:
        for s in a["suns"]:
            labels.append(f"{a['map']}\naz {s['azimuth']:g}")
            full.append(s["full_ms"])
            skip.append(s["skip_ms"])
    x = np.arange(len(labels))
    axes[2].bar(x - 0.2, full, 0.4, label="full traversal")
    axes[2].bar(x + 0.2, skip, 0.4, label="analysis skip (identical result)")
    axes[2].set_xticks(x, labels, fontsize=7)
    axes[2].set_yscale("log")
    axes[2].set_ylabel("ms")
    axes[2].legend()
    axes[2].set_title("3. sun above the no-shadow bound")
    meta = r["meta"]
    fig.suptitle(f"oclshade skipping — {meta['cpu']}, PoCL {meta['pocl_version']}, {meta['date'][:10]} "
                 "(all results identical to the full computation; error 0)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=1024, help="canyon map side (default 1024)")
    p.add_argument("--reps", type=int, default=9, help="timed repetitions (default 9)")
    p.add_argument("--frames", type=int, default=24, help="frames of the sun path (default 24)")
    p.add_argument("--quick", action="store_true", help="smoke run: 96^2 canyon, 2 repetitions, 4 frames")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results", help="output folder")
    args = p.parse_args(argv)
    if args.quick:
        args.size, args.reps, args.frames = 96, 2, 4
    return args


def main(argv: list[str] | None = None) -> int:
    argv_list = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv_list)
    args.out.mkdir(parents=True, exist_ok=True)
    meta = metadata(["bench/skipping.py", *argv_list])
    maps = load_maps(args.size)
    log(f"device {meta['device']}; canyon {args.size}^2, reps {args.reps}")
    result: dict = {"meta": meta, "config": {"size": args.size, "reps": args.reps, "frames": args.frames,
                                             "quick": args.quick,
                                             "maps": {n: m["source"] for n, m in maps.items()}}}
    half = canyon_half(maps["canyon"])
    result["disabled_feature"] = bench_disabled_feature(half, 4 * args.reps)
    log(f"1. -D off / stripped = {result['disabled_feature']['define_off_over_stripped']:.3f}")
    result["repeated"] = [bench_repeated(n, m, max(2, args.reps // 3)) for n, m in maps.items()]
    log("2. repeated: " + ", ".join(f"{r['map']} x{r['ShadowCaster.cast']['speedup']:.0f}" for r in result["repeated"]))
    result["above_bound"] = [bench_above_bound(n, m, args.reps) for n, m in maps.items()]
    log("3. above bound: " + ", ".join(f"{a['map']} {100 * max(s['ratio'] for s in a['suns']):.2f} %"
                                       for a in result["above_bound"]))
    result["frames"] = bench_frames(maps["canyon"], args.frames, (320, 180) if args.quick else (1280, 720))
    log(f"4. frames: uncached {result['frames']['uncached']['total_ms']:.0f} ms, "
        f"cached {result['frames']['cached']['total_ms']:.0f} ms")
    (args.out / "skipping.json").write_text(json.dumps(result, indent=1) + "\n")
    write_markdown(args.out / "skipping.md", result)
    write_plot(args.out / "skipping.png", result)
    log(f"wrote {args.out}/skipping.{{json,md,png}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
