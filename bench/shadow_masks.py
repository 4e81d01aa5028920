#!/usr/bin/env python
"""Cast-shadow mask benchmark: time against error for every method, in one run.

    python bench/shadow_masks.py                      # full run (4096^2 maps, 512^2 crop)
    python bench/shadow_masks.py --quick --datasets synthetic --out /tmp/b

For every dataset (Puget Sound 4096^2, the SRTM3 tiles, the synthetic
canyon-and-crater terrain) and every sun (elevation 5, 20, 45 x azimuth 37,
135 degrees) it measures, per method (exact, paper, maxmip, dda):

* pyramid build time (once per dataset, R fresh builds);
* mask time (min and median of R repetitions, the methods interleaved and
  their order rotated each repetition), host copy of the mask included;
* traversal steps per valid cell by pyramid level (``step_counts``);
* the fraction of valid cells in shadow;
* error: cells of a centre crop that differ from the float64 reference
  (float32 ties counted apart), and cells of the full map that differ from
  ``exact``.

It writes ``shadow_masks.json`` (raw numbers and metadata),
``shadow_masks.md`` (tables and headline ratios) and ``shadow_masks.png``
(time against error; steps per level on the canyon terrain) to ``--out``.
Datasets under ``../shared/data`` that are absent are recorded as skipped.
Progress goes to stderr.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data"
METHODS = ("exact", "paper", "maxmip", "dda")
AZIMUTHS = (37.0, 135.0)
ELEVATIONS = (5.0, 20.0, 45.0)
PUGET_MAX_M = 4392.0
PUGET_CELL_M = 40.0
CANYON_CELL_M = 30.0
DATASET_GROUPS = {
    "all": ("puget", "srtm_N22W160", "srtm_S16E166", "canyon"),
    "real": ("puget", "srtm_N22W160", "srtm_S16E166"),
    "srtm": ("srtm_N22W160", "srtm_S16E166"),
    "synthetic": ("canyon",),
}
SRTM_FILES = {"srtm_N22W160": "N22W160v2.3a.hgt.zip", "srtm_S16E166": "S16E166v2.3a.hgt.zip"}
ERROR_FLOOR_PCT = 1e-4   # plot floor for the symlog error axis (0 is drawn at 0)
_T0 = time.perf_counter()


def log(msg: str) -> None:
    print(f"[{time.perf_counter() - _T0:8.1f} s] {msg}", file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- data
class Skip(Exception):
    """A dataset cannot be loaded here (absent shared data): recorded, not fatal."""


def _centre_crop(h: np.ndarray, size: int) -> np.ndarray:
    r0 = max(0, (h.shape[0] - size) // 2)
    c0 = max(0, (h.shape[1] - size) // 2)
    return h[r0:r0 + size, c0:c0 + size]


def load_dataset(name: str, size: int, data_dir: Path) -> dict:
    """Heights (float64, NaN = nodata), cell sizes and a description; raises Skip."""
    if name == "canyon":
        from oclshade.synthetic import canyon_crater
        h = canyon_crater(size, size, seed=0, relief=1500.0).astype(np.float64)
        return {"heights": h, "dx": CANYON_CELL_M, "dy": CANYON_CELL_M,
                "source": f"oclshade.synthetic.canyon_crater({size}, seed=0, relief=1500), {CANYON_CELL_M:g} m cells"}
    if name == "puget":
        path = data_dir / "dem" / "puget_sound_vl" / "ps_height_4k.jpg"
        if not path.is_file():
            raise Skip(f"{path} absent")
        from PIL import Image
        with Image.open(path) as img:
            raw = np.asarray(img)
        raw = raw[..., 0] if raw.ndim == 3 else raw
        h = raw.astype(np.float64) * (PUGET_MAX_M / float(raw.max()))
        h = _centre_crop(h, size)
        return {"heights": np.ascontiguousarray(h), "dx": PUGET_CELL_M, "dy": PUGET_CELL_M,
                "source": f"{path} (first channel x {PUGET_MAX_M:g}/{int(raw.max())} m, {PUGET_CELL_M:g} m cells"
                          + (f", centre {h.shape[0]}x{h.shape[1]} crop)" if h.shape != raw.shape else ")")}
    if name in SRTM_FILES:
        path = data_dir / "dem" / "srtm3_srtmpy" / SRTM_FILES[name]
        if not path.is_file():
            raise Skip(f"{path} absent")
        from oclshade.io import read_dem
        raster = read_dem(path)
        h = _centre_crop(raster.heights, size)
        return {"heights": np.ascontiguousarray(h), "dx": raster.dx, "dy": raster.dy,
                "source": f"{path} via oclshade.io.read_dem (voids NaN, geographic cells in metres)"
                          + (f", centre {h.shape[0]}x{h.shape[1]} crop" if h.shape != raster.heights.shape else "")}
    raise ValueError(f"unknown dataset {name!r}")


# ----------------------------------------------------------------------------- metadata
def metadata(argv: list[str]) -> dict:
    import pyopencl as cl
    from oclshade.bench.machine import cpu_model
    from oclshade.runtime import get_runtime
    dev = get_runtime().device
    try:
        import oclshade
        version = getattr(oclshade, "__version__", None)
    except Exception:  # pragma: no cover
        version = None
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "device": dev.name,
        "device_version": dev.version,
        "compute_units": dev.max_compute_units,
        "pocl_version": dev.driver_version,
        "platform_version": dev.platform.version,
        "platform": dev.platform.name,
        "numpy": np.__version__,
        "pyopencl": cl.VERSION_TEXT,
        "python": platform.python_version(),
        "oclshade": version,
        "command": " ".join([Path(sys.executable).name, *argv]),
    }


def header(meta: dict, command: str) -> str:
    """A results file's line of what made it (:func:`metadata`): the command (``command`` where
    the metadata has none), the CPU, PoCL and its device, the date."""
    return (f"`{meta.get('command', command)}`; {meta.get('cpu')}, {meta.get('cores')} cores, PoCL "
            f"{meta.get('pocl_version')} `{meta.get('device')}`, {meta.get('date')}.")


def results_arguments(argv: list[str] | None, doc: str, name: str, reduced: str) -> argparse.Namespace:
    """A results bench's command line: ``--reduced`` (``reduced``: what it keeps, to check the
    script works) and ``--out`` (default bench/results/``name``)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--reduced", action="store_true", help=f"{reduced}: a check that the script works")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results" / name)
    return ap.parse_args(argv)


