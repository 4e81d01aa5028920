#!/usr/bin/env python
"""Per-pixel shadow pass over a G-buffer: q = 0 against the float64 twin, the error of q
against its time, and paper 000 Fig. 8 (time against sun elevation per level), in one run.

    python bench/screen_shadows.py                       # canyon 2048^2 + Puget 2048^2
    python bench/screen_shadows.py --quick --out /tmp/b  # tiny sizes (the smoke test)

Three parts per dataset, each a section of screen_shadows.md:

* **q = 0 against the float64 twin** (``--twin-views``, default five: straight down
  with the grid axes, oblique, low, and close-ups at a few and at many pixels per
  cell, all rendered by oclshade.terrain.TerrainRenderer at ``--twin-size``; ten suns
  :data:`TWIN_SUNS`, axis-aligned and grazing among them): every pixel's q = 0
  verdict (``exact``) against :func:`oclshade.reference.pixel_shadows`;
  disagreements (ties apart) and ties, a tie being a pixel whose margin_lo <= 0 <
  margin_hi (the twin's walk with every tested value moved by the kernel's float32
  error bound, :class:`oclshade.reference.screen_shadows.Rounding`), and the band's
  width (margin_hi - margin_lo, median and 99th percentile).
* **Error against time for q** (``--sizes`` x ``--views`` top / oblique / low x
  ``--q-elevations``): for q forced to 0, 1, 2, 3 and automatic q (Algo 1, n_a_max 16)
  with LOD bias 0, -1, +1: time (min of ``--reps``, G-buffer resident), traversal
  steps per map pixel, and the error as the share of the shadowed pixels (q = 0
  exact is the truth) that the setting misses and adds.
* **Time against sun elevation** (paper 000 Fig. 8) on the main view (``--view``,
  ``--width`` x ``--height``): every elevation 0..90 (``--step``) at ``--azimuth``,
  the settings above with ``exact`` and q = 0 / automatic with ``maxmip`` and
  ``dda``; steps per level at low sun; the whole-map heightmap-space mask's time.

G-buffer of the main view: ``rendered`` (default; ``frame_heightmap`` from
``--camera-azimuth`` / ``--camera-elevation``) or ``plane``, a perspective view of
the map's mid-height plane (``plane_view``, no renderer).  Writes
screen_shadows.json / .md / .png to ``--out``; timings are for the machine that ran
it (recorded in the report).
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
sys.path.insert(0, str(REPO))          # the source tree (its kernels), not an installed copy
sys.path.insert(0, str(REPO / "bench"))
from shadow_masks import DEFAULT_DATA, Skip, load_dataset, metadata  # noqa: E402

SETTINGS = ("q0", "q1", "q2", "q3", "auto", "auto-1", "auto+1")
EXTRA_METHODS = ("maxmip", "dda")
EXTRA_SETTINGS = ("q0", "auto")
_T0 = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - _T0:8.1f} s] {msg}", file=sys.stderr, flush=True)


def lod_options(setting: str):
    """q0..q3: forced level; auto: Algo 1 (n_a_max 16); auto+1 / auto-1: Algo 1 with LOD bias +1 / -1."""
    from oclshade.screen_shadows import LodOptions
    if setting.startswith("auto"):
        return LodOptions.automatic(bias=int(setting[4:] or 0))
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
    """The G-buffer the Fig. 8 sweep runs on and a description of it."""
    if args.view == "plane":
        return plane_view(hm, args.width, args.height), "plane_view (perspective view of the map's mid plane)"
    t0 = time.perf_counter()
    gb = render(hm, camera_for(hm, "oblique", args.width, args.height, args))
    return gb, (f"rendered by oclshade.terrain.TerrainRenderer (bisect), camera "
                f"frame_heightmap(azimuth={args.camera_azimuth:g}, elevation={args.camera_elevation:g}), "
                f"render + copy {1e3 * (time.perf_counter() - t0):.0f} ms")


#: views of the q table and the twin check: name -> how the camera is placed
VIEWS = {
    "top": "frame_heightmap from straight above (elevation 89.99, camera azimuth 180: the grid axes along the "
           "screen's)",
    "oblique": "frame_heightmap(--camera-azimuth, --camera-elevation)",
    "low": "frame_heightmap(--camera-azimuth, 12)",
    "close-few": "a pinhole 50 degrees above the steepest sample of the map's central half (so that shadows "
                 "fall in view), at the distance that gives 3 pixels per cell",
    "close-many": "the same at 20 pixels per cell",
}
#: suns of the twin check (azimuth, elevation): axis-aligned and grazing (1-4 degrees) among them
TWIN_SUNS = ((0.0, 3.0), (90.0, 1.0), (180.0, 10.0), (270.0, 2.0), (250.0, 4.0), (135.0, 8.0), (37.0, 20.0),
             (300.0, 15.0), (45.0, 45.0), (200.0, 60.0))


def camera_for(hm, view: str, width: int, height: int, args):
    """The camera of a named view (:data:`VIEWS`)."""
    from oclshade.camera import Camera, frame_heightmap
    if view == "top":
        return frame_heightmap(hm, width, height, 180.0, 89.99)
    if view in ("oblique", "low"):
        elevation = args.camera_elevation if view == "oblique" else 12.0
        return frame_heightmap(hm, width, height, args.camera_azimuth, elevation)
    per_cell = {"close-few": 3.0, "close-many": 20.0}[view]
    fov = 40.0
    half_width = math.tan(math.radians(fov) / 2.0) * width / height
    distance = width * min(hm.dx, hm.dy) / (2.0 * half_width * per_cell)
    i, j = steepest_central_sample(hm)
    centre = np.array([j * hm.dx, -i * hm.dy, float(hm.heights[i, j])])
    az, el = math.radians(args.camera_azimuth), math.radians(50.0)
    eye = centre + distance * np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
    return Camera(eye, centre, width, height, fov=fov, near=0.1, far=1e7)


def steepest_central_sample(hm) -> tuple[int, int]:
    """(row, col) of the largest gradient magnitude among the samples of the map's central half."""
    rows, cols = hm.shape
    h = np.where(np.isfinite(hm.heights), hm.heights, np.nanmin(hm.heights))
    gy, gx = np.gradient(h, hm.dy, hm.dx) if min(rows, cols) > 1 else (np.zeros_like(h), np.zeros_like(h))
    r0, c0 = rows // 4, cols // 4
    mag = np.hypot(gx, gy)[r0:rows - r0 or rows, c0:cols - c0 or cols]
    i, j = np.unravel_index(np.argmax(mag), mag.shape)
    return int(i + r0), int(j + c0)


