"""SSAO (paper 001): run time against RMSE versus two ground truths, on real DEMs.

For every dataset and resolution two views: a top-down orthographic G-buffer
(oclshade.reference.topdown_gbuffer: each pixel's position and normal from
the bilinear surface) and a perspective oblique view rendered by
oclshade.terrain.TerrainRenderer (frame_heightmap at azimuth 200, elevation
35, then moved to half the distance so the terrain fills the frame); the
rendered pixels' world positions and normals come from
oclshade.reference.world_frame (view space mapped back, snapped to the
bilinear surface).  The two ground truths are computed in float64 on a
fixed random subset of hit pixels (the same pixels for every setting):
(a) volume: fraction of the radius-R hemisphere volume under the terrain, by
exact vertical chords on 4096 lines per pixel (reference.volume_ao_lines); its
error is stated as the RMS difference to the same quadrature on 1024 lines
(an over-estimate: the error falls at least as fast as 1 / lines);
(b) ray-traced: fraction of cosine-weighted rays of length R that hit, two
independent stratified sets of 256 rays averaged; its error is stated as half
the RMS difference of the two (the standard error of their mean).
Every setting (m, blur, range check, kernel distribution, line or ray samples,
plane test) is timed on the device (inputs resident, min of --repeats runs of
prepare + AO + blur) and its RMSE against each truth is taken over the subset.
The paper's recipe and the default are then timed again in rotation
(--interleave runs each, min): those times make the "default vs paper recipe"
line (a time ratio taken on a shared machine: noisy).  The default itself is
chosen against ray-traced AO by bench/ssao_bias.py.

Writes bench/results/ssao.json, .md and .png.  ``--quick``: tiny sizes, a
synthetic terrain when the shared data is absent, a reduced grid.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from shadow_masks import DEFAULT_DATA, log, metadata  # noqa: E402  (shared bench helpers)

from dataclasses import dataclass  # noqa: E402

from oclshade import reference as ref  # noqa: E402
from oclshade.camera import Camera, frame_heightmap  # noqa: E402
from oclshade.gbuffer import GBuffer  # noqa: E402
from oclshade.terrain import Heightfield, TerrainRenderer  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.io import read_dem  # noqa: E402
from oclshade.ssao import (DEFAULT_FEATURES, DEFAULT_M, PAPER_M, PAPER_RECIPE, POINT_DISTRIBUTIONS,  # noqa: E402
                           AOFeatures, SSAO)

DATASETS = {
    # name: (path under the data folder, cells across the 1920-pixel width, R in cells, cell size in
    # metres when the file has none in metres: the .asc is in degrees, its .f32.json gives metres)
    "santo": ("dem/srtm3_srtmpy/S16E166v2.3a.hgt.zip", 480, 3.0, None),
    "front_range": ("dem/landlab/SRTMGL3_40.09_-105.55_40.21_-105.35.asc", 240, 3.0, (70.91, 92.77)),
}
BLURS = {"none": ("none", 3), "box3": ("box", 3), "box5": ("box", 5), "edge5": ("edge", 5)}
VIEWS = ("topdown", "oblique")


@dataclass
class View:
    gbuffer: GBuffer
    projection: np.ndarray
    world_position: np.ndarray   # float64 (H, W, 3), NaN where empty
    world_normal: np.ndarray
    pixel: float                 # median pixel footprint on the terrain (m): depth x pixel angle


def load(name: str, data_dir: Path) -> tuple[Heightmap, int, float, str] | None:
    if name == "synthetic":
        from oclshade.synthetic import canyon_crater
        return Heightmap.from_array(canyon_crater(128, 160, seed=4), 10.0), 120, 3.0, "oclshade.synthetic.canyon_crater(128, 160, seed=4), 10 m"
    rel, cells, r_cells, cellsize = DATASETS[name]
    path = data_dir / rel
    if not path.is_file():
        return None
    raster = read_dem(path, cellsize=cellsize)
    h = raster.heights
    h = np.where(h <= 0, np.nan, h) if name == "santo" else h   # ocean (0) and voids: no terrain
    return Heightmap.from_array(h, (raster.dx, raster.dy)), cells, r_cells, f"{rel} via oclshade.io.read_dem"


def crop(hm: Heightmap, cells: int) -> Heightmap:
    """The ``cells`` x ``cells`` window (clipped to the map) centred on the median finite sample:
    what the oblique view renders (the truths use the same cropped map)."""
    rows, cols = hm.shape
    if cells >= rows and cells >= cols:
        return hm
    fr, fc = np.nonzero(np.isfinite(hm.heights))
    r0 = min(max(int(np.median(fr)) - cells // 2, 0), max(rows - cells, 0))
    c0 = min(max(int(np.median(fc)) - cells // 2, 0), max(cols - cells, 0))
    return Heightmap.from_array(hm.heights[r0:r0 + cells, c0:c0 + cells], (hm.dx, hm.dy))


def view_for(kind: str, hm: Heightmap, cells: int, width: int, height: int) -> tuple[View, Heightmap]:
    """(view, the heightmap it shows): ``topdown`` ``cells`` cells wide centred on the map, or
    ``oblique``: the cropped map rendered in perspective (see the module docstring)."""
    if kind == "topdown":
        pixel = cells * hm.dx / width
        v = ref.topdown_gbuffer(hm, width, height, pixel)
        return View(v.gbuffer, v.projection, v.world_position, v.world_normal, pixel), hm
    hm = crop(hm, cells)
    cam = frame_heightmap(hm, width, height, azimuth=200.0, elevation=35.0, fov=45.0)
    cam = Camera(cam.look_at + 0.5 * (cam.position - cam.look_at), cam.look_at, width, height, fov=45.0,
                 near=0.25 * cam.near, far=cam.far)
    gb = TerrainRenderer(Heightfield(hm)).render(cam)
    wp, wn = ref.world_frame(hm, gb, cam.view)
    depth = -gb.position[..., 2][gb.hit]
    pixel = float(np.median(depth)) * 2.0 * cam.scale[1] / height
    return View(gb, cam.projection_matrix, wp, wn, pixel), hm


def settings(quick: bool, large: bool) -> list[tuple[int, str, bool, str, bool]]:
    """(m, blur, range check, distribution, plane test).  Point samples: at 1920x1080 only the
    5 x 5 box blur and fewer m (the must-show setting and its neighbours), to keep the run short;
    line and ray samples: fewer m (they need fewer) and every blur but the edge-aware one at
    1920x1080.  The default's setting is always in the grid."""
    if quick:
        grids = {"points": ((24, 32), ("box5",)), "lines": ((20,), ("none",)), "rays": ((8,), ("box3",))}
    elif large:
        grids = {"points": ((16, 24, 32), ("box5",)), "lines": ((8, 12, 16, 20), ("none", "box3", "box5")),
                 "rays": ((4, 8, 16), ("none", "box3", "box5"))}
    else:
        grids = {"points": ((8, 16, 24, 32, 64), ("none", "box5", "edge5")),
                 "lines": ((8, 12, 16, 20, 24, 28, 32), ("none", "box3", "box5", "edge5")),
                 "rays": ((4, 8, 12, 16), ("none", "box3", "box5", "edge5"))}
    out = []
    for kind, (ms, blurs) in grids.items():
        for dist in POINT_DISTRIBUTIONS if kind == "points" else (kind,):
            out += [(m, blur, rc, dist, pt) for m in ms for blur in blurs for rc in (False, True) for pt in (False, True)]
    default = (DEFAULT_M, "none" if DEFAULT_FEATURES.blur == "none" else f"{DEFAULT_FEATURES.blur}{DEFAULT_FEATURES.blur_size}",
               DEFAULT_FEATURES.range_check, DEFAULT_FEATURES.distribution, DEFAULT_FEATURES.plane_test)
    return out + ([] if default in out else [default])


