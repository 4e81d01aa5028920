"""Terrain ray casting benchmark (paper 004's table): time per frame and error against the reference.

    python bench/terrain_cast.py            # 1920x1080 frames, maps 256^2 .. 4096^2 (a few minutes)
    python bench/terrain_cast.py --quick    # tiny sizes, synthetic terrain (smoke test)

Terrain: the Puget Sound heightmap (../shared/data/dem/puget_sound_vl/ps_height_4k.jpg,
8-bit, vertical scale unknown: we take 10 m per step and 40 m cells at 4096^2,
a 164 km square), block-averaged to each size so every size shows the same
terrain; without the file, oclshade.synthetic.canyon_crater.  Camera: a
flyover from the southern edge, 12 % of the map's width high, looking north
and down at the map (most pixels see terrain, the far ones near the horizon).

Times: one render call with the G-buffer left on the device (kernel launch and
its argument setup), minimum of --repeats runs after a warm-up, all methods in
the same process; the interleaved section also reports the process CPU time
(both PoCL threads), steadier than wall time on a shared machine, and paired
ratios (medians of ratios of calls made back to back, so both calls see the
same load: growth 256^2 -> 4096^2 and bisect / baseline).  Traversal
counts (a profiling build, -D OCLS_STATS): voxel tests per hit pixel by
pyramid level and exact patch tests, bisect and dda.  Errors: the float64
reference (oclshade.reference.cast_terrain) on every --stride-th pixel in both
directions; "cell mismatch" counts pixels not in the reference's patch within
1e-3 cell (or hit/empty disagreements); silhouette pixels are those whose 3x3
neighbourhood in the kernel's full frame mixes hit and empty.
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
from shadow_masks import metadata  # noqa: E402  (one place records CPU, PoCL, date)

from oclshade.camera import Camera  # noqa: E402
from oclshade.reference import cast_terrain  # noqa: E402
from oclshade.terrain import METHODS, Heightfield, TerrainRenderer  # noqa: E402

PUGET = "dem/puget_sound_vl/ps_height_4k.jpg"
POSITION_TOL = 1e-3


def terrain(data: Path, quick: bool) -> tuple[np.ndarray, float, str]:
    """(heights at the largest size, cell size there, description)."""
    path = data / PUGET
    if path.is_file() and not quick:
        from PIL import Image
        with Image.open(path) as img:
            h = np.asarray(img.convert("L"), dtype=np.float64) * 10.0
        return h, 40.0, f"{path} (8-bit x 10 m, 40 m cells at 4096^2)"
    from oclshade.synthetic import canyon_crater
    n = 256 if quick else 4096
    return canyon_crater(n, n, seed=1, relief=2000.0), 40.0 * 4096 / n, f"oclshade.synthetic.canyon_crater({n})"


def resample(h: np.ndarray, n: int) -> np.ndarray:
    k = h.shape[0] // n
    return h[:n * k, :n * k].reshape(n, k, n, k).mean(axis=(1, 3))


def flyover(extent: float, width: int, height: int, far_factor: float = 3.0) -> Camera:
    return Camera([0.5 * extent, -1.05 * extent, 0.12 * extent], [0.5 * extent, -0.55 * extent, 0.0],
                  width, height, fov=50.0, near=1e-4 * extent, far=far_factor * extent)


def time_render(renderer: TerrainRenderer, cam: Camera, method: str, repeats: int) -> tuple[float, object]:
    out = renderer.render(cam, method, on_device=True)
    renderer.runtime.queue.finish()
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        renderer.render(cam, method, on_device=True, out=out)
        renderer.runtime.queue.finish()
        best = min(best, time.perf_counter() - t)
    return best, out.to_host()


def per_hit(counts: dict) -> dict:
    """Traversal counters of one frame (TerrainRenderer.step_counts) per hit pixel."""
    hits = max(counts["hits"], 1)
    levels = [float(v) / hits for v in counts["levels"]]
    return {"levels": levels, "tests": sum(levels), "patches": counts["patches"] / hits, "hits": counts["hits"]}


def silhouette(hit: np.ndarray) -> np.ndarray:
    pad = np.pad(hit, 1, mode="edge")
    r, c = hit.shape
    win = [pad[i:i + r, j:j + c] for i in range(3) for j in range(3)]
    return np.any(win, axis=0) & ~np.all(win, axis=0)


def errors(g, ref, rows: np.ndarray, cols: np.ndarray) -> dict:
    hit = g.hit[rows, cols]
    sil = silhouette(g.hit)[rows, cols]
    both = hit & ref.hit
    uv = g.uv[rows, cols][both].astype(np.float64)
    err = np.abs(uv - ref.uv[both]).max(axis=1) if both.any() else np.zeros(0)
    cell = ref.cell[both][:, ::-1]
    in_patch = np.all((uv >= cell) & (uv <= cell + 1), axis=1)
    bad_cell = ~(in_patch & (err <= POSITION_TOL))
    miss = hit != ref.hit
    n = hit.size
    return {"pixels": int(n), "hit_fraction": float(ref.hit.mean()),
            "hit_mismatch": int(miss.sum()), "hit_mismatch_off_silhouette": int((miss & ~sil).sum()),
            "cell_mismatch": int(bad_cell.sum()),
            "different_cell_fraction": float((miss.sum() + bad_cell.sum()) / n),
            "position_error_cells": {"median": float(np.median(err)) if err.size else 0.0,
                                     "max_same_cell": float(err[in_patch].max()) if in_patch.any() else 0.0}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--data", default=str(HERE.parent.parent / "shared" / "data"))
    ap.add_argument("--out", default=str(HERE / "results"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--stride", type=int, default=0, help="reference on every N-th pixel (default: auto)")
    args = ap.parse_args(argv)
    quick = args.quick
    sizes = [32, 64, 128, 256] if quick else [256, 512, 1024, 2048, 4096]
    frame = (160, 90) if quick else (1920, 1080)
    stride = args.stride or (2 if quick else 8)
    repeats = 1 if quick else args.repeats
    meta = metadata(sys.argv)
    big, cell, source = terrain(Path(args.data), quick)
    extent = cell * big.shape[0]
    print(f"terrain {source}; device {meta['device']} (PoCL {meta['pocl_version']})", file=sys.stderr)
    rows, cols = np.mgrid[0:frame[1]:stride, 0:frame[0]:stride]
    rows, cols = rows.ravel(), cols.ravel()
    res: dict = {"meta": meta, "config": {"frame": frame, "sizes": sizes, "stride": stride, "repeats": repeats,
                                          "terrain": source, "extent_m": extent, "methods": list(METHODS)},
                 "maps": [], "resolution": [], "depth_range": []}
    renderers = {}
    for n in sizes:
        field = Heightfield.from_array(resample(big, n), extent / n)
        r = renderers[n] = TerrainRenderer(field)
        cam = flyover(extent - extent / n, *frame)
        t = time.perf_counter()
        r.pyramid
        r.runtime.queue.finish()
        entry = {"size": n, "pyramid_ms": 1e3 * (time.perf_counter() - t), "methods": {}}
        ref = cast_terrain(field, cam, rows, cols)
        for m in METHODS:
            dt, g = time_render(r, cam, m, repeats)
            entry["methods"][m] = {"time_ms": 1e3 * dt, **errors(g, ref, rows, cols)}
            print(f"{n}^2 {m}: {1e3 * dt:.1f} ms, different cell {entry['methods'][m]['different_cell_fraction']:.2e}",
                  file=sys.stderr)
        entry["per_hit"] = {m: per_hit(r.step_counts(cam, m)) for m in ("bisect", "dda")}
        r.descend = 1                   # a split halves the footprint (the paper's halving), OCLS_DESCEND
        entry["bisect_descend1_ms"] = 1e3 * time_render(r, cam, "bisect", repeats)[0]
        r.descend = 3
        leaf0 = TerrainRenderer(field, leaf=0)  # leaves at level 0 (the paper's), OCLS_LEAF
        entry["bisect_leaf0_ms"] = 1e3 * time_render(leaf0, cam, "bisect", repeats)[0]
        entry["per_hit"]["bisect_leaf0"] = per_hit(leaf0.step_counts(cam, "bisect"))
        del leaf0
        res["maps"].append(entry)
    # the same frames again, interleaved (round robin over sizes and methods, min of the rounds):
    # a shared machine's load drifts over minutes, so growth and ratios are read from here
    inter = {(n, m): [float("inf"), float("inf")] for n in sizes for m in METHODS}
    rounds: list[dict] = []
    outs = {}

    def timed(n: int, m: str) -> tuple[float, float]:
        """(wall, cpu) ms of one render call of size n, method m."""
        cam = flyover(extent - extent / n, *frame)
        if (n, m) not in outs:
            outs[n, m] = renderers[n].render(cam, m, on_device=True)
            renderers[n].runtime.queue.finish()
        c, t = time.process_time(), time.perf_counter()
        renderers[n].render(cam, m, on_device=True, out=outs[n, m])
        renderers[n].runtime.queue.finish()
        return 1e3 * (time.perf_counter() - t), 1e3 * (time.process_time() - c)

    for _ in range(repeats):
        rounds.append({})
        for n in sizes:
            for m in ("bisect", "dda", "march"):          # bisect and dda back to back
                rounds[-1][n, m] = timed(n, m)
                best = inter[n, m]
                best[0], best[1] = min(best[0], rounds[-1][n, m][0]), min(best[1], rounds[-1][n, m][1])
    res["interleaved"] = [{"size": n, "method": m, "time_ms": v[0], "cpu_ms": v[1]} for (n, m), v in inter.items()]
    # paired ratios: each ratio from two calls made back to back (a fraction of a second apart,
    # so both see the same load), median over the pairs
    res["paired"] = {
        "bisect_over": {m: {str(n): [float(np.median([r[n, "bisect"][j] / r[n, m][j] for r in rounds]))
                                     for j in (0, 1)] for n in sizes} for m in ("dda", "march")},
        "growth": {}}
    for m in ("bisect", "dda"):
        pairs = []
        for _ in range(2 * repeats + 1):
            small, big_ = timed(sizes[0], m), timed(sizes[-1], m)
            pairs.append([big_[j] / small[j] for j in (0, 1)])
        res["paired"]["growth"][m] = [float(np.median([p[j] for p in pairs])) for j in (0, 1)]
    outs.clear()
    mid = sizes[len(sizes) // 2]
    r = renderers[mid]
    scale_frames = [(160, 90), (320, 180), (640, 360)] if quick else [(480, 270), (960, 540), (1920, 1080), (3840, 2160)]
    for w, h in scale_frames:
        cam = flyover(extent - extent / mid, w, h)
        res["resolution"].append({"frame": [w, h], "size": mid,
                                  "time_ms": {m: 1e3 * time_render(r, cam, m, repeats)[0] for m in ("bisect", "dda")}})
    for far in (0.5, 1.0, 2.0, 4.0):
        cam = flyover(extent - extent / mid, *frame, far_factor=far)
        res["depth_range"].append({"far_over_extent": far, "size": mid,
                                   "time_ms": {m: 1e3 * time_render(r, cam, m, repeats)[0] for m in ("bisect", "dda")}})
    t = {e["size"]: e["methods"]["bisect"]["time_ms"] for e in res["maps"]}
    res["summary"] = {
        "bisect_growth_smallest_to_largest": t[sizes[-1]] / t[sizes[0]],
        "interleaved_growth_smallest_to_largest": {
            m: {k: inter[sizes[-1], m][j] / inter[sizes[0], m][j] for j, k in enumerate(("time", "cpu"))}
            for m in METHODS},
        "interleaved_bisect_over": {
            m: {str(n): inter[n, "bisect"][0] / inter[n, m][0] for n in sizes} for m in METHODS if m != "bisect"},
        "bisect_over_dda": {str(e["size"]): e["methods"]["bisect"]["time_ms"] / e["methods"]["dda"]["time_ms"]
                            for e in res["maps"]},
        "bisect_over_march": {str(e["size"]): e["methods"]["bisect"]["time_ms"] / e["methods"]["march"]["time_ms"]
                              for e in res["maps"]},
        "descend1_over_descend3": {str(e["size"]): e["bisect_descend1_ms"] / e["methods"]["bisect"]["time_ms"]
                                   for e in res["maps"]},
        "leaf0_over_leaf2": {str(e["size"]): e["bisect_leaf0_ms"] / e["methods"]["bisect"]["time_ms"]
                             for e in res["maps"]},
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "terrain_cast.json").write_text(json.dumps(res, indent=1))
    write_md(res, out / "terrain_cast.md")
    write_png(res, out / "terrain_cast.png")
    return 0


def write_md(res: dict, path: Path) -> None:
    m = res["meta"]
    c = res["config"]
    lines = [f"# Terrain ray casting, {c['frame'][0]}x{c['frame'][1]} frames (paper 004's table)", "",
             f"- {m['date']}; CPU: {m['cpu']}, {m['cores']} cores; device: {m['device']}; "
             f"PoCL {m['pocl_version']} ({m['platform_version']})",
             f"- terrain: {c['terrain']}; flyover camera; time of a render call (kernel and its argument "
             f"setup, G-buffer left on the device), min of {c['repeats']}",
             f"- errors against the float64 reference on every {c['stride']}-th pixel (both directions)",
             f"- command: `{m['command']}`", "",
             "| map | method | time ms | different cell | hit/empty mismatches (off silhouette) | "
             "median pos. err (cells) | max pos. err, same cell |",
             "|---|---|---|---|---|---|---|"]
    for e in res["maps"]:
        for name, v in e["methods"].items():
            lines.append(f"| {e['size']}^2 | {name} | {v['time_ms']:.1f} | {v['different_cell_fraction']:.2e} | "
                         f"{v['hit_mismatch']} ({v['hit_mismatch_off_silhouette']}) | "
                         f"{v['position_error_cells']['median']:.1e} | {v['position_error_cells']['max_same_cell']:.1e} |")
    s = res["summary"]
    lines += ["", f"bisect time growth {c['sizes'][0]}^2 -> {c['sizes'][-1]}^2: "
              f"{s['bisect_growth_smallest_to_largest']:.2f}x", "",
              "bisect / dda time: " + ", ".join(f"{k}^2 {v:.2f}" for k, v in s["bisect_over_dda"].items()),
              "", "bisect / march time: " + ", ".join(f"{k}^2 {v:.2f}" for k, v in s["bisect_over_march"].items()),
              "", "bisect with splits halving the footprint (descend=1, the paper's halving) / default "
              "(descend=3) time: " + ", ".join(f"{k}^2 {v:.2f}" for k, v in s["descend1_over_descend3"].items()),
              "", "bisect with leaves at level 0 (leaf=0, the paper's) / default (leaf=2) time: "
              + ", ".join(f"{k}^2 {v:.2f}" for k, v in s["leaf0_over_leaf2"].items()),
              "", "## the same frames, interleaved (round robin over sizes and methods, min of "
              f"{c['repeats']} rounds; cpu = process CPU time, both PoCL threads)", "",
              "| map | " + " | ".join(f"{m} ms | {m} cpu ms" for m in METHODS) + " |",
              "|---|" + "---|---|" * len(METHODS)]
    inter = {(e["size"], e["method"]): e for e in res["interleaved"]}
    for n in c["sizes"]:
        lines.append(f"| {n}^2 | " + " | ".join(f"{inter[n, m]['time_ms']:.1f} | {inter[n, m]['cpu_ms']:.1f}"
                                                for m in METHODS) + " |")
    g = s["interleaved_growth_smallest_to_largest"]
    pg, pb = res["paired"]["growth"], res["paired"]["bisect_over"]
    lines += ["", f"interleaved time growth {c['sizes'][0]}^2 -> {c['sizes'][-1]}^2 (wall, cpu): "
              + ", ".join(f"{m} {g[m]['time']:.2f}x, {g[m]['cpu']:.2f}x" for m in METHODS), "",
              "interleaved bisect / baseline time: " + "; ".join(
                  f"{m}: " + ", ".join(f"{k}^2 {v:.2f}" for k, v in d.items())
                  for m, d in s["interleaved_bisect_over"].items()), "",
              f"paired (median over {2 * c['repeats'] + 1} pairs of back-to-back calls, wall / cpu) time growth "
              f"{c['sizes'][0]}^2 -> {c['sizes'][-1]}^2: "
              + ", ".join(f"{m} {v[0]:.2f}x / {v[1]:.2f}x" for m, v in pg.items()), "",
              f"paired (median over the {c['repeats']} rounds, bisect and the baseline back to back, wall / cpu) "
              "bisect / baseline time: " + "; ".join(
                  f"{m}: " + ", ".join(f"{k}^2 {v[0]:.2f} / {v[1]:.2f}" for k, v in d.items()) for m, d in pb.items()),
              ""]
    lines += per_hit_table(res)
    lines += ["", "## time against frame size", "", "| frame | bisect ms | dda ms |", "|---|---|---|"]
    for e in res["resolution"]:
        lines.append(f"| {e['frame'][0]}x{e['frame'][1]} | {e['time_ms']['bisect']:.1f} | {e['time_ms']['dda']:.1f} |")
    lines += ["", "## time against depth range (far plane / map extent)", "", "| far | bisect ms | dda ms |",
              "|---|---|---|"]
    for e in res["depth_range"]:
        lines.append(f"| {e['far_over_extent']:g} | {e['time_ms']['bisect']:.1f} | {e['time_ms']['dda']:.1f} |")
    path.write_text("\n".join(lines) + "\n")


def per_hit_table(res: dict) -> list[str]:
    """Voxel tests (texel visits for dda) per hit pixel by pyramid level, and patch tests."""
    top = max(len(e["per_hit"]["bisect"]["levels"]) for e in res["maps"])
    lines = ["## traversal work per hit pixel (profiling build, -D OCLS_STATS)", "",
             "bisect: voxel tests by the level of their footprint (voxels finer than the leaf level "
             "are tested at the leaf level); dda: texel visits by level; patches: exact patch tests.", "",
             "| map | method | " + " | ".join(f"l{k}" for k in range(top)) + " | tests | patches |",
             "|---|---|" + "---|" * (top + 2)]
    for e in res["maps"]:
        for name in ("bisect", "bisect_leaf0", "dda"):
            v = e["per_hit"][name]
            cells = [f"{x:.2f}" for x in v["levels"]] + [""] * (top - len(v["levels"]))
            label = "bisect, leaf=0" if name == "bisect_leaf0" else name
            lines.append(f"| {e['size']}^2 | {label} | " + " | ".join(cells)
                         + f" | {v['tests']:.2f} | {v['patches']:.2f} |")
    return lines


def write_png(res: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, marker in zip(METHODS, "osd"):
        ts = [e["methods"][name]["time_ms"] for e in res["maps"]]
        es = [max(e["methods"][name]["different_cell_fraction"], 1e-7) for e in res["maps"]]
        a.loglog(ts, es, marker + "-", label=name)
        for e, t, err in zip(res["maps"], ts, es):
            a.annotate(f"{e['size']}", (t, err), fontsize=7)
    a.set_xlabel("time per frame (ms)")
    a.set_ylabel("fraction of pixels in a different cell (floor 1e-7)")
    a.legend()
    a.set_title("run time against error, per map size")
    px = [e["frame"][0] * e["frame"][1] for e in res["resolution"]]
    for name in ("bisect", "dda"):
        b.loglog(px, [e["time_ms"][name] for e in res["resolution"]], "o-", label=name)
    b.set_xlabel("pixels per frame")
    b.set_ylabel("time (ms)")
    b.legend()
    b.set_title("time against frame size")
    m = res["meta"]
    fig.suptitle(f"oclshade terrain casting — {m['cpu']}, {m['cores']} cores, PoCL {m['pocl_version']}, "
                 f"{m['date'][:10]}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    raise SystemExit(main())