def render(hm, camera):
    from oclshade.terrain import Heightfield, TerrainRenderer
    return TerrainRenderer(Heightfield(hm)).render(camera)


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


def shadow_error(flag: np.ndarray, truth: np.ndarray, hit: np.ndarray) -> dict:
    """The error of a flag image against q = 0 exact, as shares of the pixels q = 0 shadows:
    missed (shadowed there, lit here), added (lit there, shadowed here), their sum."""
    shadowed = int(((truth == 1) & hit).sum())
    missed = int(((truth == 1) & (flag == 0) & hit).sum())
    added = int(((truth == 0) & (flag == 1) & hit).sum())
    pct = (lambda n: 100.0 * n / shadowed) if shadowed else (lambda n: 0.0 if n == 0 else math.inf)
    return {"shadowed_px": shadowed, "missed_pct": pct(missed), "added_pct": pct(added),
            "error_pct": pct(missed + added)}


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
    caster = ScreenShadowCaster(hm)
    t0 = time.perf_counter()
    caster.coarse
    caster.runtime.queue.finish()
    prep_ms = (time.perf_counter() - t0) * 1e3
    for m in ("exact", *EXTRA_METHODS):                 # compile every variant before timing
        caster.warm_up(m)
    res = {"name": name, "skipped": None, "shape": list(hm.shape), "cell_m": [hm.dx, hm.dy],
           "source": data["source"], "prep_ms": prep_ms, "levels": caster.pyramid.levels}
    res["twin"] = twin_check(caster, hm, args)
    res["q_table"] = q_table(caster, hm, args)
    gb, res["view"] = make_view(hm, args)
    dev = PixelBuffers.upload(gb, caster.runtime)
    hit = gb.hit
    lod = caster.shade(dev, (args.azimuth, 45.0), lod=lod_options("auto"), outputs="lod").lod
    res["auto_q_histogram"] = {int(k): int(v) for k, v in zip(*np.unique(lod[hit], return_counts=True))}
    res["hit_pixels"] = int(hit.sum())
    res["suns"] = fig8_sweep(caster, gb, dev, args, name)
    res["cells"] = time_cells(hm, args)
    res["steps"] = {}
    for elev in args.steps_elevations:
        for method in ("exact", "maxmip"):
            for setting in ("q0", "q1", "q2", "auto"):
                counts = caster.step_counts(dev, (args.azimuth, elev), method, lod_options(setting))
                res["steps"][f"{elev:g}/{method}/{setting}"] = (counts / max(int(hit.sum()), 1)).tolist()
    return res