def features_of(blur: str, rc: bool, dist: str, pt: bool) -> AOFeatures:
    kind, size = BLURS[blur]
    return AOFeatures(range_check=rc, distribution=dist, blur=kind, blur_size=size, plane_test=pt)


def setting_key(m: int, f: AOFeatures) -> str:
    blur = "none" if f.blur == "none" else f"{f.blur}{f.blur_size}"
    return (f"m = {m}, {f.distribution}, {blur}, range check {'on' if f.range_check else 'off'}, "
            f"plane test {'on' if f.plane_test else 'off'}")


def interleaved_ms(pass_: SSAO, inputs, view: View, radius: float, delta: float, runs: int) -> dict[str, float]:
    """Min wall time (ms) of the paper's recipe and of the default, run in rotation ``runs`` times
    after a warm-up (the machine is shared: the rotation spreads its noise over both)."""
    queue = pass_.runtime.queue
    pair = {setting_key(PAPER_M, PAPER_RECIPE): (PAPER_M, PAPER_RECIPE),
            setting_key(DEFAULT_M, DEFAULT_FEATURES): (DEFAULT_M, DEFAULT_FEATURES)}
    times: dict[str, list[float]] = {k: [] for k in pair}
    for i in range(runs + 1):
        for key, (m, f) in pair.items():
            queue.finish()
            t0 = time.perf_counter()
            pass_.run(inputs, view.projection, radius=radius, m=m, delta=delta, features=f)
            queue.finish()
            if i:
                times[key].append(time.perf_counter() - t0)
    return {k: 1e3 * min(v) for k, v in times.items()}


