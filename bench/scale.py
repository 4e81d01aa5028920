"""Scale bench (issue 22): tiled == whole map, a 32768^2 map on disk within 3 GB, 2 Dask workers, overlap.

    python bench/scale.py            # the full run (defaults below; about an hour on 2 cores)
    python bench/scale.py --quick    # a smoke run of every step on small maps (CI)

Writes bench/results/scale.{md,json} (--out to change).  Steps:
1. equality: whole-map outputs (mask, self-shadow, coefficient) vs cast_tiled (tiles of --tile) on
   --equal-size^2 maps (the synthetic canyon and, when ../shared/data has it, Puget Sound) for suns
   at 5/20/45 degrees: whether they are identical bit for bit, and the cells that differ
   (docs/scale.md "Exactness": none may);
2. big: a --big^2 synthetic map written tile by tile as a tiled GeoTIFF, then
   ``oclshade shadow --max-memory`` in a child process: time, peak RSS (VmHWM), s per gigacell,
   against the in-memory path on a --mem^2 map;
3. workers: the big job again with ``--workers 2`` (time, output identical byte for byte);
4. overlap: the pipeline against the serial order on the --mem^2 map;
5. the paper simulation of a 10^12-cell job (numbers for docs/scale.md).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from oclshade import ShadowCaster, Sun  # noqa: E402
from oclshade.geotiff import GeoTiffWriter, tiff_options  # noqa: E402
from oclshade.heightmap import Heightmap  # noqa: E402
from oclshade.synthetic import canyon_crater  # noqa: E402
from oclshade.tiles import ReliefGrid, Tracing, cast_tiled, plan_tiles, run_jobs  # noqa: E402
from oclshade.tiles.plan import bytes_per_cell  # noqa: E402

SUNS = [Sun(az, el) for el in (5.0, 20.0, 45.0) for az in (37.0, 135.0)]
OUTPUTS = ("mask", "self", "coefficient")
CELL = 30.0
RELIEF = 1500.0
TAGS = [(33550, 12, (CELL, CELL, 0.0))]


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def wave_terrain(r0: int, r1: int, c0: int, c1: int, seed: int = 0) -> np.ndarray:
    """A continuous synthetic terrain (sums of sine ridges over 8 octaves, 0..RELIEF m) evaluated
    on any window of an unbounded grid: the same heights whichever tiles it is made in."""
    rng = np.random.default_rng(seed)
    y = np.arange(r0, r1, dtype=np.float64)[:, None]
    x = np.arange(c0, c1, dtype=np.float64)[None, :]
    h = np.zeros((r1 - r0, c1 - c0))
    amp = 1.0
    for octave in range(8):
        f = 2 * math.pi / (4096.0 / 2 ** octave)
        for _ in range(3):
            a, b, p = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0, 2 * math.pi)
            h += amp * np.abs(np.sin(f * (a * x + b * y) + p))
        amp *= 0.55
    return (h * (RELIEF / 6.5)).astype(np.float32)


def write_big_map(path: Path, side: int, tile: int = 2048) -> None:
    """The --big map, tile by tile (never whole in memory), as a tiled DEFLATE GeoTIFF."""
    opts = tiff_options({"BLOCKSIZE": "512", "PREDICTOR": "3"}, np.float32)
    writer = GeoTiffWriter((1, side, side), np.float32, opts, TAGS, path.parent)
    for r in range(0, side, tile):
        for c in range(0, side, tile):
            writer.write_window(0, r, c, wave_terrain(r, min(r + tile, side), c, min(c + tile, side)))
    with open(path, "wb") as fh:
        writer.save(fh)
    writer.close()


def maps(size: int, data: Path) -> dict[str, Heightmap]:
    out = {"canyon": Heightmap.from_array(canyon_crater(size, size, seed=0, relief=RELIEF).astype(np.float64), CELL)}
    puget = data / "dem" / "puget_sound_vl" / "ps_height_4k.jpg"
    if puget.is_file():
        from PIL import Image
        with Image.open(puget) as img:
            raw = np.asarray(img)
        raw = (raw[..., 0] if raw.ndim == 3 else raw).astype(np.float64)
        r0 = max(0, (raw.shape[0] - size) // 2)
        out["puget"] = Heightmap.from_array(raw[r0:r0 + size, r0:r0 + size] * (4392.0 / raw.max()), 40.0)
    return out


def equality(size: int, tile: int, data: Path) -> list[dict]:
    rows = []
    for name, hm in maps(size, data).items():
        for sun in SUNS:
            t0 = time.perf_counter()
            whole = ShadowCaster(hm, cache=False).cast(sun, outputs=OUTPUTS)
            t1 = time.perf_counter()
            tiled = cast_tiled(hm, [sun], outputs=OUTPUTS, tile_size=tile)[0]
            t2 = time.perf_counter()
            differ = np.zeros(hm.shape, bool)   # cells whose bytes differ in any output (NaN == NaN)
            for field in ("mask", "self_shadow", "coefficient"):
                a, b = getattr(whole, field), getattr(tiled, field)
                differ |= (a.view(np.uint8) != b.view(np.uint8)).reshape(*a.shape, -1).any(axis=-1)
            row = {"map": name, "size": size, "sun": [sun.azimuth, sun.elevation], "tile": tile,
                   "identical": not differ.any(), "differing": int(differ.sum()),
                   "whole_s": t1 - t0, "tiled_s": t2 - t1}
            log(f"equality {row}")
            rows.append(row)
    return rows


def cli_run(args: list[str]) -> dict:
    code = ("import sys, time; from oclshade.cli import main; from oclshade.tiles.stream import peak_rss_bytes; "
            "t = time.perf_counter(); rc = main(sys.argv[1:]); print(time.perf_counter() - t, peak_rss_bytes()); "
            "sys.exit(rc)")
    run = subprocess.run([sys.executable, "-c", code, "shadow", *args, "-q"], cwd=REPO, capture_output=True, text=True)
    if run.returncode:
        raise RuntimeError(run.stderr)
    seconds, peak = run.stdout.split()[-2:]
    return {"seconds": float(seconds), "peak_rss_mib": int(peak) / 2**20}


def in_memory(size: int, work: Path) -> dict:
    path = work / f"mem{size}.tif"
    write_big_map(path, size, tile=min(size, 2048))
    res = cli_run([str(path), str(work / "mem_out.tif"), "--sun", "135,20"])
    res.update(size=size, s_per_gigacell=res["seconds"] / (size * size / 1e9))
    return res


def overlap_gain(size: int) -> dict:
    hm = Heightmap.from_array(wave_terrain(0, size, 0, size).astype(np.float64), CELL)
    relief = ReliefGrid.of(hm.heights)
    suns = (Sun(135.0, 20.0),)
    plan = plan_tiles(relief, suns, CELL, CELL, max(256, size // 4))
    tracing = Tracing(suns, dx=CELL, dy=CELL, base=hm.offset)
    out = {}
    for overlap in (False, True, False, True):
        t0 = time.perf_counter()
        run_jobs(plan.jobs, lambda w: hm.heights[w.r0:w.r1, w.c0:w.c1].copy(), lambda job, res: None, tracing,
                 overlap=overlap)
        out.setdefault("overlap" if overlap else "serial", []).append(time.perf_counter() - t0)
    return {"size": size, "jobs": len(plan.jobs), **{k: min(v) for k, v in out.items()}}


def simulation(s_per_gigacell: float) -> dict:
    """A 10^12-cell (10^6 x 10^6) job at 1 m cells, relief 3000 m, tiles of 16384^2 on GPU workers."""
    side, tile, relief, cell = 10 ** 6, 16384, 3000.0, 1.0
    tiles = math.ceil(side / tile) ** 2
    rows = []
    for el in (2.0, 5.0, 10.0, 20.0, 45.0):
        halo = min(side, math.ceil(relief / math.tan(math.radians(el)) / cell))
        # worst case: the sun on a diagonal, the halo on both axes
        overhead = ((tile + halo) ** 2 / tile ** 2) - 1.0
        rows.append({"elevation": el, "halo_cells": halo, "trace_overhead": overhead,
                     "read_tib": side * side * 4 * (1 + overhead) / 2 ** 40})
    return {"cells": side * side, "tile": tile, "tiles": tiles, "relief_m": relief, "cell_m": cell,
            "per_sun": rows, "mask_tib_per_sun": side * side / 2 ** 40,
            "cpu_hours_per_sun_at_20deg": s_per_gigacell * 1000 * (1 + rows[3]["trace_overhead"]) / 3600}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="small maps: a smoke run of every step")
    p.add_argument("--equal-size", type=int, default=4096)
    p.add_argument("--tile", type=int, default=1024)
    p.add_argument("--big", type=int, default=32768)
    p.add_argument("--mem", type=int, default=8192)
    p.add_argument("--max-memory", default="2800M")
    p.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    p.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "scale")
    a = p.parse_args()
    if a.quick:
        a.equal_size, a.tile, a.big, a.mem, a.max_memory = 384, 128, 1536, 768, "300M"
    report = {"argv": sys.argv[1:], "machine": platform.processor() or platform.machine(), "cores": os.cpu_count(),
              "date": time.strftime("%Y-%m-%d")}
    report["equality"] = equality(a.equal_size, a.tile, a.data)
    with tempfile.TemporaryDirectory(dir=REPO.parent if not a.quick else None) as tmp:
        work = Path(tmp)
        log(f"writing the {a.big}^2 map")
        big = work / "big.tif"
        t0 = time.perf_counter()
        write_big_map(big, a.big)
        report["big_write_s"] = time.perf_counter() - t0
        log("streamed run")
        streamed = cli_run([str(big), str(work / "streamed.tif"), "--sun", "135,20", "--max-memory", a.max_memory])
        streamed.update(size=a.big, s_per_gigacell=streamed["seconds"] / (a.big ** 2 / 1e9), max_memory=a.max_memory)
        report["streamed"] = streamed
        log("2 workers")
        workers = cli_run([str(big), str(work / "workers.tif"), "--sun", "135,20", "--workers", "2"])
        workers["identical"] = (work / "streamed.tif").read_bytes() == (work / "workers.tif").read_bytes()
        report["workers"] = workers
        log("in-memory path")
        report["in_memory"] = in_memory(a.mem, work)
    report["overlap"] = overlap_gain(a.mem)
    report["simulation"] = simulation(report["in_memory"]["s_per_gigacell"])
    report["bytes_per_window_cell"] = bytes_per_cell(("mask",))
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.with_suffix(".json").write_text(json.dumps(report, indent=1))
    a.out.with_suffix(".md").write_text(markdown(report))
    log(f"wrote {a.out}.md/.json")


def markdown(r: dict) -> str:
    lines = ["# Scale bench (bench/scale.py)", "",
             f"Run `python bench/scale.py {' '.join(r['argv'])}` on {r['machine']}, {r['cores']} cores, {r['date']}."
             + (" **Quick smoke run: small maps, not the figures of record.**" if "--quick" in r["argv"] else ""),
             "", "## Tiled == whole map", "", "Mask, self-shadow and coefficient compared byte for byte.", "",
             "| map | size | sun | tile | bit-identical | differing cells |", "|---|---|---|---|---|---|"]
    for e in r["equality"]:
        lines.append(f"| {e['map']} | {e['size']}^2 | {e['sun'][0]:g}/{e['sun'][1]:g} | {e['tile']} "
                     f"| {'yes' if e['identical'] else '**no**'} | {e['differing']} |")
    s, w, m, o = r["streamed"], r["workers"], r["in_memory"], r["overlap"]
    lines += ["", "## Beyond memory", "", "| run | size | time (s) | peak RSS (MiB) | s per gigacell |", "|---|---|---|---|---|",
              f"| streamed, --max-memory {s['max_memory']} | {s['size']}^2 | {s['seconds']:.1f} | {s['peak_rss_mib']:.0f} | "
              f"{s['s_per_gigacell']:.1f} |",
              f"| 2 Dask workers (LocalCluster) | {s['size']}^2 | {w['seconds']:.1f} | {w['peak_rss_mib']:.0f} (this process) "
              f"| {w['seconds'] / (s['size'] ** 2 / 1e9):.1f} |",
              f"| in memory (no tiles) | {m['size']}^2 | {m['seconds']:.1f} | {m['peak_rss_mib']:.0f} | "
              f"{m['s_per_gigacell']:.1f} |", "",
              f"Workers' output identical byte for byte to the streamed run: {w['identical']}. "
              f"Map written tile by tile in {r['big_write_s']:.0f} s.", "",
              "## Overlap", "", f"{o['jobs']} tiles of a {o['size']}^2 map: serial {o['serial']:.2f} s, "
              f"pipelined {o['overlap']:.2f} s (best of 2 each).", "", "## A 10^12-cell job (simulation)", ""]
    sim = r["simulation"]
    lines += [f"{sim['cells']:.0e} cells (1 m, relief {sim['relief_m']:g} m), {sim['tiles']} tiles of {sim['tile']}^2:",
              "", "| sun elevation | halo (cells) | traced overhead | heights read (TiB) |", "|---|---|---|---|"]
    for row in sim["per_sun"]:
        lines.append(f"| {row['elevation']:g} | {row['halo_cells']} | {100 * row['trace_overhead']:.0f}% | "
                     f"{row['read_tib']:.1f} |")
    lines += ["", f"Mask output: {sim['mask_tib_per_sun']:.2f} TiB per sun; at this machine's in-memory rate, "
              f"{sim['cpu_hours_per_sun_at_20deg']:.0f} CPU-hours per sun at 20 degrees (docs/scale.md scales it "
              "to GPU workers).", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