def fig8_sweep(caster, gb, dev, args, name: str) -> list[dict]:
    """Every setting at every sun elevation on the main view (high sun first: dda gets slower
    as the sun sinks and stops once over --dda-limit-ms)."""
    hit = gb.hit
    elevations = [float(e) for e in np.arange(0.0, 90.0 + 1e-9, args.step)][::-1]
    out: dict = {}
    skip_dda = False
    suns = []
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
                entry["runs"][f"{method}/{setting}"] = {"time_ms": t, **shadow_error(flag, base, hit),
                                                        "shadow_pct": float((flag[hit] == 1).mean() * 100.0)}
                if method == "dda" and t["min"] > args.dda_limit_ms:
                    skip_dda = True                      # dda at lower suns only gets slower
        suns.insert(0, entry)
        log(f"{name} elev {elev:4.1f}: " + ", ".join(f"{k} {v['time_ms']['min']:.0f} ms/{v['error_pct']:.2f}%"
                                                    for k, v in entry["runs"].items()))
    return suns


def twin_check(caster, hm, args) -> list[dict]:
    """q = 0 (exact) against the float64 twin on every pixel of every twin view and sun."""
    from oclshade import reference as ref
    from oclshade.sun import Sun
    out = []
    for view in args.twin_views:
        gb = render(hm, camera_for(hm, view, *args.twin_size, args))
        for az, el in args.twin_suns:
            sun = Sun(az, el)
            flag = caster.shade(gb, sun, "exact", lod_options("q0")).flag
            t0 = time.perf_counter()
            expected = ref.pixel_shadows(hm, sun, gb.uv, gb.hit)
            valid = expected.mask != 255
            ties = expected.ties() & valid
            differ = (flag != expected.mask) & valid
            seen = valid & np.isfinite(expected.margin)
            width = (expected.margin_hi - expected.margin_lo)[seen]
            row = {"view": view, "sun": [az, el], "tests": int(valid.sum()),
                   "shadowed": int((expected.mask == 1).sum()),
                   "disagreements": int((differ & ~ties).sum()), "tied_mismatches": int((differ & ties).sum()),
                   "ties": int(ties.sum()), "corner_grazes": int((expected.graze & valid).sum()),
                   "band_median": float(np.median(width)) if width.size else 0.0,
                   "band_p99": float(np.percentile(width, 99)) if width.size else 0.0,
                   "reference_s": time.perf_counter() - t0}
            out.append(row)
            log(f"twin {view} sun {az:g}/{el:g}: {row['tests']} tests, {row['disagreements']} disagreements, "
                f"{row['ties']} ties ({row['reference_s']:.1f} s)")
    return out


