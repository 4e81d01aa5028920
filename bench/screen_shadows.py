#!/usr/bin/env python
"""Per-pixel shadow pass over a G-buffer: paper 000 Fig. 8 reproduced (time against sun
elevation for each level of detail) with the error of each setting, in one run.

    python bench/screen_shadows.py                       # 1920x1080, canyon 2048^2 + Puget 2048^2
    python bench/screen_shadows.py --quick --out /tmp/b  # tiny sizes (the smoke test)

G-buffer (``--view``): ``rendered`` (default) by the terrain ray caster
(oclshade.terrain, camera ``frame_heightmap``: the whole map seen from the
south-south-west, 35 degrees up); or ``plane``, a perspective view
(``plane_view``) of the map's mid-height plane by a camera south-west of the
map looking north-east and down, uv / uv_grad / position filled per pixel
without a renderer (every pixel of the plane is a terrain point of the map).

For every dataset and every sun elevation 0..90 (``--step``) at azimuth
``--azimuth`` it times the pass (min / median of ``--reps``, kernel enqueue
to finish, G-buffer resident on the device, outputs flag + coefficient) for
q forced to 0, 1, 2, 3, automatic q (Algo 1, n_a_max 16) and automatic q
with LOD bias +1 with ``exact``,
and for q = 0 and automatic q with ``maxmip`` and ``dda``; error = percent
of map pixels whose shadow flag differs from q = 0 exact at the same sun.
At low sun it also counts traversal steps per pixel by pyramid level
(exact against maxmip: the min early exit).  Writes screen_shadows.json /
.md / .png to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from shadow_masks import DEFAULT_DATA, Skip, load_dataset, metadata  # noqa: E402

SETTINGS = ("q0", "q1", "q2", "q3", "auto", "auto+1")
EXTRA_METHODS = ("maxmip", "dda")
EXTRA_SETTINGS = ("q0", "auto")
_T0 = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - _T0:8.1f} s] {msg}", file=sys.stderr, flush=True)


def lod_options(setting: str):
    from oclshade.screen_shadows import LodOptions
    """q0..q3: forced level; auto: Algo 1 (n_a_max 16); auto+1: Algo 1 with LOD bias +1."""
    if setting.startswith("auto"):
        return LodOptions(bias=int(setting[4:] or 0))
    return LodOptions(force_q=int(setting[1:]))


# ----------------------------------------------------------------------------- the view
def plane_view(hm, width: int, height: int, vfov_deg: float = 45.0, pitch_deg: float = -28.0,
               yaw_deg: float = 45.0, altitude_frac: float = 0.06):
    """GBuffer of the map's mid plane seen by a pinhole camera (see the module docstring).

    World: x east, y north (sample (i, j) at (j dx, -i dy)), z up.  The camera
    stands outside the south-west corner at altitude_frac * map diagonal above
    the plane, yaw clockwise from north, pitch below the horizon."""
    from oclshade.gbuffer import GBuffer
    rows, cols = hm.shape
    ext_x, ext_y = (cols - 1) * hm.dx, (rows - 1) * hm.dy
    diag = math.hypot(ext_x, ext_y)
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
    eye = np.array([-0.02 * ext_x, -ext_y - 0.02 * ext_y, altitude_frac * diag])
    fwd = np.array([math.sin(yaw) * math.cos(pitch), math.cos(yaw) * math.cos(pitch), math.sin(pitch)])
    right = np.array([math.cos(yaw), -math.sin(yaw), 0.0])
    up = np.cross(right, fwd)
    ty = math.tan(math.radians(vfov_deg) / 2.0)
    tx = ty * width / height
    c = (2.0 * np.arange(width) + 1.0) / width - 1.0
    r = 1.0 - (2.0 * np.arange(height) + 1.0) / height
    cx, ry = np.meshgrid(c * tx, r * ty)                       # camera-space direction (cx, ry, -1)
    d = fwd[None, None] + cx[..., None] * right + ry[..., None] * up
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(d[..., 2] < 0, -eye[2] / d[..., 2], np.inf)   # plane z = 0 (relative)
        x, y = eye[0] + t * d[..., 0], eye[1] + t * d[..., 1]
        uv = np.stack([x / hm.dx, -y / hm.dy], -1)
    hit = np.isfinite(t) & (uv[..., 0] >= 0) & (uv[..., 0] <= cols - 1) & (uv[..., 1] >= 0) & (uv[..., 1] <= rows - 1)
    du_dc = np.gradient(np.where(np.isfinite(uv), uv, 0.0), axis=1)
    du_dr = np.gradient(np.where(np.isfinite(uv), uv, 0.0), axis=0)
    pos = np.zeros((height, width, 4))
    pos[..., 0], pos[..., 1], pos[..., 2] = cx * t, ry * t, -t
    pos[..., 3] = hit
    z = lambda a: np.where(hit[..., None] if a.ndim == 3 else hit, a, 0.0)  # noqa: E731
    return GBuffer(z(pos), np.zeros((height, width, 4)), z(uv), z(np.concatenate([du_dc, du_dr], -1)),
                   np.where(hit, t, np.inf), np.zeros((height, width, 4)))


def make_view(hm, args) -> tuple:
    """The G-buffer the pass runs on and a description of it."""
    if args.view == "plane":
        return plane_view(hm, args.width, args.height), "plane_view (perspective view of the map's mid plane)"
    from oclshade.camera import frame_heightmap
    from oclshade.terrain import Heightfield, TerrainRenderer
    camera = frame_heightmap(hm, args.width, args.height, azimuth=args.camera_azimuth,
                             elevation=args.camera_elevation)
    t0 = time.perf_counter()
    gb = TerrainRenderer(Heightfield(hm)).render(camera)
    return gb, (f"rendered by oclshade.terrain.TerrainRenderer (bisect), camera "
                f"frame_heightmap(azimuth={args.camera_azimuth:g}, elevation={args.camera_elevation:g}), "
                f"render + copy {1e3 * (time.perf_counter() - t0):.0f} ms")


# ----------------------------------------------------------------------------- measuring
def _time_pass(caster, dev_gb, sun, method, lod, reps: int, out: dict) -> tuple[dict, dict]:
    """Wall time (min, median) and process CPU time (min; PoCL's threads are ours) of the pass.
    On a shared machine cpu_min / cores estimates the wall time on idle cores."""
    q = caster.runtime.queue
    samples, cpu = [], []
    for _ in range(reps):
        q.finish()
        t0, c0 = time.perf_counter(), time.process_time()
        out = caster.shade_to_device(dev_gb, sun, method, lod, ("flag", "coefficient"), out=out)
        q.finish()
        samples.append((time.perf_counter() - t0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
    return {"min": min(samples), "median": statistics.median(samples), "n": reps, "cpu_min": min(cpu)}, out


def _flag(caster, buf, shape) -> np.ndarray:
    import pyopencl as cl
    a = np.empty(shape, np.uint8)
    cl.enqueue_copy(caster.runtime.queue, a, buf).wait()
    return a


def bench_dataset(name: str, args: argparse.Namespace) -> dict:
    from oclshade.heightmap import Heightmap
    from oclshade.screen_shadows import PixelBuffers, ScreenShadowCaster
    try:
        data = load_dataset(name, args.size, args.data)
    except Skip as e:
        log(f"{name}: skipped ({e})")
        return {"name": name, "skipped": str(e)}
    hm = Heightmap.from_array(data["heights"], (data["dx"], data["dy"]))
    log(f"{name}: {hm.shape}, G-buffer {args.width}x{args.height}")
    gb, view = make_view(hm, args)
    caster = ScreenShadowCaster(hm)
    t0 = time.perf_counter()
    caster.coarse
    caster.runtime.queue.finish()
    prep_ms = (time.perf_counter() - t0) * 1e3
    dev = PixelBuffers.upload(gb, caster.runtime)
    hit = gb.hit
    lod = caster.shade(dev, (args.azimuth, 45.0), lod=lod_options("auto"), outputs="lod").lod
    q_hist = {int(k): int(v) for k, v in zip(*np.unique(lod[hit], return_counts=True))}
    res = {"name": name, "skipped": None, "shape": list(hm.shape), "cell_m": [hm.dx, hm.dy], "view": view,
           "source": data["source"], "prep_ms": prep_ms, "hit_pixels": int(hit.sum()),
           "auto_q_histogram": q_hist, "levels": caster.pyramid.levels, "suns": []}
    for m in ("exact", *EXTRA_METHODS):                 # compile every variant before timing
        caster.warm_up(m)
    # high sun first: dda gets slower as the sun sinks and stops once over --dda-limit-ms
    elevations = [float(e) for e in np.arange(0.0, 90.0 + 1e-9, args.step)][::-1]
    out: dict = {}
    skip_dda = False
    for elev in elevations:
        sun = (args.azimuth, elev)
        entry = {"elevation": elev, "runs": {}}
        base = None
        for method in ("exact", *EXTRA_METHODS):
            for setting in SETTINGS if method == "exact" else EXTRA_SETTINGS:
                if method == "dda" and skip_dda:
                    continue
                t, out = _time_pass(caster, dev, sun, method, lod_options(setting), args.reps, out)
                flag = _flag(caster, out["flag"], gb.shape)
                if base is None:
                    base = flag
                diff = float((flag[hit] != base[hit]).mean() * 100.0) if hit.any() else 0.0
                entry["runs"][f"{method}/{setting}"] = {"time_ms": t, "error_pct": diff,
                                                        "shadow_pct": float((flag[hit] == 1).mean() * 100.0)}
                if method == "dda" and t["min"] > args.dda_limit_ms:
                    skip_dda = True                      # dda at lower suns only gets slower
        res["suns"].insert(0, entry)
        log(f"{name} elev {elev:4.1f}: " + ", ".join(f"{k} {v['time_ms']['min']:.0f} ms/{v['error_pct']:.2f}%"
                                                    for k, v in entry["runs"].items()))
    res["reference"] = check_reference(caster, hm, gb, dev, args)
    res["cells"] = time_cells(hm, args)
    res["steps"] = {}
    for elev in args.steps_elevations:
        for method in ("exact", "maxmip"):
            for setting in ("q0", "q1", "q2", "auto"):
                counts = caster.step_counts(dev, (args.azimuth, elev), method, lod_options(setting))
                res["steps"][f"{elev:g}/{method}/{setting}"] = (counts / max(int(hit.sum()), 1)).tolist()
    return res


def check_reference(caster, hm, gb, dev, args) -> list[dict]:
    """q = 0 exact against the float64 reference on a random sample of map pixels."""
    from oclshade import reference as ref
    from oclshade.sun import Sun
    rng = np.random.default_rng(0)
    idx = np.flatnonzero(gb.hit)
    pick = np.sort(rng.choice(idx, min(args.ref_pixels, idx.size), replace=False))
    uv = gb.uv.reshape(-1, 2)[pick][None]
    out = []
    for elev in args.ref_elevations:
        sun = Sun(args.azimuth, elev)
        flag = caster.shade(dev, sun, "exact", lod_options("q0")).flag.ravel()[pick][None]
        t0 = time.perf_counter()
        expected = ref.pixel_shadows(hm, sun, uv, np.ones(uv.shape[:2], bool))
        ref_s = time.perf_counter() - t0
        differ = flag != expected.mask
        ties = expected.ties()
        out.append({"elevation": elev, "pixels": int(pick.size), "mismatches": int(differ.sum()),
                    "tied": int((differ & ties).sum()), "non_tie": int((differ & ~ties).sum()),
                    "reference_s": ref_s})
        log(f"reference at {elev:g} deg: {out[-1]}")
    return out


def time_cells(hm, args) -> list[dict]:
    """Baseline: the heightmap-space exact mask of the whole map (ShadowCaster) at the same suns."""
    from oclshade.shadows import ShadowCaster
    caster = ShadowCaster(hm)
    caster.warm_up()
    caster.cast((args.azimuth, 45.0))                  # first launch outside the timing
    out = []
    for elev in args.ref_elevations:
        samples = []
        for _ in range(args.reps):
            t0 = time.perf_counter()
            caster.cast((args.azimuth, elev))
            samples.append((time.perf_counter() - t0) * 1e3)
        out.append({"elevation": elev, "time_ms_min": min(samples)})
    return out


# ----------------------------------------------------------------------------- reports
def summary(ds: dict, must_elev: float) -> dict:
    suns = {s["elevation"]: s for s in ds["suns"]}
    out = {}
    s = suns.get(must_elev)
    if s:
        out["auto_ms_at_must"] = s["runs"]["exact/auto"]["time_ms"]["min"]
        out["auto_cpu_ms_at_must"] = s["runs"]["exact/auto"]["time_ms"]["cpu_min"]
        out["auto_error_pct_at_must"] = s["runs"]["exact/auto"]["error_pct"]
    autos = [s["runs"]["exact/auto"]["error_pct"] for s in ds["suns"]]
    out["auto_error_pct_max"] = max(autos)
    out["auto_error_pct_mean"] = float(np.mean(autos))
    low = [s for s in ds["suns"] if 0 < s["elevation"] <= 20]
    out["maxmip_over_exact_low_sun"] = {
        f"{s['elevation']:g}/{setting}": s["runs"][f"maxmip/{setting}"]["time_ms"]["min"] /
        s["runs"][f"exact/{setting}"]["time_ms"]["min"] for s in low for setting in EXTRA_SETTINGS}
    return out


def _run_keys(ds: dict) -> list[str]:
    """Every method/setting measured at some elevation (dda stops at low sun), in run order."""
    keys: dict[str, None] = {}
    for s in sorted(ds["suns"], key=lambda s: -s["elevation"]):
        keys.update(dict.fromkeys(s["runs"]))
    return list(keys)


def write_markdown(path: Path, result: dict) -> None:
    meta, cfg = result["meta"], result["config"]
    lines = ["# Per-pixel shadow pass over a G-buffer (paper 000 Fig. 8)", "",
             f"- date: {meta['date']}; command: `{meta['command']}`",
             f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']} ({meta['compute_units']} compute units)",
             f"- PoCL {meta['pocl_version']} ({meta['platform_version']}); numpy {meta['numpy']}, pyopencl {meta['pyopencl']}",
             f"- G-buffer {cfg['width']}x{cfg['height']} (view per dataset below), sun azimuth "
             f"{cfg['azimuth']:g}; time = enqueue..finish of `ScreenShadowCaster.shade_to_device` (flag + "
             f"coefficient, G-buffer resident), min of {cfg['reps']}; error = % of map pixels whose shadow flag "
             "differs from q = 0 exact at the same sun; table cells: wall min / CPU min / error", ""]
    for ds in result["datasets"]:
        lines += [f"## {ds['name']}", ""]
        if ds["skipped"]:
            lines += [f"skipped: {ds['skipped']}", ""]
            continue
        sm = ds["summary"]
        lines += [f"{ds['source']}; G-buffer {ds['view']}; {ds['shape'][0]}x{ds['shape'][1]}, cells {ds['cell_m'][0]:.2f} x "
                  f"{ds['cell_m'][1]:.2f} m; {ds['hit_pixels']} map pixels; level grids + pyramids "
                  f"{ds['prep_ms']:.0f} ms; automatic q histogram (pixels per level): {ds['auto_q_histogram']}", ""]
        if "auto_ms_at_must" in sm:
            lines.append(f"- automatic q at {cfg['must_elevation']:g} deg: **{sm['auto_ms_at_must']:.0f} ms** wall (min), "
                         f"{sm['auto_cpu_ms_at_must']:.0f} ms CPU = {sm['auto_cpu_ms_at_must'] / meta['cores']:.0f} ms "
                         f"on {meta['cores']} idle cores; error {sm['auto_error_pct_at_must']:.2f} %")
        lines.append(f"- automatic q error over all elevations: mean {sm['auto_error_pct_mean']:.2f} %, "
                     f"max {sm['auto_error_pct_max']:.2f} %")
        ratios = ", ".join(f"{k}: {v:.2f}x" for k, v in sm["maxmip_over_exact_low_sun"].items())
        lines += [f"- maxmip / exact time at low sun (elevation/setting): {ratios}", ""]
        keys = _run_keys(ds)
        lines += ["| elev | " + " | ".join(keys) + " |", "|---:|" + "---:|" * len(keys)]
        for s in ds["suns"]:
            cells = []
            for k in keys:
                r = s["runs"].get(k)
                cells.append("-" if r is None else
                             f"{r['time_ms']['min']:.0f} / {r['time_ms']['cpu_min']:.0f} ms / {r['error_pct']:.2f} %")
            lines.append(f"| {s['elevation']:g} | " + " | ".join(cells) + " |")
        lines += ["", "q = 0 exact against the float64 reference `oclshade.reference.pixel_shadows` on random map "
                  "pixels, and the heightmap-space exact mask of the whole map (`ShadowCaster.cast`, wall min) at "
                  "the same sun:", "", "| elev | pixels | mismatches | of which ties | non-tie | reference s | "
                  "whole-map mask ms |", "|---:|---:|---:|---:|---:|---:|---:|"]
        for r, cc in zip(ds["reference"], ds["cells"]):
            lines.append(f"| {r['elevation']:g} | {r['pixels']} | {r['mismatches']} | {r['tied']} | {r['non_tie']} "
                         f"| {r['reference_s']:.1f} | {cc['time_ms_min']:.0f} |")
        lines += ["", "Traversal steps per map pixel by pyramid level (level 0 first):", "",
                  "| sun elev / method / setting | total | by level |", "|---|---:|---|"]
        for k, v in ds["steps"].items():
            lines.append(f"| {k} | {sum(v):.1f} | {' '.join(f'{x:.2f}' for x in v)} |")
        lines.append("")
    path.write_text("\n".join(lines) + "\n")


def write_plot(path: Path, result: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    dss = [d for d in result["datasets"] if not d["skipped"]]
    cores = max(int(result["meta"]["cores"] or 1), 1)
    fig, axes = plt.subplots(2, max(len(dss), 1), figsize=(6.5 * max(len(dss), 1), 8), squeeze=False)
    for col, ds in enumerate(dss):
        el = [s["elevation"] for s in ds["suns"]]
        ax, ax2 = axes[0][col], axes[1][col]
        for key in _run_keys(ds):
            t = [s["runs"][key]["time_ms"]["cpu_min"] / cores if key in s["runs"] else np.nan for s in ds["suns"]]
            e = [s["runs"][key]["error_pct"] if key in s["runs"] else np.nan for s in ds["suns"]]
            style = "-o" if key.startswith("exact") else "--"
            ax.plot(el, t, style, ms=3, label=key)
            ax2.plot(el, e, style, ms=3, label=key)
        ax.set_yscale("log")
        ax.set_title(f"{ds['name']} {ds['shape'][0]}x{ds['shape'][1]}: shadow pass time", fontsize=10)
        ax.set_xlabel("sun elevation (deg)")
        ax.set_ylabel(f"process CPU ms / {cores} cores (min)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        sm = ds["summary"]
        ax2.set_title(f"error vs q=0 exact (automatic q: mean {sm['auto_error_pct_mean']:.2f} %, "
                      f"max {sm['auto_error_pct_max']:.2f} %)", fontsize=9)
        ax2.set_xlabel("sun elevation (deg)")
        ax2.set_ylabel("% of map pixels with another flag")
        ax2.grid(alpha=0.3)
    fig.suptitle(f"Per-pixel shadows, G-buffer {result['config']['width']}x{result['config']['height']}, "
                 f"{result['meta']['device']} (shared machine: CPU time / cores estimates the wall time on idle "
                 "cores; wall times in the .md)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="tiny sizes: 256^2 canyon, 192x108, step 30, 1 rep")
    p.add_argument("--datasets", default="canyon,puget", help="comma list of canyon, puget, srtm_* (shadow_masks names)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA)
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results")
    p.add_argument("--name", default="screen_shadows", help="report file names: NAME.json / .md / .png")
    p.add_argument("--size", type=int, default=2048)
    p.add_argument("--width", type=int, default=1920)
    p.add_argument("--height", type=int, default=1080)
    p.add_argument("--azimuth", type=float, default=37.0, help="sun azimuth")
    p.add_argument("--view", choices=("rendered", "plane"), default="rendered")
    p.add_argument("--camera-azimuth", type=float, default=200.0)
    p.add_argument("--camera-elevation", type=float, default=35.0)
    p.add_argument("--step", type=float, default=5.0)
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--must-elevation", type=float, default=10.0)
    p.add_argument("--dda-limit-ms", type=float, default=4000.0, help="stop timing dda once a pass exceeds this")
    p.add_argument("--ref-pixels", type=int, default=20000, help="map pixels checked against the float64 reference")
    p.add_argument("--ref-elevations", type=lambda s: [float(x) for x in s.split(",") if x], default=[5.0, 10.0, 30.0])
    p.add_argument("--steps-elevations", type=lambda s: [float(x) for x in s.split(",") if x], default=[5.0, 10.0])
    args = p.parse_args(argv)
    if args.quick:
        args.size, args.width, args.height, args.step, args.reps = 256, 192, 108, 30.0, 1
        args.steps_elevations, args.ref_elevations, args.ref_pixels = [10.0], [10.0], 2000
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"meta": metadata(["bench/screen_shadows.py", *argv]),
              "config": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
              "datasets": []}
    for name in [n for n in args.datasets.split(",") if n]:
        ds = bench_dataset(name, args)
        if not ds["skipped"]:
            ds["summary"] = summary(ds, args.must_elevation)
        result["datasets"].append(ds)
    (args.out / f"{args.name}.json").write_text(json.dumps(result, indent=1))
    write_markdown(args.out / f"{args.name}.md", result)
    write_plot(args.out / f"{args.name}.png", result)
    log(f"wrote {args.out}/{args.name}.{{json,md,png}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