# ----------------------------------------------------------------------------- measuring
def write_results(out: Path, result: dict, text: str) -> None:
    """``out``.json (the result) and ``out``.md (``text``), their folder made."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(result, indent=1) + "\n")
    out.with_suffix(".md").write_text(text)


def publish(out: Path, result: dict, text: str) -> int:
    """:func:`write_results`, the markdown on stdout; 0 (a bench's exit status)."""
    write_results(out, result, text)
    print(text)
    return 0


def _stats(samples: list[float]) -> dict:
    return {"min": min(samples), "median": statistics.median(samples), "n": len(samples), "all": samples}


def _warm_kernels() -> None:
    """Compile every kernel variant (timed paths and stats builds) on a tiny map."""
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import ShadowCaster
    tiny = ShadowCaster(Heightmap.from_array(np.arange(64.0).reshape(8, 8), 1.0))
    for m in METHODS:
        tiny.warm_up(m)
        tiny.cast((37.0, 20.0), m)
        tiny.step_counts((37.0, 20.0), m)


def bench_dataset(name: str, data: dict, args: argparse.Namespace) -> dict:
    from oclshade import reference
    from oclshade.heightmap import Heightmap
    from oclshade.shadows import ShadowCaster
    from oclshade.sun import Sun

    hm = Heightmap.from_array(data["heights"], cellsize=(data["dx"], data["dy"]))
    rows, cols = hm.shape
    valid = hm.valid
    n_valid = int(valid.sum())
    finite = hm.heights[valid]
    crop = min(args.crop, rows), min(args.crop, cols)
    r0, c0 = (rows - crop[0]) // 2, (cols - crop[1]) // 2
    win = (slice(r0, r0 + crop[0]), slice(c0, c0 + crop[1]))
    crop_valid = valid[win]
    out: dict = {
        "name": name, "skipped": None, "source": data["source"], "shape": [rows, cols],
        "cellsize_m": [hm.dx, hm.dy], "valid_cells": n_valid,
        "height_range_m": [float(finite.min()), float(finite.max())] if finite.size else None,
        "load_s": data["load_s"],
        "crop": {"rows": [r0, r0 + crop[0]], "cols": [c0, c0 + crop[1]], "valid_cells": int(crop_valid.sum())},
    }

    # pyramid: R fresh builds (kernels already compiled)
    times = []
    caster = None
    for _ in range(args.reps):
        caster = ShadowCaster(hm)
        t0 = time.perf_counter()
        caster.pyramid
        caster.runtime.queue.finish()
        times.append(1e3 * (time.perf_counter() - t0))
    out["pyramid_ms"] = _stats(times)
    out["pyramid_levels"] = caster.pyramid.levels
    log(f"{name}: {rows}x{cols}, pyramid {min(times):.1f} ms (min of {len(times)})")
    for m in METHODS:
        caster.warm_up(m)

    suns_out = []
    for elev in ELEVATIONS:
        for az in AZIMUTHS:
            sun = Sun(az, elev)
            label = f"{name} az {az:g} alt {elev:g}"
            samples: dict[str, list[float]] = {m: [] for m in METHODS}
            spent = {m: 0.0 for m in METHODS}
            masks: dict[str, np.ndarray] = {}
            for rep in range(args.reps):
                order = METHODS[rep % len(METHODS):] + METHODS[:rep % len(METHODS)]
                for m in order:
                    if samples[m] and spent[m] > args.max_seconds:
                        continue  # a very slow method stops repeating (n is recorded)
                    t0 = time.perf_counter()
                    res = caster.cast(sun, m)
                    dt = time.perf_counter() - t0
                    samples[m].append(1e3 * dt)
                    spent[m] += dt
                    masks[m] = res.mask
                log(f"{label}: rep {rep + 1}/{args.reps} " +
                    " ".join(f"{m} {samples[m][-1]:.0f}" for m in METHODS) + " ms")
            steps = {}
            if not args.no_steps:
                for m in METHODS:
                    steps[m] = caster.step_counts(sun, m)
            t0 = time.perf_counter()
            ref = reference.cast_shadows(hm, sun, window=win)
            ref_s = time.perf_counter() - t0
            tol = reference.tie_tolerance(hm, sun)
            ties = ref.ties(tol) & crop_valid
            ref_shadow = int((ref.mask == 1).sum())
            log(f"{label}: reference {crop[0]}x{crop[1]} crop {ref_s:.1f} s")
            sun_out = {"azimuth": az, "elevation": elev,
                       "reference": {"seconds": ref_s, "tie_tolerance": tol, "ties_in_crop": int(ties.sum()),
                                     "shadow_fraction": ref_shadow / max(1, int(crop_valid.sum()))},
                       "methods": {}}
            exact = masks["exact"]
            for m in METHODS:
                mask = masks[m]
                cm = mask[win]
                diff = cm != ref.mask
                n_diff = int(diff.sum())
                n_tie = int((diff & ties).sum())
                full = mask != exact
                entry = {
                    "time_ms": _stats(samples[m]),
                    "shadow_fraction": int((mask == 1).sum()) / max(1, n_valid),
                    "crop": {
                        "mismatches": n_diff, "ties": n_tie, "non_tie": n_diff - n_tie,
                        "false_shadow": int((diff & (cm == 1)).sum()), "false_lit": int((diff & (cm == 0)).sum()),
                        "error_pct": 100.0 * n_diff / max(1, int(crop_valid.sum())),
                        "non_tie_error_pct": 100.0 * (n_diff - n_tie) / max(1, int(crop_valid.sum())),
                    },
                    "full_diff_vs_exact": int(full.sum()),
                    "full_extra_shadow_vs_exact": int((full & (mask == 1)).sum()),
                    "full_extra_lit_vs_exact": int((full & (mask == 0)).sum()),
                }
                if m in steps:
                    s = steps[m]
                    entry["steps_total"] = [int(v) for v in s]
                    entry["steps_per_cell"] = [float(v) / max(1, n_valid) for v in s]
                    entry["steps_per_cell_sum"] = float(s.sum()) / max(1, n_valid)
                sun_out["methods"][m] = entry
            log(f"{label}: crop mismatches " + " ".join(
                f"{m} {sun_out['methods'][m]['crop']['mismatches']}({sun_out['methods'][m]['crop']['ties']})"
                for m in METHODS))
            suns_out.append(sun_out)
    out["suns"] = suns_out
    return out


def _find(ds: dict, az: float, elev: float) -> dict | None:
    for s in ds.get("suns", []):
        if s["azimuth"] == az and s["elevation"] == elev:
            return s
    return None


def speedups(datasets: list[dict]) -> dict:
    """Ratios of times measured in this run: > 1 means exact is faster."""
    out = {}
    for ds in datasets:
        if ds.get("skipped"):
            continue
        d: dict = {"exact_vs_dda": {}, "exact_vs_maxmip": {}, "exact_plus_pyramid_ms": {}}
        for s in ds["suns"]:
            key = f"az{s['azimuth']:g}_alt{s['elevation']:g}"
            ms = s["methods"]
            for other in ("dda", "maxmip"):
                d[f"exact_vs_{other}"][key] = {
                    "min": ms[other]["time_ms"]["min"] / ms["exact"]["time_ms"]["min"],
                    "median": ms[other]["time_ms"]["median"] / ms["exact"]["time_ms"]["median"],
                }
            d["exact_plus_pyramid_ms"][key] = ms["exact"]["time_ms"]["min"] + ds["pyramid_ms"]["min"]
        out[ds["name"]] = d
    return out


# ----------------------------------------------------------------------------- reports
def write_markdown(path: Path, result: dict) -> None:
    meta, cfg = result["meta"], result["config"]
    lines = [
        "# Cast-shadow masks: time against error",
        "",
        f"- date: {meta['date']}; command: `{meta['command']}`",
        f"- CPU: {meta['cpu']}, {meta['cores']} cores; device: {meta['device']} "
        f"({meta['compute_units']} compute units)",
        f"- PoCL {meta['pocl_version']} ({meta['platform_version']}); numpy {meta['numpy']}, "
        f"pyopencl {meta['pyopencl']}, Python {meta['python']}",
        f"- repetitions: {cfg['reps']} per method and sun, methods interleaved (a method over "
        f"{cfg['max_seconds']:g} s in total stops repeating: n below); times are wall clock of "
        "`ShadowCaster.cast` including the mask's copy to the host and, for exact and maxmip, the "
        "per-sun far-field tile certificates (`shadow_certify`); pyramid not included",
        f"- error: cells of the centre {cfg['crop']}x{cfg['crop']} crop (whole map if smaller) that differ from "
        "the float64 reference `oclshade.reference.cast_shadows`; `(t)` = of which float32 ties "
        "(`ReferenceShadows.ties(tie_tolerance)`); full-map diff = cells that differ from `exact` on the whole map",
        "- steps/cell: traversal iterations per valid cell, all levels (`ShadowCaster.step_counts`)",
        "",
    ]
    sp = result["speedups"]
    lines += ["## Summary", ""]
    for ds in result["datasets"]:
        if ds.get("skipped"):
            lines.append(f"- **{ds['name']}**: skipped ({ds['skipped']})")
            continue
        name = ds["name"]
        d = sp[name]
        ex = [s["methods"]["exact"] for s in ds["suns"]]
        nontie = sum(e["crop"]["non_tie"] for e in ex)
        ties = sum(e["crop"]["ties"] for e in ex)
        paper = [s["methods"]["paper"]["crop"]["error_pct"] for s in ds["suns"]]
        e20 = [v for k, v in d["exact_plus_pyramid_ms"].items() if k.endswith("_alt20")]
        dda5 = [v["min"] for k, v in d["exact_vs_dda"].items() if k.endswith("_alt5")]
        mm = [v["min"] for v in d["exact_vs_maxmip"].values()]
        lines.append(
            f"- **{name}** ({ds['shape'][0]}x{ds['shape'][1]}): exact vs reference on the crop: "
            f"{nontie} non-tie mismatches, {ties} ties (all suns); exact at 20 deg + pyramid "
            f"{max(e20):.0f} ms (worst azimuth; pyramid {ds['pyramid_ms']['min']:.0f} ms); "
            f"dda/exact at 5 deg {min(dda5):.2f}x..{max(dda5):.2f}x; maxmip/exact "
            f"{min(mm):.2f}x..{max(mm):.2f}x; paper error {min(paper):.3f}..{max(paper):.3f} % of crop cells")
    lines.append("")
    for ds in result["datasets"]:
        lines.append(f"## {ds['name']}")
        lines.append("")
        if ds.get("skipped"):
            lines += [f"Skipped: {ds['skipped']}", ""]
            continue
        cr = ds["crop"]
        lines += [
            f"{ds['source']}; {ds['shape'][0]}x{ds['shape'][1]}, cells {ds['cellsize_m'][0]:.2f} x "
            f"{ds['cellsize_m'][1]:.2f} m, heights {ds['height_range_m'][0]:.0f}..{ds['height_range_m'][1]:.0f} m, "
            f"{ds['valid_cells']} valid cells; crop rows {cr['rows'][0]}:{cr['rows'][1]}, "
            f"cols {cr['cols'][0]}:{cr['cols'][1]}.",
            "",
            f"Pyramid ({ds['pyramid_levels']} levels): min {ds['pyramid_ms']['min']:.1f} ms, "
            f"median {ds['pyramid_ms']['median']:.1f} ms.",
            "",
            "| sun (az/alt) | method | time min ms | median ms | n | shadow % | steps/cell | "
            "crop mismatches (t) | non-tie | full-map diff vs exact |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for s in ds["suns"]:
            ref = s["reference"]
            for m in METHODS:
                e = s["methods"][m]
                steps = f"{e['steps_per_cell_sum']:.1f}" if "steps_per_cell_sum" in e else "-"
                lines.append(
                    f"| {s['azimuth']:g}/{s['elevation']:g} | {m} | {e['time_ms']['min']:.1f} | "
                    f"{e['time_ms']['median']:.1f} | {e['time_ms']['n']} | {100 * e['shadow_fraction']:.2f} | "
                    f"{steps} | {e['crop']['mismatches']} ({e['crop']['ties']}) | {e['crop']['non_tie']} | "
                    f"{e['full_diff_vs_exact']} |")
            lines.append(
                f"| {s['azimuth']:g}/{s['elevation']:g} | *reference* | {1e3 * ref['seconds']:.0f} (crop) | | | "
                f"{100 * ref['shadow_fraction']:.2f} (crop) | | ties in crop: {ref['ties_in_crop']} | | |")
        lines.append("")
    path.write_text("\n".join(lines) + "\n")


def write_plot(path: Path, result: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    markers = {"exact": "o", "paper": "s", "maxmip": "^", "dda": "D"}
    live = [ds for ds in result["datasets"] if not ds.get("skipped")]
    colours = {ds["name"]: plt.cm.tab10(k % 10) for k, ds in enumerate(live)}
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 5.2))
    for ds in live:
        for s in ds["suns"]:
            for m in METHODS:
                e = s["methods"][m]
                ax.scatter(e["time_ms"]["min"], e["crop"]["error_pct"], marker=markers[m],
                           color=colours[ds["name"]], s=22 + 2 * s["elevation"] ** 0.5 * 6, alpha=0.8,
                           edgecolors="k", linewidths=0.4)
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=ERROR_FLOOR_PCT * 10, linscale=0.5)
    ax.set_ylim(bottom=-ERROR_FLOOR_PCT)
    ax.set_xlabel("mask time, ms (min of repetitions, log)")
    ax.set_ylabel("cells differing from the float64 reference, % of crop (symlog)")
    ax.set_title("time against error (each point: one sun; larger = higher sun)")
    handles = [Line2D([], [], marker=markers[m], color="grey", ls="", label=m) for m in METHODS]
    handles += [Line2D([], [], marker="o", color=colours[n], ls="", label=n) for n in colours]
    ax.legend(handles=handles, fontsize=8, loc="best")
    ax.grid(True, which="both", alpha=0.3)

    canyon = next((ds for ds in live if ds["name"] == "canyon"), None)
    plotted = False
    if canyon is not None:
        for s in canyon["suns"]:
            if s["elevation"] != min(ELEVATIONS):
                continue
            for m, ls in (("exact", "-"), ("maxmip", "--")):
                e = s["methods"][m]
                if "steps_per_cell" not in e:
                    continue
                y = np.asarray(e["steps_per_cell"])
                ax2.plot(np.arange(y.size), np.where(y > 0, y, np.nan), ls, marker=markers[m],
                         label=f"{m}, az {s['azimuth']:g} ({e['time_ms']['min']:.0f} ms)")
                plotted = True
    if plotted:
        ax2.set_yscale("log")
        ax2.set_xlabel("pyramid level (0 = patch tests)")
        ax2.set_ylabel("steps per valid cell")
        ax2.set_title(f"canyon terrain, elevation {min(ELEVATIONS):g} deg: exact vs maxmip")
        ax2.legend(fontsize=8)
        ax2.grid(True, which="both", alpha=0.3)
    else:
        ax2.text(0.5, 0.5, "no canyon step counts in this run", ha="center", va="center")
        ax2.set_axis_off()
    meta = result["meta"]
    fig.suptitle(f"oclshade cast shadows — {meta['cpu']}, {meta['cores']} cores, PoCL {meta['pocl_version']}, "
                 f"{meta['date'][:10]}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------------------- main
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=4096, help="synthetic map side; larger maps are centre-cropped "
                   "to it (default 4096)")
    p.add_argument("--crop", type=int, default=512, help="side of the centre crop checked against the "
                   "float64 reference (default 512)")
    p.add_argument("--reps", type=int, default=3, help="timed repetitions per method and sun (default 3)")
    p.add_argument("--max-seconds", type=float, default=60.0, help="a method that has spent this long on "
                   "one sun stops repeating (default 60)")
    p.add_argument("--quick", action="store_true", help="smoke run: 512^2 maps, 128^2 crop, one repetition")
    p.add_argument("--datasets", default="all", help="comma-separated names or groups: "
                   f"{', '.join(DATASET_GROUPS)}, {', '.join(DATASET_GROUPS['all'])} (default all)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA, help=f"shared data folder (default {DEFAULT_DATA})")
    p.add_argument("--no-steps", action="store_true", help="skip the step-count (profiling) runs")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results", help="output folder")
    args = p.parse_args(argv)
    if args.quick:
        args.size, args.crop, args.reps = 512, 128, 1
    names: list[str] = []
    for item in filter(None, (s.strip() for s in args.datasets.split(","))):
        group = DATASET_GROUPS.get(item, (item,))
        for n in group:
            if n not in DATASET_GROUPS["all"]:
                p.error(f"unknown dataset {n!r}")
            if n not in names:
                names.append(n)
    if not names or args.size < 2 or args.crop < 1 or args.reps < 1:
        p.error("need at least one dataset, --size >= 2, --crop >= 1, --reps >= 1")
    args.names = names
    return args


def main(argv: list[str] | None = None) -> int:
    argv_list = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv_list)
    args.out.mkdir(parents=True, exist_ok=True)
    meta = metadata([str(Path(__file__).relative_to(REPO)) if Path(__file__).is_relative_to(REPO)
                     else __file__, *argv_list])
    log(f"device {meta['device']} (PoCL {meta['pocl_version']}); datasets {', '.join(args.names)}; "
        f"size {args.size}, crop {args.crop}, reps {args.reps}")
    t0 = time.perf_counter()
    _warm_kernels()
    log(f"kernels compiled in {time.perf_counter() - t0:.1f} s")
    datasets = []
    for name in args.names:
        t0 = time.perf_counter()
        try:
            data = load_dataset(name, args.size, args.data)
        except Skip as exc:
            log(f"{name}: skipped ({exc})")
            datasets.append({"name": name, "skipped": str(exc)})
            continue
        data["load_s"] = time.perf_counter() - t0
        log(f"{name}: loaded in {data['load_s']:.1f} s")
        datasets.append(bench_dataset(name, data, args))
        del data
    result = {
        "meta": meta,
        "config": {"size": args.size, "crop": args.crop, "reps": args.reps, "max_seconds": args.max_seconds,
                   "quick": args.quick, "datasets": args.names, "methods": list(METHODS),
                   "suns": [[az, el] for el in ELEVATIONS for az in AZIMUTHS], "steps": not args.no_steps},
        "datasets": datasets,
        "speedups": speedups(datasets),
        "total_seconds": time.perf_counter() - _T0,
    }
    (args.out / "shadow_masks.json").write_text(json.dumps(result, indent=1) + "\n")
    write_markdown(args.out / "shadow_masks.md", result)
    write_plot(args.out / "shadow_masks.png", result)
    log(f"wrote {args.out}/shadow_masks.{{json,md,png}} in {result['total_seconds']:.0f} s total")
    return 0


if __name__ == "__main__":
    sys.exit(main())