def q_table(caster, hm, args) -> list[dict]:
    """Time, steps and error (of the shadowed pixels) of every setting, per size, view and sun."""
    from oclshade.screen_shadows import PixelBuffers
    rows = []
    for width, height in args.sizes:
        for view in args.views:
            gb = render(hm, camera_for(hm, view, width, height, args))
            dev = PixelBuffers.upload(gb, caster.runtime)
            hit = gb.hit
            lod = caster.shade(dev, (args.azimuth, 45.0), lod=lod_options("auto"), outputs="lod").lod
            hist = {int(k): int(v) for k, v in zip(*np.unique(lod[hit], return_counts=True))}
            out: dict = {}
            for elev in args.q_elevations:
                sun = (args.azimuth, elev)
                row = {"size": [width, height], "view": view, "elevation": elev, "hit_pixels": int(hit.sum()),
                       "auto_q_histogram": hist, "runs": {}}
                base = None
                for setting in SETTINGS:
                    t, out = _time_pass(caster, dev, sun, "exact", lod_options(setting), args.reps, out)
                    flag = _flag(caster, out["flag"], gb.shape)
                    base = flag if base is None else base
                    steps = caster.step_counts(dev, sun, "exact", lod_options(setting))
                    row["runs"][setting] = {"time_ms": t,
                                            "steps_per_pixel": float(steps.sum()) / max(int(hit.sum()), 1),
                                            **shadow_error(flag, base, hit)}
                row["shadowed_pct"] = 100.0 * row["runs"]["q0"]["shadowed_px"] / max(int(hit.sum()), 1)
                rows.append(row)
                log(f"q table {width}x{height} {view} elev {elev:g}: " + ", ".join(
                    f"{k} {v['time_ms']['min']:.0f} ms/{v['error_pct']:.2f}%" for k, v in row["runs"].items()))
    return rows


def time_cells(hm, args) -> list[dict]:
    """Baseline: the heightmap-space exact mask of the whole map (ShadowCaster) at the same suns."""
    from oclshade.shadows import ShadowCaster
    caster = ShadowCaster(hm)
    caster.warm_up()
    caster.cast((args.azimuth, 45.0))                  # first launch outside the timing
    out = []
    for elev in args.steps_elevations:
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
    twin = ds["twin"]
    tests = sum(r["tests"] for r in twin)
    out["twin"] = {"views": len({r["view"] for r in twin}), "suns": len({tuple(r["sun"]) for r in twin}),
                   "tests": tests, "disagreements": sum(r["disagreements"] for r in twin),
                   "ties": sum(r["ties"] for r in twin),
                   "ties_pct": 100.0 * sum(r["ties"] for r in twin) / max(tests, 1)}
    out["q_error_max"] = {setting: max((r["runs"][setting]["error_pct"] for r in ds["q_table"]), default=0.0)
                          for setting in SETTINGS}
    return out


def _run_keys(ds: dict) -> list[str]:
    """Every method/setting measured at some elevation (dda stops at low sun), in run order."""
    keys: dict[str, None] = {}
    for s in sorted(ds["suns"], key=lambda s: -s["elevation"]):
        keys.update(dict.fromkeys(s["runs"]))
    return list(keys)