def run_case(pass_: SSAO, view: View, hm: Heightmap, radius: float, delta: float,
             n_truth: int, n_vol: int, n_ray: int, repeats: int, interleave: int, quick: bool) -> dict:
    gb = view.gbuffer
    hit_idx = np.flatnonzero(gb.hit.ravel() & np.isfinite(view.world_position[..., 2]).ravel())
    rng = np.random.default_rng(0)
    sub = np.sort(rng.choice(hit_idx, size=min(n_truth, hit_idx.size), replace=False))
    wp = view.world_position.reshape(-1, 3)[sub]
    wn = view.world_normal.reshape(-1, 3)[sub]
    rms = lambda a: float(np.sqrt(np.mean(a * a)))  # noqa: E731
    t0 = time.perf_counter()
    truth_vol = ref.volume_ao_lines(hm, wp, wn, radius, n=n_vol)
    t_vol = time.perf_counter() - t0
    err_vol = rms(truth_vol - ref.volume_ao_lines(hm, wp, wn, radius, n=n_vol // 4, seed=2))
    t0 = time.perf_counter()
    halves = [ref.raytraced_ao(hm, wp, wn, radius, n=n_ray // 2, seed=seed) for seed in (1, 2)]
    t_ray = time.perf_counter() - t0
    truth_ray = 0.5 * (halves[0] + halves[1])
    err_ray = 0.5 * rms(halves[0] - halves[1])
    inputs = pass_.upload(gb)
    queue = pass_.runtime.queue
    rows = []
    out = np.empty(gb.shape, np.float32)
    import pyopencl as cl
    for m, blur, rc, dist, pt in settings(quick, gb.shape[1] >= 1920):
        f = features_of(blur, rc, dist, pt)
        times = []
        for _ in range(repeats + 1):   # the first run builds the program
            queue.finish()
            t0 = time.perf_counter()
            buf = pass_.run(inputs, view.projection, radius=radius, m=m, delta=delta, features=f)
            queue.finish()
            times.append(time.perf_counter() - t0)
        cl.enqueue_copy(queue, out, buf)
        queue.finish()
        ao = out.ravel()[sub].astype(np.float64)
        rows.append({"m": m, "blur": blur, "range_check": rc, "distribution": dist, "plane_test": pt,
                     "time_ms": {"min": 1e3 * min(times[1:]), "median": 1e3 * float(np.median(times[1:]))},
                     "rmse_volume": float(np.sqrt(np.mean((ao - truth_vol) ** 2))),
                     "rmse_raytraced": float(np.sqrt(np.mean((ao - truth_ray) ** 2))),
                     "bias_volume": float(np.mean(ao - truth_vol)), "bias_raytraced": float(np.mean(ao - truth_ray))})
    return {"truth_pixels": int(sub.size), "truth_samples": {"volume_lines": n_vol, "raytraced_rays": n_ray},
            "truth_seconds": {"volume": t_vol, "raytraced": t_ray},
            "truth_mean": {"volume": float(truth_vol.mean()), "raytraced": float(truth_ray.mean())},
            "truth_error": {"volume": err_vol, "raytraced": err_ray},
            "interleaved_ms": interleaved_ms(pass_, inputs, view, radius, delta, interleave),
            "settings": rows}


def find(rows: list[dict], m: int, f: AOFeatures) -> dict:
    blur = "none" if f.blur == "none" else f"{f.blur}{f.blur_size}"
    return next(r for r in rows if r["m"] == m and r["blur"] == blur and r["range_check"] == f.range_check
                and r["distribution"] == f.distribution and r.get("plane_test", False) == f.plane_test)


def compare(case: dict) -> dict:
    """The default against the paper's recipe: RMSEs from the grid, times from the interleaved runs."""
    rows = case["settings"]
    paper, default = find(rows, PAPER_M, PAPER_RECIPE), find(rows, DEFAULT_M, DEFAULT_FEATURES)
    ms = case["interleaved_ms"]
    paper_ms, default_ms = ms[setting_key(PAPER_M, PAPER_RECIPE)], ms[setting_key(DEFAULT_M, DEFAULT_FEATURES)]
    return {"paper": paper, "default": default, "paper_ms": paper_ms, "default_ms": default_ms,
            "time_ratio": default_ms / paper_ms,
            "rmse_reduction_volume": 1 - default["rmse_volume"] / paper["rmse_volume"],
            "rmse_reduction_raytraced": 1 - default["rmse_raytraced"] / paper["rmse_raytraced"]}


def comparison_line(c: dict) -> str:
    pct = lambda x: f"{abs(100 * x):.0f}% {'lower' if x >= 0 else 'higher'}"  # noqa: E731
    return (f"default vs paper recipe: {c['default_ms']:.1f} vs {c['paper_ms']:.1f} ms (ratio {c['time_ratio']:.2f}); "
            f"RMSE volume {c['default']['rmse_volume']:.4f} vs {c['paper']['rmse_volume']:.4f} "
            f"({pct(c['rmse_reduction_volume'])}), raytraced {c['default']['rmse_raytraced']:.4f} vs "
            f"{c['paper']['rmse_raytraced']:.4f} ({pct(c['rmse_reduction_raytraced'])})")


def write_md(res: dict, path: Path) -> None:
    meta = res["meta"]
    lines = ["# SSAO (paper 001): run time against RMSE vs ground truth", "",
             f"- {meta['date']}; CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']}",
             f"- PoCL {meta['pocl_version']} ({meta['platform_version']}); numpy {meta['numpy']}, pyopencl {meta['pyopencl']}",
             f"- command: `{meta['command']}`",
             "- views: top-down orthographic G-buffers (oclshade.reference.topdown_gbuffer) and perspective oblique "
             "views rendered by TerrainRenderer (azimuth 200, elevation 35; truths at the rendered pixels' world "
             "positions, reference.world_frame); delta = 0.05 x the median pixel footprint; the machine is "
             "shared, times are the min of the repeats (prepare + AO + blur, inputs on the device)",
             "- truths on a fixed random subset of hit pixels: volume = fraction of the hemisphere volume "
             "above the terrain (ground truth a; exact vertical chords on 4096 lines per pixel), raytraced = "
             "unoccluded fraction of cosine-weighted rays of length R (ground truth b; 2 x 256 rays); 1 = open, "
             "like the AO map.  'truth error': volume, RMS difference to the same quadrature on 1024 lines; "
             "raytraced, the standard error of the two ray sets' mean",
             "- kernel `lines`: line samples (volumetric obscurance, -D OCLS_LINES), `rays`: ray samples (m rays of "
             "-D OCLS_RAY_STEPS points), the other kernels point samples",
             f"- paper recipe: m = {PAPER_M}, {PAPER_RECIPE}; default: m = {DEFAULT_M}, {DEFAULT_FEATURES} (chosen "
             "against ray-traced AO by bench/ssao_bias.py)",
             "- 'default vs paper recipe' times: the two run in rotation after the grid, min of each (a ratio on a "
             "shared machine: noisy); the grid's own times are min of the repeats, run one setting after the "
             "other (noisier)", ""]
    lines += ["## Default vs paper recipe, every view", "",
              "| view | default ms | paper ms | time ratio | RMSE volume default / paper | reduction | RMSE raytraced default / paper | reduction | truth error volume / raytraced |",
              "|---|---|---|---|---|---|---|---|---|"]
    for case in res["cases"]:
        c = case["comparison"]
        lines.append(f"| {case['dataset']} {case['view']} {case['width']}x{case['height']} | {c['default_ms']:.1f} | "
                     f"{c['paper_ms']:.1f} | {c['time_ratio']:.2f} | {c['default']['rmse_volume']:.4f} / "
                     f"{c['paper']['rmse_volume']:.4f} | {100 * c['rmse_reduction_volume']:.0f}% | "
                     f"{c['default']['rmse_raytraced']:.4f} / {c['paper']['rmse_raytraced']:.4f} | "
                     f"{100 * c['rmse_reduction_raytraced']:.0f}% | {case['truth_error']['volume']:.5f} / "
                     f"{case['truth_error']['raytraced']:.4f} |")
    lines.append("")
    for case in res["cases"]:
        lines += [f"## {case['dataset']} {case['view']} {case['width']}x{case['height']}", "",
                  f"source: {case['source']}; {case['cells']} cells across, pixel {case['pixel_m']:.1f} m (median), R = {case['radius_m']:.1f} m, "
                  f"delta = {case['delta_m']:.3f} m; truths on {case['truth_pixels']} pixels "
                  f"(truth error: volume {case['truth_error']['volume']:.5f}, raytraced "
                  f"{case['truth_error']['raytraced']:.4f}; means {case['truth_mean']['volume']:.3f}, "
                  f"{case['truth_mean']['raytraced']:.3f})", ""]
        lines += [f"**{comparison_line(case['comparison'])}**", "",
                  "| m | blur | range | kernel | plane | min ms | median ms | RMSE volume | RMSE raytraced | bias volume | bias raytraced |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in case["settings"]:
            lines.append(f"| {r['m']} | {r['blur']} | {'on' if r['range_check'] else 'off'} | {r['distribution']} | "
                         f"{'on' if r.get('plane_test') else 'off'} | "
                         f"{r['time_ms']['min']:.1f} | {r['time_ms']['median']:.1f} | {r['rmse_volume']:.4f} | "
                         f"{r['rmse_raytraced']:.4f} | {r['bias_volume']:+.4f} | {r['bias_raytraced']:+.4f} |")
        lines.append("")
    path.write_text("\n".join(lines))


def write_png(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = res["cases"]
    fig, axes = plt.subplots(len(cases), 2, figsize=(12, 3.6 * len(cases)), squeeze=False)
    colours = {"paper": "tab:red", "uniform": "tab:blue", "centre": "tab:green", "lines": "tab:purple", "rays": "tab:orange"}
    markers = {"none": "o", "box3": "s", "box5": "D", "edge5": "^"}
    for row, case in zip(axes, cases):
        for ax, key in zip(row, ("rmse_volume", "rmse_raytraced")):
            for r in case["settings"]:
                ax.scatter(r["time_ms"]["min"], r[key], c=colours[r["distribution"]], marker=markers[r["blur"]],
                           s=14 + 3 * np.log2(r["m"]) ** 2, alpha=0.35 if r["range_check"] else 0.85,
                           edgecolors="black" if r.get("plane_test") else "none", linewidths=0.6)
            c = case["comparison"]
            marks = ((("paper recipe = default", c["paper"]),) if c["paper"] == c["default"]
                     else (("paper recipe", c["paper"]), ("default", c["default"])))
            for tag, r in marks:
                ax.annotate(tag, (r["time_ms"]["min"], r[key]), fontsize=8, xytext=(6, 6), textcoords="offset points",
                            arrowprops={"arrowstyle": "-", "lw": 0.5})
            ax.axhline(case["truth_error"][key.split("_")[1]], color="grey", lw=0.6, ls=":")
            ax.set_xscale("log")
            ax.set_xlabel("run time, ms (min of repeats)")
            ax.set_ylabel(key.replace("_", " vs "))
            ax.set_title(f"{case['dataset']} {case['view']} {case['width']}x{case['height']}", fontsize=9)
            ax.grid(alpha=0.3)
    handles = [plt.Line2D([], [], color=v, marker="o", ls="", label=k) for k, v in colours.items()]
    handles += [plt.Line2D([], [], color="grey", marker=v, ls="", label=k) for k, v in markers.items()]
    handles += [plt.Line2D([], [], color="grey", marker="o", ls="", alpha=0.35, label="range check on (faint)"),
                plt.Line2D([], [], color="grey", marker="o", ls="", markeredgecolor="black", label="plane test (edged)")]
    handles += [plt.Line2D([], [], color="grey", lw=0.6, ls=":", label="truth error")]
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.975), ncol=6, fontsize=8)
    meta = res["meta"]
    fig.suptitle(f"oclshade SSAO — {meta['cpu']}, {meta['cores']} cores, PoCL {meta['pocl_version']}, {meta['date'][:10]}"
                 " (marker size ~ m)", y=0.995, fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke test: tiny sizes, reduced grid")
    ap.add_argument("--datasets", default="santo,front_range,synthetic", help="comma list of " + ", ".join(DATASETS) + ", synthetic")
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help=f"shared data folder (default {DEFAULT_DATA})")
    ap.add_argument("--sizes", default="1920x1080,640x480")
    ap.add_argument("--views", default=",".join(VIEWS), help="comma list of " + ", ".join(VIEWS))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--interleave", type=int, default=7, help="alternate runs of the default and the paper recipe")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite the comparisons, .md and .png from an existing ssao.json in --out")
    args = ap.parse_args(argv)
    if args.report_only:
        res = json.loads((args.out / "ssao.json").read_text())
        for case in res["cases"]:
            case["comparison"] = compare(case)
        write_all(res, args.out)
        return 0
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    if args.quick:
        sizes, args.repeats, args.interleave = [(96, 64)], 1, 1
    names = args.datasets.split(",")
    res = {"meta": metadata(["bench/ssao.py", *argv]), "config": {"sizes": sizes, "repeats": args.repeats},
           "cases": [], "skipped": []}
    pass_ = SSAO()
    for name in names:
        loaded = load(name, args.data)
        if loaded is None:
            if args.quick and "synthetic" not in names:
                loaded, name = load("synthetic", args.data), "synthetic"
            else:
                res["skipped"].append({"dataset": name, "reason": f"not found under {args.data}"})
                log(f"{name}: skipped (no data)")
                continue
        hm, cells, r_cells, source = loaded
        radius = r_cells * hm.dx
        for kind in args.views.split(","):
            for width, height in sizes:
                view, shown = view_for(kind, hm, cells, width, height)
                delta = 0.05 * view.pixel
                log(f"{name} {kind} {width}x{height}: R = {radius:.1f} m, pixel {view.pixel:.2f} m")
                n_truth = 400 if args.quick else 3000
                case = run_case(pass_, view, shown, radius, delta, n_truth, 256 if args.quick else 4096,
                                64 if args.quick else 512, args.repeats, args.interleave, args.quick)
                case.update({"dataset": name, "view": kind, "source": source, "width": width, "height": height,
                             "cells": cells, "radius_m": radius, "delta_m": delta, "pixel_m": view.pixel})
                case["comparison"] = compare(case)
                res["cases"].append(case)
                print(f"{name} {kind} {width}x{height}: {comparison_line(case['comparison'])}", flush=True)
    write_all(res, args.out)
    return 0


def write_all(res: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "ssao.json").write_text(json.dumps(res, indent=1))
    write_md(res, out / "ssao.md")
    if res["cases"]:
        write_png(res, out / "ssao.png")


if __name__ == "__main__":
    sys.exit(main())