def _twin_section(ds: dict) -> list[str]:
    sm = ds["summary"]["twin"]
    lines = ["### q = 0 against the float64 twin", "",
             f"Every map pixel of {sm['views']} views x {sm['suns']} suns: `ScreenShadowCaster.shade` (exact, q = 0) "
             "against `oclshade.reference.pixel_shadows`.  **Tie band**: per pixel, the twin's walk repeated with "
             "every value of f = S - z the kernel tests (a patch's entry, exit and tangent point; a start patch's "
             "linear test) moved down / up by a bound of the kernel's float32 error in that value, derived from the "
             "operations it performs (`oclshade.reference.screen_shadows.Rounding`: relative positions, heights "
             "relative to the start's nearest sample, f carried from the start within one cell); a tie is a pixel "
             "whose lowered margin is <= 0 and raised margin > 0.  Band = margin_hi - margin_lo (tangent units).", "",
             f"**Total: {sm['tests']} tests, {sm['disagreements']} disagreements, {sm['ties']} ties "
             f"({sm['ties_pct']:.5f} %).**", "",
             "| view | sun az/el | tests | shadowed | disagreements | ties | tied mismatches | corner grazes | "
             "band median | band p99 | twin s |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in ds["twin"]:
        lines.append(f"| {r['view']} | {r['sun'][0]:g}/{r['sun'][1]:g} | {r['tests']} | {r['shadowed']} | "
                     f"{r['disagreements']} | {r['ties']} | {r['tied_mismatches']} | {r['corner_grazes']} | "
                     f"{r['band_median']:.1e} | {r['band_p99']:.1e} | {r['reference_s']:.1f} |")
    lines += ["", "Views: " + "; ".join(f"{v}: {VIEWS[v]}" for v in dict.fromkeys(r["view"] for r in ds["twin"])), ""]
    return lines


def _q_section(ds: dict) -> list[str]:
    lines = ["### Error against time for q", "",
             "Error = share of the pixels q = 0 exact shadows that a setting misses + adds (missed / added in the "
             "JSON); time = wall min of the pass (G-buffer resident); steps = traversal iterations per map pixel "
             "(a measure of work that does not depend on the machine's load).  Cells: time ms / steps / error %.", "",
             "| size | view | sun elev | shadowed | " + " | ".join(SETTINGS) + " |",
             "|---|---|---:|---:|" + "---:|" * len(SETTINGS)]
    for r in ds["q_table"]:
        cells = [f"{v['time_ms']['min']:.0f} / {v['steps_per_pixel']:.1f} / {v['error_pct']:.2f} %"
                 for v in (r["runs"][k] for k in SETTINGS)]
        lines.append(f"| {r['size'][0]}x{r['size'][1]} | {r['view']} | {r['elevation']:g} | "
                     f"{r['shadowed_pct']:.1f} % | " + " | ".join(cells) + " |")
    worst = ds["summary"]["q_error_max"]
    lines += ["", "Largest error per setting: " + ", ".join(f"{k} {v:.2f} %" for k, v in worst.items()), "",
              "Automatic q histograms (pixels per level, sun at 45 degrees): " + "; ".join(
                  f"{r['size'][0]}x{r['size'][1]} {r['view']}: {r['auto_q_histogram']}"
                  for r in ds["q_table"] if r["elevation"] == ds["q_table"][0]["elevation"]), ""]
    return lines


def write_markdown(path: Path, result: dict) -> None:
    meta, cfg = result["meta"], result["config"]
    lines = ["# Per-pixel shadow pass over a G-buffer (paper 000)", "",
             f"- date: {meta['date']}; command: `{meta['command']}`",
             f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']} ({meta['compute_units']} compute units)",
             f"- PoCL {meta['pocl_version']} ({meta['platform_version']}); numpy {meta['numpy']}, pyopencl {meta['pyopencl']}",
             f"- sun azimuth {cfg['azimuth']:g} (q table and Fig. 8); times: enqueue..finish of "
             f"`ScreenShadowCaster.shade_to_device` (flag + coefficient, G-buffer resident), min of {cfg['reps']}", ""]
    for ds in result["datasets"]:
        lines += [f"## {ds['name']}", ""]
        if ds["skipped"]:
            lines += [f"skipped: {ds['skipped']}", ""]
            continue
        sm = ds["summary"]
        lines += [f"{ds['source']}; {ds['shape'][0]}x{ds['shape'][1]}, cells {ds['cell_m'][0]:.2f} x "
                  f"{ds['cell_m'][1]:.2f} m; level grids + pyramids {ds['prep_ms']:.0f} ms", ""]
        lines += _twin_section(ds)
        lines += _q_section(ds)
        lines += ["### Time against sun elevation (paper 000 Fig. 8)", "",
                  f"G-buffer {cfg['width']}x{cfg['height']} {ds['view']}; {ds['hit_pixels']} map pixels; automatic q "
                  f"histogram (pixels per level): {ds['auto_q_histogram']}", ""]
        if "auto_ms_at_must" in sm:
            lines.append(f"- automatic q at {cfg['must_elevation']:g} deg: **{sm['auto_ms_at_must']:.0f} ms** wall (min), "
                         f"{sm['auto_cpu_ms_at_must']:.0f} ms CPU = {sm['auto_cpu_ms_at_must'] / meta['cores']:.0f} ms "
                         f"on {meta['cores']} idle cores; error {sm['auto_error_pct_at_must']:.2f} % of the shadowed pixels")
        lines.append(f"- automatic q error over all elevations: mean {sm['auto_error_pct_mean']:.2f} %, "
                     f"max {sm['auto_error_pct_max']:.2f} % of the shadowed pixels")
        ratios = ", ".join(f"{k}: {v:.2f}x" for k, v in sm["maxmip_over_exact_low_sun"].items())
        lines += [f"- maxmip / exact time at low sun (elevation/setting): {ratios}", "",
                  "Cells: wall min / CPU min / error (% of the shadowed pixels, missed + added)", ""]
        keys = _run_keys(ds)
        lines += ["| elev | " + " | ".join(keys) + " |", "|---:|" + "---:|" * len(keys)]
        for s in ds["suns"]:
            cells = []
            for k in keys:
                r = s["runs"].get(k)
                cells.append("-" if r is None else
                             f"{r['time_ms']['min']:.0f} / {r['time_ms']['cpu_min']:.0f} ms / {r['error_pct']:.2f} %")
            lines.append(f"| {s['elevation']:g} | " + " | ".join(cells) + " |")
        lines += ["", "The heightmap-space exact mask of the whole map (`ShadowCaster.cast`, wall min): " + ", ".join(
            f"{c['elevation']:g} deg {c['time_ms_min']:.0f} ms" for c in ds["cells"]), "",
            "Traversal steps per map pixel by pyramid level (level 0 first):", "",
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
            ax.plot(el, t, "-o" if key.startswith("exact") else "--", ms=3, label=key)
        ax.set_yscale("log")
        ax.set_title(f"{ds['name']} {ds['shape'][0]}x{ds['shape'][1]}: shadow pass time (Fig. 8)", fontsize=10)
        ax.set_xlabel("sun elevation (deg)")
        ax.set_ylabel(f"process CPU ms / {cores} cores (min)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        for i, setting in enumerate(SETTINGS):
            pts = [(r["runs"][setting]["steps_per_pixel"], r["runs"][setting]["error_pct"]) for r in ds["q_table"]]
            if pts:
                x, y = zip(*pts)
                ax2.scatter(x, np.maximum(y, 1e-3), s=12, label=setting, marker="os^v<>D"[i % 7])
        ax2.set_yscale("log")
        ax2.set_title("q table: error against work (every size, view and sun; 0 drawn at 1e-3)", fontsize=9)
        ax2.set_xlabel("traversal steps per map pixel")
        ax2.set_ylabel("% of the shadowed pixels missed + added")
        ax2.grid(alpha=0.3)
        ax2.legend(fontsize=7)
    fig.suptitle(f"Per-pixel shadows, {result['meta']['device']} (shared machine: CPU time / cores estimates the "
                 "wall time on idle cores; wall times in the .md)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def _floats(text: str) -> list[float]:
    return [float(x) for x in text.split(",") if x]


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].replace("\n", " "))
    p.add_argument("--quick", action="store_true",
                   help="tiny sizes: 256^2 canyon, 192x108, step 30, 1 rep, q table at 10 deg, twin 96x54 x 3 suns")
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
    p.add_argument("--sizes", type=lambda s: [_size(x) for x in s.split(",") if x], default=[(480, 270), (1920, 1080)],
                   help="G-buffer sizes of the q table, e.g. 480x270,1920x1080")
    p.add_argument("--views", type=lambda s: [x for x in s.split(",") if x], default=["top", "oblique", "low"],
                   help=f"views of the q table ({', '.join(VIEWS)})")
    p.add_argument("--q-elevations", type=_floats, default=[3.0, 5.0, 10.0, 20.0, 40.0])
    p.add_argument("--twin-views", type=lambda s: [x for x in s.split(",") if x], default=list(VIEWS))
    p.add_argument("--twin-size", type=_size, default=(480, 270))
    p.add_argument("--twin-suns", type=lambda s: [tuple(_floats(x.replace("/", ","))) for x in s.split(";") if x],
                   default=list(TWIN_SUNS), help="az/el;az/el;...")
    p.add_argument("--steps-elevations", type=_floats, default=[5.0, 10.0])
    args = p.parse_args(argv)
    if args.quick:
        args.size, args.width, args.height, args.step, args.reps = 256, 192, 108, 30.0, 1
        args.steps_elevations, args.sizes, args.q_elevations = [10.0], [(192, 108)], [10.0]
        args.twin_size, args.twin_suns = (96, 54), list(TWIN_SUNS[:3])
    bad = [v for v in (*args.views, *args.twin_views) if v not in VIEWS]
    if bad:
        p.error(f"unknown view(s) {', '.join(bad)}; expected some of {', '.join(VIEWS)}")
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
